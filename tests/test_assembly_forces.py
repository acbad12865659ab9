"""Tests of the interface forces of rockjax.multiblock (``save=("forces",)``) and of return
walls that move with the building a facade stands in (``support_motion=bldg,
wall_motion=bldg``), each against an independent reference."""

import math

import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax.assembly import Assembly, collapse_multiplier
from rockjax.constants import G
from rockjax.dem import simulate_assembly, stable_dt_assembly

# Tolerances, each with its reason.
STATIC_RTOL = 1e-9  # settled statics: the residual vibration is damped out (measured < 1e-12)
EQUAL_RTOL = 1e-10  # the one-block assembly is simulate_dem's scheme: round-off only
IMPULSE_RTOL = 1e-9  # [-] of the impulse of the impacts, at beta = 0: the step's own momentum
# update, summed (round-off). With beta > 0 the recorded dashpots are at the lagged half-step
# velocity, the step's centred ones differ by dt/2 C a: 1.1e-2 at beta = 2e-3 here
STIFF_RTOL = 1e-3  # [max |theta|] a building of period 1e-3 s under a 0.5 s pulse: floor
# amplification and drift ~ (1e-3 / 0.5)^2 = 4e-6, the record's linear interpolation of the
# floor acceleration ~ (omega dt)^2 of the building's ringing after each kink of the record
PAIR_RTOL = 1e-10  # the building's walls vs the same walls given as a pair: round-off only
VMAP_RTOL = 1e-9  # an IDA vs a loop of single runs: the same arithmetic, batched
GAIN_TOL = 1e-3  # [-] of the walls' work: the contact law never creates energy (measured
# 2.9e-4, the trapezoid rule of W_base on the samples)
ENERGY_LOSS_TOL = 0.06  # [-] of the walls' work: the loss of the contact law at beta = 0
# (the release of loaded shear springs as contacts open and close; measured 3.2e-2)

CORNERS = rj.Joint(n_sub=2)
PULSE = rj.GroundMotion.sine_cycle(pga=-3.0, period=0.5, dt=0.005, duration=2.0)


def _weights_above(wall):
    """Weight [N] above each interface, overburden included: interface k carries blocks
    k..N-1 and the top load."""
    w = np.array([float(b.m) * G for b in wall.blocks])
    return np.cumsum(w[::-1])[::-1] + float(wall.top_load)


def _ramp(a, t_ramp, t_hold, dt=0.005):
    """A base acceleration [m/s^2] rising smoothly (sin^2) from 0 to ``a`` in ``t_ramp`` [s],
    then held for ``t_hold`` [s]."""
    t = np.arange(int(round((t_ramp + t_hold) / dt)) + 1) * dt
    ag = a * np.where(t < t_ramp, np.sin(0.5 * np.pi * t / t_ramp) ** 2, 1.0)
    return rj.GroundMotion(ag=ag, dt=dt)


# ----------------------------------------------------------------------------- forces


@pytest.mark.parametrize("joint", [rj.Joint(), CORNERS], ids=["face", "corners"])
def test_forces_at_rest_carry_the_weight_above(joint):
    """Reference: statics. Settled under gravity, the sub-stack above interface k (blocks
    k..N-1 and the overburden) is pushed up by the interface with its weight ``W_k``; the
    offsets tilt the blocks slightly (~1e-5 rad), so the test resolves ``(0, W_k)`` along the
    lower block's normal and tangent (``e2 = (sin t, cos t)``, ``e1 = (cos t, -sin t)``)."""
    wall = Assembly.stack(
        [rj.Block(b=0.3, h=1.2), rj.Block(b=0.25, h=1.0), rj.Block(b=0.2, h=0.8)],
        overburden=3e3,
        x_offset=[0.0, 0.02, -0.01],
    )
    # (stiffness-proportional damping: the slow elastic rocking of the eccentric blocks needs
    # a large beta to settle in 2 s; measured 1e-13 relative at 2 s with 3e-2 s)
    kw = dict(duration=2.0, beta=3e-2, joint=joint)
    r = simulate_assembly(wall, save=("forces",), **kw)
    assert r.normal_forces.shape == (r.t.shape[0], 3) and r.normal_forces.dtype == jnp.float64
    assert r.restraint_force is None and r.wall_forces is None
    weight = _weights_above(wall)
    t_l = np.concatenate([[0.0], np.asarray(r.theta[-1, :-1])])
    fn, ft = np.asarray(r.normal_forces[-1]), np.asarray(r.shear_forces[-1])
    np.testing.assert_allclose(fn, weight * np.cos(t_l), rtol=STATIC_RTOL)
    np.testing.assert_allclose(ft, -weight * np.sin(t_l), rtol=0, atol=STATIC_RTOL * weight[0])
    assert np.max(np.abs(ft)) > 1e-6 * weight[0]  # (the tilt matters at this tolerance)
    if joint.face:  # saving the forces leaves the run alone (one joint law is enough)
        plain = simulate_assembly(wall, **kw)
        assert plain.normal_forces is None and plain.shear_forces is None
        # (the same step; the forces in the scan's carry change XLA's fusion: round-off)
        atol = 1e-10 * float(wall.blocks[0].eta)
        np.testing.assert_allclose(plain.theta, r.theta, rtol=0, atol=atol)


def test_shear_under_constant_base_acceleration_is_mass_above_times_a():
    """Reference: statics in the base frame. Under a constant base acceleration ``a`` below
    the uplift threshold, the sub-stack above interface k feels its inertial force
    ``-M_k a`` and its weight and overburden, so the interface pushes it with
    ``(M_k a, M_k g + P)`` (world), which the test resolves along the lower block's tangent
    and normal (``e1 = (cos t, -sin t)``, ``e2 = (sin t, cos t)``, ``t`` its rotation)."""
    wall = Assembly.stack([rj.Block(b=0.3, h=1.2), rj.Block(b=0.25, h=1.0)], overburden=2e3)
    a = 0.02 * G  # the resultant stays in the middle third of every joint: no uplift
    gm = _ramp(a, 1.0, 1.5)
    r = simulate_assembly(wall, gm, beta=3e-2, save=("forces",))  # (beta: settled in 1.5 s)
    masses = np.array([float(b.m) for b in wall.blocks])
    m_above = np.cumsum(masses[::-1])[::-1]
    p = float(wall.top_load)
    theta = np.asarray(r.theta[-1])
    fn, ft = np.asarray(r.normal_forces[-1]), np.asarray(r.shear_forces[-1])
    for k in range(2):
        t_l = 0.0 if k == 0 else theta[k - 1]
        fx, fy = m_above[k] * a, m_above[k] * G + p
        assert ft[k] == pytest.approx(fx * math.cos(t_l) - fy * math.sin(t_l), rel=STATIC_RTOL)
        assert fn[k] == pytest.approx(fx * math.sin(t_l) + fy * math.cos(t_l), rel=STATIC_RTOL)
    assert ft[0] == pytest.approx(m_above[0] * a, rel=1e-4)  # (the tilt is ~1e-5 rad)


def test_restraint_force_matches_the_statics_of_the_restrained_wall():
    """Reference: the moment balance of the whole wall about its ground toe ``A``. A
    restrained two-block wall (corner joints, 1 mm clearance at the top) under a slow base
    acceleration ``-a`` between the free stack's and the hinge mechanism's thresholds lifts
    its ground heel and leans on the restraint. The ground reaction then acts at ``A`` (the
    toe's corner contact), the bed joint is internal, and about ``A`` (anticlockwise
    moments ``(x - x_A) F_y - (y - y_A) F_x``):

        -sum_k [m_k a (y_k - y_A) + m_k g (x_k - x_A)] - P (x_Q - x_A) - R (y_Q - y_A) = 0

    with the inertial forces ``+m_k a`` (toward +x) at the centroids, the overburden ``P`` and
    the restraint's force ``R`` (on the top block, toward +x) at the top face centre ``Q``,
    all at the wall's deformed position; and, with the rest geometry, the rigid-wall value
    to the order of the rotations."""
    blk = rj.Block(b=0.2, h=1.0)
    wall = Assembly.stack([blk, blk], top="restrained", overburden=2e3, gap=1e-3)
    free = Assembly.stack([blk, blk], overburden=2e3)
    lam = 0.5 * (
        float(collapse_multiplier(free, "stack")) + float(collapse_multiplier(wall, "hinge"))
    )
    a = lam * G
    gm = _ramp(-a, 2.0, 1.0)
    r = simulate_assembly(wall, gm, beta=3e-2, joint=CORNERS, save=("forces",))
    assert r.restraint_force.shape == r.t.shape and not bool(r.overturned)
    x, y, th = (np.asarray(v[-1]) for v in (r.x, r.y, r.theta))
    b, h = 0.2, 1.0
    c0, s0 = math.cos(th[0]), math.sin(th[0])
    x_a, y_a = x[0] + 0.5 * b * c0 - 0.5 * h * s0, y[0] - 0.5 * b * s0 - 0.5 * h * c0
    y_heel = y[0] + 0.5 * b * s0 - 0.5 * h * c0
    assert y_heel > 1e-5  # [m] the heel has lifted: the ground reaction is at A
    x_q, y_q = x[1] + 0.5 * h * math.sin(th[1]), y[1] + 0.5 * h * math.cos(th[1])
    m = float(blk.m)
    p = float(wall.top_load)
    moment = -sum(m * a * (y[k] - y_a) + m * G * (x[k] - x_a) for k in range(2))
    expected = (moment - p * (x_q - x_a)) / (y_q - y_a)
    rf = float(r.restraint_force[-1])
    assert rf < 0.0  # the restraint holds the top back
    assert rf == pytest.approx(expected, rel=STATIC_RTOL)
    # the rigid wall at rest: A = (b/2, 0), centroids (0, h/2), (0, 3h/2), Q = (0, 2h); the
    # wall has turned by about gap / 2h = 5e-4 rad, which moves the arms by that order
    rigid = (-m * a * (0.5 * h + 1.5 * h) - 2 * m * G * (-0.5 * b) - p * (-0.5 * b)) / (2 * h)
    assert rf == pytest.approx(rigid, rel=5e-3)
    # the ground joint carries the weight and overburden less nothing: vertical statics
    assert float(r.normal_forces[-1, 0]) == pytest.approx(2 * m * G + p, rel=STATIC_RTOL)
    # and the horizontal balance: ground shear + restraint = -(inertial forces)
    assert float(r.shear_forces[-1, 0]) + rf == pytest.approx(-2 * m * a, rel=STATIC_RTOL)


def test_ground_impulse_balances_vertical_momentum():
    """Reference: the vertical impulse balance. Over a free rocking run with impacts, with one
    step per sample, ``int (N_0 - W - P) dt`` (trapezoid over the steps) equals the change of
    the total vertical momentum ``sum_k m_k y_k'`` (centred differences of the sampled
    heights: the scheme's velocity at the sample)."""
    wall = Assembly.stack([rj.Block(b=0.25, h=1.5)] * 2, overburden=1e4)
    beta = 0.0
    dt = stable_dt_assembly(wall, beta, joint=CORNERS)
    r = simulate_assembly(
        wall,
        theta0=0.02,
        duration=0.8,
        dt=dt,
        save_dt=dt,
        beta=beta,
        joint=CORNERS,
        phi_deg=80.0,
        save=("forces",),
    )
    assert not bool(r.overturned) and float(jnp.min(r.theta[:, 0])) < -0.005  # impacts
    step = float(r.dt)
    assert step == pytest.approx(float(r.t[1]), rel=1e-12)
    masses = np.array([float(b.m) for b in wall.blocks])
    y = np.asarray(r.y)
    mom = (y[2:] - y[:-2]) / (2 * step) @ masses  # at samples 1..n-2
    excess = np.asarray(r.normal_forces[:, 0]) - (masses.sum() * G + float(wall.top_load))
    impulse = step * (np.cumsum(excess[1:-1]) - 0.5 * excess[1] - 0.5 * excess[1:-1])
    scale = step * np.sum(np.abs(excess))  # the impulse of the impacts
    assert scale > 1.0  # [N s]
    err = np.max(np.abs(impulse - (mom - mom[0])))
    assert err < IMPULSE_RTOL * scale, err / scale


@pytest.mark.parametrize(
    "joint", [rj.Joint(), rj.Joint(n_sub=3, dashpot="clipped")], ids=["face", "n3-clipped"]
)
def test_one_block_ground_force_equals_simulate_dem(joint):
    """Reference: rj.simulate_dem's ``extras["normal_forces"]`` (one per face with the face
    law, one per sub-contact with integer n_sub: summed), the same step and joint."""
    blk = rj.Block(b=0.2, h=1.5)
    beta = 0.5 * float(rj.beta_dejong(blk))
    kw = dict(beta=beta, theta0=0.3 * float(blk.eta), dt=rj.stable_dt(blk, beta, joint=joint))
    kw.update(joint=joint, save=("forces",))
    ref = np.asarray(rj.simulate_dem(blk, PULSE, **kw).extras["normal_forces"])
    r = rj.simulate_dem(Assembly.stack([blk]), PULSE, **kw)
    total = ref.reshape(ref.shape[0], -1).sum(axis=-1)
    assert np.max(total) > 2.0 * float(blk.m) * G  # impacts
    np.testing.assert_allclose(
        np.asarray(r.normal_forces[:, 0]), total, rtol=0, atol=EQUAL_RTOL * np.max(total)
    )


def test_return_wall_forces_of_a_facade_at_rest_on_its_walls():
    """Reference: horizontal statics in the base frame. A base acceleration ``a`` toward +x
    (inertia ``-M a``, toward the walls; no gap) leans the facade on its walls, whose normal
    forces and the ground joint's shear hold it: ``sum_k F_wall,k + F_shear,0 = M a``."""
    facade = Assembly.stack([rj.Block(b=0.2, h=0.75)] * 2)
    a = 0.3 * G  # well beyond the free stack's threshold: it leans on its walls
    r = simulate_assembly(
        facade, _ramp(a, 1.0, 0.5), beta=2e-3, mode="one_sided", joint=CORNERS, save=("forces",)
    )
    fw = np.asarray(r.wall_forces[-1])
    assert r.wall_forces.shape == (r.t.shape[0], 2) and np.all(fw > 0)
    m = float(facade.mass)
    assert fw.sum() + float(r.shear_forces[-1, 0]) == pytest.approx(m * a, rel=STATIC_RTOL)


# ----------------------------------------------------------------------------- walls in a building

FACADE = Assembly.stack([rj.Block(b=0.2, h=0.8), rj.Block(b=0.2, h=0.7)])  # H = 1.5 m
STOREY_H = 3.0


def _storey_walls(bldg, gm, storey, height):
    """The return walls' ``(u_top, v_top)`` relative to the base floor at ``height`` [m]
    within storey ``storey``: the storey's drift times ``height / storey height`` (a shear
    building's storey deforms linearly), from the floors' displacements."""
    resp = bldg.response(gm)
    d, v = np.asarray(resp.displacement), np.asarray(resp.velocity)
    below_d = d[storey - 2] if storey > 1 else 0.0
    below_v = v[storey - 2] if storey > 1 else 0.0
    f = height / STOREY_H
    return f * (d[storey - 1] - below_d), f * (v[storey - 1] - below_v)


def test_facade_walls_in_a_stiff_building_are_the_fixed_walls_on_the_ground():
    """Reference: the facade on the ground with fixed walls. In a building of period 1e-3 s
    the floors move with the ground and the drift is ~(1e-3/0.5)^2 of the pulse's ground
    displacement: the facade of storey 2 on walls that move with its storey rocks as on the
    ground (STIFF_RTOL: see its reason)."""
    stiff = rj.ShearBuilding.uniform(2, STOREY_H, period=1e-3)
    kw = dict(beta=1e-3, mode="one_sided", gap=1e-3, joint=CORNERS)
    ref = np.asarray(simulate_assembly(FACADE, PULSE, **kw).theta)
    th = simulate_assembly(FACADE, PULSE, support_motion=stiff, storey=2, wall_motion=stiff, **kw)
    th = np.asarray(th.theta)
    assert np.max(np.abs(ref)) > 0.02 and np.min(ref) < 0.0  # it rocked onto its walls
    assert np.max(np.abs(th - ref)) < STIFF_RTOL * np.max(np.abs(ref))


@pytest.mark.parametrize("storey", [1, 2])
def test_facade_walls_move_with_the_storey(storey):
    """Reference: the same run with the walls' motion given as a pair, computed here from
    the floors' displacements (bldg.response; the storey's drift times H / storey height):
    the building's walls are those, to round-off; and they differ from fixed walls."""
    bldg = rj.ShearBuilding.uniform(2, STOREY_H, period=0.3, damping=0.05)
    gm = rj.GroundMotion.sine_cycle(pga=-2.5, period=0.5, dt=0.005, duration=1.5)
    kw = dict(beta=1e-3, mode="one_sided", gap=1e-3, support_motion=bldg, storey=storey)
    kw.update(save=("energy", "forces"), joint=CORNERS)
    r = simulate_assembly(FACADE, gm, wall_motion=bldg, **kw)
    pair = _storey_walls(bldg, gm, storey, float(FACADE.height))
    ref = simulate_assembly(FACADE, gm, wall_motion=pair, **kw)
    scale = float(jnp.max(jnp.abs(ref.theta)))
    assert scale > 1e-3
    assert float(jnp.max(jnp.abs(r.theta - ref.theta))) < PAIR_RTOL * scale
    work = np.asarray(ref.work_wall)
    assert np.max(np.abs(work)) > 0.1  # [J] the walls did work
    np.testing.assert_allclose(r.work_wall, work, rtol=0, atol=PAIR_RTOL * np.max(np.abs(work)))
    fixed = simulate_assembly(FACADE, gm, **kw)
    assert float(jnp.max(jnp.abs(fixed.theta - ref.theta))) > 0.01 * scale


def test_facade_in_a_building_energy_balance():
    """Reference: the work-energy balance at beta = 0 (corner joints, friction 89 deg, the
    moving-wall test's setting in tests/test_assembly.py): in the base floor's frame the
    energy changes by the walls' work and the work of the inertial forces of the base
    floor's acceleration, ``E - E0 = W_wall + W_base``, ``W_base = -sum_k m_k int a_base
    x_k' dt`` (computed here from the floor's acceleration and the sampled x). A slow pulse
    under a flexible building (period 1 s): the walls of storey 2 push the facade out by
    their drift while the floor's acceleration (< 0.06 g) never lifts it off them. The
    contact law never creates energy (GAIN_TOL); it loses some (ENERGY_LOSS_TOL)."""
    bldg = rj.ShearBuilding.uniform(2, STOREY_H, period=1.0, damping=0.05)
    gm = rj.GroundMotion.sine_cycle(pga=0.4, period=2.5, dt=0.002, duration=3.0)
    r = simulate_assembly(
        FACADE,
        gm,
        beta=0.0,
        mode="one_sided",
        joint=CORNERS,
        phi_deg=89.0,
        support_motion=bldg,
        storey=2,
        wall_motion=bldg,
        save=("energy",),
    )
    assert not bool(r.overturned) and int(r.status) == 0
    a_base = np.asarray(bldg.response(gm).acceleration[0])
    xd = np.gradient(np.asarray(r.x), gm.dt, axis=0)
    masses = np.array([float(b.m) for b in FACADE.blocks])
    power = -(xd @ masses) * a_base
    w_base = np.concatenate([[0.0], np.cumsum(0.5 * gm.dt * (power[1:] + power[:-1]))])
    e, w_wall = np.asarray(r.energy), np.asarray(r.work_wall)
    scale = np.max(np.abs(w_wall))
    assert scale > 0.5  # [J] the walls lift the facade
    gap = e - e[0] - w_wall - w_base
    assert gap.max() < GAIN_TOL * scale, gap.max() / scale
    assert -gap.min() < ENERGY_LOSS_TOL * scale, -gap.min() / scale


def test_facade_in_a_building_ida_equals_single_runs():
    """Reference: a loop of rj.simulate_assembly(facade, record, support_motion=bldg,
    storey=2, wall_motion=bldg) on the record zero-padded to the IDA's length, each solving
    the building for its own scaled record; the IDA solves it once per record and scales
    it (the building is linear)."""
    blk = rj.Block(b=0.23, h=1.5)
    facade = Assembly.stack([blk, blk], top="restrained", gap=2e-3, overburden=5e3)
    bldg = rj.ShearBuilding.uniform(n_storeys=2, storey_height=STOREY_H, period=0.3)
    recs = [
        rj.GroundMotion.ricker(pga=3.0, period=0.5, dt=0.01, duration=1.5, name="r05"),
        rj.GroundMotion.sine_cycle(pga=2.0, period=0.8, dt=0.01, duration=1.5, name="s08"),
    ]
    scales = [0.5, 3.0]
    kw = dict(beta=6e-3, mode="one_sided", gap=1e-3)
    ds = rj.ida(
        facade,
        recs,
        scales,
        model=rj.DEM(beta=6e-3),
        mode=rj.Facade(gap=1e-3),
        tail=0.5,
        progress=False,
        support_motion=bldg,
        storey=2,
        wall_motion=bldg,
    )
    assert ds.attrs["storey"] == 2
    t_end = float(ds.attrs["t_end"])
    dt = stable_dt_assembly(facade, 6e-3, mode="one_sided")
    for i, rec in enumerate(recs):
        n = int(round(t_end / rec.dt)) + 1
        for j, s in enumerate(scales):
            ag = np.zeros(n)
            ag[: rec.n] = s * np.asarray(rec.ag)
            r = simulate_assembly(
                facade,
                rj.GroundMotion(ag=ag, dt=rec.dt),
                dt=dt,
                support_motion=bldg,
                storey=2,
                wall_motion=bldg,
                throw=False,
                **kw,
            )
            assert int(r.status) == 0
            theta = float(np.max(np.asarray(r.theta_max) / np.asarray(r.eta)))
            assert theta > 1e-3  # it rocked
            assert float(ds.max_theta_over_eta[i, j]) == pytest.approx(theta, rel=VMAP_RTOL)
            assert bool(ds.collapse[i, j]) == bool(r.overturned)
            d = np.asarray(r.x[:, -1]) + 0.75 * np.sin(np.asarray(r.theta[:, -1]))
            d_ida = float(ds.max_d_over_b[i, j])
            assert d_ida == pytest.approx(np.max(np.abs(d)) / 0.23, rel=VMAP_RTOL)


def test_walls_in_a_building_bad_input_is_refused(user_view):
    bldg = rj.ShearBuilding.uniform(2, STOREY_H, period=0.3)
    other = rj.ShearBuilding.uniform(2, STOREY_H, period=0.4)
    gm = rj.GroundMotion.sine_cycle(pga=-2.0, period=0.5, dt=0.01, duration=0.3)
    z = np.zeros(gm.n)
    kw = dict(mode="one_sided", gap=1e-3)
    cases = [
        (dict(support_motion=bldg, storey=2, wall_motion=other), "same rockjax.ShearBuilding"),
        (dict(support_motion=bldg, storey=3, wall_motion=bldg), "roof"),
        (dict(support_motion=bldg, storey=2, wall_motion=gm), "relative to the base floor"),
        (dict(support_motion=bldg, storey=2, wall_motion=(z[:-1], z)), "one value per record"),
    ]
    for extra, match in cases:
        with pytest.raises(ValueError, match=match):
            simulate_assembly(FACADE, gm, **kw, **extra)
    restrained = Assembly.stack(list(FACADE.blocks), top="restrained")
    with pytest.raises(ValueError, match=r"wall_motion=\(u_top, v_top\)"):
        simulate_assembly(restrained, gm, **kw, support_motion=(z, z), wall_motion=bldg)
    with pytest.raises(ValueError, match="same rockjax.ShearBuilding"):
        rj.ida(
            FACADE,
            [gm],
            [1.0],
            model=rj.DEM(beta=1e-3),
            mode=rj.Facade(gap=1e-3),
            progress=False,
            support_motion=bldg,
            storey=2,
            wall_motion=other,
        )


def test_simulate_dem_in_a_building_defaults_to_the_ground_storey():
    """Reference: simulate_assembly's own default (storey 1): rj.simulate_dem(assembly,
    support_motion=bldg) without ``storey`` is the same run (it was refused, naming
    storey=None)."""
    bldg = rj.ShearBuilding.uniform(2, STOREY_H, period=0.3, damping=0.05)
    kw = dict(beta=1e-3, mode="one_sided", gap=1e-3, support_motion=bldg, wall_motion=bldg)
    a = rj.simulate_dem(FACADE, PULSE, **kw)
    b = simulate_assembly(FACADE, PULSE, storey=1, **kw)
    assert float(jnp.max(jnp.abs(a.theta))) > 0.0
    assert float(jnp.max(jnp.abs(a.theta - b.theta))) == 0.0
