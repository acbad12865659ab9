"""Hostile inputs: every one must end in a clear error, never in a silent wrong result.

A table of bad inputs to the public API, the command line, the record readers, batches and
campaigns. Each case asserts the exception type, that the message names the argument at fault
(by the name the caller used: ``b``, ``--scales``, the file and its line) and that it says how
to fix it (a unit, an example value, the function to use). Batches assert the other contract:
one bad lane is flagged in its own ``status`` and leaves the others as they were.

The suite's runtime type checks (jaxtyping, under pytest only) are switched off inside each
case, so the test sees what a user sees: the library's own checks, not the test harness's.
"""

from __future__ import annotations

import dataclasses
import re
import types
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import xarray as xr

import rockjax as rj
from rockjax import campaign
from rockjax.cli import main as cli_main
from rockjax.response import STATUS_OK

BLOCK = rj.Block(b=0.25, h=1.5)  # eta = 0.165 rad, p = 2.5 rad/s
GM = rj.GroundMotion.ricker(pga_g=0.1, period=0.3, dt=0.01, duration=0.5, name="gm")
SQUAT = dict(b=1.0, h=0.5)  # eta = 63 deg: Housner's e_H = 1 - 1.5 sin^2(eta) = -0.2 < 0
NAN, INF = float("nan"), float("inf")


# every case runs as a user calls: without the test-only jaxtyping/beartype checks
pytestmark = pytest.mark.usefixtures("user_view")


@dataclasses.dataclass(frozen=True)
class Bad:
    """A hostile call and what its error must say."""

    call: Callable[[], object]
    name: str  # regex: the argument the message must name
    fix: str  # regex (case-insensitive): the fix the message must give
    exc: type[BaseException] = ValueError


def _xfail(owner: str, what: str):
    return pytest.mark.xfail(strict=True, reason=f"{owner}: {what}")


def _case(id_: str, call, name: str, fix: str, exc=ValueError, owner=None, what=""):
    marks = () if owner is None else (_xfail(owner, what),)
    return pytest.param(Bad(call, name, fix, exc), id=id_, marks=marks)


def _assert_clear(message: str, name: str, fix: str) -> None:
    """``message`` names the argument (regex ``name``) and gives the fix (regex ``fix``)."""
    assert re.search(name, message), f"the message does not name {name!r}: {message}"
    assert re.search(fix, message, re.IGNORECASE), f"no fix {fix!r} in: {message}"


def _assert_refused(case: Bad) -> None:
    with pytest.raises(case.exc) as info:
        case.call()
    _assert_clear(str(info.value), case.name, case.fix)


def _zeros_gm(n=50, dt=0.01):
    return rj.GroundMotion(ag=np.zeros(n), dt=dt, name="still")


# ----------------------------------------------------------------------------- Block

BLOCK_CASES = [
    _case("b-text", lambda: rj.Block(b="0.25", h=3.0), r"\bb\b", r"b=0\.25 without quotes"),
    _case("h-text-bytes", lambda: rj.Block(b=0.25, h=b"3"), r"\bh\b", "without quotes"),
    _case("b-none", lambda: rj.Block(b=None, h=3.0), r"\bb\b", r"e\.g\. b=0\.25|number"),
    _case("b-bool", lambda: rj.Block(b=True, h=3.0), r"\bb\b", r"number"),
    _case("b-dict", lambda: rj.Block(b={"b": 0.25}, h=3.0), r"\bb\b", r"number"),
    _case("b-complex", lambda: rj.Block(b=0.25 + 1j, h=3.0), r"\bb\b", r"number"),
    _case("b-zero", lambda: rj.Block(b=0.0, h=3.0), r"\bb\b", r"e\.g\. b=0\.25"),
    _case("b-negative", lambda: rj.Block(b=-0.25, h=3.0), r"\bb\b", r"e\.g\. b=0\.25"),
    _case("b-nan", lambda: rj.Block(b=NAN, h=3.0), r"\bb\b", r"e\.g\. b=0\.25"),
    _case("h-inf", lambda: rj.Block(b=0.25, h=INF), r"\bh\b", r"e\.g\. h=3"),
    _case("b-mm", lambda: rj.Block(b=250.0, h=3.0), r"\bb\b", r"millimetres.*divide by 1000"),
    _case("h-mm", lambda: rj.Block(b=0.25, h=3000.0), r"\bh\b", r"millimetres"),
    _case("b-1e200", lambda: rj.Block(b=1e200, h=1.0), r"\bb\b", r"millimetres"),
    _case("E-mpa", lambda: rj.Block(b=0.25, h=3.0, E=1800.0), r"\bE\b", r"MPa.*1e6"),
    _case("E-zero", lambda: rj.Block(b=0.25, h=3.0, E=0.0), r"\bE\b", r"pascals"),
    _case("rho-zero", lambda: rj.Block(b=0.25, h=3.0, rho=0.0), r"\brho\b", r"kg/m\^3"),
    _case("rho-t-per-m3", lambda: rj.Block(b=0.25, h=3.0, rho=1.8), r"\brho\b", r"t/m\^3"),
    _case("nu-half", lambda: rj.Block(b=0.25, h=3.0, nu=0.5), r"\bnu\b", r"\(-1, 0\.5\)"),
    _case("nu-nan", lambda: rj.Block(b=0.25, h=3.0, nu=NAN), r"\bnu\b", r"\(-1, 0\.5\)"),
    _case("length-text", lambda: rj.Block(b=0.25, h=3.0, length="1"), r"\blength\b", "quotes"),
    _case("nu-text", lambda: rj.Block(b=0.25, h=3.0, nu="0.2"), r"\bnu\b", "quotes"),
    _case("b-array", lambda: rj.Block(b=np.array([0.2, 0.3]), h=3.0), r"\bb\b", r"vmap"),
    _case("nu-array", lambda: rj.Block(b=0.25, h=3.0, nu=[0.2, 0.25]), r"\bnu\b", r"vmap"),
    _case("b-array-of-text", lambda: rj.Block(b=np.array(["0.25"]), h=3.0), r"\bb\b", "number"),
    _case("b-1e-300", lambda: rj.Block(b=1e-300, h=1.0), r"\bb\b.*\bm\b", r"in metres.*b=0\.25"),
    _case("h-1e-300", lambda: rj.Block(b=0.25, h=1e-300), r"\bh\b.*\bm\b", r"in metres"),
]


@pytest.mark.parametrize("case", BLOCK_CASES)
def test_block_refuses(case: Bad):
    _assert_refused(case)


# ----------------------------------------------------------------------------- GroundMotion

_T_DECREASING = [0.0, -0.01, -0.02, -0.03]
_T_REPEATED = [0.0, 0.01, 0.01, 0.02]

MOTION_CASES = [
    _case("ag-text", lambda: rj.GroundMotion(ag="0 1 0", dt=0.01), r"\bag\b", r"to numbers"),
    _case("ag-list-of-text", lambda: rj.GroundMotion(ag=["0", "1"], dt=0.01), r"\bag\b", "array"),
    _case("ag-2d", lambda: rj.GroundMotion(ag=np.zeros((3, 4)), dt=0.01), r"\bag\b", "one record"),
    _case("ag-1-sample", lambda: rj.GroundMotion(ag=[0.0], dt=0.01), r"\bag\b", "at least 2"),
    _case("ag-empty", lambda: rj.GroundMotion(ag=[], dt=0.01), r"\bag\b", "at least 2"),
    _case(
        "ag-nan",
        lambda: rj.GroundMotion(ag=[0.0, NAN, 0.0], dt=0.01),
        r"\bag\b",
        r"clean or trim",
    ),
    _case(
        "ag-cm-s2",
        lambda: rj.GroundMotion(ag=[0.0, 294.0, -150.0], dt=0.01),
        r"\bag\b",
        r"cm/s\^2.*ag / 100",
    ),
    _case(
        "ag_v-shape",
        lambda: rj.GroundMotion(ag=np.zeros(5), dt=0.01, ag_v=np.zeros(4)),
        r"\bag_v\b",
        "same shape",
    ),
    _case("dt-zero", lambda: rj.GroundMotion(ag=np.zeros(5), dt=0.0), r"\bdt\b", r"dt=0\.01"),
    _case("dt-negative", lambda: rj.GroundMotion(ag=np.zeros(5), dt=-0.01), r"\bdt\b", r"dt=0\.01"),
    _case("dt-text", lambda: rj.GroundMotion(ag=np.zeros(5), dt="0.01"), r"\bdt\b", "quotes"),
    _case(
        "dt-array",
        lambda: rj.GroundMotion(ag=np.zeros(5), dt=np.array([0.01, 0.02])),
        r"\bdt\b",
        "one number",
    ),
    _case(
        "meta-dict",
        lambda: rj.GroundMotion(ag=np.zeros(5), dt=0.01, meta={"event": "x"}),
        r"\bmeta\b",
        r"with_metadata",
    ),
    _case(
        "from_g-in-cm",
        lambda: rj.GroundMotion.from_g([0.0, 294.0, -100.0], dt=0.01),
        r"\bag_g\b",
        r"in g",
    ),
    _case(
        "time-decreasing",
        lambda: rj.GroundMotion.from_time_series(_T_DECREASING, [0.0, 1.0, 0.0, 1.0]),
        r"\bt\b",
        r"increas",
    ),
    _case(
        "time-repeated",
        lambda: rj.GroundMotion.from_time_series(_T_REPEATED, [0.0, 1.0, 0.0, 1.0]),
        r"\bt\b",
        r"increas",
    ),
    _case(
        "time-nonuniform",
        lambda: rj.GroundMotion.from_time_series([0.0, 0.01, 0.03, 0.04], [0.0, 1.0, 0.0, 1.0]),
        r"\bt\b",
        r"resample",
    ),
    _case(
        "time-nan",
        lambda: rj.GroundMotion.from_time_series([0.0, NAN, 0.02, 0.03], [0.0, 1.0, 0.0, 1.0]),
        r"\bt\b",
        r"finite",
    ),
    _case(
        "time-length",
        lambda: rj.GroundMotion.from_time_series([0.0, 0.01, 0.02], [0.0, 1.0]),
        r"\bt\b.*\bag\b",
        "equal length",
    ),
    _case(
        "ricker-pga-nan",
        lambda: rj.GroundMotion.ricker(pga=NAN, period=0.3),
        r"\bpga\b",
        "finite number",
    ),
    _case(
        "ricker-pga-array",
        lambda: rj.GroundMotion.ricker(pga=[1.0, 2.0], period=0.3),
        r"\bpga\b",
        "one finite number",
    ),
    _case(
        "ricker-pga_g-in-m-s2",
        lambda: rj.GroundMotion.ricker(pga_g=39.0, period=0.3),
        r"\bpga_g\b",
        r"divide by 9\.80665",
    ),
    _case(
        "ricker-pga-and-pga_g",
        lambda: rj.GroundMotion.ricker(pga=1.0, pga_g=0.1, period=0.3),
        r"\bpga_g\b",
        r"exactly one",
    ),
    _case(
        "ricker-no-period",
        lambda: rj.GroundMotion.ricker(pga_g=0.1),
        r"\bperiod\b",
        r"period=0\.5",
    ),
    _case(
        "ricker-period-zero",
        lambda: rj.GroundMotion.ricker(pga_g=0.1, period=0.0),
        r"\bperiod\b",
        r"e\.g\.",
    ),
    _case(
        "ricker-period-text",
        lambda: rj.GroundMotion.ricker(pga_g=0.1, period="0.3"),
        r"\bperiod\b",
        "number",
    ),
    _case(
        "ricker-period-array",
        lambda: rj.GroundMotion.ricker(pga_g=0.1, period=np.array([0.3, 0.5])),
        r"\bperiod\b",
        "one number",
    ),
    _case(
        "ricker-dt-zero",
        lambda: rj.GroundMotion.ricker(pga_g=0.1, period=0.3, dt=0.0),
        r"\bdt\b",
        r"e\.g\.",
    ),
    _case(
        "ricker-t0-nan",
        lambda: rj.GroundMotion.ricker(pga_g=0.1, period=0.3, t0=NAN),
        r"\bt0\b",
        r"t0=1\.0",
    ),
    _case(
        "ricker-duration-nan",
        lambda: rj.GroundMotion.ricker(pga_g=0.1, period=0.3, duration=NAN),
        r"\bduration\b",
        r"e\.g\.",
    ),
    _case(
        "ricker-duration-huge",
        lambda: rj.GroundMotion.ricker(pga_g=0.1, period=0.3, duration=1e12),
        r"\bduration\b",
        r"shorte[rn] (the )?duration|coarser",
    ),
    _case(
        "sine-period-negative",
        lambda: rj.GroundMotion.sine_cycle(pga_g=0.1, period=-0.5),
        r"\bperiod\b",
        r"e\.g\.",
    ),
    _case(
        "zeros-duration-negative",
        lambda: rj.GroundMotion.zeros(-1.0),
        r"\bduration\b",
        r"e\.g\.",
    ),
    _case(
        "zeros-dt-milliseconds",
        lambda: rj.GroundMotion.zeros(10.0, dt=1e-9),
        r"\bduration\b|\bdt\b",
        r"coarser|shorter",
    ),
    _case("scaled-nan", lambda: GM.scaled(NAN), r"\bfactor\b", r"finite"),
    _case("scaled-text", lambda: GM.scaled("2"), r"\bfactor\b", r"quotes"),
    _case("scaled-huge", lambda: GM.scaled(1e4), r"\bag\b", r"below 10 g"),
    _case(
        "scaled_to_pga-none", lambda: GM.scaled_to_pga(), r"\btarget_pga\b", r"target_pga_g=0\.3"
    ),
    _case(
        "scaled_to_pga-zero",
        lambda: GM.scaled_to_pga(0.0),
        r"\btarget_pga\b",
        r"target_pga_g=0\.3",
    ),
    _case(
        "scaled_to_pga_g-in-m-s2",
        lambda: GM.scaled_to_pga(target_pga_g=30.0),
        r"\btarget_pga_g\b",
        r"divide by 9\.80665",
    ),
    _case(
        "scaled_to_pga-zeros-record",
        lambda: _zeros_gm().scaled_to_pga(target_pga_g=0.3),
        r"all zeros",
        r"cannot be scaled",
    ),
    _case("resampled-zero", lambda: GM.resampled(0.0), r"\bdt_new\b", r"e\.g\."),
    _case("resampled-huge", lambda: GM.resampled(1e-12), r"\bdt_new\b", r"coarser"),
    _case("resampled-too-long", lambda: GM.resampled(10.0), r"\bdt_new\b", r"smaller dt_new"),
    _case("baseline-order-0", lambda: GM.baseline_corrected(0), r"\border\b", r"order=1"),
    _case(
        "significant-duration-swapped",
        lambda: GM.significant_duration(0.95, 0.05),
        r"\blo\b.*\bhi\b",
        r"lo=0\.05, hi=0\.95",
    ),
]


@pytest.mark.parametrize("case", MOTION_CASES)
def test_ground_motion_refuses(case: Bad):
    _assert_refused(case)


# ----------------------------------------------------------------------------- simulators

_H, _D = rj.simulate_housner, rj.simulate_dem

SIMULATOR_CASES = [
    _case(
        "housner-motion-ndarray",
        lambda: _H(BLOCK, np.zeros(10)),
        r"\bmotion\b",
        r"GroundMotion\(",
    ),
    _case("housner-mode", lambda: _H(BLOCK, GM, mode="twosided"), r"\bmode\b", r"two_sided"),
    _case("housner-free-no-duration", lambda: _H(BLOCK), r"\bduration\b", r"duration=10"),
    _case("housner-duration-nan", lambda: _H(BLOCK, duration=NAN), r"\bduration\b", r"positive"),
    _case(
        "housner-duration-huge",
        lambda: _H(BLOCK, duration=1e12),
        r"\bduration\b",
        r"shorte[rn] (the )?duration",
    ),
    _case(
        "housner-duration-text",
        lambda: _H(BLOCK, duration="1.0"),
        r"\bduration\b",
        r"quotes",
    ),
    _case(
        "housner-dt-text",
        lambda: _H(BLOCK, duration=1.0, dt="0.01"),
        r"\bdt\b",
        r"quotes",
    ),
    _case("housner-dt-zero", lambda: _H(BLOCK, duration=1.0, dt=0.0), r"\bdt\b", r"dt=None"),
    _case("housner-e-above-1", lambda: _H(BLOCK, GM, e=1.5), r"\be\b", r"0 < e <= 1"),
    _case(
        "housner-e-text",
        lambda: _H(BLOCK, GM, e="0.9"),
        r"\be\b",
        r"quotes",
    ),
    _case(
        "housner-e-array",
        lambda: _H(BLOCK, GM, e=np.array([0.9, 0.8])),
        r"\be\b",
        r"vmap",
    ),
    _case(
        "housner-theta0-array",
        lambda: _H(BLOCK, GM, theta0=np.array([0.01, 0.02])),
        r"\btheta0\b",
        r"vmap",
    ),
    _case(
        "housner-theta0-beyond-eta",
        lambda: _H(BLOCK, GM, theta0=0.2),
        r"\btheta0\b",
        r"smaller",
    ),
    _case("housner-theta0-nan", lambda: _H(BLOCK, GM, theta0=NAN), r"\btheta0\b", r"finite"),
    _case(
        "housner-squat-default-e",
        lambda: _H(rj.Block(**SQUAT), duration=1.0),
        r"\be_H\b",
        r"pass e explicitly",
    ),
    _case(
        "housner-max-impacts-0",
        lambda: _H(BLOCK, GM, max_impacts_per_step=0),
        r"\bmax_impacts_per_step\b",
        r"default, 64",
    ),
    _case("dem-motion-list", lambda: _D(BLOCK, [0.0, 1.0]), r"\bmotion\b", r"GroundMotion"),
    _case("dem-mode", lambda: _D(BLOCK, GM, mode="facade"), r"\bmode\b", r"one_sided"),
    _case("dem-beta-negative", lambda: _D(BLOCK, GM, beta=-1e-3), r"\bbeta\b", r"Rayleigh"),
    _case("dem-beta-text", lambda: _D(BLOCK, GM, beta="0.002"), r"\bbeta\b", r"quotes"),
    _case(
        "dem-beta-array",
        lambda: _D(BLOCK, GM, beta=np.array([2e-3, 1e-3])),
        r"\bbeta\b",
        r"vmap",
    ),
    _case(
        "dem-theta0-text",
        lambda: _D(BLOCK, GM, theta0="0.01"),
        r"\btheta0\b",
        r"quotes",
    ),
    _case(
        "dem-theta0-array",
        lambda: _D(BLOCK, GM, theta0=np.array([0.01, 0.02])),
        r"\btheta0\b",
        r"vmap",
    ),
    _case(
        "dem-theta0-beyond-eta",
        lambda: _D(BLOCK, GM, theta0=0.2),
        r"\btheta0\b",
        r"theta0 = 0\.5 \* block\.eta",
    ),
    _case(
        "dem-gap-negative",
        lambda: _D(BLOCK, GM, mode="one_sided", gap=-1e-3),
        r"\bgap\b",
        r"e\.g\. 0\.001",
    ),
    _case("dem-phi-95", lambda: _D(BLOCK, GM, phi_deg=95.0), r"\bphi_deg\b", r"\(0, 90\)"),
    _case("dem-dt-unstable", lambda: _D(BLOCK, GM, dt=1.0), r"\bdt\b", r"leave dt=None"),
    _case(
        "dem-dt-text",
        lambda: _D(BLOCK, GM, dt="0.001"),
        r"\bdt\b",
        r"quotes",
    ),
    _case("dem-accuracy-0", lambda: _D(BLOCK, GM, accuracy=0.0), r"\baccuracy\b", r"None"),
    _case("dem-save-unknown", lambda: _D(BLOCK, GM, save=("energy", "stress")), r"save", r"energy"),
    _case(
        "dem-save-string",
        lambda: _D(BLOCK, GM, save="energy"),
        r"\bsave\b",
        r"save=\(.energy.,\)",
    ),
    _case("dem-free-no-duration", lambda: _D(BLOCK), r"\bduration\b", r"duration=5"),
    _case(
        "dem-duration-nan",
        lambda: _D(BLOCK, GM, duration=NAN),
        r"\bduration\b",
        r"positive",
    ),
    _case(
        "dem-duration-inf",
        lambda: _D(BLOCK, GM, duration=INF),
        r"\bduration\b",
        r"positive",
    ),
    _case(
        "dem-duration-huge",
        lambda: _D(BLOCK, GM, duration=1e12),
        r"\bduration\b",
        r"shorte[rn] (the )?duration",
    ),
    _case(
        "dem-duration-text",
        lambda: _D(BLOCK, GM, duration="1"),
        r"\bduration\b",
        r"quotes",
    ),
    _case(
        "dem-free-duration-huge", lambda: _D(BLOCK, duration=1e12), r"\bduration\b", "shorte[rn]"
    ),
    _case(
        "dem-save_dt-zero",
        lambda: _D(BLOCK, duration=0.1, save_dt=0.0),
        r"\bsave_dt\b",
        r"save_dt=0\.002|e\.g\.",
    ),
    _case("stable_dt-beta-negative", lambda: rj.stable_dt(BLOCK, -1.0), r"\bbeta\b", r"Rayleigh"),
    _case("dem-block-none", lambda: _D(None, GM), r"\bblock\b.*None", r"rj\.Block\(b=0\.25"),
    _case("dem-block-ndarray", lambda: _D(np.ones(2), GM), r"\bblock\b", r"rj\.Block\("),
    _case("housner-block-none", lambda: _H(None, GM), r"\bblock\b.*None", r"rj\.Block\("),
    _case(
        "housner-assembly",
        lambda: _H(rj.Assembly.stack([BLOCK, BLOCK]), GM),
        r"\bblock\b.*Assembly",
        r"rj\.simulate_dem",
    ),
    _case(
        "assembly-of-a-block",
        lambda: rj.simulate_assembly(BLOCK, GM),
        r"\bassembly\b.*Block",
        r"rj\.simulate_dem\(block",
    ),
    _case(
        "dem-gap-two-sided",
        lambda: _D(BLOCK, GM, gap=1e-3),
        r"\bgap\b.*\bm\b.*ignored",
        r"mode='one_sided'",
    ),
    _case(
        "stable_dt-gap-two-sided",
        lambda: rj.stable_dt(BLOCK, 2e-3, gap=1e-3),
        r"\bgap\b.*ignored",
        r"mode='one_sided'",
    ),
    _case(
        "assembly-gap-two-sided",
        lambda: rj.simulate_assembly(rj.Assembly.stack([BLOCK, BLOCK]), GM, gap=1e-3),
        r"\bgap\b.*ignored",
        r"mode='one_sided'.*top='restrained'",
    ),
    _case(
        "housner-theta_dot0-nan",
        lambda: _H(BLOCK, GM, theta_dot0=NAN),
        r"\btheta_dot0\b.*rad/s",
        r"finite",
    ),
]


@pytest.mark.parametrize("case", SIMULATOR_CASES)
def test_simulator_refuses(case: Bad):
    _assert_refused(case)


# ----------------------------------------------------------------------------- batches
# One bad lane of a vmapped batch run with throw=False is flagged in its own status; the other
# lanes equal those of a batch of the same shape whose middle lane is valid. The batches share
# one compiled function per model (every lane input is batched data).


@jax.jit
def _housner_lanes(b, e, theta0):
    def one(b, e, theta0):
        return _H(rj.Block(b=b, h=1.5), GM, e=e, theta0=theta0, throw=False)

    return jax.vmap(one)(b, e, theta0)


def _assert_one_bad_lane(run, good: dict, bad: dict):
    out_bad = run(**{k: jnp.asarray(v) for k, v in bad.items()})
    out_good = run(**{k: jnp.asarray(v) for k, v in good.items()})
    status = np.asarray(out_bad.status)
    assert status[1] != STATUS_OK, f"the bad lane {bad} ran with status 0"
    assert np.all(status[[0, 2]] == STATUS_OK)
    assert np.all(np.asarray(out_good.status) == STATUS_OK)
    np.testing.assert_array_equal(
        np.asarray(out_bad.theta)[[0, 2]], np.asarray(out_good.theta)[[0, 2]]
    )


_B3, _TH3 = [0.25, 0.25, 0.25], [0.08, 0.08, 0.08]  # theta0 ~ eta / 2: the lanes rock


def test_housner_batch_one_bad_e():
    _assert_one_bad_lane(
        _housner_lanes,
        dict(b=_B3, e=[0.9, 0.5, 0.95], theta0=_TH3),
        dict(b=_B3, e=[0.9, 1.5, 0.95], theta0=_TH3),
    )


def test_housner_batch_one_theta0_beyond_eta():
    e3 = [0.9, 0.9, 0.9]
    _assert_one_bad_lane(
        _housner_lanes,
        dict(b=_B3, e=e3, theta0=[0.08, 0.05, 0.03]),
        dict(b=_B3, e=e3, theta0=[0.08, 0.25, 0.03]),
    )


def test_housner_batch_one_zero_width():
    e3 = [0.9, 0.9, 0.9]
    _assert_one_bad_lane(
        _housner_lanes,
        dict(b=[0.2, 0.25, 0.3], e=e3, theta0=[0.02, 0.02, 0.02]),
        dict(b=[0.2, 0.0, 0.3], e=e3, theta0=[0.02, 0.02, 0.02]),
    )


def test_housner_traced_zero_width_names_b():
    run = jax.vmap(lambda b: _H(rj.Block(b=b, h=1.5), GM).status)
    with pytest.raises(eqx.EquinoxRuntimeError) as info:
        run(jnp.array([0.2, 0.0, 0.3]))
    # the messages of the failed checks, without the stack equinox prints around them
    messages = re.findall(r"EquinoxRuntimeError: (.*)", str(info.value))
    assert any(re.search(r"\bb\b", m) for m in messages), messages


def test_dem_batch_one_negative_beta():
    dt = rj.stable_dt(BLOCK, 2e-3)

    def run(beta):
        return jax.vmap(lambda beta: _D(BLOCK, GM, beta=beta, dt=dt, throw=False))(beta)

    _assert_one_bad_lane(run, dict(beta=[2e-3, 1e-3, 2e-3]), dict(beta=[2e-3, -1e-3, 2e-3]))


# Traced inputs pass the concrete guards of Block and GroundMotion: a block 1e200 m wide (NaN
# energy) or a record with a NaN sample (while the block rests) must still be flagged.


@jax.jit
def _housner_status(b, ag):
    return _H(rj.Block(b=b, h=1.5), rj.GroundMotion(ag=ag, dt=GM.dt), e=0.9, throw=False).status


@jax.jit
def _dem_status(b, ag):
    motion = rj.GroundMotion(ag=ag, dt=GM.dt)
    return _D(rj.Block(b=b, h=1.5), motion, dt=1e-4, throw=False).status


def _with_nan(ag):
    ag = np.array(ag, dtype=float)
    ag[20] = np.nan
    return ag


@pytest.mark.parametrize("status", [_housner_status, _dem_status], ids=["housner", "dem"])
def test_traced_huge_block_is_flagged(status):
    assert int(status(1e200, GM.ag)) != STATUS_OK


@pytest.mark.parametrize("status", [_housner_status, _dem_status], ids=["housner", "dem"])
def test_traced_nan_in_record_is_flagged(status):
    assert int(status(0.25, _with_nan(np.zeros(GM.n)))) != STATUS_OK


def _nan_record():
    """A record at rest with one NaN sample, put in after construction (bypassing its check)."""
    return eqx.tree_at(lambda g: g.ag, _zeros_gm(), jnp.asarray(_with_nan(np.zeros(50))))


def test_housner_nan_in_record_at_rest():
    with pytest.raises(ValueError, match=r"\bag\b.*non-finite|non-finite.*\bag\b"):
        _H(BLOCK, _nan_record())


def test_dem_nan_in_record_names_the_record():
    with pytest.raises(ValueError, match=r"\bag\b.*non-finite|non-finite.*\bag\b"):
        _D(BLOCK, _nan_record())


# ----------------------------------------------------------------------------- units, geometry
# A value in another unit (millimetres, Hz, percent) or outside a model's validity is refused
# when no reading of it is right, and run with a PlausibilityWarning naming the fix when it
# could still be meant; a wrong kind of body is refused naming what to pass.

_BLDG = rj.ShearBuilding.uniform(n_storeys=2, storey_height=3.0, period=0.2)
_WALL = rj.Assembly.stack([BLOCK, BLOCK])
_HELD = rj.Assembly.stack([BLOCK, BLOCK], top="restrained", gap=1e-3)
_MM = 5.0 * np.sin(np.linspace(0.0, np.pi, GM.n))  # a wall's 5 mm typed as 5 (m)


def _capacity_in_percent():
    x = np.linspace(0.0, 95.0, 20)  # d/b in percent
    return types.SimpleNamespace(d_over_b=x, load_multiplier=(0.25 / 1.5) * (1.0 - x / 100.0))


UNIT_CASES = [
    _case(
        "storey_height-mm",
        lambda: rj.ShearBuilding.uniform(n_storeys=3, storey_height=3000.0, period=0.3),
        r"\bstorey_height\b.*\bm\b",
        r"millimetres.*divide by 1000",
    ),
    _case(
        "storey_heights-mm",
        lambda: rj.ShearBuilding(masses=[1e5], stiffnesses=[1e8], storey_heights=[3000.0]),
        r"\bstorey_heights\b.*\bm\b",
        r"millimetres.*divide by 1000",
    ),
    _case(
        "wall_top_motion-height-mm",
        lambda: rj.wall_top_motion(_BLDG, GM, height=4500.0),
        r"\bheight\b.*\bm\b",
        r"millimetres",
    ),
    _case(
        "wall_top_motion-pair-height-mm",
        lambda: rj.wall_top_motion([(3000.0, GM)], GM, height=3.0),
        r"wall_motion\[0\] height.*\bm\b",
        r"millimetres",
    ),
    _case(
        "dem-wall_motion-mm",
        lambda: _D(BLOCK, GM, mode="one_sided", wall_motion=(_MM, np.zeros(GM.n))),
        r"wall_motion.*\bu_top\b.*\bm\b",
        r"millimetres.*divide u_top and v_top by 1000",
    ),
    _case(
        "housner-wall_motion-mm",
        lambda: _H(BLOCK, GM, mode="one_sided", wall_motion=(_MM, np.zeros(GM.n))),
        r"wall_motion.*\bu_top\b.*\bm\b",
        r"millimetres",
    ),
    _case(
        "assembly-wall_motion-mm",
        lambda: rj.simulate_assembly(
            _WALL, GM, mode="one_sided", wall_motion=(_MM, np.zeros(GM.n))
        ),
        r"wall_motion.*\bu_top\b.*\bm\b",
        r"millimetres",
    ),
    _case(
        "support_motion-mm",
        lambda: rj.simulate_assembly(_HELD, GM, support_motion=(_MM, np.zeros(GM.n))),
        r"support_motion.*\bu\b.*\bm\b",
        r"millimetres",
    ),
    _case(
        "three-branch-percent",
        lambda: rj.ThreeBranchLaw(lambda_0=0.08, Delta_1=4.0, Delta_2=20.0, Delta_u=90.0),
        r"\bDelta_u\b.*fractions of b",
        r"percent.*divide.*by 100.*Delta_u=0\.9",
    ),
    _case(
        "three-branch-fit-percent",
        lambda: rj.fit_three_branch(_capacity_in_percent()),
        r"\bd_over_b\b",
        r"percent.*divide it by 100",
    ),
    _case(
        "pushover-d_over_b-percent",
        lambda: rj.pushover(BLOCK, d_over_b=100.0),
        r"\bd_over_b\b.*over b",
        r"d_over_b=1\.0|divide by 100",
    ),
    _case("pushover-block-none", lambda: rj.pushover(None), r"\bblock\b.*None", r"rj\.Block\("),
    _case(
        "pushover-gap-two-sided",
        lambda: rj.pushover(BLOCK, gap=1e-3),
        r"\bgap\b.*ignored",
        r"mode='one_sided'",
    ),
    _case(
        "stack-one-block",
        lambda: rj.Assembly.stack(BLOCK),
        r"\bblocks\b.*Block",
        r"Assembly\.stack\(\[block\]\)",
    ),
    _case("stack-none", lambda: rj.Assembly.stack(None), r"\bblocks\b.*None", r"\[block\]"),
    _case(
        "stack-free-top-gap",
        lambda: rj.Assembly.stack([BLOCK, BLOCK], gap=1e-3),
        r"\bgap\b.*\bm\b.*ignored",
        r"top='restrained'",
    ),
    _case(
        "stack-gap-negative",
        lambda: rj.Assembly.stack([BLOCK, BLOCK], top="restrained", gap=-1e-3),
        r"\bgap\b.*\bm\b",
        r"e\.g\. 0\.002",
    ),
    _case(
        "collapse_multiplier-block",
        lambda: rj.collapse_multiplier(BLOCK),
        r"\bassembly\b.*Block",
        r"Assembly\.stack\(\[block\]\)",
    ),
    _case(
        "collapse_multiplier-none",
        lambda: rj.collapse_multiplier(None),
        r"\bassembly\b.*None",
        r"b/h",
    ),
]


@pytest.mark.parametrize("case", UNIT_CASES)
def test_units_and_kinds_refused(case: Bad):
    _assert_refused(case)


# (call, name regex, fix regex): run, with a warning that names the argument and the fix
WARN_CASES = [
    pytest.param(
        lambda: rj.ShearBuilding.uniform(n_storeys=3, storey_height=3.0, period=10.0),
        r"\bperiod\b.*\bs\b",
        r"Hz.*period=0\.1 for 10 Hz",
        id="period-in-hz",
    ),
    pytest.param(
        lambda: rj.stable_dt(BLOCK, 2e-3, mode="one_sided", gap=1.0),
        r"\bgap\b.*\bm\b",
        r"millimetres.*gap=0\.001 for 1 mm",
        id="facade-gap-mm",
    ),
    pytest.param(
        lambda: rj.Assembly.stack([BLOCK, BLOCK], top="restrained", gap=2.0),
        r"\bgap\b.*\bm\b",
        r"millimetres",
        id="restraint-gap-mm",
    ),
    pytest.param(
        lambda: rj.pushover(BLOCK, duration=1.0, n_out=20),
        r"\bduration\b.*\bs\b",
        r"duration >= 3\d\.\d+ s|duration=None",
        id="pushover-too-fast",
    ),
]


@pytest.mark.parametrize("call, name, fix", WARN_CASES)
def test_implausible_values_warned(call, name, fix):
    with pytest.warns(rj.PlausibilityWarning) as record:
        call()
    messages = [str(w.message) for w in record if issubclass(w.category, rj.PlausibilityWarning)]
    _assert_clear(messages[0], name, fix)


def test_plausible_values_run_quietly():
    """The limits leave usual values alone (the suite turns any warning into an error): a
    3-storey building at 2 s (flexible, or base-isolated) and a 30-storey one at 10 s, a 5 cm
    facade gap, a restraint clearance of 2 cm, a block of 5 mm (a thin specimen), a
    three-branch law with Delta_u = 1.2 (past the rigid block's 1)."""
    rj.ShearBuilding.uniform(n_storeys=3, storey_height=3.0, period=2.0)
    rj.ShearBuilding.uniform(n_storeys=30, storey_height=3.5, period=10.0)
    rj.stable_dt(BLOCK, 2e-3, mode="one_sided", gap=0.05)
    rj.Assembly.stack([BLOCK, BLOCK], top="restrained", gap=0.02)
    rj.Block(b=0.005, h=0.03)
    rj.ThreeBranchLaw(lambda_0=0.1, Delta_1=0.05, Delta_2=0.3, Delta_u=1.2)


def test_huge_initial_velocity_overturns():
    """A start far faster than the solver resolves overturns (``overturned=True``, status OK,
    a finite history) instead of failing as non-finite. Independent check that it must: the
    start's kinetic energy ``I_O w^2 / 2`` exceeds the climb to the overturning position,
    ``m g R (1 - cos eta)``, a million-fold, far beyond what the record's 0.1 g can take."""
    climb = float(BLOCK.m * 9.80665 * BLOCK.R * (1.0 - np.cos(BLOCK.eta)))
    for w in (1e6, 1e12, -1e200):
        assert 0.5 * float(BLOCK.I_O) * min(w * w, 1e300) > 1e6 * climb
        resp = _H(BLOCK, GM, theta_dot0=w)
        assert bool(resp.overturned), w
        assert int(resp.status) == STATUS_OK, w
        theta = np.asarray(resp.theta)
        assert np.all(np.isfinite(theta)), w
        assert np.sign(theta[-1]) == np.sign(w), w
    traced = jax.jit(lambda w: _H(BLOCK, GM, theta_dot0=w, throw=False))(jnp.asarray(1e9))
    assert bool(traced.overturned) and int(traced.status) == STATUS_OK


# ----------------------------------------------------------------------------- IDA


def _ida(records=(GM,), scales=(0.5, 1.0), **kw):
    kw = {"model": rj.DEM(beta=2e-3), "progress": False} | kw
    return rj.ida(BLOCK, list(records), scales, **kw)


IDA_CASES = [
    _case("scales-decreasing", lambda: _ida(scales=[1.0, 0.5]), r"\bscales\b", r"np\.unique"),
    _case("scales-nan", lambda: _ida(scales=[0.5, NAN]), r"\bscales\b", r"finite"),
    _case("scales-text", lambda: _ida(scales="0.5,1"), r"\bscales\b", r"np\.linspace"),
    _case("scales-2d", lambda: _ida(scales=[[0.5, 1.0]]), r"\bscales\b", r"1-D"),
    _case("model", lambda: _ida(model="fem"), r"\bmodel\b", r"housner"),
    _case("mode", lambda: _ida(mode="parapet"), r"\bmode\b", r"two_sided"),
    _case("dem-no-beta", lambda: _ida(model="dem"), r"\bbeta\b", r"beta_dejong"),
    _case("dem-beta-negative", lambda: rj.DEM(beta=-1e-3), r"\bbeta\b", r">= 0"),
    _case("dem-with-e", lambda: rj.as_model("dem", beta=2e-3, e=0.9), r"\be\b", r"beta"),
    _case("housner-with-beta", lambda: rj.as_model("housner", beta=2e-3), r"\bbeta\b", r"takes e"),
    _case(
        "housner-gap",
        lambda: _ida(model=rj.Housner(), mode=rj.Facade(gap=1e-3)),
        r"\bgap\b",
        r"gap=0",
    ),
    _case("gap-negative", lambda: _ida(mode=rj.Facade(gap=-1e-3)), r"\bgap\b", r"e\.g\."),
    _case("im-malformed", lambda: _ida(im="sa(x)"), r"\bim\b", r"sa\(0\.5\)"),
    _case("im-unknown", lambda: _ida(im="pgd"), r"\bim\b", r"sa\(0\.5\)"),
    _case("im-sa0", lambda: _ida(im="sa(0)"), r"\bim\b", r"im='pga'"),
    _case("chunk_size-0", lambda: _ida(chunk_size=0), r"\bchunk_size\b", r"None"),
    _case("tail-negative", lambda: _ida(tail=-1.0), r"\btail\b", r">= 0|e\.g\."),
    _case("tail-nan", lambda: _ida(tail=NAN), r"\btail\b", r">= 0|e\.g\."),
    _case("records-empty", lambda: _ida(records=()), r"\brecords\b", r"GroundMotion"),
    _case("records-same-name", lambda: _ida(records=(GM, GM)), r"\bnames?\b", r"distinct|rename"),
    _case(
        "records-ndarray",
        lambda: _ida(records=[np.zeros(10)], scales=[1.0]),
        r"\brecords\b",
        r"GroundMotion",
    ),
    _case(
        "records-one-motion",
        lambda: rj.ida(BLOCK, GM, [1.0], model=rj.DEM(beta=2e-3), progress=False),
        r"\brecords\b",
        r"\[",
    ),
    _case(
        "t_end-cuts-record",
        lambda: _ida(t_end=0.1),
        r"\bt_end\b",
        r"longest|at least",
    ),
    _case(
        "dem-beta-array",
        lambda: rj.DEM(beta=np.array([1e-3, 2e-3])),
        r"\bbeta\b",
        r"one number",
    ),
    _case("dem-beta-text", lambda: rj.DEM(beta="2e-3"), r"\bbeta\b", r"quotes"),
    _case(
        "housner-e-text",
        lambda: rj.Housner(e="0.9"),
        r"\be\b",
        r"quotes",
    ),
    _case(
        "housner-e-above-1",
        lambda: _ida(model=rj.Housner(e=1.5)),
        r"\be\b",
        r"0 < e <= 1",
    ),
    _case(
        "tail-text",
        lambda: _ida(tail="2"),
        r"\btail\b",
        r"quotes",
    ),
    _case("devices-empty", lambda: _ida(devices=[]), r"\bdevices\b", r"jax\.local_devices"),
    _case(
        # a block wider than tall: every run would fail (e_H = -0.2), refused before any
        "housner-squat-default-e",
        lambda: rj.ida(rj.Block(**SQUAT), [GM], [1.0], model=rj.Housner(), progress=False),
        r"e_H = -0\.2",
        r"pass e explicitly, 0 < e <= 1",
    ),
    _case(
        "housner-e-negative",
        lambda: _ida(model=rj.Housner(e=-0.5)),
        r"\be\b.*-0\.5",
        r"0 < e <= 1",
    ),
    _case(
        "dem-gap-two-sided",
        lambda: rj.as_mode("two_sided", 1e-3),
        r"\bgap\b.*ignored",
        r"mode='one_sided'",
    ),
]


@pytest.mark.parametrize("case", IDA_CASES)
def test_ida_refuses(case: Bad):
    _assert_refused(case)


# ----------------------------------------------------------------------------- spectra, pulses


def _other_length():
    return rj.GroundMotion(ag=np.zeros(20), dt=0.01, name="short")


SPECTRA_CASES = [
    _case("periods-negative", lambda: rj.response_spectrum(GM, [-0.5]), r"\bperiods\b", r">= 0"),
    _case("periods-nan", lambda: rj.response_spectrum(GM, [NAN]), r"\bperiods\b", r"finite"),
    _case("periods-2d", lambda: rj.response_spectrum(GM, [[0.5]]), r"\bperiods\b", r"geomspace"),
    _case("periods-text", lambda: rj.response_spectrum(GM, "0.5"), r"\bperiods\b", r"quotes"),
    _case("periods-empty", lambda: rj.response_spectrum(GM, []), r"\bperiods\b", r"geomspace"),
    _case(
        "damping-percent", lambda: rj.response_spectrum(GM, [0.5], 5.0), r"\bdamping\b", r"0\.05"
    ),
    _case(
        "damping-text", lambda: rj.response_spectrum(GM, [0.5], "0.05"), r"\bdamping\b", "quotes"
    ),
    _case(
        "damping-array",
        lambda: rj.response_spectrum(GM, [0.5], [0.02, 0.05]),
        r"\bdamping\b",
        r"0\.05",
    ),
    _case("array-no-dt", lambda: rj.response_spectrum(np.zeros(10), [0.5]), r"\bdt\b", r"dt=0\.01"),
    _case(
        "motion-and-dt",
        lambda: rj.response_spectrum(GM, [0.5], dt=0.02),
        r"\bdt\b",
        r"leave dt=None",
    ),
    _case(
        "array-in-cm",
        lambda: rj.response_spectrum(np.array([0.0, 300.0, 0.0]), [0.5], dt=0.01),
        r"\bmotion\b|\bag\b",
        r"cm/s\^2",
    ),
    _case("n_sub-0", lambda: rj.response_spectrum(GM, [0.5], n_sub=0), r"\bn_sub\b", r">= 1"),
    _case(
        "rotd-lengths",
        lambda: rj.rotd_spectrum(GM, _other_length(), [0.5]),
        r"\bmotion_x\b.*\bmotion_y\b",
        r"resample or trim",
    ),
    _case(
        "rotd-n_angles-0",
        lambda: rj.rotd_spectrum(GM, GM, [0.5], n_angles=0),
        r"\bn_angles\b",
        r"180",
    ),
    _case("im-malformed", lambda: rj.spectra.parse_im("sa(0.5"), r"\bim\b", r"sa\(0\.5\)"),
    _case("im-negative", lambda: rj.spectra.parse_im("sa(-1)"), r"\bim\b", r"sa\(0\.5\)"),
    _case("im-number", lambda: rj.spectra.parse_im(0.5), r"\bim\b", r"sa\(0\.5\)"),
    _case("im-of-ndarray", lambda: rj.spectra.intensity(np.zeros(5), "pga"), r"motion", r"Ground"),
    _case("lowpass-f_cut-0", lambda: rj.pulses.lowpass(GM, 0.0), r"\bf_cut\b", r"f_cut=3"),
    _case(
        "lowpass-ndarray",
        lambda: rj.pulses.lowpass(np.zeros(10)),
        r"\bmotion\b",
        r"GroundMotion",
    ),
    _case("pulse-shape", lambda: rj.pulses.fit_pulse(GM, "XX"), r"\bshape\b", r"MH"),
    _case(
        "pulse-periods-short",
        lambda: rj.pulses.fit_pulse(GM, "MH", periods=[0.5]),
        r"\bperiods\b",
        r"geomspace",
    ),
    _case(
        "pulse-shapes-unknown",
        lambda: rj.identify_pulse(GM, shapes=("MH", "ZZ")),
        r"\bshapes?\b",
        r"MH",
    ),
    _case(
        "pulse-shapes-string",
        lambda: rj.identify_pulse(GM, shapes="MH"),
        r"\bshapes\b",
        r"\(.MH.,\)",
    ),
    _case("pulse-zeros", lambda: rj.identify_pulse(_zeros_gm()), r"all zeros", r"no pulse"),
]


@pytest.mark.parametrize("case", SPECTRA_CASES)
def test_spectra_and_pulses_refuse(case: Bad):
    _assert_refused(case)


# ----------------------------------------------------------------------------- fragility


def _ida_dataset(collapse_from=(2, 3, 4), n_scale=6):
    """An IDA-like Dataset: record k collapses from scale index ``collapse_from[k]`` on."""
    scale = np.linspace(0.5, 3.0, n_scale)
    pga = np.linspace(1.0, 2.0, len(collapse_from))
    collapse = np.arange(n_scale)[None, :] >= np.asarray(collapse_from)[:, None]
    dims = ("record", "scale")
    im = pga[:, None] * scale[None, :]
    return xr.Dataset(
        {
            "collapse": (dims, collapse),
            "status": (dims, np.zeros(collapse.shape, int)),
            "im": (dims, im, {"units": "m/s^2"}),
            "pga_scaled": (dims, im, {"units": "m/s^2"}),
        },
        coords={"record": [f"r{k}" for k in range(len(pga))], "scale": scale},
        attrs={"im": "pga"},
    )


FRAGILITY_CASES = [
    _case(
        "ds-not-dataset",
        lambda: rj.fragility(np.zeros((3, 4))),
        r"\bds\b",
        r"rj\.ida returns",
    ),
    _case(
        "ds-without-collapse",
        lambda: rj.fragility(_ida_dataset().drop_vars("collapse")),
        r"collapse",
        r"rj\.ida returns",
    ),
    _case("im-unknown", lambda: rj.fragility(_ida_dataset(), "sd"), r"\bsd\b", r"'pga'"),
    _case(
        "im-not-in-ida",
        lambda: rj.fragility(_ida_dataset(), "sa(1.0)"),
        r"\bsa\(1\)",
        r"im='sa\(1\)'",
    ),
    _case("ci-above-1", lambda: rj.fragility(_ida_dataset(), ci=90), r"\bci\b", r"0\.9"),
    _case("ci-text", lambda: rj.fragility(_ida_dataset(), ci="0.9"), r"\bci\b", r"0\.9"),
    _case(
        "n_boot-negative", lambda: rj.fragility(_ida_dataset(), n_boot=-1), r"\bn_boot\b", "1000"
    ),
    _case("n_boot-float", lambda: rj.fragility(_ida_dataset(), n_boot=10.5), r"\bn_boot\b", "1000"),
    _case(
        # the IM named with its unit, in g first: 6 m/s^2 / 9.80665 = 0.6118 g
        "no-collapse",
        lambda: rj.fragility(_ida_dataset(collapse_from=(9, 9, 9))),
        r"no valid run collapsed up to pga = 0\.6118 g \(6 m/s\^2\)",
        r"larger scale",
    ),
    _case(
        # 0.5 m/s^2 / 9.80665 = 0.05099 g
        "all-collapse",
        lambda: rj.fragility(_ida_dataset(collapse_from=(0, 0, 0))),
        r"every valid run collapsed down to pga = 0\.05099 g \(0\.5 m/s\^2\)",
        r"smaller scale",
    ),
    _case(
        # one record: collapses from 2 m/s^2 (0.2039 g), survivals up to 1.5 m/s^2 (0.153 g)
        "separated",
        lambda: rj.fragility(_ida_dataset(collapse_from=(3,))),
        r"from pga = 0\.2039 g \(2 m/s\^2\)\).*up to pga = 0\.153 g \(1\.5 m/s\^2\)",
        r"overlap",
    ),
]


@pytest.mark.parametrize("case", FRAGILITY_CASES)
def test_fragility_refuses(case: Bad):
    _assert_refused(case)


# ----------------------------------------------------------------------------- calibration

_CAL = rj.Block(b=0.25, h=3.0)

CALIBRATION_CASES = [
    _case("fit_beta-no-e", lambda: rj.fit_beta(_CAL), r"\be\b", r"e_housner"),
    _case("fit_beta-e-above-1", lambda: rj.fit_beta(_CAL, e=1.5), r"\be\b", r"e=0\.9"),
    _case("fit_beta-e-text", lambda: rj.fit_beta(_CAL, e="0.9"), r"\be\b", r"quotes"),
    _case("fit_beta-e-nan", lambda: rj.fit_beta(_CAL, e=NAN), r"\be\b", r"e=0\.9"),
    _case(
        "fit_beta-e_H-of-a-squat-block",
        lambda: rj.fit_beta(rj.Block(**SQUAT), e=rj.e_housner(rj.Block(**SQUAT))),
        r"\be\b",
        r"measured",
    ),
    _case(
        "fit_beta-method", lambda: rj.fit_beta(_CAL, 0.95, method="adam"), r"\bmethod\b", "lbfgs"
    ),
    _case("fit_beta-target", lambda: rj.fit_beta(_CAL, 0.95, target="E"), r"\btarget\b", "bounces"),
    _case("fit_beta-mode", lambda: rj.fit_beta(_CAL, 0.95, mode="2SR"), r"\bmode\b", "two_sided"),
    _case(
        "fit_beta-n_bounces-0",
        lambda: rj.fit_beta(_CAL, 0.95, n_bounces=0),
        r"\bn_bounces\b",
        r"leave it None",
    ),
    _case(
        "fit_beta-beta_max-negative",
        lambda: rj.fit_beta(_CAL, 0.95, beta_max=-1.0),
        r"\bbeta_max\b",
        r"positive|e\.g\.|default",
    ),
    _case(
        "fit_beta-theta0-beyond-eta",
        lambda: rj.fit_beta(_CAL, 0.95, theta0=1.0),
        r"\btheta0\b",
        r"smaller|0\.5",
    ),
    _case(
        "fit_beta-bounces-two-sided",
        lambda: rj.fit_beta(_CAL, target="bounces"),
        r"\btarget\b",
        r"one_sided",
    ),
    _case(
        "fit_beta-one-sided-with-e",
        lambda: rj.fit_beta(_CAL, 0.9, mode="one_sided"),
        r"\be\b",
        r"drop e",
    ),
    _case("fit_beta-rtol-0", lambda: rj.fit_beta(_CAL, 0.95, rtol=0.0), r"\brtol\b", r"default"),
    _case(
        "fit_beta-max_iter-0", lambda: rj.fit_beta(_CAL, 0.95, max_iter=0), r"\bmax_iter\b", "40"
    ),
    _case("fit_beta-n_grid-1", lambda: rj.fit_beta(_CAL, 0.95, n_grid=1), r"\bn_grid\b", "256"),
    _case(
        "fit_beta-gap-negative",
        lambda: rj.fit_beta(_CAL, mode="one_sided", gap=-1e-3),
        r"\bgap\b.*\bm\b",
        r"e\.g\. 0\.001",
    ),
    _case(
        "fit_beta-gap-two-sided",
        lambda: rj.fit_beta(_CAL, 0.95, gap=1e-3),
        r"\bgap\b.*ignored",
        r"mode='one_sided'",
    ),
    _case("fit_e-beta-negative", lambda: rj.fit_e(_CAL, -1e-3), r"\bbeta\b", r">= 0"),
    _case("fit_e-beta-text", lambda: rj.fit_e(_CAL, "1e-3"), r"\bbeta\b", r"quotes"),
    _case(
        "fit_history-not-a-response",
        lambda: rj.fit_history(_CAL, np.zeros(10)),
        r"\bmeasured\b",
        r"Response",
    ),
    _case(
        "history_error-lengths",
        lambda: rj.metrics.history_error(np.zeros(5), np.ones(4)),
        r"\btheta\b.*\btheta_ref\b",
        r"same (times|samples)",
    ),
]


@pytest.mark.parametrize("case", CALIBRATION_CASES)
def test_calibration_refuses(case: Bad):
    _assert_refused(case)


# ----------------------------------------------------------------------------- campaign


def _plan(cases=None, records=None, **kw):
    cases = [campaign.Case("c", BLOCK, "set", model=rj.DEM(beta=2e-3))] if cases is None else cases
    records = {"set": [GM]} if records is None else records
    return campaign.plan(cases, records, **{"scales": [0.5, 1.0]} | kw)


CAMPAIGN_CASES = [
    _case("cases-empty", lambda: _plan(cases=[]), r"\bcases\b", r"Case"),
    _case(
        "cases-one-case",
        lambda: _plan(cases=campaign.Case("c", BLOCK, "set", model=rj.DEM(beta=2e-3))),
        r"\bcases\b",
        r"sequence",
    ),
    _case(
        "case-name-path",
        lambda: _plan(cases=[campaign.Case("a/b", BLOCK, "set", model=rj.DEM(beta=2e-3))]),
        r"a/b",
        r"letters, digits",
    ),
    _case(
        "case-names-repeat",
        lambda: _plan(cases=[campaign.Case("c", BLOCK, "set", model=rj.DEM(beta=2e-3))] * 2),
        r"case names",
        r"distinct",
    ),
    _case(
        "record-set-missing",
        lambda: _plan(cases=[campaign.Case("c", BLOCK, "other", model=rj.DEM(beta=2e-3))]),
        r"other",
        r"records given",
    ),
    _case("record-set-empty", lambda: _plan(records={"set": []}), r"set", r"non-empty"),
    _case(
        "dem-case-without-beta",
        lambda: _plan(cases=[campaign.Case("c", BLOCK, "set")]),
        r"\bbeta\b",
        r"beta_dejong",
    ),
    _case(
        "grid-without-beta",
        lambda: campaign.grid({"p": BLOCK}, ["set"], models=("dem",)),
        r"\bbeta\b",
        r"beta=\{",
    ),
    _case("records_per_task-0", lambda: _plan(records_per_task=0), r"records_per_task", ">= 1"),
    _case("scales-decreasing", lambda: _plan(scales=[2.0, 1.0]), r"\bscales\b", "np.unique"),
    _case("tail-text", lambda: _plan(tail="2"), r"\btail\b", r"quotes"),
    _case("tail-negative", lambda: _plan(tail=-1.0), r"\btail\b", r">= 0"),
]


@pytest.mark.parametrize("case", CAMPAIGN_CASES)
def test_campaign_refuses(case: Bad):
    _assert_refused(case)


def test_campaign_load_without_manifest(tmp_path):
    with pytest.raises(ValueError) as info:
        campaign.load(tmp_path)
    _assert_clear(str(info.value), re.escape(str(tmp_path)), r"run")


# ----------------------------------------------------------------------------- readers

_HEADER = "TITLE\nEVENT, 1/1/2000, STATION, 0\nACCELERATION TIME SERIES IN UNITS OF G\n"

# (file name, content, read_csv keywords or None for read_at2, name regex, fix regex, owner, what)
READER_CASES = [
    (
        "down.csv",
        "0 0\n-0.01 0.1\n-0.02 0\n",
        {"units": "g"},
        r"\bt\b.*'down'.*must increase",
        r"sort",
        None,
        "",
    ),
    (
        "same.csv",
        "0 0\n0.01 0.1\n0.01 0\n",
        {"units": "g"},
        r"\bt\b.*'same'.*must increase",
        r"sort",
        None,
        "",
    ),
    (
        "uneven.csv",
        "0 0\n0.01 0.1\n0.03 0\n",
        {"units": "g"},
        r"\bt\b.*'uneven'",
        r"resample",
        None,
        "",
    ),
    ("text.csv", "0 0\n0.01 abc\n0.02 0\n", {}, r"text\.csv, line 2", r"abc", None, ""),
    ("nan.csv", "0 0\n0.01 nan\n", {}, r"nan\.csv, line 2", r"non-finite", None, ""),
    ("one_row.csv", "0 0\n", {}, r"one_row\.csv", r"at least 2", None, ""),
    ("empty.csv", "", {}, r"empty\.csv", r"empty|at least 2", None, ""),
    ("header_only.csv", "t,a\n", {}, r"header_only\.csv", r"at least 2", None, ""),
    ("three.csv", "0 0 1\n0.01 0 1\n", {}, r"three\.csv, line 1", r"delimiter=", None, ""),
    ("units.csv", "0 0\n0.01 1\n", {"units": "mg"}, r"\bunits\b", r"cm/s2", None, ""),
    (
        "time_units.csv",
        "0 0\n0.01 1\n",
        {"time_units": "sec"},
        r"\btime_units\b",
        r"'ms'",
        None,
        "",
    ),
    ("no_dt.csv", "0\n1\n", {"time_column": False}, r"\bdt\b", r"dt=", None, ""),
    ("both.csv", "0 0\n0.01 1\n", {"dt": 0.01}, r"\bdt\b", r"time_column=False", None, ""),
    (
        "cm_as_g.csv",
        "0 0\n0.01 294\n0.02 -150\n",
        {"units": "g"},
        r"\bunits\b",
        r"units='cm/s2'",
        None,
        "",
    ),
    # a file in m/s^2 (an OpenSees recorder of an SI model) is not read as g without a word
    ("si.out", "0.01 0.5\n0.02 -0.3\n", {}, r"si\.out.*units", r"units='m/s2'", None, ""),
    (
        "no_unit.csv",
        "t,acc\n0 0.5\n0.01 -0.3\n",
        {},
        r"no_unit\.csv.*'acc'",
        r"units='m/s2'.*'acc \[m/s2\]'",
        None,
        "",
    ),
    (
        "header_m_s2.csv",
        "t [s],acc [m/s2]\n0,0.5\n0.01,-0.3\n",
        {"units": "g"},
        r"units='g'.*acc \[m/s2\]",
        r"Drop units=",
        None,
        "",
    ),
    (
        "time_ms.csv",
        "0 0\n10 0.1\n20 0\n",
        {"units": "g"},
        r"time_ms\.csv.*time column",
        r"time_units='ms'",
        None,
        "",
    ),
    (
        "time_ms_header.csv",
        "t [ms],a [g]\n0,0\n10,0.1\n",
        {"time_units": "s"},
        r"time_units='s'.*header",
        r"Drop time_units=",
        None,
        "",
    ),
    (
        "decimal_comma.csv",
        "0,00;0,1\n0,01;0,2\n",
        {"units": "g"},
        r"decimal_comma\.csv, line 1: '0,00'",
        r"decimal=','",
        None,
        "",
    ),
    ("decimal.csv", "0 0\n0.01 1\n", {"decimal": ";"}, r"\bdecimal\b", r'"\." or ","', None, ""),
    (
        "velocity.csv",
        "t [s],v [m/s]\n0,0\n0.01,0.1\n",
        {"units": "m/s2"},
        r"velocity.csv.*'v \[m/s\]'",
        r"column=",
        None,
        "",
    ),
    ("missing.AT2", None, None, r"missing\.AT2", r"no such file", None, ""),
    ("empty.AT2", "", None, r"empty\.AT2", r"empty", None, ""),
    ("no_npts.AT2", _HEADER + "0.1 0.2\n", None, r"no_npts\.AT2", r"NPTS=", None, ""),
    (
        "truncated.AT2",
        _HEADER + "NPTS=  10, DT= .0100 SEC,\n0.1 0.2 0.3\n",
        None,
        r"truncated\.AT2.*NPTS=10",
        r"truncated",
        None,
        "",
    ),
    (
        "dt_zero.AT2",
        _HEADER + "NPTS=  3, DT= 0.0 SEC,\n0.1 0.2 0.3\n",
        None,
        r"dt_zero\.AT2.*\bDT\b",
        r"DT",
        None,
        "",
    ),
    (
        "text.AT2",
        _HEADER + "NPTS=  3, DT= .0100 SEC,\n0.1 x 0.3\n",
        None,
        r"text\.AT2, line 5",
        r"'x'",
        None,
        "",
    ),
    (
        "velocity.VT2",
        _HEADER + "NPTS= 2, DT= .01 SEC,\n0 0\n",
        None,
        r"velocity",
        r"\.AT2",
        None,
        "",
    ),
]


@pytest.mark.parametrize(
    "fname, content, kw, name, fix",
    [
        pytest.param(*c[:5], id=c[0], marks=() if c[5] is None else (_xfail(c[5], c[6]),))
        for c in READER_CASES
    ],
)
def test_readers_refuse(tmp_path, fname, content, kw, name, fix):
    path = tmp_path / fname
    if content is not None:
        path.write_text(content)
    read = rj.read_at2 if kw is None else (lambda p: rj.read_csv(p, **kw))
    with pytest.raises((ValueError, FileNotFoundError)) as info:
        read(path)
    _assert_clear(str(info.value), name, fix)


@pytest.mark.parametrize(
    "text",
    [
        pytest.param(
            "\ufeff0.0,0.1\n0.01,0.2\n0.02,0.3\n",
            id="utf8-bom",
        ),
        pytest.param(
            "0.0,0.1 # start\n0.01,0.2\n0.02,0.3\n",
            id="trailing-comment",
        ),
        pytest.param("t,a\n0.0,0.1\n0.01,0.2\n0.02,0.3\n", id="header"),
    ],
)
def test_read_csv_drops_no_row(tmp_path, text):
    path = tmp_path / "rec.csv"
    path.write_bytes(text.encode("utf-8"))
    gm = rj.read_csv(path, units="m/s2")
    np.testing.assert_array_equal(np.asarray(gm.ag), [0.1, 0.2, 0.3])


def test_records_load_refuses(tmp_path):
    with pytest.raises(ValueError) as info:
        rj.records.load([tmp_path / "nope"])
    _assert_clear(str(info.value), r"nope", r"no such file.*record set")
    with pytest.raises(ValueError) as info:
        rj.records.load([tmp_path])
    _assert_clear(str(info.value), re.escape(str(tmp_path)), r"no \.AT2")


# ----------------------------------------------------------------------------- command line
# Each bad invocation exits with status 2 and one "error: ..." line on stderr before any
# computation; argparse's own refusals (a flag's type) exit through SystemExit(2).


@pytest.fixture(scope="module")
def at2_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("records") / "pulse.AT2"
    rj.write_at2(path, GM)
    return path


def _cli_id(argv: list[str]) -> str:
    """``argv`` without the usual record and output paths, e.g. ``ida --scales 2:1:3``."""
    usual = {("--records", "{at2}")} | {("--out", f"{{tmp}}/{x}") for x in ("x.nc", "c", "d")}
    pairs = zip(argv[1::2], argv[2::2], strict=True)
    return " ".join([argv[0], *(f"{k} {v}" for k, v in pairs if (k, v) not in usual)])


CLI_CASES = [
    # (argv with {at2} and {tmp}, name regex, fix regex, owner, what)
    (
        ["ida", "--records", "{at2}", "--scales", "2:1:3", "--out", "{tmp}/x.nc"],
        r"scales",
        r"increasing|unique",
        None,
        "",
    ),
    (
        ["ida", "--records", "{at2}", "--scales", "a,b", "--out", "{tmp}/x.nc"],
        r"--scales",
        r"e\.g\. --scales",
        None,
        "",
    ),
    (
        ["ida", "--records", "{at2}", "--scales", "0:1:0", "--out", "{tmp}/x.nc"],
        r"--scales",
        r"e\.g\. --scales",
        None,
        "",
    ),
    (
        ["ida", "--records", "{at2}", "--im", "sa(x)", "--out", "{tmp}/x.nc"],
        r"\bim\b",
        r"sa\(0\.5\)",
        None,
        "",
    ),
    (
        ["ida", "--records", "{at2}", "--chunk-size", "0", "--out", "{tmp}/x.nc"],
        r"--chunk-size",
        r">= 1",
        None,
        "",
    ),
    (
        ["ida", "--records", "{at2}", "--b", "250", "--out", "{tmp}/x.nc"],
        r"\bb\b",
        r"millimetres",
        None,
        "",
    ),
    (
        ["ida", "--records", "{at2}", "--h", "nan", "--out", "{tmp}/x.nc"],
        r"\bh\b",
        r"h=3",
        None,
        "",
    ),
    (
        [
            "ida",
            "--records",
            "{at2}",
            "--model",
            "housner",
            "--beta",
            "1e-3",
            "--out",
            "{tmp}/x.nc",
        ],
        r"--beta",
        r"--e",
        None,
        "",
    ),
    (
        ["ida", "--records", "{at2}", "--e", "0.9", "--out", "{tmp}/x.nc"],
        r"--e",
        r"--beta",
        None,
        "",
    ),
    (
        ["ida", "--records", "{at2}", "--beta", "-1", "--out", "{tmp}/x.nc"],
        r"\bbeta\b",
        r">= 0",
        None,
        "",
    ),
    (
        ["ida", "--records", "{at2}", "--tail", "-1", "--out", "{tmp}/x.nc"],
        r"\btail\b",
        r">= 0|e\.g\.",
        None,
        "",
    ),
    (
        ["ida", "--records", "{at2}", "--mode", "one_sided", "--gap", "-1", "--out", "{tmp}/x.nc"],
        r"\bgap\b",
        r"e\.g\. 0\.001",
        None,
        "",
    ),
    (
        ["ida", "--records", "{tmp}/none.AT2", "--out", "{tmp}/x.nc"],
        r"--records",
        r"record set",
        None,
        "",
    ),
    (["ida", "--records", "{at2}", "--out", "{tmp}"], r"--out", r"file path", None, ""),
    (
        ["ida", "--records", "{at2}", "--out", "{at2}/x.nc"],
        r"--out",
        r"folder you can write",
        None,
        "",
    ),
    (
        ["calibrate", "--b", "0.25", "--h", "3", "--E", "1800", "--out", "{tmp}/c"],
        r"\bE\b",
        r"MPa",
        None,
        "",
    ),
    (
        ["calibrate", "--b", "0.25", "--h", "3", "--theta0", "1.2", "--out", "{tmp}/c"],
        r"--theta0",
        r"\[0\.05, 1\)",
        None,
        "",
    ),
    (
        ["calibrate", "--b", "0.25", "--h", "3", "--e", "1.5", "--out", "{tmp}/c"],
        r"--e",
        r"\(0, 1\]",
        None,
        "",
    ),
    (
        ["calibrate", "--b", "0.25", "--h", "3", "--beta-max", "-1", "--out", "{tmp}/c"],
        r"beta[-_]max",
        r"default|positive",
        None,
        "",
    ),
    (
        [
            "calibrate",
            "--b",
            "0.25",
            "--h",
            "3",
            "--mode",
            "two_sided",
            "--target",
            "bounces",
            "--out",
            "{tmp}/c",
        ],
        r"--target",
        r"--mode one_sided",
        None,
        "",
    ),
    (
        [
            "calibrate",
            "--b",
            "0.2",
            "--h",
            "1.5",
            "--mode",
            "one_sided",
            "--e",
            "0.5",
            "--out",
            "{tmp}/c",
        ],
        r"--e",
        r"drop --e",
        None,
        "",
    ),
    (["calibrate", "--b", "0.25", "--h", "3", "--out", "{at2}"], r"--out", r"folder", None, ""),
    (
        ["calibrate", "--b", "1", "--h", "0.5", "--out", "{tmp}/c"],
        r"--e",
        r"e_H",
        None,
        "",
    ),
    (["demo", "--n-beta", "1", "--out", "{tmp}/d"], r"--n-beta", r">= 2", None, ""),
    (["demo", "--b", "nan", "--out", "{tmp}/d"], r"\bb\b", r"b=0\.25", None, ""),
    (["demo", "--out", "{at2}"], r"--out", r"folder", None, ""),
    (["demo", "--out", "{at2}/sub"], r"--out", r"folder you can write", None, ""),
    (
        ["ida", "--records", "{at2}", "--scales", "0.5,,1", "--out", "{tmp}/x.nc"],
        r"--scales '0\.5,,1'.*empty item",
        r"e\.g\. --scales",
        None,
        "",
    ),
    (
        ["ida", "--records", "{at2}", "--scales", "0.5,1,", "--out", "{tmp}/x.nc"],
        r"--scales.*empty item",
        r"e\.g\. --scales",
        None,
        "",
    ),
    (
        # a block wider than tall: Eq. 2 gives e_H = -0.2, no restitution coefficient
        ["ida", "--records", "{at2}", "--b", "1", "--h", "0.5", "--model", "housner"]
        + ["--out", "{tmp}/x.nc"],
        r"e_H \(Eq\. 2\) = -0\.2",
        r"--e 0\.9",
        None,
        "",
    ),
    (
        ["ida", "--records", "{at2}", "--model", "housner", "--e", "-0.5", "--out", "{tmp}/x.nc"],
        r"--e",
        r"\(0, 1\]",
        None,
        "",
    ),
    (
        ["ida", "--records", "{at2}", "--out", "{tmp}/x.h5"],
        r"--out .*x\.h5",
        r"ending in \.nc",
        None,
        "",
    ),
]


@pytest.mark.parametrize(
    "argv, name, fix",
    [
        pytest.param(
            *c[:3],
            id=_cli_id(c[0]),
            marks=() if c[3] is None else (_xfail(c[3], c[4]),),
        )
        for c in CLI_CASES
    ],
)
def test_cli_refuses(tmp_path, at2_file, capsys, argv, name, fix):
    argv = [a.format(at2=at2_file, tmp=tmp_path) for a in argv]
    before = set(tmp_path.iterdir())
    status = cli_main(argv)
    err = capsys.readouterr().err
    assert status == 2, err
    assert err.startswith("error: ") and err.count("\n") == 1, err
    _assert_clear(err, name, fix)
    assert set(tmp_path.iterdir()) == before, "a refused command left files behind"


@pytest.mark.parametrize(
    "argv, flag",
    [
        pytest.param(["ida", "--records", "x", "--b", "abc", "--out", "x.nc"], "--b", id="b-text"),
        pytest.param(
            ["ida", "--records", "x", "--model", "fem", "--out", "x.nc"], "--model", id="model"
        ),
        pytest.param(["calibrate", "--h", "3"], "--b", id="calibrate-no-b"),
        pytest.param(
            ["calibrate", "--b", "0.25", "--h", "3", "--method", "adam"], "--method", id="method"
        ),
        pytest.param(["ida", "--out", "x.nc"], "--records", id="ida-no-records"),
        pytest.param([], "command", id="no-command"),
    ],
)
def test_cli_argparse_refuses(capsys, argv, flag):
    with pytest.raises(SystemExit) as info:
        cli_main(argv)
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert flag in err and "usage: rockjax" in err, err
