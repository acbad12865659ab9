"""rockjax.pulses: identifying the analytic pulse in a record (paper Fig. 8)."""

import numpy as np
import pytest

import rockjax as rj
from rockjax import pulses

CASES = [("MH", 0.8, 3.0, 5.0), ("AR", 1.3, -2.0, 6.0), ("SC", 0.6, 4.0, 4.0)]


def _pulse(shape, T, A, t0, dt=0.01, duration=15.0):
    if shape == "MH":
        return rj.GroundMotion.ricker(A, T, dt=dt, duration=duration, t0=t0)
    if shape == "AR":
        return rj.GroundMotion.ricker_antisymmetric(A, T, dt=dt, duration=duration, t0=t0)
    return rj.GroundMotion.sine_cycle(A, T, dt=dt, duration=duration, t0=t0)


@pytest.mark.parametrize(("shape", "T", "A", "t0"), CASES)
def test_exact_pulse_is_recovered(shape, T, A, t0):
    """Reference: the pulse itself, unfiltered. The period grid is refined by a parabola, so
    T comes back to ~1 % (grid spacing 5.5 %); amplitude and time follow from it."""
    best, fits = pulses.identify_pulse(_pulse(shape, T, A, t0), f_cut=None)
    assert best.shape == shape
    assert best.r2 > 0.995
    assert abs(best.period / T - 1) < 0.015
    assert abs(best.amplitude / A - 1) < 0.02
    assert abs(best.t0 - t0) < 0.02 * T + 0.01
    # the fitted pulse reproduces the record
    err = np.linalg.norm(np.asarray(best.pulse.ag) - np.asarray(_pulse(shape, T, A, t0).ag))
    assert err / np.linalg.norm(np.asarray(_pulse(shape, T, A, t0).ag)) < 0.1
    assert set(fits) == set(pulses.SHAPES)


@pytest.mark.parametrize(("shape", "T", "A", "t0"), CASES)
def test_shape_is_identified_in_noise(shape, T, A, t0):
    """White noise of 30 % of the pulse amplitude: the low-pass filter removes most of it and
    the right shape still explains the most energy. The 3 Hz filter also trims the broadband
    content of the short (0.6 s) one-sine cycle, which biases its period by about -6 %."""
    g = _pulse(shape, T, A, t0)
    noise = np.random.default_rng(1).normal(0.0, 0.3 * abs(A), g.n)
    best, _ = pulses.identify_pulse(rj.GroundMotion(ag=np.asarray(g.ag) + noise, dt=g.dt))
    assert best.shape == shape
    assert abs(best.period / T - 1) < 0.08


def test_lowpass_gain():
    """A 0.5 Hz sine passes unchanged, a 10 Hz sine is removed (corner 3 Hz)."""
    t = np.arange(0, 20, 0.005)
    slow = np.sin(2 * np.pi * 0.5 * t)
    fast = np.sin(2 * np.pi * 10.0 * t)
    out = np.asarray(pulses.lowpass(rj.GroundMotion(ag=slow + fast, dt=0.005)).ag)
    mid = slice(400, -400)  # away from the ends (the record is not periodic)
    assert np.max(np.abs(out[mid] - slow[mid])) < 1e-2


def test_bad_input():
    g = rj.GroundMotion.zeros(2.0, 0.01)
    with pytest.raises(ValueError, match="all zeros"):
        pulses.identify_pulse(g)
    with pytest.raises(ValueError, match="shape"):
        pulses.fit_pulse(_pulse("MH", 1.0, 1.0, 3.0), "XX")


@pytest.mark.parametrize(
    ("shape", "constructor"),
    [("MH", "ricker"), ("AR", "ricker_antisymmetric"), ("SC", "sine_cycle")],
)
def test_pulse_is_its_shapes_constructor(shape, constructor):
    gm = pulses.pulse(shape, 2.0, 0.5, dt=0.01, duration=3.0)
    ref = getattr(rj.GroundMotion, constructor)(2.0, 0.5, dt=0.01, duration=3.0)
    np.testing.assert_array_equal(np.asarray(gm.ag), np.asarray(ref.ag))
    assert gm.dt == 0.01 and gm.name == ref.name


def test_pulse_refuses_an_unknown_shape():
    with pytest.raises(ValueError, match="shape must be one of"):
        pulses.pulse("ricker", 2.0, 0.5)
