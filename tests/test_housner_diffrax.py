"""The Housner model through diffrax (``simulate_housner(..., solver=...)``) against the exact
free-rocking impact time, the independent event-driven reference of
``tests/test_housner_events.py`` (SciPy DOP853 with its own root finder) on broadband records,
the default fixed-step loop, and central finite differences for its derivatives."""

from __future__ import annotations

import math

import diffrax
import jax
import numpy as np
import pytest
from helpers import housner_time_to_impact
from test_housner_events import (
    DT,
    FEMA_ONE_SIDED,
    FEMA_TWO_SIDED,
    KT_CASES,
    NEAR_CASES,
    NEAR_PEAK_ATOL,
    PEAK_ATOL,
    PEAK_RTOL,
    event_reference,
    load_near_records,
    load_records,
    near_threshold_record,
    needs_fema,
)

import rockjax as rj
from rockjax.constants import G
from rockjax.response import STATUS_OK

SOLVERS = {"Tsit5": diffrax.Tsit5(), "Dopri8": diffrax.Dopri8()}
# The exact first impact time of a free release (quadrature to 1e-13): the events' root finder
# works to 1e-12 s on the dense output of steps held to rtol 1e-8 (measured: 4.5e-13 s).
IMPACT_TIME_ATOL = 1e-9  # [s]
# An impact keeps e^2 of the energy (the map is exact); between impacts it is conserved up to
# the controller's tolerance, 1e-8 per step (measured: 5e-12 relative after the first impact).
ENERGY_RTOL = 1e-9
# Derivatives against central differences with a relative step of 1e-6 (their truncation and
# rounding errors both ~1e-10 of the slope here; measured agreement 1e-9 for grad, 5e-11 for
# jvp, and 1e-10 to 3e-9 with steps from 1e-5 to 1e-7).
GRAD_RTOL = 1e-6
FD_STEP = 1e-6


def _scaled(ag, b, h, pga):
    """``ag`` [m/s^2] scaled to ``pga`` [g tan(eta)], or as given for None."""
    if pga is None:
        return ag
    return ag * (pga * G * math.tan(math.atan2(b, h)) / np.max(np.abs(ag)))


def _peak(resp):
    """``max|theta|/eta``, or None if the block overturned."""
    return None if bool(resp.overturned) else float(resp.theta_max / resp.eta)


def _agree(got, ref):
    """Same overturning flag, and peaks within PEAK_RTOL (+ PEAK_ATOL) of the reference's."""
    if got is None or ref is None:
        return got is None and ref is None
    return abs(got - ref) <= PEAK_RTOL * ref + PEAK_ATOL


@pytest.fixture(scope="module")
def cases():
    """Broadband cases with the reference's peak: the FEMA P695 components of
    test_housner_events (their screened references) when installed, and a Kanai-Tajimi record
    whose reference runs here (the one that overturns: a few seconds of SciPy)."""
    records = load_records()
    out = []
    for name, b, h, mode, pga, ref in FEMA_TWO_SIDED + FEMA_ONE_SIDED:
        if name in records:
            out.append((name, b, h, mode, _scaled(records[name], b, h, pga), ref))
    name, b, h, mode, _ = KT_CASES[1]
    ag = records[name]
    eta = math.atan2(b, h)
    r = event_reference(b, h, ag, 0.01, 1.0 - 1.5 * math.sin(eta) ** 2, mode=mode)
    out.append((name, b, h, mode, ag, None if r["overturned"] else r["theta_max"] / eta))
    return out


@pytest.mark.parametrize("solver", SOLVERS)
def test_broadband_records_match_the_event_reference_and_the_default_loop(cases, solver):
    for name, b, h, mode, ag, ref in cases:
        block, motion = rj.Block(b=b, h=h), rj.GroundMotion(ag=ag, dt=0.01)
        got = rj.simulate_housner(block, motion, mode=mode, solver=SOLVERS[solver])
        default = rj.simulate_housner(block, motion, mode=mode)
        assert int(got.status) == STATUS_OK, (name, mode)
        assert _agree(_peak(got), ref), (name, mode, _peak(got), ref)
        assert _agree(_peak(got), _peak(default)), (name, mode, _peak(got), _peak(default))


@needs_fema
def test_near_threshold_peaks_match_the_event_reference():
    # Flights often shorter than a record step, peaks of 8.6e-6 to 0.47 eta: the turning
    # points are the peak events (measured: within 3.4e-5 of the references, as the default).
    records = load_near_records()
    for name, b, h, mode, pga, ref in NEAR_CASES:
        motion = rj.GroundMotion(ag=near_threshold_record(records[name], b, h, mode, pga), dt=DT)
        got = rj.simulate_housner(rj.Block(b=b, h=h), motion, mode=mode, solver=diffrax.Tsit5())
        assert not bool(got.overturned), (name, b, h, mode, pga)
        peak = float(got.theta_max / got.eta)
        assert abs(peak - ref) <= PEAK_RTOL * ref + NEAR_PEAK_ATOL, (name, b, h, mode, pga, peak)


def test_free_rocking_impact_time_and_energy_are_exact():
    block = rj.Block(b=0.25, h=1.5)
    eta, p, theta0, e = float(block.eta), float(block.p), 0.5 * float(block.eta), 0.9
    resp = rj.simulate_housner(
        block, None, theta0=theta0, e=e, duration=1.5, dt=0.01, solver=diffrax.Tsit5()
    )
    n = np.asarray(resp.extras["n_impacts"])
    first = np.flatnonzero(n == 1)
    t_impact = float(resp.extras["t_last_impact"][first[0]])
    assert t_impact == pytest.approx(housner_time_to_impact(p, eta, theta0), abs=IMPACT_TIME_ATOL)
    energy = np.asarray(resp.energy)
    np.testing.assert_allclose(energy[first], e**2 * energy[0], rtol=ENERGY_RTOL)


def _pulse():
    """A one-sine pulse that rocks the 0.25 x 3 m parapet to 0.45 eta with 9 impacts."""
    return rj.GroundMotion.sine_cycle(pga_g=0.2, period=0.5, dt=0.01, duration=4.0)


@pytest.mark.slow  # 25-28 s (reverse and forward mode through diffrax); ./test.sh -m slow
def test_grad_and_jvp_match_central_differences():
    block, pulse = rj.Block(b=0.25, h=3.0), _pulse()

    def peak(scale, e, adjoint=None):
        r = rj.simulate_housner(
            block, pulse.scaled(scale), e=e, solver=diffrax.Tsit5(), adjoint=adjoint
        )
        return r.theta_max

    run = jax.jit(peak)
    assert 0.2 < float(run(1.0, 0.9) / block.eta) < 0.9  # rocking, not overturning

    def central(f, x):
        return (float(f(x + FD_STEP)) - float(f(x - FD_STEP))) / (2.0 * FD_STEP)

    grad = float(jax.jit(jax.grad(peak))(1.0, 0.9))
    assert grad == pytest.approx(central(lambda s: run(s, 0.9), 1.0), rel=GRAD_RTOL)

    forward = diffrax.ForwardMode()
    _, tangent = jax.jit(lambda e: jax.jvp(lambda x: peak(1.0, x, forward), (e,), (1.0,)))(0.9)
    assert float(tangent) == pytest.approx(central(lambda x: run(1.0, x), 0.9), rel=GRAD_RTOL)


def test_arguments_of_the_diffrax_path_are_checked(user_view):
    block, pulse = rj.Block(b=0.25, h=3.0), _pulse()
    with pytest.raises(ValueError, match="solver must be None"):
        rj.simulate_housner(block, pulse, solver="tsit5")
    with pytest.raises(ValueError, match="adaptive"):
        rj.simulate_housner(
            block, pulse, solver=diffrax.Tsit5(), stepsize_controller=diffrax.ConstantStepSize()
        )
    with pytest.raises(ValueError, match="with a diffrax solver only"):
        rj.simulate_housner(block, pulse, stepsize_controller=diffrax.PIDController(1e-6, 1e-8))
    with pytest.raises(ValueError, match="dt=0.001"):
        rj.simulate_housner(block, pulse, solver=diffrax.Tsit5(), dt=0.001)
    u = np.zeros(pulse.n)
    with pytest.raises(ValueError, match="default loop only"):
        rj.simulate_housner(
            block, pulse, mode="one_sided", solver=diffrax.Tsit5(), wall_motion=(u, u)
        )
