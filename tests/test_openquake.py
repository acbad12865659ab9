"""Tests of rockjax.openquake: the NRML fragility model, the exposure and the round trip
through the OpenQuake engine itself (``oq run``, scenario_damage with given ground-motion
fields).

Independent references: the lognormal's moments by numerical quadrature (scipy), the XML read
back with the standard library, the engine's own computation of the damage (a separate
program), and for the discrete form NumPy's linear interpolation of the written levels.
"""

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from scipy import integrate, stats

import rockjax as rj
from rockjax.constants import G

oq = rj.openquake

MOMENT_RTOL = 1e-9
"""Closed-form lognormal moments vs adaptive quadrature (quad's own error ~1e-12)."""
ENGINE_ATOL = 1e-4
"""Engine's collapse fraction vs Fragility.prob (the task's tolerance; the engine's CSV export
keeps 7 significant digits, so a correct round trip agrees to ~5e-7)."""
NS = {"n": "http://openquake.org/xmlns/nrml/0.5"}


def _fragility(median, beta_log, im="pga", units="m/s^2", im_range=(0.5, 20.0)):
    empty = np.zeros(0)
    return rj.Fragility(
        median=median,
        beta_log=beta_log,
        median_ci=(math.nan, math.nan),
        beta_log_ci=(math.nan, math.nan),
        ci=0.9,
        n_records=10,
        n_runs=100,
        n_no_collapse=0,
        n_boot_failed=0,
        method="mle",
        im=im,
        im_units=units,
        boot_median=empty,
        boot_beta_log=empty,
        im_range=im_range,
    )


@pytest.mark.parametrize("median, beta", [(0.3, 0.1), (1.7, 0.45), (0.05, 0.8)])
def test_lognormal_moments_match_quadrature(median, beta):
    dist = stats.lognorm(s=beta, scale=median)
    m1 = integrate.quad(lambda x: x * dist.pdf(x), 0, np.inf, epsabs=0, epsrel=1e-13)[0]
    m2 = integrate.quad(lambda x: (x - m1) ** 2 * dist.pdf(x), 0, np.inf, epsrel=1e-13)[0]
    mean, std = oq.lognormal_moments(median, beta)
    assert mean == pytest.approx(m1, rel=MOMENT_RTOL)
    assert std == pytest.approx(math.sqrt(m2), rel=MOMENT_RTOL)


def test_fragility_model_xml(tmp_path):
    frag = {
        "P_b20_h100": _fragility(3.0, 0.4),
        "F_b25_h300": _fragility(5.0, 0.3, im_range=(1.0, 30.0)),
    }
    imt = oq.fragility_model(frag, tmp_path / "f.xml")
    assert imt == "PGA"
    root = ET.parse(tmp_path / "f.xml").getroot()
    model = root.find("n:fragilityModel", NS)
    assert model.get("lossCategory") == "nonstructural"
    assert model.find("n:limitStates", NS).text.split() == ["collapse"]
    funcs = model.findall("n:fragilityFunction", NS)
    assert [f.get("id") for f in funcs] == list(frag)
    imls = funcs[1].find("n:imls", NS)
    assert float(imls.get("minIML")) == pytest.approx(1.0 / G, rel=1e-15)
    assert float(imls.get("maxIML")) == pytest.approx(30.0 / G, rel=1e-15)
    assert float(imls.get("noDamageLimit")) == float(imls.get("minIML"))
    params = funcs[1].find("n:params", NS)
    # mean and stddev of the IM in g: invert to the median and dispersion
    mean, std = float(params.get("mean")), float(params.get("stddev"))
    sigma = math.sqrt(math.log1p((std / mean) ** 2))
    assert sigma == pytest.approx(0.3, rel=1e-12)
    assert mean / math.exp(0.5 * sigma**2) == pytest.approx(5.0 / G, rel=1e-12)


def test_fragility_model_refuses(tmp_path):
    good = _fragility(3.0, 0.4)
    with pytest.raises(ValueError, match="letters, digits"):
        oq.fragility_model({"bad id": good}, tmp_path / "f.xml")
    with pytest.raises(ValueError, match="same IM"):
        oq.fragility_model({"a": good, "b": _fragility(3.0, 0.4, im="sa(0.3)")}, tmp_path / "f.xml")
    with pytest.raises(ValueError, match="no intensity measure"):
        oq.fragility_model({"a": _fragility(3.0, 0.4, im="scale", units="")}, tmp_path / "f.xml")
    with pytest.raises(ValueError, match="iml_range"):
        oq.fragility_model({"a": _fragility(3.0, 0.4, im_range=(math.nan,) * 2)}, tmp_path / "f")
    with pytest.raises(ValueError, match="more probable"):  # collapse above the milder state
        oq.fragility_model(
            {"a": {"d_over_b_0p3": good, "collapse": _fragility(2.0, 0.4)}}, tmp_path / "f.xml"
        )
    with pytest.raises(ValueError, match="loss_category"):
        oq.fragility_model({"a": good}, tmp_path / "f.xml", loss_category="parapets")


def test_sa_and_pgv_names_and_units(tmp_path):
    assert oq.engine_imt("sa(0.3)") == "SA(0.3)" and oq.engine_imt("pgv") == "PGV"
    oq.fragility_model({"a": _fragility(0.5, 0.4, im="pgv", units="m/s")}, tmp_path / "v.xml")
    params = ET.parse(tmp_path / "v.xml").getroot().find(".//n:params", NS)
    mean, _ = oq.lognormal_moments(50.0, 0.4)  # cm/s
    assert float(params.get("mean")) == pytest.approx(mean, rel=1e-12)


# ----------------------------------------------------------------------------- a real IDA

RECORD_PERIODS = (0.25, 0.35, 0.5, 0.7, 1.0, 1.4)  # Ricker pulses [s]: scattered capacities
SCALES = np.geomspace(0.6, 12.0, 14)  # [-], times a 1 m/s^2 pulse


@pytest.fixture(scope="module")
def ida_ds():
    block = rj.Block(b=0.2, h=1.0)
    records = [
        rj.GroundMotion.ricker(1.0, T, dt=0.01, name=f"ricker_{i}")
        for i, T in enumerate(RECORD_PERIODS)
    ]
    return rj.ida(block, records, SCALES, model="housner", tail=1.0, progress=False)


def test_limit_states_from_one_ida(ida_ds, tmp_path):
    frags = oq.limit_state_fragilities(ida_ds, (0.3,))
    assert list(frags) == ["d_over_b_0p3", "collapse"]
    # one dispersion, the milder state's median below collapse's: the curves never cross
    assert frags["d_over_b_0p3"].beta_log == frags["collapse"].beta_log
    assert frags["d_over_b_0p3"].median < frags["collapse"].median
    reached = np.asarray(ida_ds.collapse | (ida_ds.max_d_over_b >= 0.3))
    assert reached.sum() > np.asarray(ida_ds.collapse).sum()
    oq.fragility_model({"P1": frags}, tmp_path / "ls.xml")
    root = ET.parse(tmp_path / "ls.xml").getroot()
    assert root.find(".//n:limitStates", NS).text.split() == ["d_over_b_0p3", "collapse"]
    lo, hi = frags["collapse"].im_range
    assert (lo, hi) == (float(ida_ds.pga_scaled.min()), float(ida_ds.pga_scaled.max()))
    # fitted one by one, these two curves cross, which the writer refuses
    apart = oq.limit_state_fragilities(ida_ds, (0.3,), common_beta=False, n_boot=0)
    with pytest.raises(ValueError, match="more probable"):
        oq.fragility_model({"P1": apart}, tmp_path / "apart.xml")


ORDINAL_RTOL = 1e-6
"""Ordinal probit with one state vs rj.fragility's Newton MLE: the same likelihood, both
optimisers converged far below this."""


def test_ordinal_probit_with_one_state_is_the_fragility_mle(ida_ds):
    frag = rj.fragility(ida_ds, "pga", n_boot=0)
    x = np.log(np.asarray(ida_ds.pga_scaled)).ravel()
    y = np.asarray(ida_ds.collapse).ravel().astype(int)
    mu, sigma = oq.ordinal_probit(x, y, [0.0], 1.0)
    assert math.exp(mu[0]) == pytest.approx(frag.median, rel=ORDINAL_RTOL)
    assert sigma == pytest.approx(frag.beta_log, rel=ORDINAL_RTOL)


def test_ordinal_probit_recovers_truth():
    """Runs drawn from the ordinal model itself (a latent capacity per run); N = 20000 runs
    give standard errors of ~0.005 in mu and sigma, so 0.02 is a 4-SE bound."""
    rng = np.random.default_rng(3)
    mu_true, sigma_true = np.array([0.2, 0.9]), 0.45
    x = rng.uniform(-1.0, 2.2, 20000)
    u = x - sigma_true * rng.standard_normal(x.size)
    state = (u[:, None] >= mu_true[None, :]).sum(1)
    mu, sigma = oq.ordinal_probit(x, state, [0.0, 1.0], 1.0)
    np.testing.assert_allclose(mu, mu_true, atol=0.02)
    assert sigma == pytest.approx(sigma_true, abs=0.02)


def test_exposure_files(tmp_path):
    import pandas as pd

    inv = pd.DataFrame(
        {"id": ["b1", "b2"], "lon": [10.0, 10.1], "lat": [45.0, 45.1], "cls": ["P1", "F2"]}
    )
    paths = oq.exposure(inv, tmp_path, "cls")
    mapping = pd.read_csv(paths["taxonomy_mapping"])
    assert mapping.to_dict("list") == {
        "taxonomy": ["b1", "b2"],
        "risk_id": ["P1", "F2"],
        "weight": [1.0, 1.0],
    }
    assets = pd.read_csv(paths["assets"])
    assert list(assets.columns[:5]) == ["id", "lon", "lat", "taxonomy", "number"]
    root = ET.parse(paths["exposure"]).getroot()
    assert root.find(".//n:assets", NS).text == paths["assets"].name
    with pytest.raises(ValueError, match="lon"):
        oq.exposure(inv.drop(columns="lon"), tmp_path, "cls")


# ----------------------------------------------------------------------------- the engine

needs_engine = pytest.mark.skipif(
    not oq.engine_available(),
    reason="the OpenQuake engine is not installed (./test.sh installs it: .ci/ensure-venv; "
    "by hand see docs/openquake.md, 'Installing the engine')",
)


def _town(n, seed=0):
    rng = np.random.default_rng(seed)
    return 10.0 + 0.01 * rng.random(n), 45.0 + 0.01 * rng.random(n)


@needs_engine
@pytest.mark.parametrize("form", ["continuous", "discrete"])
def test_engine_round_trip(ida_ds, tmp_path, form):
    """A fragility fitted by rockjax, written as NRML and run by `oq run` (scenario_damage on
    given ground-motion fields): the engine's collapse fraction of each building equals
    Fragility.prob at its IM (continuous), or the linear interpolation of the written levels
    (discrete, the engine's documented rule)."""
    import pandas as pd

    frag = rj.fragility(ida_ds, "pga", n_boot=0)
    lo, hi = frag.im_range
    n = 12
    # IMs inside the range that was run (outside it the engine clips: the module docstring)
    pga = np.geomspace(lo * 1.05, hi * 0.95, n)
    lon, lat = _town(n)
    ids = [f"bldg_{i:03d}" for i in range(n)]
    inv = pd.DataFrame({"id": ids, "lon": lon, "lat": lat, "cls": "P_test"})
    paths = oq.exposure(inv, tmp_path, "cls")
    gm = oq.ground_motion_fields(lon, lat, pga / G, tmp_path)
    imt = oq.fragility_model({"P_test": frag}, tmp_path / "fragility.xml", form=form)
    job = oq.scenario_job(
        tmp_path,
        fragility=tmp_path / "fragility.xml",
        exposure=paths["exposure"],
        sites=gm["sites"],
        gmfs=gm["gmfs"],
        imt=imt,
        taxonomy_mapping=paths["taxonomy_mapping"],
    )
    damage = oq.run_job(job).loc[ids]
    engine = damage["collapse"].to_numpy()
    np.testing.assert_allclose(damage["no_damage"] + damage["collapse"], 1.0, atol=1e-6)
    if form == "continuous":
        expected = frag.prob(pga)
    else:
        levels = np.geomspace(lo / G, hi / G, 40)
        expected = np.interp(pga / G, levels, frag.prob(levels * G))
    assert np.ptp(expected) > 0.5  # the IMs span the curve, not one flat end of it
    np.testing.assert_allclose(engine, expected, atol=ENGINE_ATOL, rtol=0)
    assert (tmp_path / "oqdata" / "home" / "oqdata" / "db.sqlite3").is_file()  # not in ~/oqdata


# ----------------------------------------------------------------------------- the catalogue


def test_class_ids_and_binning():
    cat = oq.Catalogue.grid()
    assert len(cat.classes) == 36  # 3 storeys x (9 parapet + 3 facade) bins
    ids = {c.id for c in cat.classes}
    assert "P-b25-h100-n2-T20-z5-roof" in ids and "F-b38-h300-g0-n3-T30-z5-s3" in ids
    for cid in ids:
        assert len(cid) <= 75  # the engine's longest identifier
    row = {"element": "parapet", "b": 0.27, "h": 1.1, "storeys": 2}
    assert cat.class_of(row) == "P-b25-h100-n2-T20-z5-roof"
    row = {"element": "facade", "b": 0.47, "h": 3.2, "storeys": 3}
    assert cat.class_of(row) == "F-b50-h300-g0-n3-T30-z5-s3"
    with pytest.raises(ValueError, match="outside the catalogue"):
        cat.class_of({"element": "parapet", "b": 0.8, "h": 1.0, "storeys": 2})
    with pytest.raises(ValueError, match="4-storey"):
        cat.class_of({"element": "parapet", "b": 0.25, "h": 1.0, "storeys": 4})
    with pytest.raises(ValueError, match="roof"):
        oq.BuildingClass("parapet", 0.25, 1.0, 2, storey=1)


FLOOR_RTOL = 1e-12
SAME_RUN_RTOL = 1e-12  # the same runs in batches of other sizes: round-off
"""A linear building: floor motion of the scaled record vs the scaled floor motion (round-off)."""


def test_floor_records_scale_with_the_ground_record():
    """The premise of the ground IM: the run at scale s of the floor record is the element under
    the building's response to the ground record scaled by s (the building is linear)."""
    cat = oq.Catalogue.grid(parapet_b=(0.2,), parapet_h=(1.0,), facade_b=(0.3,), storeys=(2,))
    rec = rj.GroundMotion.ricker(2.0, 0.3, dt=0.005, name="r")
    sets = cat.record_sets([rec])
    roof = sets["n2-T200-z50-H300-f2"][0]
    bldg = cat.classes[0].building()
    direct = bldg.floor_motions(rec.scaled(3.0))[1]
    np.testing.assert_allclose(
        3.0 * np.asarray(roof.ag),
        np.asarray(direct.ag),
        rtol=FLOOR_RTOL,
        atol=FLOOR_RTOL * float(direct.pga),
    )
    assert sets["n2-T200-z50-H300-f1"][0].metadata["ground"] == "r"  # the top-storey facade


def test_catalogue_run_fits_in_the_ground_im(tmp_path):
    """One class end to end (a Dask campaign of one worker, ~20 s): the IDA's IM is the ground
    record's PGA times the scale, and the roof's PGA exceeds it."""
    cat = oq.Catalogue.grid(parapet_b=(0.2,), parapet_h=(1.0,), facade_b=(), storeys=(2,))
    records = [
        rj.GroundMotion.ricker(1.0, T, dt=0.005, name=f"r{i}") for i, T in enumerate(RECORD_PERIODS)
    ]
    datasets, frags = cat.run(records, tmp_path, scales=SCALES, progress=False, n_workers=1)
    (cid,) = frags
    ds = datasets[cid]
    ground = np.array([float(r.pga) for r in records])
    np.testing.assert_allclose(ds["im"], ground[:, None] * SCALES[None, :], rtol=1e-12)
    assert float(ds["pga_scaled"].max()) > float(ds["im"].max())  # the roof amplifies
    assert frags[cid].im == "pga" and frags[cid].im_range == (
        float(ds["im"].min()),
        float(ds["im"].max()),
    )


def test_dem_class_runs_the_dem_on_its_floor_motion(tmp_path):
    """The catalogue's DEM path (``model="dem"``, a beta per class): its campaign gives the
    same runs as ``rj.ida`` of the DEM on the class's floor records, called directly."""
    cat = oq.Catalogue.grid(parapet_b=(0.2,), parapet_h=(1.0,), facade_b=(), storeys=(2,))
    (c,) = cat.classes
    records = [
        rj.GroundMotion.ricker(1.0, T, dt=0.005, name=f"r{i}")
        for i, T in enumerate(RECORD_PERIODS[:3])
    ]
    scales = SCALES[::3]
    beta = 0.5 * float(rj.beta_dejong(c.block()))
    datasets, _ = cat.run(
        records,
        tmp_path,
        scales=scales,
        model="dem",
        beta={c.id: beta},
        progress=False,
        n_workers=1,
    )
    floor = cat.record_sets(records)[c.host_key()]
    t_end = float(datasets[c.id].attrs["t_end"])
    direct = rj.ida(
        c.block(), floor, scales, model=rj.DEM(beta=beta), mode=c.mode(), t_end=t_end,
        progress=False,
    )  # fmt: skip
    got = datasets[c.id]
    assert got.attrs["model"] == "dem" and float(got.attrs["beta"]) == beta
    np.testing.assert_array_equal(got["collapse"].values, direct["collapse"].values)
    np.testing.assert_allclose(
        got["max_d_over_b"].values, direct["max_d_over_b"].values, rtol=SAME_RUN_RTOL
    )
