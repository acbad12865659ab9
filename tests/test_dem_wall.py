"""DEM facades with a moving return wall (``simulate_dem(..., wall_motion=...)``).

References: the fixed-wall facade (a wall that does not move relative to the base), the
kinematics of a block leaning on a slowly rotating wall (``theta = u_top / h``), and the energy
balance ``E(t) - E(0) = W_wall(t)`` with no damping and no slip (the wall's work is the only
energy input).
"""

import importlib.util

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import smooth_push

import rockjax as rj
from rockjax import dem

FACADE = dict(b=0.2, h=1.5)
DT_OUT = 0.002  # [s] record step of the synthetic wall histories

SAME_RTOL = 1e-12  # a zero wall motion is the fixed wall: same arithmetic up to fusion order
KINEMATIC_TOL = 0.01  # [-] of u_top / h: the wall contact's compression (~1e-6 m over h) and
# the lag of a damped block following a 2 s push (measured 1.4e-3)
CLOSURE_TOL = 5e-3  # [-] of the wall's peak work (6.7 J, the block lifted): central differences
# balance the energy to O(dt^2), the error made where the block lands back on its base
# (measured 2.8e-3 at the default step, 7.4e-4 at half of it)
DISSIPATION_TOL = 1e-3  # [-] of the wall's peak work: the same O(dt^2) wobble
GRAD_RTOL = 1e-3  # AD vs central differences of a smooth response (measured 2.5e-6)
FD_STEP = 1e-6  # [s] relative step of the beta finite difference


@pytest.fixture(scope="module")
def facade():
    return rj.Block(**FACADE)


def _smooth_push(amp, period, n, dt=DT_OUT):
    return smooth_push(amp, period, n, dt)


def _quiet(n):
    return rj.GroundMotion(ag=np.zeros(n), dt=DT_OUT)


def _pulse(n):
    """One sine cycle of 0.5 g, 0.4 s, then quiet: the facade rocks off its wall and back."""
    t = np.arange(n) * DT_OUT
    ag = np.where(t < 0.4, -0.5 * 9.80665 * np.sin(2 * np.pi * t / 0.4), 0.0)
    return rj.GroundMotion(ag=ag, dt=DT_OUT)


N_BATCH = 300  # samples of the batched runs (shared, so the compiled run is reused)
BETA_BATCH = 1e-3  # [s]


def _batch_dt(facade):
    return rj.stable_dt(facade, BETA_BATCH, mode="one_sided")


def test_zero_wall_motion_is_the_fixed_wall(facade):
    """Reference: the fixed-wall code path (no wall arrays: what ``wall_motion=None`` runs)."""
    gm = _pulse(N_BATCH)
    dt = _batch_dt(facade)
    kw = dict(mode="one_sided", beta=BETA_BATCH, gap=0.002, dt=dt, save=("energy",))
    z = np.zeros(gm.n)
    moving = rj.simulate_dem(facade, gm, wall_motion=(z, z), **kw)
    default = rj.simulate_dem(facade, gm, **kw)
    peak = float(np.max(np.abs(default.theta)))
    np.testing.assert_allclose(moving.theta, default.theta, rtol=0, atol=SAME_RTOL * peak)
    # a fixed wall does no work: reported as zeros
    np.testing.assert_array_equal(np.asarray(default.extras["work_wall"]), z)
    # the driver without wall arrays, called directly
    params = dem.dem_params(facade, BETA_BATCH, mode="one_sided", gap=0.002)
    s0 = dem.initial_state(facade, params)
    n_in = round(gm.dt / float(moving.extras["dt"]))
    # (the steps a sample as data, and the open steps the facade takes off its wall)
    n_open = np.int32(round(gm.dt / float(moving.extras["dt_open"])))
    assert n_open < n_in
    step = np.asarray(gm.dt / n_in)
    args = (params, s0, np.asarray(gm.ag), z, step, gm.dt, np.int32(n_in), (), True)
    fixed = dem.run(*args, n_open=n_open)
    fixed = eqx.tree_at(lambda r: r.theta, fixed, fixed.theta[:, 0])
    scale = float(np.max(np.abs(fixed.theta)))
    assert scale > 0.1 * float(facade.eta)  # it rocks
    np.testing.assert_allclose(moving.theta, fixed.theta, rtol=0, atol=SAME_RTOL * scale)
    np.testing.assert_allclose(default.theta, fixed.theta, rtol=0, atol=SAME_RTOL * scale)


@pytest.mark.skipif(
    importlib.util.find_spec("rockjax.building") is None, reason="rockjax.building not present"
)
def test_wall_moving_with_the_ground_is_the_fixed_wall(facade):
    """Reference: a wall whose absolute acceleration is the ground's moves with the base
    (u = v = 0), so the facade responds as against a fixed wall."""
    gm = _pulse(N_BATCH)
    kw = dict(mode="one_sided", beta=BETA_BATCH, dt=_batch_dt(facade))
    moving = rj.simulate_dem(facade, gm, wall_motion=gm, **kw)
    fixed = rj.simulate_dem(facade, gm, **kw)
    scale = float(np.max(np.abs(fixed.theta)))
    np.testing.assert_allclose(moving.theta, fixed.theta, rtol=0, atol=SAME_RTOL * scale)


def test_slow_push_tilts_the_facade_with_the_wall(facade):
    """Reference: kinematics. A wall rotating slowly by u_top / h about the base carries the
    facade leaning on it: the block pivots on its toe with theta = u_top / h (small angles,
    rigid contact) while theta < eta."""
    n = 1000
    amp = 0.5 * float(facade.eta) * FACADE["h"]  # tilt to half the slenderness
    u, v = _smooth_push(amp, 4.0, n)  # the peak at t = 2 s (quasi-static: T >> 1/p)
    r = rj.simulate_dem(
        facade, _quiet(n), mode="one_sided", beta=rj.beta_dejong(facade), wall_motion=(u, v)
    )
    # the loading half (on the way back the block falls after the wall, bouncing on it)
    theta = np.asarray(r.theta)
    ref = u / FACADE["h"]
    assert theta.max() > 0.45 * float(facade.eta)
    assert np.max(np.abs(theta - ref)) < KINEMATIC_TOL * ref.max(), np.max(np.abs(theta - ref))
    assert not bool(r.overturned)


def test_wall_work_closes_the_energy_balance(facade):
    """Reference: energy conservation with a moving support. With beta = 0, no ground motion,
    point contacts that stay closed and friction that sticks (phi = 89 deg: no slip, so the
    contact law is elastic), the block's energy changes only by the wall's work:
    E(t) - E(0) = W_wall(t)."""
    n = 600
    u, v = _smooth_push(0.02, 1.0, n)
    r = rj.simulate_dem(
        facade,
        _quiet(n),
        mode="one_sided",
        beta=0.0,
        joint=rj.Joint(n_sub=2),
        phi_deg=89.0,
        wall_motion=(u, v),
        save=("energy",),
    )
    e, work = np.asarray(r.energy), np.asarray(r.extras["work_wall"])
    assert work.max() > 1.0  # [J] the wall does real work (it lifts the block)
    err = np.max(np.abs(e - e[0] - work))
    assert err < CLOSURE_TOL * work.max(), (err, work.max())


def test_wall_work_covers_the_energy_with_friction(facade):
    """Reference: dissipation is never negative. With the paper's phi = 30 deg the back face
    slides along the wall as the block tilts, so friction takes part of the wall's work:
    E(t) - E(0) <= W_wall(t), and the block that returns to rest has lost it all."""
    n = 600
    u, v = _smooth_push(0.02, 1.0, n)
    r = rj.simulate_dem(
        facade, _quiet(n), mode="one_sided", beta=0.0, wall_motion=(u, v), save=("energy",)
    )
    e, work = np.asarray(r.energy), np.asarray(r.extras["work_wall"])
    gain = e - e[0]
    assert gain.max() > 1.0  # [J] the block was lifted
    assert np.all(gain - work < DISSIPATION_TOL * work.max())
    assert work[-1] > 0.01 * work.max()  # friction dissipated: net work into the block
    # a wall that does not move does no work
    z = np.zeros(n)
    still = rj.simulate_dem(
        facade, _quiet(n), mode="one_sided", beta=0.0, wall_motion=(z, z), save=("energy",)
    )
    np.testing.assert_array_equal(np.asarray(still.extras["work_wall"]), z)


def test_jit_and_vmap_over_wall_histories(facade):
    """jit(vmap) over two wall histories equals a Python loop of eager runs: with the step as
    data, each run of the batch takes its own open and closed steps as it would alone."""
    u1, v1 = _smooth_push(0.01, 0.5, N_BATCH)
    u2, v2 = _smooth_push(0.03, 0.4, N_BATCH)
    gm = _quiet(N_BATCH)
    dt = _batch_dt(facade)

    def run(u, v, dt):
        return rj.simulate_dem(
            facade, gm, mode="one_sided", beta=BETA_BATCH, dt=dt, wall_motion=(u, v)
        ).theta

    loop = np.stack([np.asarray(run(u1, v1, dt)), np.asarray(run(u2, v2, dt))])
    batch = jax.jit(jax.vmap(run, in_axes=(0, 0, None)))
    batched = batch(jnp.stack([u1, u2]), jnp.stack([v1, v2]), jnp.asarray(dt))
    assert loop[1].max() > 2 * loop[0].max() > 0
    scale = float(np.max(np.abs(loop)))
    np.testing.assert_allclose(batched, loop, rtol=0, atol=SAME_RTOL * scale)
    assert batched.dtype == jnp.float64


def _wall_push_objective(facade, n=100):
    """A smooth scalar of a moving-wall run as a function of beta (integrated theta^2)."""
    u, v = _smooth_push(0.04, 0.3, n)
    gm = _quiet(n)
    dt = rj.stable_dt(facade, 1.1 * BETA0, mode="one_sided")

    def objective(beta):
        r = rj.simulate_dem(facade, gm, mode="one_sided", beta=beta, dt=dt, wall_motion=(u, v))
        return jnp.sum(r.theta**2) * DT_OUT

    return objective


BETA0 = 2e-3  # [s]


def _central_difference(f, x):
    h = FD_STEP * x
    return (float(f(x + h)) - float(f(x - h))) / (2 * h)


@pytest.mark.slow  # ~15-25 s of compilation; DEM jvp in beta is also tested in tests/test_dem.py
def test_jvp_wrt_beta_with_a_moving_wall(facade):
    """Forward mode through the moving-wall run matches central differences."""
    f = _wall_push_objective(facade)
    _, tangent = jax.jvp(f, (jnp.asarray(BETA0),), (jnp.asarray(1.0),))
    fd = _central_difference(f, BETA0)
    assert np.isfinite(float(tangent)) and float(tangent) != 0.0
    assert abs(float(tangent) - fd) < GRAD_RTOL * abs(fd), (tangent, fd)


@pytest.mark.slow  # reverse mode compiles for ~40 s
def test_grad_wrt_beta_with_a_moving_wall(facade):
    """Reverse mode through the moving-wall run is finite and matches central differences."""
    f = _wall_push_objective(facade)
    g = float(jax.grad(f)(jnp.asarray(BETA0)))
    fd = _central_difference(f, BETA0)
    assert np.isfinite(g) and g != 0.0
    assert abs(g - fd) < GRAD_RTOL * abs(fd), (g, fd)


def test_wall_motion_needs_one_sided(facade):
    z = np.zeros(10)
    with pytest.raises(ValueError, match="wall_motion.*one_sided"):
        rj.simulate_dem(facade, _quiet(10), wall_motion=(z, z))


def test_wall_motion_shape_is_checked(facade):
    z = np.zeros(9)
    with pytest.raises(ValueError, match="wall_motion: u_top.*shape"):
        rj.simulate_dem(facade, _quiet(10), mode="one_sided", wall_motion=(z, z))
    bad = np.full(10, np.nan)
    with pytest.raises(ValueError, match="non-finite"):
        rj.simulate_dem(facade, _quiet(10), mode="one_sided", wall_motion=(bad, np.zeros(10)))


def test_longer_duration_holds_the_wall(facade):
    """Past the record's end the wall holds its last position (velocity zero): the run equals
    one with the wall's history padded that way."""
    n = N_BATCH // 2
    u = np.linspace(0.0, 0.004, n)
    v = np.full(n, 0.004 / ((n - 1) * DT_OUT))
    kw = dict(mode="one_sided", beta=BETA_BATCH, dt=_batch_dt(facade))
    longer = rj.simulate_dem(
        facade, _quiet(n), wall_motion=(u, v), duration=(N_BATCH - 1) * DT_OUT, **kw
    )
    u_pad = np.concatenate([u, np.full(N_BATCH - n, u[-1])])
    v_pad = np.concatenate([v, np.zeros(N_BATCH - n)])
    padded = rj.simulate_dem(facade, _quiet(N_BATCH), wall_motion=(u_pad, v_pad), **kw)
    assert longer.theta.shape == (N_BATCH,)
    np.testing.assert_array_equal(np.asarray(longer.theta), np.asarray(padded.theta))
    assert float(np.max(longer.theta)) > 0
