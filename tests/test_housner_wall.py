"""Tests of simulate_housner(..., mode="one_sided", wall_motion=...): a facade against a moving
return wall (docs/three_branch.md, "Moving return walls").

Independent references: the fixed-wall facade (zero relative wall motion must give it to
round-off); an event-driven scipy solve_ivp solver written here (flights between impacts on the
moving wall, relative restitution, riding on the wall until it pulls away faster than the block
can follow); a loop for vmap; finite differences for grad.
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import rockjax as rj
from rockjax.constants import G
from rockjax.three_branch import ThreeBranchLaw

DT = 0.01
# Zero wall motion evaluates the same expressions with zeros added: the same numbers.
SAME_ATOL = 1e-15
# Against the event-driven reference (DOP853, rtol 1e-11): both resolve impacts and lift-off
# exactly and differ by Tsit5's error (measured 6e-6 of the peak rotation over 6 s and nine
# impacts; theta_max, refined between samples, is 2.6e-5 above the reference's sampled peak).
REF_RTOL_PEAK = 1e-4
FD_RTOL = 1e-5
FD_STEP = 1e-6


@pytest.fixture(scope="module")
def block():
    return rj.Block(b=0.25, h=3.0)


@pytest.fixture(scope="module")
def record():
    t = np.arange(0.0, 6.0 + DT / 2, DT)
    return rj.GroundMotion(ag=-1.0 * np.sin(2 * np.pi * t) * (t < 2.5), dt=DT)


def _wall_from_acceleration(a_w, dt):
    """The wall's (u, v) [m, m/s] at the samples, exact for its acceleration a_w [m/s^2]
    linear between samples, from rest."""
    u, v = np.zeros_like(a_w), np.zeros_like(a_w)
    for i in range(a_w.size - 1):
        v[i + 1] = v[i] + dt * (a_w[i] + a_w[i + 1]) / 2
        u[i + 1] = u[i] + v[i] * dt + dt * dt * (a_w[i] / 3 + a_w[i + 1] / 6)
    return u, v


def _sine_wall(n, amplitude=0.005, f=2.0, dt=DT):
    """Acceleration [m/s^2] of a wall that oscillates as u = A (1 - cos(w t)) from rest: it
    pushes the facade outward by up to 2 A and comes back, without drift."""
    t = np.arange(n) * dt
    w = 2 * np.pi * f
    return amplitude * w * w * np.cos(w * t)


def test_zero_wall_motion_is_the_fixed_wall(block, record):
    fixed = rj.simulate_housner(block, record, mode="one_sided", e=0.8)
    zero = np.zeros(record.n)
    moving = rj.simulate_housner(block, record, mode="one_sided", e=0.8, wall_motion=(zero, zero))
    assert int(fixed.extras["n_impacts"][-1]) > 5
    np.testing.assert_allclose(np.asarray(moving.theta), np.asarray(fixed.theta), atol=SAME_ATOL)
    np.testing.assert_allclose(
        np.asarray(moving.theta_dot), np.asarray(fixed.theta_dot), atol=SAME_ATOL
    )
    np.testing.assert_array_equal(
        np.asarray(moving.extras["n_impacts"]), np.asarray(fixed.extras["n_impacts"])
    )


def _reference(block, record, a_w, e, t_end):
    """Event-driven one-sided rocking against a wall rotating by theta_w = u / h (pivot +1).

    Riding: theta = theta_w(t) until the block's free acceleration exceeds the wall's (a root
    of the excess, bracketed on a 1 ms grid); flying: solve_ivp with a terminal event at
    theta = theta_w(t) moving inward; impact: theta_dot - w_w -> -e (theta_dot - w_w).
    Returns the rotation at the record's samples.
    """
    eta, h = float(block.eta), float(block.h)
    k = float(block.p) ** 2 / G
    ag, dt = np.asarray(record.ag), record.dt
    u, v = _wall_from_acceleration(a_w, dt)

    def wall(t):  # the exact cubic of a linear acceleration (Taylor form about the sample)
        i = min(int(t // dt), ag.size - 2)
        tau = t - i * dt
        slope = (a_w[i + 1] - a_w[i]) / dt
        th = u[i] + v[i] * tau + a_w[i] * tau**2 / 2 + slope * tau**3 / 6
        om = v[i] + a_w[i] * tau + slope * tau**2 / 2
        al = a_w[i] + slope * tau
        return th / h, om / h, al / h

    def free(t, theta):
        a = np.interp(t, np.arange(ag.size) * dt, ag)
        return -k * (G * math.sin(eta - theta) + a * math.cos(eta - theta))

    def excess(t):
        th, _, al = wall(t)
        return free(t, th) - al

    t_s = np.arange(ag.size) * dt
    out = np.full(t_s.size, np.nan)
    t0, riding, y0 = 0.0, True, None
    while t0 < t_end:
        if riding:
            grid = np.arange(t0, t_end, 1e-3)
            ex = np.array([excess(t) for t in grid])
            up = np.flatnonzero((ex[:-1] <= 0) & (ex[1:] > 0))
            t_up = brentq(excess, grid[up[0]], grid[up[0] + 1], xtol=1e-14) if up.size else t_end
            sel = (t_s >= t0) & (t_s <= t_up)
            out[sel] = [wall(t)[0] for t in t_s[sel]]
            if not up.size:
                break
            th, om, _ = wall(t_up)
            t0, riding, y0 = t_up, False, [th, om]
            continue

        def rhs(t, y):
            return [y[1], free(t, y[0])]

        def gap(t, y):
            return y[0] - wall(t)[0]

        gap.terminal, gap.direction = True, -1
        # start just after lift-off or impact so the event does not fire at the start
        sol = solve_ivp(
            rhs,
            (t0, t_end),
            y0,
            events=gap,
            rtol=1e-11,
            atol=1e-14,
            dense_output=True,
            method="DOP853",
            first_step=1e-6,
        )
        sel = (t_s >= t0) & (t_s <= sol.t[-1])
        if sel.any():
            out[sel] = sol.sol(t_s[sel])[0]
        if sol.status != 1:
            break
        t_hit = float(sol.t_events[0][0])
        th, om, _ = wall(t_hit)
        rel = -e * (float(sol.y_events[0][0][1]) - om)
        t0 = t_hit
        if rel < 1e-7 and excess(t_hit + 1e-9) < 0:
            riding = True
        else:
            y0 = [th, om + rel]
    return out


def test_sinusoidal_wall_matches_an_event_driven_reference(block, record):
    a_w = _sine_wall(record.n)
    u, v = _wall_from_acceleration(a_w, DT)
    resp = rj.simulate_housner(block, record, mode="one_sided", e=0.8, wall_motion=(u, v))
    theta = np.asarray(resp.theta)
    assert int(resp.extras["n_impacts"][-1]) > 5
    # the block never goes behind the wall
    assert np.min(theta - u / float(block.h)) > -1e-12
    ref = _reference(block, record, a_w, 0.8, (record.n - 1) * DT)
    peak = np.max(np.abs(ref))
    np.testing.assert_allclose(theta, ref, rtol=0, atol=REF_RTOL_PEAK * peak)
    assert float(resp.theta_max) == pytest.approx(peak, rel=REF_RTOL_PEAK)


def test_sinusoidal_wall_with_two_solver_steps_per_sample(block):
    """The same reference with a record sampled at 0.05 s: p dt = 0.11 > P_DT_TARGET, so the
    solver takes two steps per sample and reads the wall inside a sample interval."""
    dt = 0.05
    assert float(block.p) * dt > rj.housner.P_DT_TARGET
    t = np.arange(0.0, 6.0 + dt / 2, dt)
    record = rj.GroundMotion(ag=-1.0 * np.sin(2 * np.pi * t) * (t < 2.5), dt=dt)
    a_w = _sine_wall(record.n, dt=dt)
    u, v = _wall_from_acceleration(a_w, dt)
    resp = rj.simulate_housner(block, record, mode="one_sided", e=0.8, wall_motion=(u, v))
    theta = np.asarray(resp.theta)
    assert int(resp.extras["n_impacts"][-1]) >= 5
    assert np.min(theta - u / float(block.h)) > -1e-12
    ref = _reference(block, record, a_w, 0.8, (record.n - 1) * dt)
    peak = np.max(np.abs(ref))
    np.testing.assert_allclose(theta, ref, rtol=0, atol=REF_RTOL_PEAK * peak)


def test_a_facade_at_rest_rides_on_its_wall(block):
    """Reference: the wall's own rotation u / h. With no ground motion and a wall that moves
    gently (peak acceleration 0.08 m/s^2, far below what would pull it away from the block),
    every pass is a quiet one: the facade never lifts off its wall and turns with it, sample for
    sample, alone and in a batch beside a run that rocks (whose passes are not quiet)."""
    n = 301
    u, v = _wall_from_acceleration(_sine_wall(n, amplitude=5e-4, f=2.0), DT)
    assert np.max(u) > 9e-4  # it moved (2 A at the top of its cycle)
    still = rj.GroundMotion(ag=np.zeros(n), dt=DT)
    resp = rj.simulate_housner(block, still, mode="one_sided", e=0.8, wall_motion=(u, v))
    assert int(resp.extras["n_impacts"][-1]) == 0
    np.testing.assert_allclose(np.asarray(resp.theta), u / float(block.h), rtol=1e-12, atol=1e-16)
    assert float(resp.theta_max) == pytest.approx(np.max(np.abs(u)) / float(block.h), rel=1e-12)
    # in a batch beside a run that rocks, the resting run still rides on its wall
    shaken = rj.GroundMotion(ag=-3.0 * np.sin(2 * np.pi * np.arange(n) * DT), dt=DT)

    def run(ag):
        gm = rj.GroundMotion(ag=ag, dt=DT)
        r = rj.simulate_housner(block, gm, mode="one_sided", e=0.8, wall_motion=(u, v), throw=False)
        return r.theta, r.theta_max

    theta, peak = jax.vmap(run)(jnp.stack([jnp.asarray(still.ag), jnp.asarray(shaken.ag)]))
    assert float(peak[1]) > 0.1 * float(block.eta)  # the other run rocked
    np.testing.assert_allclose(np.asarray(theta[0]), u / float(block.h), rtol=1e-12, atol=1e-16)


def test_jit_vmap_and_grad_over_the_wall_amplitude(block, record):
    a_w = _sine_wall(record.n)
    u, v = (jnp.asarray(x) for x in _wall_from_acceleration(a_w, DT))

    def peak(scale):
        return rj.simulate_housner(
            block, record, mode="one_sided", e=0.8, wall_motion=(scale * u, scale * v)
        ).theta_max

    scales = jnp.array([0.5, 1.0, 1.5])
    batched = jax.jit(jax.vmap(peak))(scales)
    loop = np.array([float(peak(float(c))) for c in scales])
    np.testing.assert_allclose(np.asarray(batched), loop, rtol=1e-12)
    assert batched.dtype == jnp.float64
    g = float(jax.jit(jax.grad(peak))(1.0))
    fd = (float(peak(1.0 + FD_STEP)) - float(peak(1.0 - FD_STEP))) / (2 * FD_STEP)
    assert g == pytest.approx(fd, rel=FD_RTOL)


def test_wall_motion_bad_input_raises(block, record, user_view):
    zero = np.zeros(record.n)
    with pytest.raises(ValueError, match="one_sided"):
        rj.simulate_housner(block, record, mode="two_sided", wall_motion=(zero, zero))
    with pytest.raises(ValueError, match="ground motion"):
        rj.simulate_housner(block, None, mode="one_sided", duration=1.0, wall_motion=(zero, zero))
    with pytest.raises(ValueError, match="one value per record sample"):
        rj.simulate_housner(block, record, mode="one_sided", wall_motion=(zero[:-1], zero[:-1]))
    with pytest.raises(ValueError, match="outlast the record"):
        rj.simulate_housner(
            block, record, mode="one_sided", duration=10.0, wall_motion=(zero, zero)
        )


def test_a_wall_acceleration_record_goes_through_building_wall_top_motion(block, record):
    """wall_motion=GroundMotion (the wall's absolute acceleration) equals the (u, v) pair of its
    acceleration relative to the base, integrated here."""
    pytest.importorskip("rockjax.building")
    a_rel = _sine_wall(record.n)
    wall_abs = rj.GroundMotion(ag=np.asarray(record.ag) + a_rel, dt=DT)
    via_building = rj.simulate_housner(block, record, mode="one_sided", e=0.8, wall_motion=wall_abs)
    u, v = _wall_from_acceleration(a_rel, DT)
    direct = rj.simulate_housner(block, record, mode="one_sided", e=0.8, wall_motion=(u, v))
    # the same wall motion, integrated by two codes: rounding, amplified a little by impacts
    np.testing.assert_allclose(
        np.asarray(via_building.theta), np.asarray(direct.theta), rtol=0, atol=1e-10
    )


def test_zero_wall_motion_with_a_three_branch_law_is_the_fixed_wall(block, record):
    """The two options together: a semi-rigid facade (its kinks are events too) against a wall
    that does not move relative to the base."""
    law = ThreeBranchLaw(lambda_0=0.25 / 3.0, Delta_1=0.04, Delta_2=0.2, Delta_u=0.9)
    fixed = rj.simulate_housner(block, record, mode="one_sided", e=0.8, law=law)
    zero = np.zeros(record.n)
    moving = rj.simulate_housner(
        block, record, mode="one_sided", e=0.8, law=law, wall_motion=(zero, zero)
    )
    assert int(fixed.extras["n_impacts"][-1]) >= 1  # it rocked and hit the wall
    np.testing.assert_allclose(np.asarray(moving.theta), np.asarray(fixed.theta), atol=SAME_ATOL)
