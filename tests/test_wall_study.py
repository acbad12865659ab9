"""The wall study (experiments/wall_study.py): its limit analysis is the library's, and (slow:
~30 s of CPU, mostly compiling the two-block DEM) its --quick path runs end to end and writes
sane tables (no NaN, capacities on the sampled scales, the limit analysis it printed)."""

import csv
import importlib.util
import json
import math
import pathlib

import numpy as np
import pytest

import rockjax as rj
from rockjax.constants import G

PATH = pathlib.Path(__file__).parents[1] / "experiments" / "wall_study.py"

MULTIPLIER_RTOL = 1e-12
"""The study's multipliers are rj.collapse_multiplier's: the same float64 operations."""


@pytest.fixture(scope="module")
def study():
    spec = importlib.util.spec_from_file_location("wall_study", PATH)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def quick(study, tmp_path_factory):
    out = tmp_path_factory.mktemp("wall_study")
    return study.main(["--quick", "--out", str(out)]), out


@pytest.mark.slow
def test_quick_outputs_are_sane(study, quick):
    result, out = quick
    rows = list(csv.DictReader((out / "capacities.csv").read_text().splitlines()))
    assert {r["case"] for r in rows} == set(study.QUICK_CASES)
    coarse = study.QUICK["coarse"]
    ratio = coarse[1] / coarse[0]
    for r in rows:
        cap = float(r["capacity_g"])
        assert not math.isnan(cap)
        # the lowest and highest scales the two stages can sample
        assert math.isinf(cap) or coarse[0] / ratio <= cap <= coarse[-1] * ratio
        assert int(r["n_failed"]) == 0
    summary = list(csv.DictReader((out / "summary.csv").read_text().splitlines()))
    assert all(not math.isnan(float(s["median_g"])) for s in summary)
    assert (out / "wall_study.png").stat().st_size > 0
    written = json.loads((out / "summary.json").read_text())
    assert written["records"] == result["records"]
    assert written["limits"] == study.limit_analysis(study.cases())


def test_limit_analysis_is_collapse_multiplier(study):
    # Reference: rj.collapse_multiplier on the walls built here, and the closed form of the
    # restrained two-block hinge, (b/h)(2 + 1.5 P/W) (docs/assemblies.md).
    limits = study.limit_analysis(study.cases())
    blk = rj.Block(b=0.23, h=1.5)
    p = float(blk.rho) * G * 0.23 * 3.0  # the storey above's wall, 0.23 x 3.0 m
    wall = rj.Assembly.stack([blk, blk], top="restrained", overburden=p)
    ref = float(rj.collapse_multiplier(wall, "hinge"))
    assert limits["wall2"]["hinge"] == pytest.approx(ref, rel=MULTIPLIER_RTOL)
    w = float(blk.m) * G
    assert ref == pytest.approx(0.23 / 1.5 * (2 + 1.5 * p / w), rel=1e-12)
    for name, (asm, _, _, mechanisms) in study.cases().items():
        for m in mechanisms:
            assert limits[name][m] == pytest.approx(
                float(rj.collapse_multiplier(asm, m)), rel=MULTIPLIER_RTOL
            )
    assert math.isinf(limits["wall1_restrained"]["governing"])
    par = rj.Block(b=0.23, h=1.0)
    assert limits["parapet_roof"]["stack"] == pytest.approx(float(np.tan(par.eta)), rel=1e-12)
