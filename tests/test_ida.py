"""Tests of rockjax.ida: batched IDA against single runs, chunking, per-run status,
collapse intervals, the uplift threshold and the NetCDF round trip."""

import os

import jax
import numpy as np
import pytest
import xarray as xr

import rockjax as rj
from rockjax.constants import G
from rockjax.ida import host_threads
from rockjax.response import STATUS_BAD_INPUT, STATUS_NONFINITE, STATUS_OK

BATCH_RTOL = 1e-12
"""vmap vs a loop of single runs: the same float64 operations, up to XLA's fusion choices."""

SMALL = dict(b=0.2, h=1.0)  # p ~ 3.8 rad/s, eta ~ 0.197 rad: short runs overturn quickly
BETA = 2e-3  # [s]
SCALES = np.array([0.3, 0.9, 1.5, 2.1])


def _records():
    """Two short pulses of different dt and length (so ida pads and groups by dt)."""
    return [
        rj.GroundMotion.sine_cycle(3.0, 0.5, dt=0.01, duration=1.5, name="sine"),
        rj.GroundMotion.ricker(3.0, 0.4, dt=0.005, duration=1.2, name="ricker").with_metadata(
            event="synthetic"
        ),
    ]


@pytest.fixture(scope="module")
def dem_ds():
    block = rj.Block(**SMALL)
    return rj.ida(
        block, _records(), SCALES, model=rj.DEM(beta=BETA), tail=0.5, chunk_size=3, progress=False
    )


@pytest.fixture(scope="module")
def housner_ds():
    block = rj.Block(**SMALL)
    return rj.ida(block, _records(), SCALES, model=rj.Housner(), tail=0.5, progress=False)


def _single(model, block, ds):
    """Reference: a Python loop of single simulate_* runs, each record on its own dt, for the
    Dataset's run length."""
    t_end = float(ds.attrs["t_end"])
    out = {k: np.zeros((2, SCALES.size)) for k in ("d", "th", "col", "st")}
    for i, rec in enumerate(_records()):
        for j, s in enumerate(SCALES):
            if model == "dem":
                r = rj.simulate_dem(
                    block,
                    rec.scaled(s),
                    beta=BETA,
                    dt=rj.stable_dt(block, BETA),
                    duration=t_end,
                    throw=False,
                )
                out["d"][i, j] = float(r.extras["d_max"]) / block.b
            else:
                r = rj.simulate_housner(block, rec.scaled(s), duration=t_end, throw=False)
                th = float(r.theta_max)
                out["d"][i, j] = (0.5 * block.b * (1 - np.cos(th)) + block.h * np.sin(th)) / block.b
            out["th"][i, j] = float(r.theta_max / r.eta)
            out["col"][i, j] = bool(r.overturned)
            out["st"][i, j] = int(r.status)
    return out


@pytest.mark.parametrize("model", ["dem", "housner"])
def test_batch_equals_loop_of_single_runs(model, dem_ds, housner_ds):
    # Reference: the same simulator run once per (record, scale) in a Python loop.
    ds = dem_ds if model == "dem" else housner_ds
    ref = _single(model, rj.Block(**SMALL), ds)
    assert ds["max_d_over_b"].dtype == np.float64
    assert ds["max_theta_over_eta"].dims == ("record", "scale")
    np.testing.assert_array_equal(ds["status"], ref["st"])
    np.testing.assert_array_equal(ds["collapse"], ref["col"].astype(bool))
    np.testing.assert_allclose(ds["max_theta_over_eta"], ref["th"], rtol=BATCH_RTOL, atol=0)
    np.testing.assert_allclose(ds["max_d_over_b"], ref["d"], rtol=BATCH_RTOL, atol=0)
    # the grid spans both outcomes, so the comparison covers rocking and overturning runs
    assert ds["collapse"].any() and not ds["collapse"].all()


def test_dataset_layout(dem_ds):
    # Reference: the records' own dt, duration, pga and metadata.
    recs = _records()
    assert list(dem_ds["record"].values) == ["sine", "ricker"]
    np.testing.assert_array_equal(dem_ds["scale"], SCALES)
    np.testing.assert_array_equal(dem_ds["dt"], [0.01, 0.005])
    np.testing.assert_array_equal(dem_ds["duration"], [r.duration for r in recs])
    assert list(dem_ds["meta_event"].values) == ["", "synthetic"]
    assert dem_ds.attrs["t_end"] == pytest.approx(1.5 + 0.5, rel=1e-12)
    assert dem_ds.attrs["beta"] == BETA and dem_ds.attrs["model"] == "dem"
    for i, rec in enumerate(recs):  # each record runs on its own dt, as a single run would
        single = rj.simulate_dem(rj.Block(**SMALL), rec, beta=BETA)
        assert float(dem_ds["dt_step"][i]) == pytest.approx(float(single.extras["dt"]), rel=1e-14)
    # pga of the record as run
    np.testing.assert_allclose(dem_ds["pga"], [float(r.pga) for r in recs], rtol=1e-15)
    np.testing.assert_allclose(
        dem_ds["pga_scaled"], dem_ds["pga"].values[:, None] * SCALES[None, :], rtol=1e-15
    )


def test_chunk_size_does_not_change_results(dem_ds):
    # Reference: the same IDA in one chunk of 64 (dem_ds used chunks of 3, the last padded).
    block = rj.Block(**SMALL)
    one = rj.ida(
        block, _records(), SCALES, model=rj.DEM(beta=BETA), tail=0.5, chunk_size=64, progress=False
    )
    for var in ("max_d_over_b", "max_theta_over_eta", "collapse", "status"):
        np.testing.assert_array_equal(one[var], dem_ds[var])


def test_failed_run_is_flagged_and_batch_kept(housner_ds, capsys):
    # Reference: the batch without the failing scale. A scale of 1e308 overflows the record to
    # inf inside the run (the scale itself is finite, so it passes the input checks).
    scales = np.array([0.3, 0.9, 1e308])
    ds = rj.ida(
        rj.Block(**SMALL),
        _records(),
        scales,
        model=rj.Housner(),
        tail=0.5,
        chunk_size=4,
        progress=True,
    )
    assert "chunk 2/2" in capsys.readouterr().err  # the bar advances per chunk
    # the overflowed record is a bad input of that run, flagged before it runs
    np.testing.assert_array_equal(ds["status"][:, 2], [STATUS_BAD_INPUT] * 2)
    assert np.all(np.isnan(ds["max_theta_over_eta"][:, 2]))
    assert not ds["collapse"][:, 2].any()
    np.testing.assert_array_equal(ds["status"][:, :2], STATUS_OK)
    np.testing.assert_array_equal(
        ds["max_theta_over_eta"][:, :2], housner_ds["max_theta_over_eta"][:, :2]
    )


def test_collapse_intervals_resurrection():
    # Reference: intervals read off a hand-made collapse pattern, with a failed run inside one.
    scales = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7])
    collapse = np.array(
        [
            [0, 1, 1, 0, 0, 1, 1],  # collapse, resurrection, collapse again
            [0, 0, 0, 0, 0, 0, 0],  # never
            [0, 0, 1, 0, 1, 0, 0],  # single scales; the 0 at 0.4 is a failed run, dropped
        ],
        bool,
    )
    status = np.zeros(collapse.shape, np.int32)
    status[2, 3] = STATUS_NONFINITE
    ds = xr.Dataset(
        {
            "collapse": (("record", "scale"), collapse),
            "status": (("record", "scale"), status),
        },
        coords={"record": ["a", "b", "c"], "scale": scales},
    )
    res = rj.collapse_intervals(ds.isel(scale=slice(None, None, -1)))  # order does not matter
    assert res.intervals == {"a": [(0.2, 0.3), (0.6, 0.7)], "b": [], "c": [(0.3, 0.5)]}
    np.testing.assert_array_equal(res.lowest.sel(record=["a", "c"]), [0.2, 0.3])
    assert np.isnan(res.lowest.sel(record="b"))


def test_sine_pulse_collapses_only_above_uplift():
    # Reference: Housner's uplift criterion pga > g tan(eta): below it the block does not move
    # (so cannot collapse); far above it a long one-sine pulse overturns it.
    block = rj.Block(**SMALL)
    uplift = G * float(np.tan(block.eta))
    pulse = rj.GroundMotion.sine_cycle(uplift, 1.0, dt=0.01, duration=1.0, name="sine_T1")
    scales = np.array([0.5, 0.9, 0.99, 1.5, 3.0, 5.0])
    ds = rj.ida(block, [pulse], scales, model=rj.Housner(), tail=1.5, progress=False)
    below = ds["pga_scaled"] <= uplift
    assert not ds["collapse"].where(below, False).any()
    np.testing.assert_array_equal(ds["max_theta_over_eta"].where(below, 0.0), 0.0)
    assert ds["collapse"].sel(scale=5.0).all()
    res = rj.collapse_intervals(ds)
    assert res.lowest.item() > 1.0


def test_netcdf_round_trip(dem_ds, tmp_path):
    # Reference: the Dataset itself, written and read back.
    path = tmp_path / "ida.nc"
    dem_ds.to_netcdf(path)
    with xr.open_dataset(path) as back:
        xr.testing.assert_identical(back.load(), dem_ds)
        assert back["collapse"].dtype == bool


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(model="dem"), "needs beta"),
        (dict(model=rj.Housner(), mode=rj.Facade(gap=0.001)), "no facade gap"),
        (dict(model="housner", scales=[0.5, 0.2]), "strictly increasing"),
        (dict(model="housner", scales=[0.5, np.nan]), "finite"),
        (dict(model="housner", chunk_size=0), "chunk_size"),
        (dict(model="fem"), "model must be one of"),
    ],
)
def test_invalid_input(kwargs, match):
    kwargs = {"scales": SCALES, **kwargs}
    with pytest.raises(ValueError, match=match):
        rj.ida(rj.Block(**SMALL), _records(), progress=False, **kwargs)


def test_invalid_records():
    block = rj.Block(**SMALL)
    rec = _records()[0]
    with pytest.raises(ValueError, match="distinct"):
        rj.ida(block, [rec, rec], model=rj.Housner(), progress=False)


@pytest.mark.parametrize("mode", ["two_sided", "one_sided"])
def test_chunks_in_threads_give_the_same_results_to_the_bit(monkeypatch, mode):
    """Reference: the same IDA one chunk at a time (devices named: one thread). By default, on
    a host CPU, the chunks run in one thread per core (here three, with several chunks at once
    in each): the parapet's vmap batches, the facade's and Housner's runs one after another."""
    block = rj.Block(**SMALL)
    monkeypatch.setattr(os, "sched_getaffinity", lambda _: {0, 1, 2}, raising=False)
    monkeypatch.setattr(os, "cpu_count", lambda: 3)
    assert host_threads() == 3
    for model in (rj.DEM(beta=BETA), rj.Housner()):
        m = rj.as_mode(mode) if model.name == "dem" else rj.as_mode(mode).without_gap()
        kw = dict(model=model, mode=m, tail=0.5, chunk_size=2, progress=False)
        # (one thread first: it compiles, so that the threads then run chunks at once)
        one = rj.ida(block, _records(), SCALES, devices=jax.local_devices(), **kw)
        threaded = rj.ida(block, _records(), SCALES, **kw)
        xr.testing.assert_identical(threaded.drop_attrs(), one.drop_attrs())


_SHARDED = """
import os
os.environ["XLA_FLAGS"] = os.environ.get("XLA_FLAGS", "") + " --xla_force_host_platform_device_count=2"
import jax
import numpy as np
import rockjax as rj
assert jax.local_device_count() == 2
recs = [
    rj.GroundMotion.sine_cycle(3.0, 0.5, dt=0.01, duration=1.5, name="sine"),
    rj.GroundMotion.ricker(3.0, 0.4, dt=0.005, duration=1.2, name="ricker"),
]
blk = rj.Block(b=0.2, h=1.0)
sc = np.array([0.3, 0.9, 1.5, 2.1, 2.5])
kw = dict(model=rj.DEM(beta=2e-3), tail=0.5, chunk_size=3, progress=False)
two = rj.ida(blk, recs, sc, **kw)
one = rj.ida(blk, recs, sc, devices=jax.local_devices()[:1], **kw)
for v in ("max_d_over_b", "max_theta_over_eta", "collapse", "status"):
    np.testing.assert_allclose(two[v].values, one[v].values, rtol=1e-12)
assert two["collapse"].any() and not two["collapse"].all()
kw["model"] = rj.Housner()  # its runs one after another on each device
two = rj.ida(blk, recs, sc, **kw)
one = rj.ida(blk, recs, sc, devices=jax.local_devices()[:1], **kw)
for v in ("max_d_over_b", "max_theta_over_eta", "collapse", "status"):
    np.testing.assert_allclose(two[v].values, one[v].values, rtol=1e-12)
print("ok")
"""


def test_sharding_over_two_host_devices_does_not_change_results():
    """Reference: the same IDA on one device. XLA fixes the device count when its backend
    starts, so the two-device run is a fresh process with two host CPU devices (it inherits
    the suite's XLA_FLAGS and adds the device count)."""
    import subprocess
    import sys

    res = subprocess.run(
        [sys.executable, "-c", _SHARDED], capture_output=True, text=True, timeout=600
    )
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.strip().endswith("ok")


# ----------------------------------------------------------------------------- intensity measures


def test_intensity_measures(housner_ds):
    """References: the default IM is the PGA (equal to pga_scaled); the PGV of the one-sine
    record is pga T / pi (trapezoid rule, tolerance of tests/test_motion.py); Sa(T) of each
    record is rj.response_spectrum's (tests/test_spectra.py checks it against solve_ivp and
    lsim) times the scale; the IM does not change the runs."""
    assert housner_ds.attrs["im"] == "pga"
    np.testing.assert_array_equal(housner_ds["im"], housner_ds["pga_scaled"])
    np.testing.assert_allclose(housner_ds["im_g"], housner_ds["pga_scaled"] / G, rtol=1e-15)
    assert housner_ds["im"].attrs["units"] == "m/s^2" and housner_ds["im_g"].attrs["units"] == "g"
    trapz_rtol = 2.0 * (np.pi**3 / 3 + np.pi**2 / 2) * (0.01 / 0.5) ** 2
    np.testing.assert_allclose(housner_ds["pgv"][0], 3.0 * 0.5 / np.pi, rtol=trapz_rtol)

    block = rj.Block(**SMALL)
    kw = dict(model=rj.Housner(), tail=0.5, progress=False)
    sa = rj.ida(block, _records(), SCALES, im="Sa(0.5)", **kw)
    assert sa.attrs["im"] == "sa(0.5)"
    ref = [float(rj.response_spectrum(r, [0.5]).sa[0]) for r in _records()]
    np.testing.assert_allclose(sa["im_record"], ref, rtol=1e-15)
    np.testing.assert_allclose(sa["im"], np.outer(ref, SCALES), rtol=1e-15)
    np.testing.assert_allclose(sa["im_g"], sa["im"] / G, rtol=1e-15)
    for var in ("max_theta_over_eta", "collapse", "status", "pga_scaled"):
        np.testing.assert_array_equal(sa[var], housner_ds[var])
    pgv = rj.ida(block, _records(), SCALES, im="pgv", **kw)
    assert pgv["im"].attrs["units"] == "m/s" and "im_g" not in pgv
    np.testing.assert_allclose(pgv["im"], pgv["pgv"].values[:, None] * SCALES, rtol=1e-15)
    with pytest.raises(ValueError, match="im must be 'pga', 'pgv' or 'sa\\(T\\)'"):
        rj.ida(block, _records(), SCALES, im="sa", **kw)


def test_progress_bar_per_chunk(dem_ds, capsys):
    """A tqdm bar over the runs on request, advanced per chunk; none by default when stderr is
    not a terminal (as under pytest); the results do not depend on it."""
    block = rj.Block(**SMALL)
    kw = dict(model=rj.DEM(beta=BETA), tail=0.5, chunk_size=3)  # dem_ds's chunks: no new compile
    capsys.readouterr()
    ds = rj.ida(block, _records(), SCALES, progress=True, **kw)
    err = capsys.readouterr().err
    assert "rockjax.ida" in err and "8/8" in err and "chunk 4/4, dt = 0.005 s" in err, err
    assert "compiling" not in err  # dem_ds compiled these chunks' programs
    xr.testing.assert_identical(ds.drop_attrs(), dem_ds.drop_attrs())
    # a chunk that compiles (a joint no other test runs, a new chunk size) says so while it runs
    model = rj.DEM(beta=BETA, joint=rj.Joint(n_sub=5))
    rj.ida(block, _records(), SCALES, progress=True, **(kw | dict(chunk_size=5, model=model)))
    assert "compiling" in capsys.readouterr().err
    rj.ida(block, _records(), SCALES, **kw)  # progress=None: stderr is no terminal here
    assert capsys.readouterr().err == ""


def test_dem_joint_reaches_every_run(dem_ds):
    """Reference: single runs with the same joint. The paper's corner contacts
    (rj.Joint(n_sub=2)) and the default converged joint answer differently (a facade's rebound
    about doubles), so the joint must reach every run of the batch, and it is recorded. The
    default-joint IDA of the same runs is dem_ds's first record and scales (same block, beta,
    tail and t_end = 2 s; chunking does not change results, test above)."""
    block = rj.Block(**SMALL)
    corners = rj.Joint(n_sub=2)
    rec = _records()[0]
    model = rj.DEM(beta=BETA, joint=corners)
    ds = rj.ida(block, [rec], SCALES[:2], model=model, tail=0.5, progress=False)
    assert ds.attrs["joint"] == repr(corners)
    for k, s in enumerate(SCALES[:2]):
        g = rj.GroundMotion(ag=s * np.asarray(rec.ag), dt=rec.dt)
        single = rj.simulate_dem(block, g, beta=BETA, duration=2.0, joint=corners)
        expect = float(single.theta_max / single.eta)
        got = float(ds["max_theta_over_eta"][0, k])
        np.testing.assert_allclose(got, expect, rtol=BATCH_RTOL)
    assert dem_ds.attrs["t_end"] == ds.attrs["t_end"] and dem_ds["record"][0] == rec.name
    default = dem_ds["max_theta_over_eta"][:1, :2].values
    assert not np.allclose(default, ds["max_theta_over_eta"].values, rtol=1e-3)
    with pytest.raises(ValueError, match="joint .* is not a Housner parameter"):
        rj.as_model("housner", joint=corners)


def _pulses():
    return [
        rj.GroundMotion.ricker(pga=3.0, period=0.5, name="r05"),
        rj.GroundMotion.sine_cycle(pga=2.0, period=0.8, name="s08"),
    ]


def test_three_branch_with_the_rigid_law_is_the_housner_ida():
    # The rigid law (Delta_1 = Delta_2 = 0, Delta_u = 1, lambda_0 = b/h) is plain Housner
    # (docs/three_branch.md); the IDA must route the law to every run and change nothing else.
    block = rj.Block(b=0.25, h=3.0)
    scales = [0.4, 0.8, 1.6]
    tb = rj.ida(
        block,
        _pulses(),
        scales,
        model=rj.ThreeBranch(rj.ThreeBranchLaw.rigid(block)),
        progress=False,
    )
    hs = rj.ida(block, _pulses(), scales, model=rj.Housner(), progress=False)
    np.testing.assert_allclose(tb.max_theta_over_eta, hs.max_theta_over_eta, rtol=1e-9, atol=1e-12)
    assert (tb.collapse.values == hs.collapse.values).all()
    assert tb.attrs["model"] == "three_branch" and tb.attrs["law_Delta_u"] == 1.0


@pytest.mark.slow  # the rigid-law test above covers the routing
def test_three_branch_law_changes_the_ida():
    # a law with a flexible first branch and a shorter Delta_u lowers the capacity
    block = rj.Block(b=0.25, h=3.0)
    law = rj.ThreeBranchLaw(lambda_0=0.25 / 3.0, Delta_1=0.05, Delta_2=0.2, Delta_u=0.8)
    scales = [0.4, 0.8, 1.6]
    tb = rj.ida(block, _pulses(), scales, model=rj.ThreeBranch(law), progress=False)
    hs = rj.ida(block, _pulses(), scales, model=rj.Housner(), progress=False)
    assert (tb.status.values == 0).all()
    assert not np.allclose(tb.max_theta_over_eta, hs.max_theta_over_eta)


def test_wall_motion_reaches_every_run():
    # Each (record, scale) run of the IDA equals a single simulate_housner call with the same
    # building moving the return walls under the scaled record.
    block = rj.Block(b=0.25, h=3.0)
    bldg = rj.ShearBuilding.uniform(n_storeys=2, storey_height=3.2, period=0.25, damping=0.05)
    scales = [0.5, 1.2]
    ds = rj.ida(
        block,
        _pulses(),
        scales,
        model=rj.Housner(),
        mode="one_sided",
        wall_motion=bldg,
        progress=False,
    )
    fixed = rj.ida(block, _pulses(), scales, model=rj.Housner(), mode="one_sided", progress=False)
    assert not np.allclose(ds.max_theta_over_eta, fixed.max_theta_over_eta)
    np.testing.assert_allclose(ds.attrs["building_periods"], np.asarray(bldg.periods))
    t_end = float(ds.attrs["t_end"])
    for i, rec in enumerate(_pulses()):
        n = int(round(t_end / rec.dt))
        for j, s in enumerate(scales):
            ag = np.zeros(n)
            ag[: rec.ag.shape[0]] = s * np.asarray(rec.ag)
            r = rj.simulate_housner(
                block, rj.GroundMotion(ag=ag, dt=rec.dt), mode="one_sided", wall_motion=bldg
            )
            assert float(r.theta_max / r.eta) == pytest.approx(
                float(ds.max_theta_over_eta[i, j]), rel=1e-9, abs=1e-12
            )
            # the time the rigid block would rock on its heel: the run's, sample for sample
            assert float(ds.t_heel[i, j]) == float(r.extras["t_heel"])
    assert "t_heel" not in fixed
    assert np.any(np.isfinite(ds.t_heel))  # the building's wall recedes behind the base


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(model="three_branch"), "needs law"),
        (
            dict(
                model=rj.Housner(),
                mode="two_sided",
                wall_motion=rj.ShearBuilding.uniform(n_storeys=1, storey_height=3.0, period=0.2),
            ),
            "one_sided",
        ),
    ],
)
def test_law_and_wall_motion_errors(kwargs, match):
    with pytest.raises(ValueError, match=match):
        rj.ida(rj.Block(b=0.25, h=3.0), _pulses(), [1.0], progress=False, **kwargs)


def test_assembly_of_one_block_is_the_block_ida():
    # One block as an Assembly runs the assembly DEM (equal to simulate_dem to round-off,
    # tests/test_assembly.py): the IDA's peaks and collapse flags must match the block's.
    block = rj.Block(b=0.25, h=3.0)
    beta = float(rj.beta_dejong(block))
    scales = [0.3, 0.9]
    one = rj.ida(
        rj.Assembly.stack([block]), _pulses(), scales, model=rj.DEM(beta=beta), progress=False
    )
    ref = rj.ida(block, _pulses(), scales, model=rj.DEM(beta=beta), progress=False)
    np.testing.assert_allclose(one.max_theta_over_eta, ref.max_theta_over_eta, rtol=1e-8)
    assert (one.collapse.values == ref.collapse.values).all()
    assert one.attrs["n_blocks"] == 1


@pytest.mark.slow  # the one-block test above covers the routing; this adds two blocks
def test_assembly_ida_equals_single_runs():
    wall = rj.Assembly.stack([rj.Block(b=0.23, h=1.5), rj.Block(b=0.23, h=1.5)])
    beta = float(rj.beta_dejong(rj.Block(b=0.23, h=1.5)))
    rec = _pulses()[0]
    ds = rj.ida(wall, [rec], [0.5, 2.0], model=rj.DEM(beta=beta), tail=1.0, progress=False)
    n = int(round(float(ds.attrs["t_end"]) / rec.dt))
    dt = rj.stable_dt_assembly(wall, beta)
    for j, s in enumerate([0.5, 2.0]):
        ag = np.zeros(n)
        ag[: rec.ag.shape[0]] = s * np.asarray(rec.ag)
        r = rj.simulate_assembly(wall, rj.GroundMotion(ag=ag, dt=rec.dt), beta=beta, dt=dt)
        theta = float(np.max(np.asarray(r.theta_max) / np.asarray(r.eta)))
        assert float(ds.max_theta_over_eta[0, j]) == pytest.approx(theta, rel=1e-9)
        assert bool(ds.collapse[0, j]) == bool(r.overturned)
    with pytest.raises(ValueError, match=r"Assembly runs with the DEM only, model=rj\.DEM\(beta="):
        rj.ida(wall, [rec], [1.0], model=rj.Housner(), progress=False)


def _strip():
    """The wall of a storey: two 0.23 x 1.5 m blocks, top held by the floor above."""
    blk = rj.Block(b=0.23, h=1.5)
    return rj.Assembly.stack([blk, blk], top="restrained", overburden=5e3)


STRIP_BETA = 6e-3  # [s], about rj.beta_dejong of the 0.23 x 1.5 m block
STRIP_SCALES = [0.5, 3.0]


def _strip_records():
    """Two short pulses of one step (one compiled batch, shared by the tests below)."""
    return [
        rj.GroundMotion.ricker(pga=3.0, period=0.5, dt=0.01, duration=1.5, name="r05"),
        rj.GroundMotion.sine_cycle(pga=2.0, period=0.8, dt=0.01, duration=1.5, name="s08"),
    ]


def _strip_ida(building=None, storey=None):
    kw = {} if building is None else dict(support_motion=building, storey=storey)
    return rj.ida(
        _strip(),
        _strip_records(),
        STRIP_SCALES,
        model=rj.DEM(beta=STRIP_BETA),
        tail=0.5,
        progress=False,
        **kw,
    )


def test_assembly_in_a_building_equals_single_runs():
    # Reference: a loop of rj.simulate_dem(wall, record, support_motion=bldg, storey=2), each
    # solving the building for its own scaled record; the IDA solves it once per record and
    # scales it (the building is linear), so the runs differ by round-off only.
    wall = _strip()
    bldg = rj.ShearBuilding.uniform(n_storeys=2, storey_height=3.0, period=0.3, damping=0.05)
    ds = _strip_ida(bldg, 2)
    np.testing.assert_allclose(ds.attrs["building_periods"], np.asarray(bldg.periods))
    assert ds.attrs["storey"] == 2
    t_end = float(ds.attrs["t_end"])
    dt = rj.stable_dt_assembly(wall, STRIP_BETA)
    rec = _strip_records()[0]
    for j, s in enumerate(STRIP_SCALES):
        r = rj.simulate_dem(
            wall,
            rec.scaled(s),
            beta=STRIP_BETA,
            dt=dt,
            duration=t_end,
            support_motion=bldg,
            storey=2,
        )
        theta = float(np.max(np.asarray(r.theta_max) / np.asarray(r.eta)))
        assert float(ds.max_theta_over_eta[0, j]) == pytest.approx(theta, rel=1e-9)
        assert bool(ds.collapse[0, j]) == bool(r.overturned)
        d = np.asarray(r.x[:, -1]) + 0.75 * np.sin(np.asarray(r.theta[:, -1]))
        assert float(ds.max_d_over_b[0, j]) == pytest.approx(np.max(np.abs(d)) / 0.23, rel=1e-9)


def test_assembly_facade_on_moving_walls_equals_single_runs():
    # Reference: a loop of rj.simulate_dem(facade, record, mode="one_sided", gap=...,
    # wall_motion=bldg) on the record zero-padded to the IDA's length, each solving the
    # building for its own scaled record at the stack's height; the IDA solves it once per
    # record and scales it (the building is linear), so the runs differ by round-off only.
    blk = rj.Block(b=0.23, h=1.5)
    facade = rj.Assembly.stack([blk, blk])
    bldg = rj.ShearBuilding.uniform(n_storeys=2, storey_height=3.0, period=0.2, damping=0.05)
    kw = dict(beta=STRIP_BETA, mode="one_sided", gap=1e-3)
    ida_kw = dict(model=rj.DEM(beta=STRIP_BETA), mode=rj.Facade(gap=1e-3), wall_motion=bldg)
    ds = rj.ida(facade, _strip_records(), STRIP_SCALES, tail=0.5, progress=False, **ida_kw)
    assert ds.attrs["mode"] == "one_sided" and ds.attrs["gap"] == 1e-3
    np.testing.assert_allclose(ds.attrs["building_periods"], np.asarray(bldg.periods))
    t_end = float(ds.attrs["t_end"])
    dt = rj.stable_dt_assembly(facade, STRIP_BETA, mode="one_sided")
    for i, rec in enumerate(_strip_records()):
        n = int(round(t_end / rec.dt)) + 1
        for j, s in enumerate(STRIP_SCALES):
            ag = np.zeros(n)
            ag[: rec.n] = s * np.asarray(rec.ag)
            r = rj.simulate_dem(
                facade, rj.GroundMotion(ag=ag, dt=rec.dt), dt=dt, wall_motion=bldg, **kw
            )
            assert int(r.status) == 0
            theta = float(np.max(np.asarray(r.theta_max) / np.asarray(r.eta)))
            assert theta > 1e-3  # it rocked
            assert float(ds.max_theta_over_eta[i, j]) == pytest.approx(theta, rel=1e-9)
            assert bool(ds.collapse[i, j]) == bool(r.overturned)
            d = np.asarray(r.x[:, -1]) + 0.75 * np.sin(np.asarray(r.theta[:, -1]))
            d_ida = float(ds.max_d_over_b[i, j])
            assert d_ida == pytest.approx(np.max(np.abs(d)) / 0.23, rel=1e-9)
    # the walls' motion matters: still walls (the same compiled run) give another response
    z = np.zeros(n)
    still = rj.simulate_dem(
        facade, rj.GroundMotion(ag=ag, dt=rec.dt), dt=dt, wall_motion=(z, z), **kw
    )
    theta_still = float(np.max(np.asarray(still.theta_max) / np.asarray(still.eta)))
    assert abs(theta_still / float(ds.max_theta_over_eta[-1, -1]) - 1.0) > 0.01


def test_assembly_facade_ida_errors(user_view):
    bldg = rj.ShearBuilding.uniform(n_storeys=2, storey_height=3.0, period=0.3)
    for kwargs, match in [
        (dict(wall_motion=bldg), "one_sided"),
        (
            dict(
                mode="one_sided",
                wall_motion=bldg.floor_motions(_pulses()[0])[0],
                support_motion=bldg,
            ),
            "same rockjax.ShearBuilding",
        ),
    ]:
        with pytest.raises(ValueError, match=match):
            rj.ida(_strip(), _pulses(), [1.0], model=rj.DEM(beta=1e-3), progress=False, **kwargs)


RIGID_RTOL = 1e-3
"""A 0.005 s building under 0.5-0.8 s pulses: floor motions differ from the ground's by about
(0.005 / 0.5)^2 = 1e-4 (docs/assemblies.md measured 6e-5 of the peak rotation)."""


def test_assembly_in_a_rigid_building_is_the_ground_ida():
    rigid = rj.ShearBuilding.uniform(n_storeys=2, storey_height=3.0, period=0.005, damping=0.05)
    ds = _strip_ida(rigid, 2)
    ground = _strip_ida()
    np.testing.assert_allclose(
        ds.max_theta_over_eta, ground.max_theta_over_eta, rtol=RIGID_RTOL, atol=1e-6
    )
    assert (ds.collapse.values == ground.collapse.values).all()


@pytest.mark.parametrize(
    "block, kwargs, match",
    [
        (rj.Block(b=0.23, h=1.5), dict(support_motion="bldg"), "needs an rj.Assembly"),
        ("strip", dict(storey=2), "needs support_motion"),
        ("strip", dict(support_motion="bldg", storey=3), r"integer in 1\.\.2"),
        ("strip", dict(support_motion="bldg", storey=0), r"integer in 1\.\.2"),
        ("strip", dict(support_motion="floors"), "must be a rockjax.ShearBuilding"),
    ],
)
def test_support_motion_errors(block, kwargs, match, user_view):
    bldg = rj.ShearBuilding.uniform(n_storeys=2, storey_height=3.0, period=0.3)
    block = _strip() if block == "strip" else block
    if kwargs.get("support_motion") == "bldg":
        kwargs = {**kwargs, "support_motion": bldg}
    elif kwargs.get("support_motion") == "floors":
        kwargs = {**kwargs, "support_motion": bldg.floor_motions(_pulses()[0])}
    with pytest.raises(ValueError, match=match):
        rj.ida(block, _pulses(), [1.0], model=rj.DEM(beta=1e-3), progress=False, **kwargs)


def test_precomputed_supports_are_checked(user_view):
    # The pair form of support_motion that the IDA passes to rj.simulate_assembly.
    wall, gm = _strip(), _strip_records()[0]
    zeros = np.zeros(gm.n)
    for kwargs, match in [
        (dict(support_motion=(zeros[:-1], zeros)), r"shape \(151,\)"),
        (dict(support_motion=(zeros, zeros), storey=2), "leave storey=1"),
        (dict(support_motion=(zeros + np.nan, zeros)), "non-finite"),
    ]:
        with pytest.raises(ValueError, match=match):
            rj.simulate_assembly(wall, gm, beta=STRIP_BETA, **kwargs)
    free = rj.Assembly.stack(list(wall.blocks))
    with pytest.raises(ValueError, match="top='restrained'"):
        rj.simulate_assembly(free, gm, beta=STRIP_BETA, support_motion=(zeros, zeros))
