"""DEM rigid block: physics against independent references, transforms, and bad input."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import PARAPET, SQUAT, first_downcrossing, housner_time_to_impact

import rockjax as rj
from rockjax import dem
from rockjax.constants import G

# Tolerances, each with its reason.
REST_TOL = 1e-6  # [rad] issue spec; an exact static equilibrium should not move at all
ENERGY_RTOL = 5e-3  # issue spec; central differences conserve a shadow energy to O(dt^2)
DT_CONV_RTOL = 5e-3  # issue spec for halving dt at the default step
UPLIFT_RTOL = 0.05  # issue spec; a slow ramp adds a small inertial lag
FD_RTOL = 1e-4  # issue spec; FD step 1e-6 relative gives ~1e-9 truncation/round-off
IMPACT_TIME_RTOL = 0.01
WALL_PENETRATION = 2e-4  # [m] rocking energy ~26 J into a ~1e9 N/m spring is ~0.2 mm at most  # penalty contact compliance shifts the rigid (Housner) fall by <1 %


@pytest.fixture(scope="module")
def parapet():
    return rj.Block(**PARAPET)


def test_at_rest_stays_at_rest(parapet):
    """Reference: exact static equilibrium (springs carry the weight, theta = 0)."""
    r = rj.simulate_dem(parapet, beta=0.0, duration=10.0)
    assert r.theta.dtype == jnp.float64
    assert float(jnp.max(jnp.abs(r.theta))) < REST_TOL
    assert not bool(r.overturned) and int(r.status) == 0


def _energy_history(blk):
    rest = rj.simulate_dem(blk, beta=0.0, duration=0.1, save=("energy",))
    r = rj.simulate_dem(blk, beta=0.0, theta0=0.5 * blk.eta, duration=10.0, save=("energy",))
    e = np.asarray(r.energy)
    return r, (e - e[0]) / (e[0] - float(rest.energy[0]))


def test_energy_conserved_without_damping():
    """Reference: conservation of total energy (kinetic + gravity + springs) with beta = 0."""
    blk = rj.Block(**PARAPET)
    r, rel = _energy_history(blk)
    assert np.max(np.abs(rel)) < ENERGY_RTOL, np.max(np.abs(rel))
    assert r.theta_max > 0.45 * blk.eta  # it really rocked


def test_energy_never_grows_without_damping():
    """Reference: the only non-conservative parts (Mohr-Coulomb slip, spring release on opening)
    can only dissipate. The squat block does lose ~2 % per impact at beta = 0 (e = 0.988, as
    measured with independent codes in the issue), so only the sign is checked here."""
    r, rel = _energy_history(rj.Block(**SQUAT))
    assert np.max(rel) < ENERGY_RTOL, np.max(rel)
    assert rel[-1] < 0


def test_free_rocking_restitution(parapet):
    """Reference: the issue's independently measured e(beta=0) ~ 1 and Eq. 2's e_H."""
    eta = float(parapet.eta)
    r0 = rj.simulate_dem(parapet, beta=0.0, theta0=0.5 * eta, duration=5.0)
    rb = rj.simulate_dem(parapet, beta=rj.beta_dejong(parapet), theta0=0.5 * eta, duration=5.0)
    e0, eb = r0.e_exp(3), rb.e_exp(3)
    assert np.all(e0 >= 0.99), e0
    assert np.all(eb < float(rj.e_housner(parapet))), eb


def test_first_impact_time_matches_housner_quadrature(parapet):
    """Reference: quadrature of the rigid Housner EOM from theta0 to the first impact."""
    eta = float(parapet.eta)
    r = rj.simulate_dem(parapet, beta=0.0, theta0=0.5 * eta, duration=1.5, save_dt=1e-4)
    t_dem = first_downcrossing(r.t, r.theta)
    t_ref = housner_time_to_impact(float(parapet.p), eta, 0.5 * eta)
    assert abs(t_dem - t_ref) / t_ref < IMPACT_TIME_RTOL, (t_dem, t_ref)


@pytest.mark.parametrize("geometry", [PARAPET, SQUAT])
def test_halving_dt_changes_peak_little(geometry):
    """Reference: self-convergence (the same run at dt/2)."""
    blk = rj.Block(**geometry)
    beta = rj.beta_dejong(blk)
    gm = rj.GroundMotion.sine_cycle(pga=-2.0 * G * float(blk.b / blk.h), period=0.6, duration=4.0)
    dt = rj.stable_dt(blk, beta)
    m1 = float(rj.simulate_dem(blk, gm, beta=beta, dt=dt).theta_max)
    m2 = float(rj.simulate_dem(blk, gm, beta=beta, dt=dt / 2).theta_max)
    assert m1 > 0.1 * float(blk.eta)  # the pulse really rocks the block
    assert abs(m1 - m2) / m2 < DT_CONV_RTOL, (m1, m2)


def test_uplift_under_slow_ramp(parapet):
    """Reference: static uplift at a_g = g tan(eta) (moment balance about the toe)."""
    rate = 0.1 * G  # [m/s^2 per s]
    dt = 0.001
    t = np.arange(0.0, 2.0, dt)
    gm = rj.GroundMotion(ag=rate * t, dt=dt)  # positive: heel is the +x corner
    r = rj.simulate_dem(parapet, gm, beta=rj.beta_dejong(parapet), save=("forces",))
    heel = np.asarray(r.extras["normal_forces"])[:, -1]
    i = int(np.flatnonzero(heel <= 0.0)[0])
    a_uplift = rate * float(r.t[i])
    ref = G * float(parapet.b / parapet.h)
    assert abs(a_uplift - ref) / ref < UPLIFT_RTOL, (a_uplift, ref)


def test_one_sided_rebounds_off_the_wall():
    """Reference: geometry; the back face's top corner stops at the wall plane x = -b/2 - gap."""
    blk = rj.Block(**SQUAT)
    gap = 0.002
    r = rj.simulate_dem(
        blk,
        beta=0.0,
        mode="one_sided",
        gap=gap,
        theta0=0.5 * blk.eta,
        duration=3.0,
        save_dt=0.0005,
    )
    th = np.asarray(r.theta)
    x = np.asarray(r.extras["x"])
    x_top_back = x - 0.5 * float(blk.b) * np.cos(th) + 0.5 * float(blk.h) * np.sin(th)
    wall = -0.5 * float(blk.b) - gap
    penetration = wall - x_top_back.min()
    # it reaches the wall, and the wall spring (k = j_kn h/2 ~ 1e9 N/m) stops it within 0.2 mm
    assert 0.0 < penetration < WALL_PENETRATION, penetration
    # after the base-and-wall impact (t ~ 0.42 s) the facade rebounds outward, losing energy:
    # one-sided impacts are lossy (|e_1SR| = 0.48 for this block, Eq. 5), so the rebound is
    # well below theta0 = 0.5 eta but far above the gap (gap/h = 0.01 eta)
    after = np.asarray(r.t) > 0.45
    assert 0.05 < th[after].max() / float(blk.eta) < 0.5, th[after].max() / float(blk.eta)


def test_overturning_is_flagged_and_frozen(parapet):
    """Reference: a pulse far above the overturning threshold; the state must stay finite."""
    gm = rj.GroundMotion.sine_cycle(pga=-3.0 * G, period=1.5, duration=5.0)
    r = rj.simulate_dem(parapet, gm, beta=rj.beta_dejong(parapet))
    assert bool(r.overturned)
    assert np.all(np.isfinite(np.asarray(r.theta)))
    assert abs(float(r.theta[-1])) < 1.2 * float(parapet.eta)  # frozen near eta, not falling


def test_jit_matches_eager_and_vmap_matches_loop(parapet):
    beta = rj.beta_dejong(parapet)
    dt = rj.stable_dt(parapet, beta)
    amps = jnp.array([-0.5, -1.0, 1.5]) * G * float(parapet.b / parapet.h)
    base = rj.GroundMotion.sine_cycle(pga=1.0, period=0.5, duration=2.0)

    def peak(a):
        gm = rj.GroundMotion(ag=a * jnp.asarray(base.ag), dt=base.dt)
        return rj.simulate_dem(parapet, gm, beta=beta, dt=dt, throw=False).theta_max

    looped = jnp.stack([peak(a) for a in amps])
    batched = jax.vmap(peak)(amps)
    jitted = jax.jit(peak)(amps[1])
    np.testing.assert_allclose(batched, looped, rtol=1e-12)
    np.testing.assert_allclose(jitted, looped[1], rtol=1e-12)


def test_jvp_and_grad_wrt_beta_match_finite_differences(parapet):
    """Reference: central finite differences of a scalar output (theta at t = 2 s)."""
    beta0 = 0.5 * rj.beta_dejong(parapet)
    dt = rj.stable_dt(parapet, 1.1 * beta0)
    theta0 = 0.5 * float(parapet.eta)

    def out(beta):
        r = rj.simulate_dem(parapet, beta=beta, theta0=theta0, duration=2.0, dt=dt)
        return r.theta[-1]

    _, tangent = jax.jvp(out, (jnp.asarray(beta0),), (jnp.asarray(1.0),))
    grad = jax.grad(out)(jnp.asarray(beta0))
    h = 1e-6 * beta0
    fd = (out(beta0 + h) - out(beta0 - h)) / (2 * h)
    assert abs(tangent - fd) < FD_RTOL * abs(fd), (tangent, fd)
    assert abs(grad - tangent) < 1e-8 * abs(tangent)


def test_grad_wrt_geometry_and_amplitude(parapet):
    """Reference: central finite differences w.r.t. b, E, h and the record amplitude."""
    beta = 0.5 * rj.beta_dejong(parapet)
    dt = 0.8 * rj.stable_dt(rj.Block(b=0.26, h=2.9, E=2.0e9), beta)
    base = rj.GroundMotion.sine_cycle(pga=-1.5 * G * 0.25 / 3.0, period=0.5, duration=1.5)

    def out(b, E, h, amp):
        gm = rj.GroundMotion(ag=amp * jnp.asarray(base.ag), dt=base.dt)
        blk = rj.Block(b=b, h=h, E=E)
        return rj.simulate_dem(blk, gm, beta=beta, dt=dt).theta[-1]

    x0 = (0.25, 1.8e9, 3.0, 1.0)
    g = jax.grad(out, argnums=(0, 1, 2, 3))(*x0)
    for k in range(4):
        h = 1e-6 * x0[k]
        xp = list(x0)
        xm = list(x0)
        xp[k] += h
        xm[k] -= h
        fd = (out(*xp) - out(*xm)) / (2 * h)
        assert abs(g[k] - fd) < FD_RTOL * abs(fd) + 1e-12, (k, g[k], fd)


def test_traced_unstable_dt_fails_loudly_or_reports_status(parapet):
    """An unstable step for a traced beta: error_if under jit, a status with throw=False."""
    dt = rj.stable_dt(parapet, 0.0)  # stable only for small beta

    def run(beta, throw):
        return rj.simulate_dem(parapet, beta=beta, theta0=0.04, duration=0.2, dt=dt, throw=throw)

    with pytest.raises(Exception, match="stability limit"):
        jax.jit(lambda b: run(b, True).theta)(rj.beta_dejong(parapet)).block_until_ready()
    r = jax.jit(lambda b: run(b, False))(rj.beta_dejong(parapet))
    assert int(r.status) == rj.response.STATUS_UNSTABLE
    statuses = jax.vmap(lambda b: run(b, False).status)(jnp.array([0.0, rj.beta_dejong(parapet)]))
    assert list(np.asarray(statuses)) == [0, rj.response.STATUS_UNSTABLE]


def test_dashpot_conventions_differ(parapet):
    """The clipped dashpot cannot pull, so it dissipates less per impact (contact.py)."""
    beta = rj.beta_dejong(parapet)
    kw = dict(beta=beta, theta0=0.5 * parapet.eta, duration=5.0)
    e_closed = rj.simulate_dem(parapet, **kw).e_exp(2)
    e_clipped = rj.simulate_dem(parapet, dashpot="clipped", **kw).e_exp(2)
    assert np.all(e_clipped > e_closed)


def test_omega_max_bounds_every_contact_subset(parapet):
    """Reference: interlacing; the all-closed frequency bounds single-corner rocking."""
    p = dem.dem_params(parapet, 0.0)
    w_all = float(dem.omega_max(p))
    one = eqx.tree_at(lambda q: q.kn_base, p, p.kn_base.at[0].set(0.0))
    one = eqx.tree_at(lambda q: q.ks_base, one, p.ks_base.at[0].set(0.0))
    assert float(dem.omega_max(one)) <= w_all


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(beta=-1.0), "beta must be finite and >= 0"),
        (dict(mode="three_sided"), "mode must be one of"),
        (dict(gap=-0.001), "gap must be finite and >= 0"),
        (dict(theta0=0.2), "theta0=0.2 rad must satisfy"),
        (dict(dt=0.0), "dt must be a positive time step"),
        (dict(dt=0.1), "exceeds the explicit stability limit"),
        (dict(n_sub=1), "n_sub"),
        (dict(save=("stress",)), "save entry must be one of"),
        (dict(mode="one_sided", theta0=-0.01), "can only rotate outward"),
    ],
)
def test_bad_input_is_refused(parapet, kwargs, match):
    kw = dict(duration=1.0)
    kw.update(kwargs)
    with pytest.raises(ValueError, match=match):
        rj.simulate_dem(parapet, **kw)


def test_free_rocking_needs_duration(parapet):
    with pytest.raises(ValueError, match="needs duration"):
        rj.simulate_dem(parapet, theta0=0.01)


def test_traced_beta_without_dt_is_refused(parapet):
    with pytest.raises(ValueError, match="Pass dt=rj.stable_dt"):
        jax.grad(lambda b: rj.simulate_dem(parapet, beta=b, theta0=0.01, duration=0.1).theta[-1])(
            0.001
        )


def test_vertical_ground_motion_scales_the_settlement(parapet):
    """Reference: statics; an upward base acceleration a_v loads the springs with m (g + a_v)."""
    n = 2001
    still = rj.GroundMotion(ag=np.zeros(n), dt=0.005)
    lifted = rj.GroundMotion(ag=np.zeros(n), dt=0.005, ag_v=np.full(n, 0.5 * G))
    beta = rj.beta_dejong(parapet)  # damps the vertical bounce from the step in load
    sink0 = 0.5 * float(parapet.h) - float(
        rj.simulate_dem(parapet, still, beta=beta).extras["y"][-1]
    )
    sink1 = 0.5 * float(parapet.h) - float(
        rj.simulate_dem(parapet, lifted, beta=beta).extras["y"][-1]
    )
    k_total = float(parapet.j_kn * parapet.b * parapet.length)
    assert np.isclose(sink0, float(parapet.m) * G / k_total, rtol=1e-9)
    assert np.isclose(sink1, 1.5 * sink0, rtol=1e-6)


def test_nonfinite_state_fails_loudly_under_jit(parapet):
    """A non-finite record inside jit (0 x inf): error_if raises, throw=False gives a status."""
    base = rj.GroundMotion.sine_cycle(pga=1.0, period=0.5, duration=1.0)
    dt = rj.stable_dt(parapet, 0.0)

    def run(amp, throw):
        gm = rj.GroundMotion(ag=amp * jnp.asarray(base.ag), dt=base.dt)
        return rj.simulate_dem(parapet, gm, beta=0.0, dt=dt, throw=throw)

    with pytest.raises(Exception, match="non-finite"):
        jax.jit(lambda a: run(a, True).theta)(jnp.inf).block_until_ready()
    assert int(jax.jit(lambda a: run(a, False).status)(jnp.inf)) == rj.response.STATUS_NONFINITE
