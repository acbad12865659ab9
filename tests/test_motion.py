import numpy as np
import pytest

import rockjax as rj
from rockjax.constants import G


def test_from_g_converts_units():
    gm = rj.GroundMotion.from_g([0.0, 0.5, -1.0], dt=0.01)
    np.testing.assert_allclose(gm.ag, [0.0, 0.5 * G, -G])
    assert gm.n == 3 and np.isclose(gm.duration, 0.02)


def test_pulses_have_requested_peak_and_period():
    """Reference: the analytic pulse definitions (peak value, zero crossings)."""
    r = rj.GroundMotion.ricker(pga=2.0, period=0.5, dt=0.001)
    assert np.isclose(np.max(np.abs(r.ag)), 2.0, rtol=1e-6)
    # zeros of 1 - 2 pi^2 tau^2 / T^2 at tau = T / (pi sqrt 2)
    t0 = 0.75
    tz = t0 + 0.5 / (np.pi * np.sqrt(2))
    assert abs(np.interp(tz, r.t, r.ag)) < 1e-2
    s = rj.GroundMotion.sine_cycle(pga=-3.0, period=0.4, dt=0.001)
    assert np.isclose(s.ag.min(), -3.0, rtol=1e-4) and np.isclose(s.ag.max(), 3.0, rtol=1e-4)
    assert np.all(s.ag[s.t > 0.4 + 1e-9] == 0.0)


def test_scaled():
    gm = rj.GroundMotion.sine_cycle(pga=1.0, period=0.5)
    assert np.isclose(float(gm.scaled(2.5).pga), 2.5)


def test_bad_records_are_refused():
    with pytest.raises(ValueError, match="non-finite samples"):
        rj.GroundMotion(ag=np.array([0.0, np.nan, 1.0]), dt=0.01)
    with pytest.raises(ValueError, match="at least 2 samples"):
        rj.GroundMotion(ag=np.array([]), dt=0.01)
    with pytest.raises(ValueError, match="dt must be a positive"):
        rj.GroundMotion(ag=np.zeros(4), dt=0.0)
    with pytest.raises(ValueError, match="not uniformly sampled"):
        rj.GroundMotion.from_time_series([0.0, 0.01, 0.03], [0.0, 1.0, 0.0])
