"""The building study's pieces (experiments/building_study.py) against the library's own IDA.

The study batches its runs itself (rj.ida has no wall motion), so these tests check that its
batching and its capacity rule give what rj.ida and rj.collapse_intervals give for the same
runs, and (slow) that the --quick path writes its tables and figures.
"""

import importlib.util
import json
import math
import pathlib

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


@pytest.mark.parametrize("model", ["dem", "housner"])
def test_runner_matches_ida(study, model):
    """The study's batches give rj.ida's collapse flags and peaks for the same runs (the same
    simulators, padded to the same length: equal to round-off)."""
    block = rj.Block(b=0.17, h=1.5)
    recs = _ricker_set()
    scales = np.geomspace(0.05, 0.6, 5)
    beta = 2.2e-3 if model == "dem" else None
    (g,) = study.group_records(recs)
    t_end = (g.n - 1) * g.dt
    ds = rj.ida(block, recs, scales, model=model, beta=beta, t_end=t_end, progress=False)
    rows = np.repeat(np.arange(len(recs)), scales.size)
    col, status, peak = study.run_pairs(
        block, model, "two_sided", beta, g, g.ag, None, rows, np.tile(scales, len(recs)), 4
    )
    np.testing.assert_array_equal(status, 0)
    np.testing.assert_array_equal(col, np.asarray(ds["collapse"]).ravel())
    # peaks of runs that stood (a run that overturned stops just past eta in both)
    ok = ~col
    np.testing.assert_allclose(
        peak[ok], np.asarray(ds["max_theta_over_eta"]).ravel()[ok], rtol=1e-9, atol=1e-12
    )
    assert col.any() and (~col).any()  # the grid brackets the capacities


@pytest.mark.slow
def test_quick_run_writes_its_results(study, tmp_path):
    summary = study.main(["--quick", "--out", str(tmp_path)])
    for name in ("capacities.csv", "capacity_table.csv", "ratios.csv", "summary.json"):
        assert (tmp_path / name).exists()
    for name in summary["figures"]:
        assert (tmp_path / name).exists()
    saved = json.loads((tmp_path / "summary.json").read_text())
    assert {r["ratio"] for r in saved["ratios"]} == set(study.RATIOS)
    assert all(r["n_pairs"] + r["n_censored_pairs"] == 4 for r in saved["ratios"])
