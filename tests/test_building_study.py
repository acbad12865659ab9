"""The building study's pieces (experiments/building_study.py) against the library's own IDA.

The study batches its runs itself (it shares one building response per record between its
cases), so these tests check that its batching and its capacity rule give what rj.ida and
rj.collapse_intervals give for the same runs (DEM, Housner and the three-branch model, also a
facade on walls moving with a building), that its pushover calibration recovers a known law,
that its run cache refuses another law, and (slow) that the --quick path writes its tables and
figures.
"""

import importlib.util
import json
import math
import pathlib
import types

import numpy as np
import pytest
import xarray as xr

import rockjax as rj

PATH = pathlib.Path(__file__).parents[1] / "experiments" / "building_study.py"


@pytest.fixture(scope="module")
def study():
    spec = importlib.util.spec_from_file_location("building_study", PATH)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _ricker_set():
    """Two short records of one step (one batch group), normalised to PGA 1 g."""
    return [
        rj.GroundMotion.ricker(pga_g=1.0, period=T, dt=0.01, duration=4.0, name=f"MH{T}")
        for T in (0.4, 0.7)
    ]


def test_lowest_collapse_matches_collapse_intervals(study):
    """Reference: rj.collapse_intervals on the same grid (failed runs left out, resurrection)."""
    rng = np.random.default_rng(0)
    scales = np.geomspace(0.02, 4.0, 14)
    collapse = rng.random((40, scales.size)) < 0.4
    status = np.where(rng.random((40, scales.size)) < 0.1, 3, 0)
    ds = xr.Dataset(
        {
            "collapse": (("record", "scale"), collapse),
            "status": (("record", "scale"), status),
        },
        coords={"record": [f"r{i}" for i in range(40)], "scale": scales},
    )
    ref = rj.collapse_intervals(ds)
    perm = rng.permutation(scales.size)  # the study's runs come in any order
    for i in range(40):
        cap, n_int = study.lowest_collapse(scales[perm], collapse[i, perm], status[i, perm])
        low = float(ref.lowest[i])
        assert cap == (low if math.isfinite(low) else math.inf)
        assert n_int == len(ref.intervals[f"r{i}"])


def test_grouping_pads_with_zeros_and_a_tail(study):
    recs = _ricker_set() + [
        rj.GroundMotion.ricker(pga_g=1.0, period=0.5, dt=0.005, duration=3.0, name="fine")
    ]
    groups = study.group_records(recs)
    assert sorted(len(g.idx) for g in groups) == [1, 2]
    for g in groups:
        longest = max(recs[i].duration for i in g.idx)
        assert g.n == int(math.floor((longest + study.TAIL) / g.dt + 1e-9)) + 1
        for row, i in enumerate(g.idx):
            np.testing.assert_array_equal(g.ag[row, : recs[i].n], np.asarray(recs[i].ag))
            assert not np.any(g.ag[row, recs[i].n :])


def test_inputs_scale_with_the_record(study):
    """The study computes roof and wall motions once per record at PGA 1 g and scales them
    with the run: exact for a linear building. Reference: the building's response to the
    scaled record (round-off tolerance)."""
    recs = _ricker_set()
    (g,) = study.group_records(recs)
    bldg = rj.ShearBuilding.uniform(3, 3.2, 0.3, 0.05)
    inputs = study.Inputs([g], {"3st": bldg}, [3.0])
    s = 0.37
    for row in range(len(recs)):
        gm = rj.GroundMotion(ag=s * g.ag[row], dt=g.dt)
        roof = np.asarray(bldg.response(gm).acceleration[-1])
        u, v = rj.wall_top_motion(bldg, gm, 3.0)
        wu, wv = inputs.wall[("3st", 0, 3.0)]
        np.testing.assert_allclose(s * inputs.roof[("3st", 0)][row], roof, rtol=0, atol=1e-12)
        np.testing.assert_allclose(s * wu[row], np.asarray(u), rtol=0, atol=1e-15)
        np.testing.assert_allclose(s * wv[row], np.asarray(v), rtol=0, atol=1e-14)
        # the wall at 3 m in a 3.2 m storey: 3/3.2 of the first floor (docs/building.md)
        u1 = np.asarray(bldg.response(gm).displacement[0])
        np.testing.assert_allclose(np.asarray(u), 3.0 / 3.2 * u1, rtol=0, atol=1e-15)


# a semi-rigid wall's law, of the fitted laws' shape (stiff branch, plateau, descent)
LAW = rj.ThreeBranchLaw(lambda_0=0.17 / 1.5, Delta_1=0.01, Delta_2=0.2, Delta_u=0.93)


@pytest.mark.parametrize(
    "model",
    # three_branch also runs (faster to compile) in test_facade_on_moving_walls_matches_ida
    ["dem", "housner", pytest.param("three_branch", marks=pytest.mark.slow)],
)
def test_runner_matches_ida(study, model):
    """The study's batches give rj.ida's collapse flags and peaks for the same runs (the same
    simulators, padded to the same length: equal to round-off)."""
    block = rj.Block(b=0.17, h=1.5)
    recs = _ricker_set()
    scales = np.geomspace(0.05, 0.6, 5)
    beta = 2.2e-3 if model == "dem" else None
    law = LAW if model == "three_branch" else None
    (g,) = study.group_records(recs)
    t_end = (g.n - 1) * g.dt
    model_obj = rj.as_model(model, beta=beta, law=law)
    ds = rj.ida(block, recs, scales, model=model_obj, t_end=t_end, progress=False)
    rows = np.repeat(np.arange(len(recs)), scales.size)
    col, status, peak = study.run_pairs(
        block,
        model,
        "two_sided",
        beta,
        g,
        g.ag,
        None,
        rows,
        np.tile(scales, len(recs)),
        4,
        law=law,
    )
    np.testing.assert_array_equal(status, 0)
    np.testing.assert_array_equal(col, np.asarray(ds["collapse"]).ravel())
    # peaks of runs that stood (a run that overturned stops just past eta in both)
    ok = ~col
    np.testing.assert_allclose(
        peak[ok], np.asarray(ds["max_theta_over_eta"]).ravel()[ok], rtol=1e-9, atol=1e-12
    )
    assert col.any() and (~col).any()  # the grid brackets the capacities


@pytest.mark.slow  # ~30 s; tests/test_ida.py checks the IDA's wall motion against single runs
def test_facade_on_moving_walls_matches_ida(study):
    """A three-branch facade on return walls moving with a building: the study's precomputed,
    scaled wall motion gives rj.ida(..., wall_motion=bldg)'s results, which compute the
    building's response to each scaled record (a linear building: equal to round-off)."""
    block = rj.Block(b=0.17, h=1.5)
    recs = _ricker_set()
    scales = np.array([0.1, 0.25, 0.5, 1.0])
    (g,) = study.group_records(recs)
    bldg = rj.ShearBuilding.uniform(2, 3.2, 0.2, 0.05)
    inputs = study.Inputs([g], {"2st": bldg}, [1.5])
    ds = rj.ida(
        block,
        recs,
        scales,
        model=rj.ThreeBranch(LAW),
        mode=rj.Facade(),
        wall_motion=bldg,
        t_end=(g.n - 1) * g.dt,
        progress=False,
    )
    rows = np.repeat(np.arange(len(recs)), scales.size)
    col, status, peak = study.run_pairs(
        block,
        "three_branch",
        "one_sided",
        None,
        g,
        g.ag,
        inputs.wall[("2st", 0, 1.5)],
        rows,
        np.tile(scales, len(recs)),
        4,
        law=LAW,
    )
    np.testing.assert_array_equal(status, 0)
    np.testing.assert_array_equal(col, np.asarray(ds["collapse"]).ravel())
    ok = ~col
    np.testing.assert_allclose(
        peak[ok], np.asarray(ds["max_theta_over_eta"]).ravel()[ok], rtol=1e-8, atol=1e-12
    )
    assert col.any() and (~col).any()


def test_fit_law_recovers_a_known_law(study):
    """The calibration of the paper's Fig. 9 on a synthetic pushover: the known law sampled up
    to zero capacity, then a fall far below the law's line (a falling block, which the fit must
    drop). Reference: the known Deltas (the fit is exact on exact data: the library documents
    1e-7; 1e-4 allowed), lambda_0 held at b/h."""
    b_over_h = 0.25 / 3.0
    true = rj.ThreeBranchLaw(lambda_0=b_over_h, Delta_1=0.02, Delta_2=0.3, Delta_u=0.9)
    d = np.linspace(0.0, 1.0, 201)
    lam = np.array(true.load_multiplier(d))
    past = d > 0.9 + 1e-12
    lam[past] = -5.0 * b_over_h * (d[past] - 0.9) ** 0.5  # falls much faster than the line
    fit = study.fit_law(d, lam, b_over_h)
    assert float(fit.law.lambda_0) == pytest.approx(b_over_h, rel=1e-12)
    for k in ("Delta_1", "Delta_2", "Delta_u"):
        assert float(getattr(fit.law, k)) == pytest.approx(float(getattr(true, k)), abs=1e-4)
    held = d <= 0.9  # the law itself where the block is held
    np.testing.assert_allclose(
        np.asarray(fit.law.load_multiplier(d[held])), lam[held], rtol=0, atol=1e-6 * b_over_h
    )
    # without the cut the falling tail pulls the descent: the cut is what the test checks
    whole = rj.fit_three_branch(
        types.SimpleNamespace(d_over_b=d, load_multiplier=lam), lambda_0=b_over_h
    )
    assert abs(float(whole.law.Delta_u) - 0.9) > 1e-3


def test_cache_refuses_another_law(study, tmp_path):
    """A cached three-branch case is read back only for the same law (and the same grid)."""
    coarse = np.geomspace(0.02, 4.0, 5)
    per_rec = {
        "A": dict(
            scales=coarse,
            collapse=np.array([0, 0, 1, 1, 1], bool),
            status=np.zeros(5, int),
            peak=np.linspace(0.1, 1.2, 5),
        )
    }
    path = tmp_path / "case.npz"
    study.save_case(path, per_rec, 1.5, LAW)
    back, seconds = study.load_case(path, coarse, LAW)
    assert seconds == 1.5 and back["A"]["capacity_g"] == coarse[2]
    other = rj.ThreeBranchLaw(lambda_0=0.17 / 1.5, Delta_1=0.01, Delta_2=0.21, Delta_u=0.93)
    assert study.load_case(path, coarse, other) == (None, None)
    assert study.load_case(path, coarse, None) == (None, None)  # a rigid (Housner) case
    study.save_case(path, per_rec, 1.5)
    assert study.load_case(path, coarse, None)[0]["A"]["capacity_g"] == coarse[2]
    assert study.load_case(path, coarse, LAW) == (None, None)


def test_model_ratio_table(study):
    """Per-record ratios between models against a direct computation on made-up capacities;
    a censored record (no collapse) is counted apart."""
    rng = np.random.default_rng(1)
    caps = {m: rng.uniform(0.05, 0.5, 9) for m in study.MODELS}
    caps["dem"][3] = math.inf
    rows = [
        dict(geometry="g", element="facade", base="fixed", model=m, record=f"r{i}", capacity_g=c)
        for m in study.MODELS
        for i, c in enumerate(caps[m])
    ]
    table = {t["ratio"]: t for t in study.model_ratio_table(rows)}
    assert set(table) == set(study.MODEL_RATIOS)
    for name, (num, den) in study.MODEL_RATIOS.items():
        v = caps[num] / caps[den]
        v = v[np.isfinite(v) & (v > 0)]
        t = table[name]
        assert t["n_pairs"] + t["n_censored_pairs"] == 9
        assert t["n_pairs"] == v.size
        assert t["median"] == pytest.approx(np.median(v), rel=1e-12)
        assert t["frac_below_1"] == pytest.approx(np.mean(v < 1))


@pytest.mark.slow
def test_quick_run_writes_its_results(study, tmp_path):
    summary = study.main(["--quick", "--out", str(tmp_path)])
    for name in (
        "capacities.csv",
        "capacity_table.csv",
        "ratios.csv",
        "model_ratios.csv",
        "three_branch_laws.csv",
        "summary.json",
    ):
        assert (tmp_path / name).exists()
    for name in summary["figures"]:
        assert (tmp_path / name).exists()
    saved = json.loads((tmp_path / "summary.json").read_text())
    assert {r["ratio"] for r in saved["ratios"]} == set(study.RATIOS)
    assert all(r["n_pairs"] + r["n_censored_pairs"] == 4 for r in saved["ratios"])
    assert {r["model"] for r in saved["ratios"]} == set(study.MODELS)
    assert {(r["element"], r["mode"]) for r in saved["three_branch_laws"]} == {
        ("parapet", "two_sided"),
        ("facade", "one_sided"),
    }
    for r in saved["three_branch_laws"]:  # lambda_0 held at b/h, the Deltas in order
        assert r["lambda_0"] == pytest.approx(r["b"] / r["h"], rel=1e-12)
        assert 0 <= r["Delta_1"] <= r["Delta_2"] < r["Delta_u"] <= 1.0
