"""rockjax.metrics: bounce peaks and the calibration losses, against exact references."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax import metrics

ETA = 0.1


def _decaying(t, amps, half_period):
    """|sin|-shaped half-cycles of alternating sign with the given peak amplitudes [rad]."""
    k = np.minimum((t // half_period).astype(int), len(amps) - 1)
    phase = (t % half_period) / half_period
    sign = np.where(k % 2 == 0, 1.0, -1.0)
    return sign * np.asarray(amps)[k] * np.sin(np.pi * phase)


def test_peaks_recover_half_cycle_amplitudes_and_times():
    """Reference: a signal with known peaks at the middle of each half-cycle. The parabola
    through three samples recovers a sine peak to (pi h / T)^2 / 8 relative (~1e-5 here)."""
    amps = [0.05, 0.04, 0.03, 0.02, 0.01]
    t = np.arange(0, 5.0, 0.002)
    # start at a maximum (the release): shift by a quarter half-cycle so t=0 is the peak
    th = _decaying(t + 0.5, amps, 1.0)
    pk = metrics.peaks(t, th, ETA, 3)
    np.testing.assert_allclose(pk.amplitude[1:4], amps[1:4], rtol=2e-5)
    np.testing.assert_allclose(pk.t[1:4], [1.0, 2.0, 3.0], atol=1e-9)
    assert bool(jnp.all(pk.valid)) and int(pk.n_impacts) == 4
    np.testing.assert_allclose(
        pk.log_energy, np.log(rj.relations.rocking_energy(pk.amplitude, ETA))
    )


def test_missing_bounces_are_invalid_and_floored():
    t = np.arange(0, 2.0, 0.002)
    th = _decaying(t + 0.5, [0.05, 0.04], 1.0)
    th = np.where(t > 1.5, 0.0, th)
    pk = metrics.peaks(t, th, ETA, 4)
    assert list(np.asarray(pk.valid)) == [True, False, False, False, False]
    assert np.allclose(pk.amplitude[1:], metrics.HYSTERESIS * ETA)


def test_one_sided_ignores_wall_chatter():
    """A rebound smaller than RELATIVE_BOUNCE of the previous peak is not a bounce."""
    t = np.arange(0, 3.0, 0.001)
    big = np.abs(_decaying(t + 0.5, [0.05, 0.02, 0.01], 1.0))
    chatter = 3e-4 * np.abs(np.sin(np.pi * (t - 0.5) / 0.05)) * ((t > 0.5) & (t < 0.55))
    th = np.where((t > 0.5) & (t < 0.55), chatter, big)
    pk = metrics.peaks(t, th, ETA, 2, mode="one_sided")
    np.testing.assert_allclose(pk.amplitude[1:], [0.02, 0.01], rtol=1e-4)


def test_housner_bounce_energies_give_e_exactly():
    """Housner free rocking: U_k = e^(2k) U_0 exactly (the impact map scales theta_dot by e and
    energy is conserved in flight), so the least-squares slope recovers e."""
    blk = rj.Block(b=0.25, h=3.0)
    for e in (0.97, 0.9):
        r = rj.simulate_housner(blk, e=e, theta0=0.5 * float(blk.eta), duration=12.0, dt=0.002)
        pk = metrics.peaks(r.t, r.theta, blk.eta, 8)
        assert abs(float(jnp.exp(metrics.log_e_fit(pk))) - e) < 2e-5


def test_peak_loss_is_squared_log_e_gap():
    """For two constant-e responses the loss equals (log e1 - log e2)^2 and the signed gap
    log e1 - log e2 (to the peak-refinement error)."""
    blk = rj.Block(b=0.25, h=3.0)
    kw = dict(theta0=0.5 * float(blk.eta), duration=12.0, dt=0.002)
    a = rj.simulate_housner(blk, e=0.95, **kw)
    b = rj.simulate_housner(blk, e=0.97, **kw)
    pa, pb = (metrics.peaks(r.t, r.theta, blk.eta, 6) for r in (a, b))
    gap = np.log(0.95) - np.log(0.97)
    assert abs(float(metrics.log_e_gap(pa, pb)) - gap) < 1e-4
    assert abs(float(metrics.peak_loss(pa, pb)) - gap**2) < 2e-6
    assert float(metrics.peak_loss(pa, pa)) == 0.0


def test_peaks_jit_vmap_grad():
    """d(peak)/d(scale) = peak / scale for a scaled signal; jit and vmap agree with eager."""
    t = jnp.arange(0, 3.0, 0.002)
    th = jnp.asarray(_decaying(np.asarray(t) + 0.5, [0.05, 0.04, 0.03, 0.02], 1.0))

    def amp2(s):
        pk = metrics.peaks(t, s * th, ETA, 2)
        return jnp.where(pk.valid[2], pk.amplitude[2], jnp.nan)

    g = jax.grad(amp2)(1.3)
    assert np.isclose(g, amp2(1.3) / 1.3, rtol=1e-10)
    v = jax.jit(jax.vmap(amp2))(jnp.array([1.0, 1.3]))
    np.testing.assert_allclose(v, [amp2(1.0), amp2(1.3)], rtol=1e-12)


def test_history_error():
    x = jnp.sin(jnp.linspace(0, 20, 2001))
    assert float(metrics.history_error(x, x)) < 1e-12
    assert np.isclose(float(metrics.history_error(0.9 * x, x)), 0.1, rtol=1e-9)
    w = jnp.where(jnp.arange(2001) < 1000, 1.0, 0.0)
    y = jnp.where(jnp.arange(2001) < 1000, x, 0.0)
    assert float(metrics.history_error(y, x, w)) < 1e-12


def test_bad_mode():
    with pytest.raises(ValueError, match="mode"):
        metrics.half_cycles(jnp.zeros(5), ETA, "three_sided")


def test_amplitude_and_timing_losses():
    """A signal scaled by s and delayed by tau: amplitude loss (log s)^2, timing loss
    (tau / scale)^2, over the compared bounces (exact up to the parabola refinement)."""
    t = np.arange(0, 6.0, 0.002)
    amps = [0.05, 0.04, 0.03, 0.02, 0.015]
    ref = metrics.peaks(t, _decaying(t + 0.5, amps, 1.0), ETA, 3)
    sim = metrics.peaks(t, 1.1 * _decaying(t + 0.5, amps, 1.0), ETA, 3)
    assert np.isclose(float(metrics.amplitude_loss(sim, ref)), np.log(1.1) ** 2, rtol=1e-6)
    late = metrics.peaks(t, _decaying(t + 0.5 - 0.1, amps, 1.0), ETA, 3)
    assert np.isclose(float(metrics.timing_loss(late, ref, 0.5)), (0.1 / 0.5) ** 2, rtol=1e-3)


def test_bounce_weights_keep_valid_bounces_above_the_energy_floor():
    """Hand-built peaks, energy ratios U_k/U_0 = 0.5, 0.03, 0.01, 0.2 (the last not completed):
    weight 1 exactly for the completed bounces k >= 1 keeping >= 2 % of the release energy."""
    ratios = np.array([1.0, 0.5, 0.03, 0.01, 0.2])
    pk = metrics.Peaks(
        t=jnp.arange(5.0),
        amplitude=jnp.ones(5),
        log_energy=jnp.log(jnp.asarray(ratios)) + 3.0,  # the offset (log U_0) must not matter
        valid=jnp.array([True, True, True, True, False]),
        n_impacts=jnp.asarray(4),
    )
    w, k = metrics.bounce_weights(pk, 0.02)
    np.testing.assert_array_equal(np.asarray(w), [0.0, 1.0, 1.0, 0.0, 0.0])
    np.testing.assert_array_equal(np.asarray(k), np.arange(5.0))
