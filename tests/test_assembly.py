"""Tests of rockjax.assembly (geometry, limit analysis) and rockjax.multiblock (the
multi-block DEM), each against an independent reference."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import coulomb_slip, smooth_push
from scipy.integrate import solve_ivp

import rockjax as rj
from rockjax.assembly import Assembly, collapse_multiplier
from rockjax.constants import G
from rockjax.dem import simulate_assembly, stable_dt_assembly
from rockjax.response import find_peaks

# Tolerances, each with its reason.
EQUAL_RTOL = 1e-10  # the one-block assembly is simulate_dem's scheme: round-off only (~1e-13)
GLUED_PEAK_TOL = 2e-3  # [eta] glued pair vs tall block: bed joint compliance (measured 2.3e-4)
GLUED_OPEN_TOL = 1e-3  # [eta] relative rotation of the glued pair (measured 1.3e-4)
ENERGY_RTOL = 5e-3  # central differences conserve a shadow energy; corners barely slip
MIN_ORDER = 1.6  # centred dashpots, exact two-body block solve: second order
RIGID_TOL = 0.2  # [theta0] DEM at E = 1.8e11 Pa vs the rigid model (compliance; measured 0.14)
UPLIFT_LAG = 0.1  # a ramp of 2 lambda in 4 s lags the static onset (measured 2.5-6.3 %)
VMAP_RTOL = 1e-9  # vmap vs a Python loop: the same arithmetic, fused differently (1e-12)
PUSHOVER_RTOL = 2e-3  # DEM pushover peak below the rigid limit (corner joint compliance)
FD_RTOL = 1e-3  # central differences, step 1e-6 relative, of a piecewise-smooth contact response
# slip history of a squat stack on stiff joints vs rigid Coulomb sliding: the joints' elastic
# shear and small rocking (measured below 1e-3 for both joints)
COULOMB_RTOL = 0.01

ONE = rj.Block(b=0.2, h=1.5)
CORNERS = rj.Joint(n_sub=2)
PULSE = rj.GroundMotion.sine_cycle(pga=-3.0, period=0.5, dt=0.005, duration=2.0)


def _peaks(t, y, n):
    """The first ``n`` rocking peaks of ``y`` after the release (|y| maxima at least 0.3 s
    apart), signed."""
    idx = []
    for sign in (1.0, -1.0):
        tp, _ = find_peaks(t, np.maximum(sign * y, 0.0), min_separation=0.3)
        idx += [int(np.argmin(np.abs(t - v))) for v in tp]
    # (skip the release: a settling wobble at t ~ 0 is no rocking peak)
    idx = sorted(i for i in idx if abs(y[i]) > 0.1 * np.max(np.abs(y)) and t[i] > 0.1)
    return y[np.array(idx[:n], dtype=int)]


# ----------------------------------------------------------------------------- one block


@pytest.mark.parametrize(
    "joint",
    [rj.Joint(), pytest.param(rj.Joint(n_sub=3, dashpot="clipped"), marks=pytest.mark.slow)],
    ids=["face", "n3-clipped"],
)
def test_one_block_equals_simulate_dem(joint):
    """A block is the assembly of one: simulate_dem(block) and the one-block assembly run the
    same kernel, so their histories are equal to the bit (theta, x, y, the maxima, the
    energy), eager and under vmap alike."""
    beta = 0.5 * float(rj.beta_dejong(ONE))
    dt = rj.stable_dt(ONE, beta, joint=joint)
    kw = dict(beta=beta, theta0=0.3 * float(ONE.eta), dt=dt, joint=joint, save=("energy",))
    ref = rj.simulate_dem(ONE, PULSE, **kw)
    r = simulate_assembly(Assembly.stack([ONE]), PULSE, **kw)
    assert r.theta.dtype == jnp.float64 and r.theta.shape == (PULSE.n, 1)
    scale = float(jnp.max(jnp.abs(ref.theta)))
    assert scale > 0.2 * float(ONE.eta)  # it rocked
    _assert_equals_single_block(r, ref, scale)
    for a, b in ((r.theta[:, 0], ref.theta), (r.x[:, 0], ref.extras["x"]), (r.energy, ref.energy)):
        np.testing.assert_array_equal(a, b)
    assert float(r.theta_max[0]) == float(ref.theta_max)
    assert float(r.d_max[0]) == float(ref.extras["d_max"])

    def both(a):
        gm = rj.GroundMotion(ag=a * jnp.asarray(PULSE.ag), dt=PULSE.dt)
        one = rj.simulate_dem(ONE, gm, **kw).theta
        stacked = rj.simulate_dem(Assembly.stack([ONE]), gm, **kw).theta[:, 0]
        return one, stacked

    one, stacked = jax.vmap(both)(jnp.array([0.5, 1.0]))
    np.testing.assert_array_equal(one, stacked)


def _assert_equals_single_block(r, ref, scale):
    """A one-block assembly's response ``r`` equals simulate_dem's ``ref`` (theta, x, y,
    overturning, theta_max) to EQUAL_RTOL of ``scale`` [rad] and of the block's height."""
    assert float(jnp.max(jnp.abs(r.theta[:, 0] - ref.theta))) < EQUAL_RTOL * scale
    for key in ("x", "y"):
        err = float(jnp.max(jnp.abs(getattr(r, key)[:, 0] - ref.extras[key])))
        assert err < EQUAL_RTOL * float(ONE.h), key
    assert bool(r.overturned) == bool(ref.overturned)
    assert abs(float(r.theta_max[0]) - float(ref.theta_max)) < EQUAL_RTOL * scale


def test_default_step_is_simulate_dems():
    """Reference: rj.stable_dt (the same accuracy rule on the same stiffness matrix)."""
    for joint in (rj.Joint(), rj.Joint(n_sub=2)):
        for mode in ("two_sided", "one_sided"):
            a = stable_dt_assembly(Assembly.stack([ONE]), 2e-3, joint=joint, mode=mode)
            ref = rj.stable_dt(ONE, 2e-3, joint=joint, mode=mode)
            assert a == pytest.approx(ref, rel=1e-12), mode


# ----------------------------------------------------------------------------- two blocks


@pytest.mark.slow  # (keeps the file under 60 s on a loaded machine)
def test_glued_pair_rocks_like_one_tall_block():
    """Reference: rj.simulate_dem of the tall block (0.2 x 1.5 m). The pair 2 x (0.2 x 0.75 m)
    has the same ground joint (E of the bottom block halved, so E/h is the tall block's), a
    bed joint 10x stiffer and friction 80 deg: it stays closed, and the first three rocking
    peaks (through two impacts) match to GLUED_PEAK_TOL eta. Damping (0.25 beta_DeJong)
    settles the bed joint's own vibration: at beta = 0 it rings after each impact and takes
    ~2.5 % of the amplitude per impact, which the single block has not."""
    tall = ONE
    pair = Assembly.stack([rj.Block(b=0.2, h=0.75, E=0.9e9), rj.Block(b=0.2, h=0.75, E=1.8e10)])
    beta = 0.25 * float(rj.beta_dejong(tall))
    kw = dict(beta=beta, theta0=0.5 * float(tall.eta), duration=3.0, phi_deg=80.0)
    ref = rj.simulate_dem(tall, **kw)
    r = simulate_assembly(pair, **kw)
    th = np.asarray(r.theta)
    eta = float(tall.eta)
    assert np.max(np.abs(th[:, 1] - th[:, 0])) < GLUED_OPEN_TOL * eta  # the bed joint stays shut
    t = np.asarray(r.t)
    p_ref, p = _peaks(t, np.asarray(ref.theta), 3), _peaks(t, th[:, 0], 3)
    assert len(p_ref) == 3 and len(p) == 3
    assert np.max(np.abs(p - p_ref)) < GLUED_PEAK_TOL * eta, (p / eta, p_ref / eta)


def test_energy_conserved_two_block_stack():
    """Reference: conservation of energy (kinetic + gravity + overburden + springs) at beta = 0
    over 10 s of free rocking of a two-block stack released tilted; corner contacts and an
    overburden of 20 kN/m keep the bed joint closed, friction 80 deg prevents slip."""
    joint = rj.Joint(n_sub=2)
    wall = Assembly.stack([rj.Block(b=0.25, h=1.5)] * 2, overburden=2e4)
    kw = dict(phi_deg=80.0, save=("energy",), joint=joint)
    rest = simulate_assembly(wall, duration=0.1, **kw)
    w = float(wall.mass * G)
    y_g = (w * 1.5 + 2e4 * 3.0) / (w + 2e4)
    eta = math.atan(0.125 / y_g)
    r = simulate_assembly(wall, theta0=0.5 * eta, duration=10.0, **kw)
    e = np.asarray(r.energy)
    rel = (e - e[0]) / (e[0] - float(rest.energy[-1]))
    assert np.max(np.abs(rel)) < ENERGY_RTOL, np.max(np.abs(rel))
    assert float(jnp.min(r.theta)) < -0.4 * eta  # it rocked through impacts
    assert not bool(r.overturned) and int(r.status) == 0


def _order(h, err):
    return np.polyfit(np.log(h), np.log(np.abs(err)), 1)[0]


@pytest.mark.slow
def test_convergence_order_in_dt():
    """Reference: the observed order of the scheme, from a log-log fit of the error at
    dt0, dt0/2, dt0/4 against dt0/16 (a damped two-block stack under a pulse, before any
    joint opens to the onset band's non-smoothness)."""
    wall = Assembly.stack([rj.Block(b=0.3, h=1.0), rj.Block(b=0.2, h=1.5)])
    beta = 2e-3
    motion = rj.GroundMotion.sine_cycle(pga=-1.0, period=0.4, dt=0.01, duration=0.2)
    dt0 = stable_dt_assembly(wall, beta)
    runs = {}
    for k in (1, 2, 4, 16):
        r = simulate_assembly(wall, motion, beta=beta, dt=dt0 / k)
        runs[k] = np.asarray(r.theta[-1])
    err = [np.max(np.abs(runs[k] - runs[16])) for k in (1, 2, 4)]
    order = _order(np.array([1.0, 0.5, 0.25]), np.array(err))
    assert order > MIN_ORDER, (order, err)


def _rigid_two_block(b1, h1, b2, h2, theta0, side):
    """Psycharis-type rigid model: block 1 rocks about its +x base corner, block 2 about its
    bottom corner on side ``side`` (+1/-1) on block 1's top; Lagrange's equations in
    (theta1, theta2), clockwise positive, integrated by scipy up to block 1's first impact."""
    rho = 1800.0
    m1, m2 = rho * b1 * h1, rho * b2 * h2
    i1, i2 = m1 * (b1**2 + h1**2) / 12, m2 * (b2**2 + h2**2) / 12
    r1 = np.array([-b1 / 2, h1 / 2])
    rb = np.array([side * b2 / 2 - b1 / 2, h1])
    r2 = np.array([-side * b2 / 2, h2 / 2])

    def rot(t, r):
        c, s = np.cos(t), np.sin(t)
        return np.array([r[0] * c + r[1] * s, -r[0] * s + r[1] * c])

    def drot(t, r):
        c, s = np.cos(t), np.sin(t)
        return np.array([-r[0] * s + r[1] * c, -r[0] * c - r[1] * s])

    def rhs(t, y):
        t1, t2, w1, w2 = y
        j1 = np.stack([drot(t1, r1), np.zeros(2)], axis=1)
        j2 = np.stack([drot(t1, rb), drot(t2, r2)], axis=1)
        a1 = -rot(t1, r1) * w1**2
        a2 = -rot(t1, rb) * w1**2 - rot(t2, r2) * w2**2
        mass = m1 * j1.T @ j1 + m2 * j2.T @ j2 + np.diag([i1, i2])
        force = -(m1 * j1.T @ a1 + m2 * j2.T @ a2) - G * (m1 * j1[1] + m2 * j2[1])
        acc = np.linalg.solve(mass, force)
        return [w1, w2, acc[0], acc[1]]

    def impact(t, y):
        return y[0]

    impact.terminal, impact.direction = True, -1
    y0 = [theta0, theta0, 0.0, 0.0]
    phi_dd = rhs(0.0, y0)[3] - rhs(0.0, y0)[2]
    sol = solve_ivp(rhs, (0, 3), y0, events=impact, rtol=1e-10, atol=1e-12, dense_output=True)
    return sol, phi_dd


@pytest.mark.slow
def test_first_phase_matches_rigid_two_block_model():
    """Reference: the rigid two-block model (Psycharis type, integrated in the test with
    scipy): a slender 0.2 x 1.5 m block on a squat 0.3 x 1.0 m one, released as a rigid tilt,
    opens its bed joint (the top block keeps leaning while the bottom one falls back). Up to
    90 % of the time to the first impact the DEM with stiff joints (E = 1.8e11 Pa) follows
    both rotations to RIGID_TOL theta0, and closer than at E = 1.8e10 Pa (convergence to the
    rigid limit as the joints stiffen)."""
    b1, h1, b2, h2 = 0.3, 1.0, 0.2, 1.5
    theta0 = 0.6 * math.atan(b1 / (h1 + h2))
    sol, phi_dd = _rigid_two_block(b1, h1, b2, h2, theta0, side=1)
    assert phi_dd > 0  # the assumed mode (bed joint opening at the -x side) is the right one
    t_end = 0.9 * float(sol.t_events[0][0])
    errs = []
    for e_mod in (1.8e10, 1.8e11):
        wall = Assembly.stack([rj.Block(b=b1, h=h1, E=e_mod), rj.Block(b=b2, h=h2, E=e_mod)])
        r = simulate_assembly(wall, theta0=theta0, duration=t_end, phi_deg=80.0, save_dt=0.004)
        ref = sol.sol(np.asarray(r.t))[:2].T
        errs.append(np.max(np.abs(np.asarray(r.theta) - ref)) / theta0)
    assert errs[1] < RIGID_TOL, errs
    assert errs[1] < 0.7 * errs[0], errs
    # the relative rotation really grows: the rigid model's mode, not the stuck stack
    assert sol.sol(t_end)[1] - sol.sol(t_end)[0] > 0.5 * theta0


RIGID_HINGE_TOL = 5e-3  # [theta0] DEM (E = 1.8e10 Pa, corner joints) vs the rigid mechanism:
# the joints' compliance (measured 5.3e-4; 2.5e-3 at E = 1.8e9 Pa, 1.5e-4 at 1.8e11 Pa)


def _rigid_hinge(b, h, m, p_top, theta0):
    """The rigid three-hinge mechanism of a restrained wall of two equal aligned blocks
    (b x h, mass m, overburden force p_top): block 0 rocks about its +x ground toe A, block 1
    about the hinge B at the -x end of the bed joint, its top face centre C held at x = 0. One
    degree of freedom: Lagrange's equation M(t) t'' + M'(t) t'^2 / 2 + V'(t) = 0, with M and
    V from the geometry (derivatives by central differences), integrated by scipy up to the
    return to t = 0. Returns the solution and block 1's rotation as a function of block 0's."""
    inertia = m * (b * b + h * h) / 12.0

    def rot(t, u, v):
        return np.array([u * math.cos(t) + v * math.sin(t), -u * math.sin(t) + v * math.cos(t)])

    toe = np.array([0.5 * b, 0.0])

    def geometry(t):
        x0 = toe + rot(t, -0.5 * b, 0.5 * h)
        xb = toe + rot(t, -b, h)
        # C = B + R(t1) (b/2, h) at x = 0: (b/2) cos t1 + h sin t1 = -x_B
        t1 = math.asin(-xb[0] / math.hypot(0.5 * b, h)) - math.atan2(0.5 * b, h)
        return x0, xb + rot(t1, 0.5 * b, 0.5 * h), xb + rot(t1, 0.5 * b, h), t1

    def mass(t, d=1e-6):
        hi, lo = geometry(t + d), geometry(t - d)
        j0, j1, jt1 = ((hi[i] - lo[i]) / (2 * d) for i in (0, 1, 3))
        return m * (j0 @ j0 + j1 @ j1) + inertia * (1.0 + jt1 * jt1)

    def potential(t):
        x0, x1, xc, _ = geometry(t)
        return m * G * (x0[1] + x1[1]) + p_top * xc[1]

    def rhs(_, y):
        t, w = y
        d = 1e-5
        dm = (mass(t + d) - mass(t - d)) / (2 * d)
        dv = (potential(t + d) - potential(t - d)) / (2 * d)
        return [w, (-dv - 0.5 * dm * w * w) / mass(t)]

    def back(_, y):
        return y[0]

    back.terminal, back.direction = True, -1
    sol = solve_ivp(
        rhs, (0, 5), [theta0, 0.0], events=back, rtol=1e-10, atol=1e-12, dense_output=True
    )
    return sol, lambda t: geometry(t)[3]


def test_restrained_wall_released_from_its_hinge_matches_rigid_mechanism():
    """Reference: the rigid three-hinge mechanism (Lagrange, integrated in the test with
    scipy). A restrained wall of two 0.2 x 1.0 m blocks (2 kN/m overburden, stiff corner
    joints) released from theta0 = 0.3 eta in its hinge mechanism falls back with both blocks
    on the mechanism's path to RIGID_HINGE_TOL theta0, up to 90 % of the time to the impact."""
    b, h, p_top = 0.2, 1.0, 2e3
    blk = rj.Block(b=b, h=h, E=1.8e10)
    theta0 = 0.3 * math.atan(b / h)
    sol, upper = _rigid_hinge(b, h, float(blk.m), p_top * float(blk.length), theta0)
    t_end = 0.9 * float(sol.t_events[0][0])
    wall = Assembly.stack([blk, blk], top="restrained", overburden=p_top)
    r = simulate_assembly(
        wall, theta0=theta0, duration=t_end, save_dt=0.002, joint=CORNERS, phi_deg=80.0
    )
    t, th = np.asarray(r.t), np.asarray(r.theta)
    ref0 = sol.sol(t)[0]
    ref1 = np.array([upper(v) for v in ref0])
    assert ref0[-1] < 0.25 * theta0  # it fell most of the way back
    assert np.max(np.abs(th[:, 0] - ref0)) < RIGID_HINGE_TOL * theta0
    assert np.max(np.abs(th[:, 1] - ref1)) < RIGID_HINGE_TOL * theta0
    assert not bool(r.overturned) and int(r.status) == 0


# ----------------------------------------------------------------------------- transforms


def test_vmap_over_records_equals_loop():
    """Reference: a Python loop over the records (the same arithmetic)."""
    wall = Assembly.stack([rj.Block(b=0.2, h=1.0)] * 2, top="restrained", overburden=5e3)
    dt = stable_dt_assembly(wall, 1e-3, joint=CORNERS)
    ags = jnp.stack(
        [
            rj.GroundMotion.sine_cycle(pga=a, period=0.3, dt=0.01, duration=0.5).ag
            for a in (-4.0, 6.0)
        ]
    )

    def run(ag):
        motion = rj.GroundMotion(ag=ag, dt=0.01)
        return simulate_assembly(wall, motion, beta=1e-3, dt=dt, joint=CORNERS).theta

    batch = jax.vmap(run)(ags)
    loop = jnp.stack([run(a) for a in ags])
    assert batch.shape == (2, 51, 2)
    assert float(jnp.max(jnp.abs(batch - loop))) <= VMAP_RTOL * float(jnp.max(jnp.abs(loop)))
    assert float(jnp.max(jnp.abs(loop))) > 1e-4  # it moved


def test_face_law_programs_agree():
    """An eager or a jitted history computes each face's end kinematics and point law as
    separate XLA computations (``single_history``); a batch (``vmap``) takes the face law's
    points as scalars. Reference: the eager run of each record, to round-off of the peak
    (VMAP_RTOL: the same arithmetic, grouped differently)."""
    wall = Assembly.stack([rj.Block(b=0.2, h=1.0)] * 2, top="restrained", overburden=5e3)
    base = rj.GroundMotion.sine_cycle(pga=1.0, period=0.3, dt=0.01, duration=1.0)
    dt = stable_dt_assembly(wall, 1e-3)

    def run(ag):
        r = simulate_assembly(wall, rj.GroundMotion(ag=ag, dt=0.01), beta=1e-3, dt=dt)
        return r.theta

    ags = jnp.stack([a * jnp.asarray(base.ag) for a in (-6.0, 8.0)])
    eager = jnp.stack([run(a) for a in ags])
    jitted = jax.jit(run)(ags[0])
    batched = jax.vmap(run)(ags)
    peak = float(jnp.max(jnp.abs(eager)))
    assert peak > 1e-3  # it rocked
    assert float(jnp.max(jnp.abs(eager[0] - jitted))) <= VMAP_RTOL * peak
    assert float(jnp.max(jnp.abs(eager - batched))) <= VMAP_RTOL * peak


@pytest.mark.slow
def test_grad_wrt_beta_matches_finite_differences():
    """Reference: central finite differences of the same function."""
    wall = Assembly.stack([rj.Block(b=0.2, h=1.0)] * 2)
    # one step per sample (n_in = 1): the smallest reverse-mode program
    dt = 1e-4
    motion = rj.GroundMotion.sine_cycle(pga=-5.0, period=0.3, dt=dt, duration=0.5)

    def peak(beta):
        r = simulate_assembly(wall, motion, beta=beta, dt=dt, joint=CORNERS)
        return jnp.sum(r.theta[:, 1] ** 2)

    beta = 2e-3
    g = jax.grad(peak)(beta)
    h = 1e-6 * beta
    fd = (peak(beta + h) - peak(beta - h)) / (2 * h)
    assert np.isfinite(float(g))
    assert float(g) == pytest.approx(float(fd), rel=FD_RTOL)


# ----------------------------------------------------------------------------- collapse


def test_overturning_is_flagged_and_frozen():
    """A strong pulse overturns a free two-block stack: flagged, the state frozen, no NaN."""
    wall = Assembly.stack([rj.Block(b=0.2, h=1.0)] * 2)
    motion = rj.GroundMotion.sine_cycle(pga=-20.0, period=1.0, dt=0.01, duration=2.0)
    r = simulate_assembly(wall, motion, beta=1e-3, throw=False)
    assert bool(r.overturned) and int(r.status) == 0
    assert np.all(np.isfinite(np.asarray(r.theta)))
    assert np.all(np.asarray(r.theta[-1]) == np.asarray(r.theta[-2]))


def test_restrained_wall_is_not_flagged_before_its_hinge_mechanism_fails():
    """A restrained two-block wall collapses by the mid-height hinge: its blocks turn by
    ``eta`` before the flag. The upper block's centroid passes the lower block's edge by
    rotation alone at about ``eta / 2`` (relative rotation 2 theta); that is not sliding off
    (the slide-off rule measured at the centroid flagged these runs at 0.50-0.56 eta)."""
    wall = Assembly.stack([rj.Block(b=0.2, h=1.0)] * 2, top="restrained", overburden=5e3)
    motion = rj.GroundMotion.sine_cycle(pga=-15.0, period=1.0, dt=0.01, duration=2.5)
    r = simulate_assembly(wall, motion, beta=1e-3, throw=False)
    peak = np.max(np.abs(np.asarray(r.theta)), axis=0) / float(wall.blocks[0].eta)
    assert bool(r.overturned) and int(r.status) == 0
    assert np.all(peak > 0.95), peak  # measured 1.03, 1.04 (the eta rule)


@pytest.mark.slow
def test_top_restraint_holds_the_top():
    """The top face centre stays within the restraint's gap (plus the penalty's compliance)."""
    gap = 2e-3
    wall = Assembly.stack([rj.Block(b=0.2, h=1.0)] * 2, top="restrained", gap=gap, overburden=5e3)
    motion = rj.GroundMotion.sine_cycle(pga=-8.0, period=0.5, dt=0.01, duration=1.0)
    r = simulate_assembly(wall, motion, beta=1e-3)
    top = np.asarray(r.x[:, 1] + 0.5 * 1.0 * np.sin(r.theta[:, 1]))
    assert np.max(np.abs(top)) < gap + 1e-3
    assert float(jnp.max(jnp.abs(r.theta[:, 0]))) > 1e-3  # the wall really rocked


# ----------------------------------------------------------------------------- limit analysis


def test_collapse_multiplier_closed_forms():
    """Reference: the static thresholds in closed form: one block tan(eta) = b/h (Housner);
    an aligned stack of n equal blocks b/(n h) (the tall block); the top block (b/h)(1 + P/W);
    the restrained two-block hinge (b/h)(2 + 1.5 P/W)."""
    b, h = 0.2, 1.0
    blk = rj.Block(b=b, h=h)
    w = float(blk.m * G)
    assert float(collapse_multiplier(Assembly.stack([blk]))) == pytest.approx(b / h)
    three = Assembly.stack([blk] * 3)
    assert float(collapse_multiplier(three, "stack")) == pytest.approx(b / (3 * h))
    p = 4e3
    loaded = Assembly.stack([blk] * 2, overburden=p)
    assert float(collapse_multiplier(loaded, "top")) == pytest.approx(b / h * (1 + p / w))
    wall = Assembly.stack([blk] * 2, top="restrained", overburden=p)
    assert float(collapse_multiplier(wall, "hinge")) == pytest.approx(b / h * (2 + 1.5 * p / w))


def _uplift_multiplier(wall, lam_max, duration=4.0):
    """Ground acceleration (in g) at which the stack starts rocking under a slow ramp toward
    +x (a DEM pushover on corner contacts, whose uplift is sharp): the first sample with a
    block rotated beyond 2e-3 eta (twice the elastic rotation at the onset)."""
    dt = 0.002
    t = np.arange(0.0, duration + dt / 2, dt)
    ag = -lam_max * G * t / duration  # inertia toward +x
    r = simulate_assembly(wall, rj.GroundMotion(ag=ag, dt=dt), beta=2e-3, joint=rj.Joint(n_sub=2))
    moved = np.max(np.abs(np.asarray(r.theta)), axis=1) > 2e-3 * float(jnp.min(r.eta))
    return -ag[np.argmax(moved)] / G


@pytest.mark.slow
@pytest.mark.parametrize("case", ["stack", "top", "hinge"])
def test_collapse_multiplier_matches_dem_ramp(case):
    """Reference: a slow ramp of ground acceleration in the DEM (quasi-static pushover): the
    mechanism starts at the multiplier, not before (statics) and within UPLIFT_LAG after
    (the ramp's inertial lag)."""
    blk = rj.Block(b=0.2, h=1.0)
    if case == "stack":
        wall = Assembly.stack([blk, blk])
    elif case == "top":  # a narrow top block on a wide one: the top mechanism comes first
        wall = Assembly.stack([rj.Block(b=0.4, h=1.0), rj.Block(b=0.15, h=1.0)])
    else:
        wall = Assembly.stack([blk, blk], top="restrained", overburden=2e3)
    lam = float(collapse_multiplier(wall, case))
    ratio = _uplift_multiplier(wall, 2.0 * lam) / lam
    assert 0.99 < ratio < 1.0 + UPLIFT_LAG, ratio


def test_collapse_multiplier_matches_pushover_if_available():
    """Reference: the single-block DEM pushover of rockjax.pushover (an independent model and
    derivation), when that module exists: its rigid limit equals the one-block "stack"
    multiplier with overburden, and the peak of its pushover on corner contacts (whose uplift
    is sharp) lies within PUSHOVER_RTOL below it (measured 1.5e-4)."""
    pushover = pytest.importorskip("rockjax.pushover")
    blk = rj.Block(b=0.2, h=1.5)
    p = 3e3
    lam = float(collapse_multiplier(Assembly.stack([blk], overburden=p), "stack"))
    cap = pushover.pushover(blk, overburden=p, joint=CORNERS)
    assert float(cap.lambda_rigid) == pytest.approx(lam, rel=1e-12)
    peak = float(jnp.max(cap.load_multiplier))
    assert lam * (1.0 - PUSHOVER_RTOL) < peak < lam * (1.0 + PUSHOVER_RTOL), (peak, lam)


# ----------------------------------------------------------------------------- bad input


def test_bad_input_is_refused_with_a_fix():
    blk = rj.Block(b=0.2, h=1.0)
    with pytest.raises(ValueError, match="top must be one of"):
        Assembly.stack([blk], top="pinned")
    with pytest.raises(ValueError, match="overburden"):
        Assembly.stack([blk], overburden=-1.0)
    with pytest.raises(ValueError, match="do not overlap"):
        Assembly.stack([blk, blk], x_offset=(0.0, 0.5))
    with pytest.raises(ValueError, match="non-empty"):
        Assembly.stack([])
    with pytest.raises(ValueError, match="length"):
        Assembly.stack([blk, rj.Block(b=0.2, h=1.0, length=2.0)])
    wall = Assembly.stack([blk, blk], top="restrained")
    with pytest.raises(ValueError, match="top='free'"):  # the hinge mechanism: two blocks
        simulate_assembly(Assembly.stack([blk] * 3, top="restrained"), theta0=0.01, duration=0.1)
    with pytest.raises(ValueError, match="hinge mechanism"):
        simulate_assembly(wall, theta0=0.25, duration=0.1)
    with pytest.raises(ValueError, match="wholly on the lower block"):
        wide = Assembly.stack([blk, rj.Block(b=0.3, h=1.0)], top="restrained")
        simulate_assembly(wide, theta0=0.01, duration=0.1)
    with pytest.raises(ValueError, match="overturning angle"):
        simulate_assembly(Assembly.stack([blk, blk]), theta0=0.2, duration=0.1)
    with pytest.raises(ValueError, match="stability limit"):
        simulate_assembly(Assembly.stack([blk]), duration=0.1, dt=0.01)
    with pytest.raises(ValueError, match="hinge"):
        collapse_multiplier(wall, "stack")
    with pytest.raises(ValueError, match="mechanism"):
        collapse_multiplier(wall, "sideways")


# ----------------------------------------------------------------------------- in a building

BUILDING_RTOL = 1e-3  # [max |theta|] a building of period 0.005 s under a 0.5 s pulse: its
# floors' amplification ~ (0.005 / 0.5)^2 = 1e-4, the storey drift ~ 1e-6 m (measured 6e-5)
FOLLOW_TOL = 1e-3  # [m] the top face centre against the floor drift, beyond the gap: the
# restraint's penalty compliance and the top block's own rotation between samples
IN_STOREY = Assembly.stack([rj.Block(b=0.2, h=1.0)] * 2, top="restrained", gap=1e-3, overburden=2e3)
STOREY_PULSE = rj.GroundMotion.sine_cycle(pga=-2.0, period=0.5, dt=0.005, duration=1.0)


def test_rigid_building_gives_the_ground_result():
    """Reference: the wall on the ground (rj.simulate_assembly without a building). In a
    building of period 0.005 s, floor 1's acceleration is the ground's and the drift nil, so
    the wall of storey 2 (base on floor 1, top held by floor 2) moves as on the ground."""
    from rockjax.building import ShearBuilding

    wall, gm = IN_STOREY, rj.GroundMotion.sine_cycle(pga=-6.0, period=0.5, dt=0.005, duration=1.0)
    ref = np.asarray(simulate_assembly(wall, gm, beta=1e-3).theta)
    rigid = ShearBuilding.uniform(2, 3.0, period=0.005)
    th = np.asarray(simulate_assembly(wall, gm, beta=1e-3, support_motion=rigid, storey=2).theta)
    assert np.max(np.abs(ref)) > 0.05  # it rocked
    assert np.max(np.abs(th - ref)) < BUILDING_RTOL * np.max(np.abs(ref))


def test_top_floor_pushes_the_wall():
    """Reference: kinematics of the top restraint. In a flexible building (period 0.5 s) the
    first storey's drift (2 cm) far exceeds the gap (1 mm): the top face centre of the wall
    of storey 1 follows floor 1 within the gap (plus FOLLOW_TOL), and on the ground (no
    building) it stays within the gap of its rest position."""
    from rockjax.building import ShearBuilding

    wall, gm = IN_STOREY, STOREY_PULSE
    soft = ShearBuilding.uniform(2, 3.0, period=0.5)
    drift = np.asarray(soft.response(gm).displacement[0])
    assert np.max(np.abs(drift)) > 10 * float(wall.gap)
    r = simulate_assembly(wall, gm, beta=1e-3, support_motion=soft, storey=1)
    assert not bool(r.overturned)
    top = np.asarray(r.x[:, 1] + 0.5 * np.sin(r.theta[:, 1]))
    assert np.max(np.abs(top - drift)) < float(wall.gap) + FOLLOW_TOL
    ground = simulate_assembly(wall, gm, beta=1e-3)
    top_g = np.asarray(ground.x[:, 1] + 0.5 * np.sin(ground.theta[:, 1]))
    assert np.max(np.abs(top_g)) < float(wall.gap) + FOLLOW_TOL


def test_in_building_bad_input_is_refused():
    from rockjax.building import ShearBuilding

    bldg = ShearBuilding.uniform(2, 3.0, period=0.3)
    with pytest.raises(ValueError, match="storey"):
        simulate_assembly(IN_STOREY, STOREY_PULSE, support_motion=bldg, storey=3)
    with pytest.raises(ValueError, match="storey"):
        simulate_assembly(IN_STOREY, STOREY_PULSE, storey=2)
    with pytest.raises(ValueError, match="needs motion"):
        simulate_assembly(IN_STOREY, duration=0.1, support_motion=bldg)


@pytest.mark.slow
def test_wall_on_the_roof_stands_on_the_top_floor():
    """Reference: the top floor's absolute acceleration as a record
    (ShearBuilding.floor_motions, the building module's own output): a free-top wall of
    storey n + 1 (on the roof) under the ground motion and the building equals the wall on
    the ground under that record (the same arithmetic)."""
    from rockjax.building import ShearBuilding

    wall = Assembly.stack([rj.Block(b=0.2, h=1.0)] * 2)
    bldg = ShearBuilding.uniform(2, 3.0, period=0.3)
    r = simulate_assembly(wall, STOREY_PULSE, beta=1e-3, support_motion=bldg, storey=3)
    ref = simulate_assembly(wall, bldg.floor_motions(STOREY_PULSE)[1], beta=1e-3)
    scale = float(jnp.max(jnp.abs(ref.theta)))
    assert scale > 1e-3
    assert float(jnp.max(jnp.abs(r.theta - ref.theta))) <= VMAP_RTOL * scale


@pytest.mark.slow
def test_vmap_in_a_building_equals_loop():
    """Reference: a Python loop over the records (the same arithmetic)."""
    from rockjax.building import ShearBuilding

    wall = IN_STOREY
    dt = stable_dt_assembly(wall, 1e-3)
    bldg = ShearBuilding.uniform(2, 3.0, period=0.4)
    ags = jnp.stack(
        [
            rj.GroundMotion.sine_cycle(pga=a, period=0.3, dt=0.01, duration=0.5).ag
            for a in (-2.0, 3.0)
        ]
    )

    def run(ag):
        motion = rj.GroundMotion(ag=ag, dt=0.01)
        return simulate_assembly(
            wall, motion, beta=1e-3, dt=dt, support_motion=bldg, storey=2
        ).theta

    batch = jax.vmap(run)(ags)
    loop = jnp.stack([run(a) for a in ags])
    assert float(jnp.max(jnp.abs(batch - loop))) <= VMAP_RTOL * float(jnp.max(jnp.abs(loop)))
    assert float(jnp.max(jnp.abs(loop))) > 1e-4


# ----------------------------------------------------------------------------- return walls

WALL_PENETRATION = 1e-3  # [m] the wall's Winkler joint stops a 1.5 m facade within ~0.3 mm
# (the single-block bound of tests/test_dem.py; measured 0.1-0.3 mm per block)
GLUED_WALL_TOL = 2e-3  # [eta] glued facade pair vs the tall facade: the bed joint's compliance
# (as stiff as the ground joint; its relative rotation measured 2.3e-3 eta, the histories 8.6e-4)
GLUED_WALL_OPEN_TOL = 5e-3  # [eta] relative rotation of the glued pair (measured 2.3e-3)
FACADE_GAP = 0.002  # [m] behind the back faces: the wall is met at theta = -gap/h, not at rest


@pytest.mark.parametrize(
    "joint",
    [rj.Joint(), pytest.param(rj.Joint(n_sub=3, dashpot="clipped"), marks=pytest.mark.slow)],
    ids=["face", "n3-clipped"],
)
def test_one_block_facade_equals_simulate_dem(joint):
    """Reference: rj.simulate_dem of the facade (mode="one_sided", the same gap, joint and
    step): the one-block assembly's back face on its return wall is the same model, equal to
    round-off; reached through rj.simulate_dem's routing of an Assembly. The pulse rocks the
    facade out and back onto its wall, past ``theta = -gap/h``."""
    beta = 0.5 * float(rj.beta_dejong(ONE))
    dt = rj.stable_dt(ONE, beta, joint=joint, mode="one_sided")
    kw = dict(
        beta=beta, theta0=0.3 * float(ONE.eta), dt=dt, joint=joint, mode="one_sided", gap=FACADE_GAP
    )
    ref = rj.simulate_dem(ONE, PULSE, **kw)
    r = rj.simulate_dem(Assembly.stack([ONE]), PULSE, **kw)
    assert isinstance(r, rj.AssemblyResponse) and r.theta.dtype == jnp.float64
    scale = float(jnp.max(jnp.abs(ref.theta)))
    assert float(jnp.min(ref.theta)) < -0.5 * FACADE_GAP / float(ONE.h)  # it met the wall
    _assert_equals_single_block(r, ref, scale)


def test_facade_blocks_stop_at_their_return_walls():
    """Reference: geometry. A free two-block facade (shifted by x_offset = 0.05 m, so the wall
    line is ``x = x_offset - b/2 - gap``) released outward falls back onto its return wall:
    the top-back corner of each block reaches the wall plane and is stopped within
    WALL_PENETRATION by the wall's joint; the mirror wall (no wall at +x) never acts, so the
    facade only leans back to about ``-gap/h`` (plus the penetration)."""
    blk = rj.Block(b=0.2, h=0.75)
    shift = 0.05
    wall = Assembly.stack([blk, blk], x_offset=(shift, shift))
    r = simulate_assembly(
        wall,
        mode="one_sided",
        gap=FACADE_GAP,
        theta0=0.3 * math.atan(0.2 / 1.5),
        duration=0.8,
        save_dt=0.0005,
        phi_deg=80.0,
    )
    th = np.asarray(r.theta)
    corner = shift + np.asarray(r.x) - 0.1 * np.cos(th) + 0.375 * np.sin(th)  # x: from x0
    penetration = (shift - 0.1 - FACADE_GAP) - corner.min(axis=0)
    assert np.all(penetration > 0.0) and np.all(penetration < WALL_PENETRATION), penetration
    lean = (FACADE_GAP + WALL_PENETRATION) / 1.5
    assert np.all(th.min(axis=0) > -2.0 * lean), th.min(axis=0)
    assert not bool(r.overturned) and int(r.status) == 0


@pytest.mark.slow  # (keeps the file under 60 s on a loaded machine)
def test_glued_facade_pair_leans_like_one_tall_facade():
    """Reference: rj.simulate_dem of the tall facade (0.2 x 1.5 m, mode="one_sided"). The pair
    2 x (0.2 x 0.75 m, E halved) has the tall block's joint stiffness E/h on every face: the
    ground joint, the bed joint and both back faces on the wall; friction 80 deg and damping
    (0.25 beta_DeJong) keep its bed joint shut through the impact on the wall (at beta = 0 the
    pair rattles: the wall's impulse is spread over the height, and a no-tension bed joint
    opens under it). Released from 0.5 eta, it falls back onto the wall and settles as the tall
    block, to GLUED_WALL_TOL eta over the whole history."""
    tall = ONE
    pair = Assembly.stack([rj.Block(b=0.2, h=0.75, E=0.9e9)] * 2)
    eta = float(tall.eta)
    beta = 0.25 * float(rj.beta_dejong(tall))
    kw = dict(beta=beta, theta0=0.5 * eta, duration=1.5, phi_deg=80.0, mode="one_sided")
    ref = np.asarray(rj.simulate_dem(tall, **kw).theta)
    th = np.asarray(rj.simulate_dem(pair, **kw).theta)
    assert ref.min() < 0.0 and th.min() < 0.0  # both met the wall
    assert np.max(np.abs(th[:, 1] - th[:, 0])) < GLUED_WALL_OPEN_TOL * eta
    assert np.max(np.abs(th[:, 0] - ref)) < GLUED_WALL_TOL * eta


def test_facade_energy_at_beta_zero_never_grows():
    """Reference: the energy balance at beta = 0 (kinetic + gravity + overburden + springs,
    the return walls' included). The penalty springs are elastic, so in flight (before the
    first impact) the energy is conserved to ENERGY_RTOL, and the contact law's only
    non-conservative parts (Mohr-Coulomb slip, the release of a shear spring as its contact
    opens) can only take energy out: the energy never rises above its start by more than
    ENERGY_RTOL over 4 s of rocking against the walls (measured 1.6e-4 in flight, 1.5e-4
    overall, while the impacts take out 97 %). (One-sided impacts are lossy in this
    model even at beta = 0: the wall's horizontal impulse loads the shear springs of the base
    and the wall, released as the facade rebounds; the single 0.25 x 1.5 m facade of
    rj.simulate_dem loses half its rocking energy at its first impact with corner contacts,
    0.4 % with friction 0.01 deg.)"""
    joint = rj.Joint(n_sub=2)
    wall = Assembly.stack([rj.Block(b=0.25, h=1.5)] * 2, overburden=2e4)
    # sampled every 0.5 ms: an impact on the wall lasts a few ms
    kw = dict(phi_deg=80.0, save=("energy",), joint=joint, mode="one_sided", gap=1e-3, save_dt=5e-4)
    rest = simulate_assembly(wall, duration=4.0, **kw)  # (the same program as the run's)
    w = float(wall.mass * G)
    y_g = (w * 1.5 + 2e4 * 3.0) / (w + 2e4)
    eta = math.atan(0.125 / y_g)
    r = simulate_assembly(wall, theta0=0.5 * eta, duration=4.0, **kw)
    e, th = np.asarray(r.energy), np.asarray(r.theta)
    rel = (e - e[0]) / (e[0] - float(rest.energy[-1]))
    first = int(np.argmax(th[:, 0] < 0.0))  # the first sample on the wall side
    assert first > 0 and np.max(np.abs(rel[: first - 1])) < ENERGY_RTOL
    assert np.max(rel) < ENERGY_RTOL, np.max(rel)
    assert rel[-1] < -ENERGY_RTOL  # the impacts on the walls did take energy out
    assert np.sum(np.diff(np.sign(th[:, 0])) < 0) >= 3  # it met the walls again and again
    assert not bool(r.overturned) and int(r.status) == 0


def test_facade_jit_and_vmap_over_records_and_gaps():
    """Reference: a Python loop (the same arithmetic): a restrained two-block facade on its
    return walls under ``jit(vmap)`` over (record, gap) pairs, the gap traced."""
    wall = Assembly.stack([rj.Block(b=0.2, h=1.0)] * 2, top="restrained", overburden=5e3)
    dt = stable_dt_assembly(wall, 1e-3, joint=CORNERS, mode="one_sided")
    ags = jnp.stack(
        [
            rj.GroundMotion.sine_cycle(pga=a, period=0.3, dt=0.01, duration=0.5).ag
            for a in (-6.0, 8.0)
        ]
    )
    gaps = jnp.array([0.0, 2e-3])

    def run(ag, gap):
        motion = rj.GroundMotion(ag=ag, dt=0.01)
        r = rj.simulate_dem(
            wall, motion, beta=1e-3, dt=dt, joint=CORNERS, mode="one_sided", gap=gap
        )
        return r.theta

    batch = jax.jit(jax.vmap(run))(ags, gaps)
    loop = jnp.stack([run(a, g) for a, g in zip(ags, gaps)])
    assert batch.shape == (2, 51, 2) and batch.dtype == jnp.float64
    scale = float(jnp.max(jnp.abs(loop)))
    assert scale > 1e-4  # it moved
    assert float(jnp.max(jnp.abs(batch - loop))) <= VMAP_RTOL * scale
    assert float(jnp.min(loop)) < 0.0  # onto the walls


def test_facade_bad_input_is_refused_with_a_fix():
    blk = rj.Block(b=0.2, h=1.0)
    wall = Assembly.stack([blk, blk])
    with pytest.raises(ValueError, match="rotate outward"):
        simulate_assembly(wall, mode="one_sided", theta0=-0.01, duration=0.1)
    with pytest.raises(ValueError, match="mode='one_sided'"):
        simulate_assembly(wall, gap=1e-3, duration=0.1)
    with pytest.raises(ValueError, match="gap"):
        simulate_assembly(wall, mode="one_sided", gap=-1e-3, duration=0.1)
    with pytest.raises(ValueError, match="mode must be one of"):
        simulate_assembly(wall, mode="facade", duration=0.1)
    z = np.zeros(11)
    with pytest.raises(ValueError, match="wall_motion.*one_sided"):
        rj.simulate_dem(wall, duration=0.1, wall_motion=(z, z), save_dt=0.01)


# ----------------------------------------------------------------------------- moving walls

GLUED_MOVING_TOL = 1e-3  # [eta] stiff-bedded glued pair vs the tall facade on a moving wall:
# the bed joint's compliance (measured 4.0e-4 with the bed joint 10x stiffer than the ground
# joint, 9.9e-4 as stiff; with a gap the wall's first touch is an impact and the pair rattles)
RIDE_TOL = 2e-3  # [eta] a facade pushed by a slow wall lies on it, theta = u_top / H (contact
# compression and the lag of a damped block; measured 5.7e-4)
MOVING_CLOSURE_TOL = 5e-3  # [-] of the wall's peak work: E - E0 = W_wall to the single block's
# CLOSURE_TOL (tests/test_dem_wall.py); the rest is the release of the heels' loaded shear
# springs as they lift off, a loss (measured -3.4e-3 overall, -1.5e-3 while pushed, the same
# at half and a quarter of the step: no O(dt^2) error)
GAIN_TOL = 1e-4  # [-] of the wall's peak work: the contact law never creates energy
MOVING_DT = 0.002  # [s] sample step of the synthetic wall histories
BUILDING = rj.ShearBuilding.uniform(n_storeys=2, storey_height=3.0, period=0.2, damping=0.05)


def _wall_push(amp, period, n, dt=MOVING_DT):
    return smooth_push(amp, period, n, dt)


def _quiet(n):
    return rj.GroundMotion(ag=np.zeros(n), dt=MOVING_DT)


@pytest.mark.parametrize("motion", ["building", "pair"])
def test_one_block_on_a_moving_wall_equals_simulate_dem(motion):
    """Reference: rj.simulate_dem of the facade with the same moving wall (a building whose
    response at the facade's height h = H drives the wall, or a pair of histories that turns
    it both ways): the one-block assembly's wall turns about the same toe (heel) to the same
    line, to round-off; the wall's work too, and the energy up to its datum (gravity from the
    ground here, from y = h/2 in simulate_dem)."""
    beta = 0.5 * float(rj.beta_dejong(ONE))
    dt = rj.stable_dt(ONE, beta, mode="one_sided")
    t = np.arange(PULSE.n) * PULSE.dt
    omega = 2.0 * np.pi / 0.4
    pair = (0.004 * np.sin(omega * t), 0.004 * omega * np.cos(omega * t))
    wall_motion = BUILDING if motion == "building" else pair
    kw = dict(
        beta=beta,
        theta0=0.3 * float(ONE.eta),
        dt=dt,
        mode="one_sided",
        gap=FACADE_GAP,
        wall_motion=wall_motion,
        save=("energy",),
    )
    ref = rj.simulate_dem(ONE, PULSE, **kw)
    r = rj.simulate_dem(Assembly.stack([ONE]), PULSE, **kw)
    scale = float(jnp.max(jnp.abs(ref.theta)))
    assert float(jnp.min(ref.theta)) < 0.0  # it met the wall
    assert float(jnp.max(jnp.abs(r.theta[:, 0] - ref.theta))) < EQUAL_RTOL * scale
    for key in ("x", "y"):
        err = float(jnp.max(jnp.abs(getattr(r, key)[:, 0] - ref.extras[key])))
        assert err < EQUAL_RTOL * float(ONE.h), key
    work, work_ref = np.asarray(r.work_wall), np.asarray(ref.extras["work_wall"])
    assert np.max(np.abs(work_ref)) > 0.5  # [J] the wall did work
    np.testing.assert_allclose(work, work_ref, rtol=0, atol=EQUAL_RTOL * np.max(np.abs(work_ref)))
    e, e_ref = np.asarray(r.energy), np.asarray(ref.energy)
    np.testing.assert_allclose(
        e - e[0], e_ref - e_ref[0], rtol=0, atol=EQUAL_RTOL * np.max(np.abs(e_ref))
    )


def test_zero_wall_motion_is_the_fixed_wall():
    """Reference: the fixed walls (a wall that does not move relative to the base): the same
    arithmetic with zero rotation, and no work."""
    wall = Assembly.stack([rj.Block(b=0.2, h=0.75)] * 2, overburden=2e3)
    kw = dict(beta=1e-3, mode="one_sided", gap=1e-3, joint=CORNERS, save=("energy",))
    z = np.zeros(PULSE.n)
    fixed = simulate_assembly(wall, PULSE, **kw)
    still = simulate_assembly(wall, PULSE, wall_motion=(z, z), **kw)
    scale = float(jnp.max(jnp.abs(fixed.theta)))
    assert scale > 1e-3 and float(jnp.min(fixed.theta)) < 0.0  # it rocked onto the walls
    np.testing.assert_allclose(still.theta, fixed.theta, rtol=0, atol=EQUAL_RTOL * scale)
    np.testing.assert_array_equal(np.asarray(fixed.work_wall), np.zeros(PULSE.n))
    assert float(jnp.max(jnp.abs(still.work_wall))) == 0.0


@pytest.mark.slow  # (keeps the file under 60 s on a loaded machine)
def test_glued_pair_rides_a_moving_wall_like_one_tall_facade():
    """Reference: rj.simulate_dem of the tall facade (0.2 x 1.5 m) on the same moving wall,
    and the kinematics of a facade carried by a slow wall (theta = u_top / H). The pair
    2 x (0.2 x 0.75 m) has the tall block's ground and wall joints (E/h), a bed joint 10x
    stiffer, friction 80 deg and damping (0.25 beta_DeJong): the wall, starting at the back
    faces (gap 0) and turning about block 0's toe, tilts it to 0.3 eta and back over 1 s
    (quasi-static: 1 s >> 1/p), and the pair follows it as the tall block does, to
    GLUED_MOVING_TOL eta over the whole history."""
    tall = ONE
    pair = Assembly.stack([rj.Block(b=0.2, h=0.75, E=0.9e9), rj.Block(b=0.2, h=0.75, E=9e9)])
    eta = float(tall.eta)
    n = 751
    u, v = _wall_push(0.3 * eta * 1.5, 1.0, n)
    kw = dict(
        beta=0.25 * float(rj.beta_dejong(tall)), phi_deg=80.0, mode="one_sided", wall_motion=(u, v)
    )
    ref = np.asarray(rj.simulate_dem(tall, _quiet(n), **kw).theta)
    th = np.asarray(rj.simulate_dem(pair, _quiet(n), **kw).theta)
    assert ref.max() > 0.29 * eta
    assert np.max(np.abs(ref - u / 1.5)) < RIDE_TOL * eta  # the tall block rides the wall
    assert np.max(np.abs(th[:, 1] - th[:, 0])) < GLUED_MOVING_TOL * eta  # the bed stays shut
    assert np.max(np.abs(th[:, 0] - ref)) < GLUED_MOVING_TOL * eta


def test_moving_wall_work_closes_the_energy_balance():
    """Reference: energy conservation with a moving support. With beta = 0, no ground motion,
    point contacts and friction that sticks (phi = 89 deg), the stack's energy changes only
    by the walls' work, E(t) - E(0) = W_wall(t), as for the single facade
    (tests/test_dem_wall.py): a wall pushed 20 mm at the top of a free two-block stack over
    1 s lifts it by 6.7 J and lets it back down."""
    wall = Assembly.stack([rj.Block(b=0.2, h=0.75)] * 2)
    n = 600
    u, v = _wall_push(0.02, 1.0, n)
    r = rj.simulate_dem(
        wall,
        _quiet(n),
        beta=0.0,
        mode="one_sided",
        joint=CORNERS,
        phi_deg=89.0,
        wall_motion=(u, v),
        save=("energy",),
    )
    e, work = np.asarray(r.energy), np.asarray(r.work_wall)
    assert work.max() > 1.0  # [J] the wall does real work (it lifts the stack)
    gap = e - e[0] - work
    assert np.max(np.abs(gap)) < MOVING_CLOSURE_TOL * work.max(), np.max(np.abs(gap))
    assert gap.max() < GAIN_TOL * work.max(), gap.max()
    assert not bool(r.overturned) and int(r.status) == 0


def test_moving_wall_bad_input_is_refused_with_a_fix(user_view):
    wall = Assembly.stack([rj.Block(b=0.2, h=0.75)] * 2, top="restrained")
    gm = _quiet(50)
    z = np.zeros(50)
    with pytest.raises(ValueError, match="wall_motion.*one_sided"):
        rj.simulate_dem(wall, gm, wall_motion=(z, z))
    with pytest.raises(ValueError, match="one value per record sample"):
        rj.simulate_dem(wall, gm, mode="one_sided", wall_motion=(z[:-1], z))
    with pytest.raises(ValueError, match="non-finite"):
        rj.simulate_dem(wall, gm, mode="one_sided", wall_motion=(z + np.nan, z))
    with pytest.raises(ValueError, match="same rockjax.ShearBuilding"):
        other = rj.ShearBuilding.uniform(n_storeys=2, storey_height=3.0, period=0.3)
        rj.simulate_dem(
            wall, gm, mode="one_sided", wall_motion=other, support_motion=BUILDING, storey=1
        )


# ----------------------------------------------------------------------------- friction


@pytest.mark.parametrize("joint", [rj.Joint(), CORNERS], ids=["face", "corners"])
def test_squat_stack_slides_as_rigid_coulomb(joint):
    """Reference: rigid Coulomb sliding of the whole stack on the record, integrated exactly
    in the test (helpers.coulomb_slip), with the friction of the base joint ``mu (W + N)``:
    the stack's deceleration ``mu g (1 + N/W)``. The bed joint sticks: it must carry
    ``mu W_1 (1 + N/W)``, below its cap ``mu (W_1 + N)``. The joints' shear dashpots act only
    while they stick (docs/theory.md, "Friction on the whole joint"); on the sliding joint
    they used to hold the stack nearly still."""
    blk = rj.Block(b=1.0, h=0.25)  # each b/h = 4, the stack's 2 > mu = tan(30 deg)
    weight = 2.0 * float(blk.m) * G / float(blk.length)  # W [N/m]
    wall = Assembly.stack([blk, blk], overburden=0.5 * weight)
    gm = rj.GroundMotion.ricker(pga_g=1.2, period=0.5, dt=0.002)
    r = simulate_assembly(wall, gm, beta=rj.beta_dejong(blk), joint=joint, phi_deg=30.0)
    u = coulomb_slip(gm.ag, gm.dt, 1.5 * np.tan(np.radians(30.0)))
    x = np.asarray(r.x)
    assert abs(u[-1]) > 0.01
    for k in range(2):  # the stack slides as one
        assert x[-1, k] == pytest.approx(u[-1], rel=COULOMB_RTOL)
        assert np.max(np.abs(x[:, k] - u)) < COULOMB_RTOL * np.max(np.abs(u))


def test_assembly_response_to_dataframe():
    """The table holds each block's series and the saved energy and forces, named with
    their units; the run's scalars in ``attrs``; a batch is refused."""
    blk = rj.Block(b=0.2, h=0.75)
    wall = Assembly.stack([blk, blk], top="restrained")
    gm = rj.GroundMotion.ricker(pga_g=0.4, period=0.3, dt=0.005)
    r = simulate_assembly(wall, gm, beta=1e-3, save=("energy", "forces"))
    df = r.to_dataframe()
    assert df.index.name == "t [s]" and len(df) == gm.n
    for k in range(2):
        np.testing.assert_array_equal(df[f"theta_{k} [rad]"], np.asarray(r.theta)[:, k])
        np.testing.assert_array_equal(df[f"y_{k} [m]"], np.asarray(r.y)[:, k])
        np.testing.assert_array_equal(
            df[f"normal_force_{k} [N]"], np.asarray(r.normal_forces)[:, k]
        )
        assert df.attrs[f"d_max_{k} [m]"] == float(r.d_max[k])
    np.testing.assert_array_equal(df["restraint_force [N]"], np.asarray(r.restraint_force))
    np.testing.assert_array_equal(df["energy [J]"], np.asarray(r.energy))
    assert "wall_force_0 [N]" not in df and df.attrs["n_blocks"] == 2
    assert df.attrs["status"] == 0 and df.attrs["overturned"] is False
    batch = jax.tree.map(lambda x: jnp.stack([x, x]), r)
    with pytest.raises(ValueError, match="takes one run"):
        batch.to_dataframe()
