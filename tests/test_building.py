"""Tests of rockjax.building: the linear shear building and the return walls' motion.

Independent references: the closed-form steady-state transmissibility of a damped oscillator
under harmonic base motion; scipy.linalg.eigh of the (K, M) pencil assembled here; a
piecewise scipy.integrate.solve_ivp (DOP853) integration of M u'' + C u' + K u = -M 1 a_g with
C assembled here (modal and Rayleigh); the quasi-static limit of a very stiff building; the
polynomial motion of a wall whose relative acceleration is linear in time; central finite
differences for the gradients; Python loops for vmap.
"""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import integrate, linalg

import rockjax as rj
from rockjax.building import ShearBuilding, floor_spectra
from rockjax.supports import wall_top_motion

EIGEN_RTOL = 1e-12  # two eigensolvers on a well-conditioned 5x5 pencil: round-off only
EXACT_RTOL = 1e-12  # a closed-form integration of a linear acceleration: float64 round-off
ODE_RTOL = 1e-8  # solve_ivp at rtol 1e-11 over ~300 steps, relative to the history's peak
TRANSFORM_RTOL = 1e-12  # jit/vmap against eager calls: the same float64 operations
FD_RTOL = 1e-6  # central differences with a relative step of 1e-6: O(h^2) + rounding / h

MASSES = np.array([1.2e5, 1.0e5, 0.8e5])
STIFFNESSES = np.array([9.0e7, 7.0e7, 5.0e7])
STOREY_HEIGHTS = np.array([3.5, 3.0, 3.0])


def _noise_record(seed=0, n=300, dt=0.01, pga=3.0):
    """A broadband synthetic record: a random-phase sum of sines under a smooth envelope."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    freqs = np.geomspace(0.5, 15.0, 20)
    phases = rng.uniform(0, 2 * np.pi, freqs.size)
    ag = np.sin(2 * np.pi * freqs[:, None] * t + phases[:, None]).sum(axis=0)
    ag *= np.sin(np.pi * t / t[-1]) ** 2
    return rj.GroundMotion(ag=pga * ag / np.max(np.abs(ag)), dt=dt, name=f"noise{seed}")


def _k_matrix(k):
    """Storey stiffness matrix of a chain fixed at the ground, assembled storey by storey."""
    n = len(k)
    K = np.zeros((n, n))
    for i, ki in enumerate(k):  # storey i joins floor i-1 (the ground for i = 0) and floor i
        K[i, i] += ki
        if i > 0:
            K[i - 1, i - 1] += ki
            K[i - 1, i] -= ki
            K[i, i - 1] -= ki
    return K


# ----------------------------------------------------------------------------- modal properties


def test_periods_and_modes_against_scipy_eigh():
    """Reference: scipy.linalg.eigh(K, M) of the pencil assembled in the test."""
    rng = np.random.default_rng(1)
    m = rng.uniform(0.5e5, 2e5, 5)
    k = rng.uniform(2e7, 1e8, 5)
    bldg = ShearBuilding(masses=m, stiffnesses=k, storey_heights=np.full(5, 3.0))
    lam, vec = linalg.eigh(_k_matrix(k), np.diag(m))
    np.testing.assert_allclose(bldg.periods, 2 * np.pi / np.sqrt(lam), rtol=EIGEN_RTOL)
    assert bldg.periods.dtype == np.float64 and bldg.modes.shape == (5, 5)
    np.testing.assert_allclose(bldg.modes, (vec / vec[-1]).T, rtol=1e-10, atol=1e-12)
    gamma = (vec.T @ m) / np.einsum("fj,f,fj->j", vec, m, vec) * vec[-1]
    np.testing.assert_allclose(bldg.participation_factors, gamma, rtol=1e-10)
    np.testing.assert_allclose(bldg.heights, 3.0 * np.arange(1, 6), rtol=1e-15)


@pytest.mark.parametrize("n", [1, 2, 3, 7])
def test_uniform_fundamental_period(n):
    """Reference: scipy.linalg.eigh of the uniform chain built with uniform()'s stiffness."""
    bldg = ShearBuilding.uniform(n_storeys=n, storey_height=3.0, period=0.35, damping=0.05)
    k, m = float(bldg.stiffnesses[0]), float(bldg.masses[0])
    lam = linalg.eigh(_k_matrix(np.full(n, k)), m * np.eye(n), eigvals_only=True)
    np.testing.assert_allclose(2 * np.pi / np.sqrt(lam[0]), 0.35, rtol=EIGEN_RTOL)
    np.testing.assert_allclose(bldg.periods, 2 * np.pi / np.sqrt(lam), rtol=EIGEN_RTOL)
    np.testing.assert_allclose(bldg.heights[-1], 3.0 * n, rtol=1e-15)


def test_rayleigh_damping_ratios():
    """Reference: zeta_j = a0 / (2 w_j) + a1 w_j / 2 with a0, a1 solved here from zeta at
    modes 1 and 2 (a 2x2 linear system)."""
    bldg = ShearBuilding(MASSES, STIFFNESSES, STOREY_HEIGHTS, 0.05, damping_model="rayleigh")
    w = 2 * np.pi / np.asarray(bldg.periods)
    a0, a1 = np.linalg.solve([[1 / (2 * w[0]), w[0] / 2], [1 / (2 * w[1]), w[1] / 2]], [0.05, 0.05])
    np.testing.assert_allclose(bldg.damping_ratios, a0 / (2 * w) + a1 * w / 2, rtol=1e-12)
    modal = ShearBuilding(MASSES, STIFFNESSES, STOREY_HEIGHTS, 0.05)
    np.testing.assert_allclose(modal.damping_ratios, 0.05, rtol=0)


# ----------------------------------------------------------------------------- responses


@pytest.mark.parametrize("r", [0.5, 1.0, 1.6, 3.0])
def test_sdof_transmissibility(r):
    """Reference: steady state of a one-storey building under a_g = A sin(W t), W = r w.

    The closed forms are the absolute-acceleration transmissibility
    |T| = sqrt((1 + (2 zeta r)^2) / ((1 - r^2)^2 + (2 zeta r)^2)) and the relative
    displacement A / w^2 / sqrt((1 - r^2)^2 + (2 zeta r)^2). The record is the sampled sine
    taken as linear between samples, whose spectrum is the sampled sine's lines at
    W_k = W + 2 pi k / dt times the transfer function of linear interpolation,
    L(W) = sinc^2(W dt / 2); at the samples every line shows as frequency W, so the sampled
    steady amplitude is A |sum_k H(W_k) L(W_k)| with the complex transmissibility H (k = 0:
    the closed form times sinc^2; the images k != 0 add up to 4e-5 of it at r = 3). The
    transient has decayed to exp(-zeta w 30 s) ~ 3e-14."""
    period, zeta, dt, amp = 0.3, 0.05, 0.005, 2.0
    bldg = ShearBuilding(masses=[1e5], stiffnesses=[1e5 * (2 * np.pi / period) ** 2],
                         storey_heights=[3.0], damping=zeta)  # fmt: skip
    w = 2 * np.pi / period
    big_w = r * w
    t = np.arange(round(40.0 / dt) + 1) * dt
    resp = bldg.response(rj.GroundMotion(ag=amp * np.sin(big_w * t), dt=dt))
    tail = t > 30.0
    basis = np.stack([np.sin(big_w * t[tail]), np.cos(big_w * t[tail])], axis=1)

    def amplitude(x):
        coef, *_ = np.linalg.lstsq(basis, np.asarray(x)[tail], rcond=None)
        return math.hypot(*coef)

    den = (1 - r**2) ** 2 + (2 * zeta * r) ** 2
    sinc2 = (math.sin(0.5 * big_w * dt) / (0.5 * big_w * dt)) ** 2
    closed_acc = amp * sinc2 * math.sqrt((1 + (2 * zeta * r) ** 2) / den)
    closed_disp = amp * sinc2 / w**2 / math.sqrt(den)
    w_k = big_w + 2 * np.pi / dt * np.arange(-200, 201)
    lin = np.sinc(w_k * dt / (2 * np.pi)) ** 2  # np.sinc(x) = sin(pi x) / (pi x)
    den_k = w**2 - w_k**2 + 2j * zeta * w * w_k
    ref_acc = amp * abs(np.sum((w**2 + 2j * zeta * w * w_k) / den_k * lin))
    ref_disp = amp * abs(np.sum(lin / den_k))
    closed_rtol = 1e-4  # the images neglected by the closed form (4e-5 at r = 3)
    steady_rtol = 1e-9  # the transient, the truncated image sum (~1e-11) and the lstsq fit
    acc, disp = amplitude(resp.acceleration[0]), amplitude(resp.displacement[0])
    np.testing.assert_allclose(acc, closed_acc, rtol=closed_rtol)
    np.testing.assert_allclose(disp, closed_disp, rtol=closed_rtol)
    np.testing.assert_allclose(acc, ref_acc, rtol=steady_rtol)
    np.testing.assert_allclose(disp, ref_disp, rtol=steady_rtol)


def _solve_ivp_reference(m, k, zeta, model, gm):
    """u, v (floor, time) and absolute accelerations by DOP853, one call per record step (the
    excitation is linear within each), with C assembled from the scipy modes."""
    M, K = np.diag(m), _k_matrix(k)
    lam, phi = linalg.eigh(K, M)  # mass-normalised
    w = np.sqrt(lam)
    if model == "modal":
        C = M @ phi @ np.diag(2 * zeta * w) @ phi.T @ M
    else:
        a0, a1 = 2 * zeta * w[0] * w[1] / (w[0] + w[1]), 2 * zeta / (w[0] + w[1])
        C = a0 * M + a1 * K
    n = len(m)
    Minv = np.linalg.inv(M)
    ag, dt = np.asarray(gm.ag), gm.dt

    def rhs(t, x, a0, a1, t0):
        a = a0 + (a1 - a0) * (t - t0) / dt
        u, v = x[:n], x[n:]
        return np.concatenate([v, -Minv @ (C @ v + K @ u) - a])

    x = np.zeros(2 * n)
    out = [x]
    for i in range(len(ag) - 1):
        t0 = i * dt
        sol = integrate.solve_ivp(
            rhs, (t0, t0 + dt), x, method="DOP853", rtol=1e-11, atol=1e-14,
            args=(ag[i], ag[i + 1], t0),
        )  # fmt: skip
        x = sol.y[:, -1]
        out.append(x)
    x = np.array(out).T
    u, v = x[:n], x[n:]
    acc = -Minv @ (C @ v + K @ u)
    return u, v, acc


@pytest.mark.parametrize("model", ["modal", "rayleigh"])
def test_three_storeys_against_solve_ivp(model):
    """Reference: DOP853 on M u'' + C u' + K u = -M 1 a_g (_solve_ivp_reference)."""
    gm = _noise_record(seed=2, n=250, dt=0.01)
    bldg = ShearBuilding(MASSES, STIFFNESSES, STOREY_HEIGHTS, 0.05, damping_model=model)
    resp = bldg.response(gm)
    u, v, acc = _solve_ivp_reference(MASSES, STIFFNESSES, 0.05, model, gm)
    assert resp.displacement.shape == (3, 250) and resp.acceleration.dtype == np.float64
    for got, ref in ((resp.displacement, u), (resp.velocity, v), (resp.acceleration, acc)):
        np.testing.assert_allclose(got, ref, rtol=0, atol=ODE_RTOL * np.max(np.abs(ref)))


def test_rigid_limit_floors_follow_the_ground():
    """Reference: a very stiff building (T1 = 1e-5 s) follows the ground quasi-statically,
    u = -a_g / w^2 ~ 0 and floor accelerations = a_g; the residual is the dynamic response to
    the record's slope jumps, ~ (slope jump) / w ~ 3 / 0.01 / 6e5 = 5e-4 of the PGA."""
    gm = _noise_record(seed=3, n=200, dt=0.01, pga=3.0)
    bldg = ShearBuilding.uniform(n_storeys=3, storey_height=3.0, period=1e-5)
    floors = bldg.floor_motions(gm)
    quasi_static_atol = 2e-3 * 3.0
    for floor in floors:
        np.testing.assert_allclose(floor.ag, gm.ag, rtol=0, atol=quasi_static_atol)
    assert np.max(np.abs(bldg.response(gm).displacement)) < 3.0 / (2 * np.pi / 1e-5) ** 2 * 10


def test_floor_motions_are_ground_motions():
    gm = _noise_record(seed=4, n=120).with_metadata(event="test")
    bldg = ShearBuilding.uniform(3, 3.0, 0.3)
    floors = bldg.floor_motions(gm)
    resp = bldg.response(gm)
    assert [f.name for f in floors] == [f"{gm.name} floor {i}" for i in (1, 2, 3)]
    assert all(f.dt == gm.dt and f.n == gm.n for f in floors)
    assert floors[1].metadata == {"event": "test", "floor": "2", "height_m": "6"}
    np.testing.assert_array_equal(floors[2].ag, resp.acceleration[2])
    np.testing.assert_allclose(resp.t, gm.t, rtol=0)
    np.testing.assert_allclose(resp.drift[1], resp.displacement[1] - resp.displacement[0])


def test_floor_spectra():
    """Reference: rj.response_spectrum of each floor record; Sa(0) is the peak floor
    acceleration."""
    gm = _noise_record(seed=5, n=200)
    bldg = ShearBuilding.uniform(2, 3.0, 0.25)
    periods = np.array([0.0, 0.1, 0.25, 0.5])
    spec = floor_spectra(bldg, gm, periods)
    floors = bldg.floor_motions(gm)
    assert spec.sa.shape == (2, 4)
    for i, floor in enumerate(floors):
        ref = rj.response_spectrum(floor, periods)
        np.testing.assert_allclose(spec.sa[i], ref.sa, rtol=TRANSFORM_RTOL)
        np.testing.assert_allclose(spec.sa[i, 0], np.max(np.abs(floor.ag)), rtol=1e-15)
    # the roof amplifies most near the fundamental period
    assert spec.sa[1, 2] > spec.sa[0, 2] > rj.response_spectrum(gm, [0.25]).sa[0]


# ----------------------------------------------------------------------------- transforms


def test_jit_and_vmap_over_records():
    """Reference: eager calls, one per record."""
    gms = [_noise_record(seed=s, n=150) for s in (6, 7)]
    bldg = ShearBuilding(MASSES, STIFFNESSES, STOREY_HEIGHTS)

    def roof(ag):
        return bldg.response(rj.GroundMotion(ag=ag, dt=0.01)).acceleration[-1]

    batched = jax.vmap(roof)(jnp.stack([g.ag for g in gms]))
    jitted = jax.jit(roof)(gms[0].ag)
    for i, g in enumerate(gms):
        np.testing.assert_allclose(
            batched[i], bldg.response(g).acceleration[-1], rtol=TRANSFORM_RTOL
        )
    np.testing.assert_allclose(jitted, bldg.response(gms[0]).acceleration[-1], rtol=TRANSFORM_RTOL)


def test_vmap_over_buildings():
    """Reference: a Python loop over the periods."""
    gm = _noise_record(seed=8, n=150)
    periods = jnp.array([0.2, 0.45])

    def roof(period):
        bldg = ShearBuilding.uniform(3, 3.0, period, damping_model="rayleigh")
        return bldg.response(gm).acceleration[-1]

    batched = jax.vmap(roof)(periods)
    for i, p in enumerate(periods):
        np.testing.assert_allclose(batched[i], roof(float(p)), rtol=TRANSFORM_RTOL, atol=1e-13)


def test_grad_matches_finite_differences():
    """Reference: central differences of the roof's mean-square acceleration in the period of
    a uniform building and in the first storey's stiffness of a general one."""
    gm = _noise_record(seed=9, n=150)

    def of_period(period):
        bldg = ShearBuilding.uniform(3, 3.0, period, damping=0.05)
        return jnp.mean(bldg.response(gm).acceleration[-1] ** 2)

    def of_k1(k1):
        k = jnp.concatenate([k1[None], jnp.asarray(STIFFNESSES[1:])])
        bldg = ShearBuilding(MASSES, k, STOREY_HEIGHTS, damping_model="rayleigh")
        return jnp.mean(bldg.response(gm).acceleration[-1] ** 2)

    for fn, x in ((jax.jit(of_period), 0.3), (jax.jit(of_k1), STIFFNESSES[0])):
        g = jax.grad(fn)(jnp.asarray(x))
        step = 1e-6 * x
        fd = (fn(jnp.asarray(x + step)) - fn(jnp.asarray(x - step))) / (2 * step)
        assert np.isfinite(g) and abs(g) > 0
        np.testing.assert_allclose(g, fd, rtol=FD_RTOL)


# ----------------------------------------------------------------------------- return walls


def test_wall_with_the_ground_acceleration_does_not_move():
    gm = _noise_record(seed=10, n=100)
    u, v = wall_top_motion(gm, gm, 3.0)
    assert u.shape == v.shape == (100,) and u.dtype == np.float64
    np.testing.assert_array_equal(u, 0.0)
    np.testing.assert_array_equal(v, 0.0)


def test_wall_ground_motion_integrates_exactly():
    """Reference: a relative acceleration c0 + c1 t (linear, so its interpolant is exact) gives
    v = c0 t + c1 t^2 / 2 and u = c0 t^2 / 2 + c1 t^3 / 6 from rest."""
    gm = _noise_record(seed=11, n=200)
    t = gm.t
    c0, c1 = 0.3, -0.2
    wall = rj.GroundMotion(ag=np.asarray(gm.ag) + c0 + c1 * t, dt=gm.dt)
    u, v = wall_top_motion(wall, gm, 2.0)
    np.testing.assert_allclose(v, c0 * t + c1 * t**2 / 2, rtol=0, atol=EXACT_RTOL * 10)
    np.testing.assert_allclose(u, c0 * t**2 / 2 + c1 * t**3 / 6, rtol=0, atol=EXACT_RTOL * 10)


def test_wall_pairs_interpolate_in_height():
    """Reference: pairs at 2 m (relative acceleration c t) and 4 m (2 c t): the motion at z is
    (z / 2) c t^3 / 6 below 2 m, linear between, and the top's 2 c t^3 / 6 above 4 m."""
    gm = _noise_record(seed=12, n=100)
    t, c = gm.t, 0.5
    pairs = [
        (2.0, rj.GroundMotion(ag=np.asarray(gm.ag) + c * t, dt=gm.dt)),
        (4.0, rj.GroundMotion(ag=np.asarray(gm.ag) + 2 * c * t, dt=gm.dt)),
    ]
    for z, factor in ((0.0, 0.0), (1.0, 0.5), (2.0, 1.0), (3.0, 1.5), (4.0, 2.0), (6.0, 2.0)):
        u, v = wall_top_motion(pairs, gm, z)
        np.testing.assert_allclose(u, factor * c * t**3 / 6, rtol=0, atol=1e-12)
        np.testing.assert_allclose(v, factor * c * t**2 / 2, rtol=0, atol=1e-12)


def test_wall_from_building_interpolates_floors():
    """Reference: the floor histories of bldg.response, interpolated by hand; and the floor
    records as pairs, integrated, agree to O((w_n dt)^2) (their linear interpolant is not
    the floors' exact motion)."""
    gm = _noise_record(seed=13, n=300, dt=0.005)
    bldg = ShearBuilding(MASSES, STIFFNESSES, STOREY_HEIGHTS)  # floors at 3.5, 6.5, 9.5 m
    resp = bldg.response(gm)
    d, vel = np.asarray(resp.displacement), np.asarray(resp.velocity)
    cases = {
        0.0: (0 * d[0], 0 * vel[0]),
        1.75: (0.5 * d[0], 0.5 * vel[0]),
        3.5: (d[0], vel[0]),
        5.0: (0.5 * (d[0] + d[1]), 0.5 * (vel[0] + vel[1])),
        9.5: (d[2], vel[2]),
        12.0: (d[2], vel[2]),
    }
    for z, (u_ref, v_ref) in cases.items():
        u, v = wall_top_motion(bldg, gm, z)
        np.testing.assert_allclose(u, u_ref, rtol=0, atol=1e-14)
        np.testing.assert_allclose(v, v_ref, rtol=0, atol=1e-13)
    pairs = list(zip(np.asarray(bldg.heights), bldg.floor_motions(gm), strict=True))
    u_pairs, _ = wall_top_motion(pairs, gm, 5.0)
    u_bldg, _ = wall_top_motion(bldg, gm, 5.0)
    interpolation_rtol = 1e-2  # (w_3 dt)^2 / 12 with w_3 ~ 60 rad/s, dt = 5 ms
    np.testing.assert_allclose(
        u_pairs, u_bldg, rtol=0, atol=interpolation_rtol * np.max(np.abs(u_bldg))
    )


def test_wall_top_motion_under_vmap():
    """Reference: one call per record (the DEM batches records through vmap)."""
    gms = [_noise_record(seed=s, n=120) for s in (14, 15)]
    bldg = ShearBuilding.uniform(2, 3.0, 0.2)

    def top(ag):
        return wall_top_motion(bldg, rj.GroundMotion(ag=ag, dt=0.01), 4.0)[0]

    batched = jax.vmap(top)(jnp.stack([g.ag for g in gms]))
    for i, g in enumerate(gms):
        np.testing.assert_allclose(batched[i], wall_top_motion(bldg, g, 4.0)[0], rtol=1e-12)

    # the other two kinds with traced records, and a traced height
    wall = rj.GroundMotion(ag=0.5 * np.asarray(gms[0].ag), dt=0.01)

    def top_of_record(ag):
        gm = rj.GroundMotion(ag=ag, dt=0.01)
        return wall_top_motion(wall, gm, 4.0)[0], wall_top_motion([(3.0, wall)], gm, 1.5)[1]

    u_b, v_b = jax.vmap(top_of_record)(jnp.stack([g.ag for g in gms]))
    pairs_at = jax.jit(lambda z: wall_top_motion([(3.0, wall)], gms[1], z)[0])
    for i, g in enumerate(gms):
        np.testing.assert_allclose(u_b[i], wall_top_motion(wall, g, 4.0)[0], rtol=1e-12)
        np.testing.assert_allclose(v_b[i], wall_top_motion([(3.0, wall)], g, 1.5)[1], rtol=1e-12)
    np.testing.assert_allclose(
        pairs_at(1.5), wall_top_motion([(3.0, wall)], gms[1], 1.5)[0], rtol=1e-12
    )


# ----------------------------------------------------------------------------- bad input


def test_bad_input(user_view):
    """Each message names the argument, its unit and the fix."""
    gm = _noise_record(seed=16, n=50)
    other = rj.GroundMotion(ag=np.zeros(50), dt=0.02)
    with pytest.raises(ValueError, match="one value per storey"):
        ShearBuilding([1e5, 1e5], [1e7], [3.0, 3.0])
    with pytest.raises(ValueError, match="masses must be positive finite numbers in kg"):
        ShearBuilding([-1e5], [1e7], [3.0])
    with pytest.raises(ValueError, match="damping .* must lie in"):
        ShearBuilding([1e5], [1e7], [3.0], damping=5.0)
    with pytest.raises(ValueError, match="damping_model must be one of"):
        ShearBuilding([1e5], [1e7], [3.0], damping_model="caughey")
    with pytest.raises(ValueError, match="n_storeys must be an int"):
        ShearBuilding.uniform(0, 3.0, 0.3)
    with pytest.raises(ValueError, match="period must be a positive finite number in s"):
        ShearBuilding.uniform(3, 3.0, -0.3)
    with pytest.raises(ValueError, match="stiffnesses must be a number in N/m, not text"):
        ShearBuilding([1e5], "1e7", [3.0])
    with pytest.raises(ValueError, match="must share the ground motion's step"):
        wall_top_motion(other, gm, 3.0)
    with pytest.raises(ValueError, match="positive and increasing"):
        wall_top_motion([(4.0, gm), (2.0, gm)], gm, 3.0)
    with pytest.raises(ValueError, match="wall_motion must be a rockjax.ShearBuilding"):
        wall_top_motion(np.zeros(50), gm, 3.0)
    with pytest.raises(ValueError, match="height must be a finite height >= 0 in m"):
        wall_top_motion(gm, gm, -1.0)
    undamped = ShearBuilding.uniform(1, 3.0, 0.5, damping=0.0)
    resonant = rj.GroundMotion(ag=9.0 * np.sin(4 * np.pi * np.arange(1001) * 0.01), dt=0.01)
    with pytest.raises(ValueError, match="floor 1 of the building peaks at .* above the plaus"):
        undamped.floor_motions(resonant)
    with pytest.raises(ValueError, match="motion must be a rockjax.GroundMotion"):
        ShearBuilding.uniform(2, 3.0, 0.3).response(np.zeros(50))


def test_overdamped_rayleigh_mode_raises():
    """A tall building with a large Rayleigh ratio overdamps its top modes: refused in-graph."""
    bldg = ShearBuilding.uniform(20, 3.0, 1.0, damping=0.6, damping_model="rayleigh")
    assert float(bldg.damping_ratios[-1]) > 1.0
    with pytest.raises(eqx.EquinoxRuntimeError, match="overdamped"):
        bldg.response(_noise_record(seed=17, n=50))
