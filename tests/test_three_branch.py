"""Tests of rockjax.three_branch and of simulate_housner(..., law=...).

Independent references: the law's closed form written here in NumPy; plain Housner (the rigid
law must give its results to round-off); the static equilibrium a/g = lambda(x) and the
zero-capacity rotation of the law's definition (docs/three_branch.md); energy conservation with
e = 1, the potential by scipy quadrature of the law's moment; an event-driven scipy solve_ivp
solver written here with the same law; a synthetic pushover curve for the fit; central finite
differences for grad.
"""

import math
from types import SimpleNamespace

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq

import rockjax as rj
from rockjax.constants import G
from rockjax.three_branch import ThreeBranchFit, ThreeBranchLaw, fit_three_branch

# The rigid law and law=None evaluate the same moment (and uplift threshold) in two algebraic
# forms: only rounding differs, 4e-16 rad in free rocking; a forced run with ~50 impacts, rests
# and uplifts amplifies it to 1.5e-10 rad (measured).
ROUNDOFF_ATOL = 1e-9
# A synthetic exact curve: the zoomed grid search ends within ~1e-7 of the breakpoints.
FIT_EXACT_ATOL = 1e-5
# 1e-3 noise (about 1 % of lambda_0) and one outlier: breakpoints within 0.01 b.
FIT_NOISY_ATOL = 0.01
# Equilibrium held: Tsit5 keeps a rest state of the exact ODE to round-off over the run.
STATIC_ATOL = 1e-10
# Energy with e = 1: Tsit5's local error (p dt)^6 ~ 1e-6 per step is larger where a step
# straddles a kink of the law (its slope jumps); measured drift 2e-8 relative over 10 s.
ENERGY_RTOL = 1e-6
# Against the event-driven scipy solver (rtol 1e-11): Tsit5 at p dt <= 0.1 with kinks inside
# steps; histories over the first seconds (a few impacts) before chaos can amplify.
REF_ATOL_ETA = 1e-4  # as a fraction of eta
FD_RTOL = 1e-5
FD_STEP = 1e-6


@pytest.fixture(scope="module")
def block():
    return rj.Block(b=0.25, h=3.0)


@pytest.fixture(scope="module")
def law(block):
    """A semi-rigid law: stiff branch to 0.04 b, plateau to 0.2 b, zero at 0.9 b."""
    return ThreeBranchLaw(lambda_0=0.25 / 3.0, Delta_1=0.04, Delta_2=0.2, Delta_u=0.9)


def _lam(x, lam0, d1, d2, du):
    """The law, written independently: lambda(x) for x >= 0."""
    lam_p = lam0 * (1.0 - d2 / du)
    x = np.abs(np.asarray(x, dtype=float))
    first = lam_p * x / d1 if d1 > 0 else np.full_like(x, lam_p)
    return np.where(x < d1, first, np.where(x < d2, lam_p, lam0 * (1.0 - x / du)))


def _x_of(u, eta):
    """Rigid-equivalent displacement x(u) = 1 - tan(eta - u) / tan(eta) (docs/three_branch.md)."""
    return 1.0 - np.tan(eta - u) / np.tan(eta)


def _u_of(x, eta):
    return eta - np.arctan(np.tan(eta) * (1.0 - x))


def _params(law):
    return tuple(float(v) for v in (law.lambda_0, law.Delta_1, law.Delta_2, law.Delta_u))


# ----------------------------------------------------------------------------- the law


def test_load_multiplier_matches_the_closed_form(law):
    x = np.linspace(0.0, 1.2, 241)
    got = np.asarray(law.load_multiplier(x))
    np.testing.assert_allclose(got, _lam(x, *_params(law)), rtol=0, atol=1e-15)
    assert got.dtype == np.float64
    # continuous at the breakpoints, zero at Delta_u
    lam_p = float(law.lambda_p)
    for xb, want in ((0.04, lam_p), (0.2, lam_p), (0.9, 0.0)):
        np.testing.assert_allclose(
            np.asarray(law.load_multiplier(jnp.array([xb - 1e-12, xb]))), want, atol=1e-9
        )


def test_rigid_law_is_the_rigid_line(block):
    rigid = ThreeBranchLaw.rigid(block)
    x = np.linspace(0.0, 1.0, 11)
    np.testing.assert_allclose(
        np.asarray(rigid.load_multiplier(x)), (0.25 / 3.0) * (1 - x), atol=1e-15
    )
    assert float(rigid.lambda_uplift) == pytest.approx(0.25 / 3.0, rel=1e-15)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(lambda_0=0.1, Delta_1=0.3, Delta_2=0.2, Delta_u=0.9), "Delta_1 <= Delta_2"),
        (dict(lambda_0=0.1, Delta_1=0.0, Delta_2=0.95, Delta_u=0.9), "Delta_2 < Delta_u"),
        (dict(lambda_0=-0.1, Delta_1=0.0, Delta_2=0.0, Delta_u=1.0), "lambda_0"),
        (dict(lambda_0=0.1, Delta_1=np.nan, Delta_2=0.0, Delta_u=1.0), "finite"),
    ],
)
def test_inconsistent_law_raises(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ThreeBranchLaw(**kwargs)


def test_simulate_refuses_a_law_of_the_wrong_type(block, user_view):
    with pytest.raises(ValueError, match="law must be a rockjax ThreeBranchLaw"):
        rj.simulate_housner(block, duration=1.0, theta0=0.01, law=(0.1, 0.0, 0.0, 1.0))


# ----------------------------------------------------------------------------- dynamics


@pytest.mark.parametrize("mode", ["two_sided", "one_sided"])
def test_rigid_law_reproduces_plain_housner(block, mode):
    t = np.arange(0.0, 6.0, 0.01)
    motion = rj.GroundMotion(ag=-1.0 * np.sin(2 * np.pi * 1.0 * t) * (t < 2.5), dt=0.01)
    plain = rj.simulate_housner(block, motion, mode=mode, e=0.9, duration=8.0)
    rigid = rj.simulate_housner(
        block, motion, mode=mode, e=0.9, duration=8.0, law=ThreeBranchLaw.rigid(block)
    )
    assert int(plain.extras["n_impacts"][-1]) > 2  # rocking with impacts, not a trivial case
    np.testing.assert_allclose(
        np.asarray(rigid.theta), np.asarray(plain.theta), rtol=0, atol=ROUNDOFF_ATOL
    )
    np.testing.assert_allclose(
        np.asarray(rigid.theta_dot), np.asarray(plain.theta_dot), rtol=0, atol=1e-7
    )
    e_plain = np.asarray(plain.energy)  # the same rounding, through I_O theta_dot dtheta_dot
    np.testing.assert_allclose(
        np.asarray(rigid.energy), e_plain, rtol=0, atol=1e-7 * np.max(e_plain)
    )
    np.testing.assert_array_equal(
        np.asarray(rigid.extras["n_impacts"]), np.asarray(plain.extras["n_impacts"])
    )
    assert bool(rigid.overturned) == bool(plain.overturned)


def test_static_equilibrium_on_the_stiff_branch_is_held(block, law):
    """At rotation u* with a/g = -lambda(x(u*)) the block stays put (one-sided, outward a_g)."""
    eta = float(block.eta)
    x_star = 0.02  # on the stiff branch (Delta_1 = 0.04)
    lam_star = float(_lam(x_star, *_params(law)))
    u_star = float(_u_of(x_star, eta))
    motion = rj.GroundMotion(ag=np.full(301, -lam_star * G), dt=0.01)
    resp = rj.simulate_housner(block, motion, mode="one_sided", theta0=u_star, law=law)
    np.testing.assert_allclose(np.asarray(resp.theta), u_star, rtol=0, atol=STATIC_ATOL)


@pytest.mark.parametrize("factor, lifts", [(0.98, False), (1.02, True)])
def test_uplift_from_rest_at_the_plateau_threshold(block, factor, lifts):
    """Without a stiff branch (Delta_1 = 0) a block at rest lifts only once |a_g| > lambda_p g."""
    law = ThreeBranchLaw(lambda_0=0.25 / 3.0, Delta_1=0.0, Delta_2=0.15, Delta_u=0.95)
    lam_p = float(law.lambda_p)
    motion = rj.GroundMotion(ag=np.full(201, -factor * lam_p * G), dt=0.01)
    resp = rj.simulate_housner(block, motion, mode="one_sided", law=law)
    assert (float(resp.theta_max) > 1e-6) == lifts
    if not lifts:
        assert float(np.max(np.abs(np.asarray(resp.theta)))) == 0.0


# The rest rule gives up motions below REST_HOP eta (docs/theory.md, "Housner rest and chatter
# rule"), its documented value.
REST_HOP_ETA = 1e-6


@pytest.mark.parametrize("factor, lifts", [(0.5, False), (2.0, True)])
def test_lift_off_on_a_stiff_branch_needs_a_deflection_above_the_rest_rules_size(
    block, law, factor, lifts
):
    """From rest on a stiff first branch a constant forcing lifts the block only if its static
    deflection of the branch, from the law's closed form here, exceeds 1e-6 eta; the block
    then swings to about twice it (a step load on a spring)."""
    eta = float(block.eta)
    u_target = REST_HOP_ETA * eta  # the static rotation to reach
    x = brentq(lambda x: _u_of(x, eta) - u_target, 0.0, 0.5 * float(law.Delta_1))
    a_static = float(_lam(x, *_params(law))) * G  # the forcing that holds it there [m/s^2]
    motion = rj.GroundMotion(ag=np.full(201, -factor * a_static), dt=0.01)
    resp = rj.simulate_housner(block, motion, mode="one_sided", law=law)
    theta_max = float(resp.theta_max)
    if lifts:
        assert 1.5 * factor * u_target < theta_max < 2.5 * factor * u_target
    else:
        assert theta_max == 0.0


@pytest.mark.parametrize("offset, overturns", [(-2e-3, False), (2e-3, True)])
def test_zero_capacity_rotation_is_where_the_law_says(block, law, offset, overturns):
    """Released from rest just inside (outside) x = Delta_u the block falls back (overturns)."""
    eta = float(block.eta)
    u_u = float(_u_of(float(law.Delta_u), eta))
    assert u_u < eta  # Delta_u < 1: the semi-rigid wall is less stable than the rigid block
    resp = rj.simulate_housner(
        block, theta0=u_u + offset * eta, duration=8.0, mode="one_sided", law=law
    )
    assert bool(resp.overturned) == overturns
    if not overturns:
        assert int(resp.extras["n_impacts"][-1]) >= 1  # it came back to the wall


def _potential(u, block, law):
    """V(u) [J] = int_0^u m g R cos(eta - v) lambda(x(v)) dv, by quadrature (breakpoints given)."""
    eta, m, R = float(block.eta), float(block.m), float(block.R)
    lam0, d1, d2, du = _params(law)
    pts = [float(_u_of(x, eta)) for x in (d1, d2)]

    def f(v):
        return m * G * R * math.cos(eta - v) * float(_lam(_x_of(v, eta), lam0, d1, d2, du))

    return quad(
        f,
        0.0,
        abs(u),
        points=[p for p in pts if 0 < p < abs(u)],
        epsabs=1e-13,
        epsrel=1e-12,
        limit=200,
    )[0]


@pytest.mark.parametrize("mode", ["one_sided", "two_sided"])
def test_energy_is_conserved_with_e_one_and_matches_the_quadrature_potential(block, law, mode):
    eta = float(block.eta)
    theta0 = float(_u_of(0.5, eta))  # on the rigid branch: the flight crosses all three
    resp = rj.simulate_housner(
        block, theta0=theta0, duration=10.0, dt=0.005, mode=mode, e=1.0, law=law
    )
    assert int(resp.extras["n_impacts"][-1]) >= 3
    theta, theta_dot = np.asarray(resp.theta), np.asarray(resp.theta_dot)
    idx = np.arange(0, theta.size, 50)
    e_ref = np.array(
        [0.5 * float(block.I_O) * theta_dot[i] ** 2 + _potential(theta[i], block, law) for i in idx]
    )
    e0 = _potential(theta0, block, law)
    np.testing.assert_allclose(e_ref, e0, rtol=ENERGY_RTOL)
    np.testing.assert_allclose(np.asarray(resp.energy)[idx], e_ref, rtol=1e-9, atol=1e-9 * e0)


def _event_reference(block, law, ag, dt, theta0, e, t_end):
    """One-sided rocking with the law, event-driven: solve_ivp between impacts at theta = 0,
    theta_dot -> -e theta_dot there. The forcing is the record, linear between samples."""
    eta = float(block.eta)
    k = float(block.p) ** 2 / G
    lam = law if callable(law) else (lambda x, pr=_params(law): float(_lam(x, *pr)))
    t_rec = np.arange(ag.size) * dt

    def rhs(t, y):
        a = np.interp(t, t_rec, ag)
        c = math.cos(eta - y[0])
        return [y[1], -k * c * (G * lam(_x_of(y[0], eta)) + a)]

    def hit(t, y):
        return y[0]

    hit.terminal, hit.direction = True, -1
    t0, y0 = 0.0, [theta0, 0.0]
    ts = []
    while t0 < t_end:
        sol = solve_ivp(
            rhs,
            (t0, t_end),
            y0,
            events=hit,
            rtol=1e-11,
            atol=1e-13,
            dense_output=True,
            method="DOP853",
        )
        ts.append(sol)
        if sol.status != 1:
            break
        t0 = float(sol.t_events[0][0])
        y0 = [0.0, -e * float(sol.y_events[0][0][1])]
        assert abs(y0[1]) > 1e-6, "the reference came to rest: choose a livelier case"

    def theta(t):
        out = np.empty_like(t)
        for i, ti in enumerate(t):
            seg = next(s for s in ts if s.t[0] <= ti <= s.t[-1] + 1e-12)
            out[i] = seg.sol(ti)[0]
        return out

    return theta


def test_one_sided_with_a_law_matches_an_event_driven_reference(block, law):
    dt = 0.01
    t = np.arange(0.0, 4.0 + dt / 2, dt)
    ag = -0.6 * G * float(law.lambda_0) * np.sin(2 * np.pi * 1.2 * t)
    theta0 = float(_u_of(0.3, float(block.eta)))
    e = 0.85
    resp = rj.simulate_housner(
        block, rj.GroundMotion(ag=ag, dt=dt), mode="one_sided", theta0=theta0, e=e, law=law
    )
    assert int(resp.extras["n_impacts"][-1]) >= 3
    ref = _event_reference(block, law, ag, dt, theta0, e, t[-1])
    np.testing.assert_allclose(
        np.asarray(resp.theta), ref(t), rtol=0, atol=REF_ATOL_ETA * float(block.eta)
    )


# ----------------------------------------------------------------------------- transforms


def _peak_of_delta_2(block, law):
    """theta_max [rad] of a forced one-sided run as a function of the law's Delta_2."""
    motion = rj.GroundMotion(
        ag=-0.5 * G * float(law.lambda_0) * np.sin(2 * np.pi * np.arange(0, 3.0, 0.01)), dt=0.01
    )
    theta0 = float(_u_of(0.3, float(block.eta)))

    def peak(delta_2):
        lw = eqx.tree_at(lambda z: z.Delta_2, law, delta_2)
        return rj.simulate_housner(
            block, motion, mode="one_sided", theta0=theta0, e=0.85, law=lw
        ).theta_max

    return peak


def test_jit_vmap_over_laws_equals_a_loop(block, law):
    peak = _peak_of_delta_2(block, law)
    d2s = jnp.array([0.15, 0.2, 0.25])
    batched = jax.jit(jax.vmap(peak))(d2s)
    loop = np.array([float(peak(float(d))) for d in d2s])
    np.testing.assert_allclose(np.asarray(batched), loop, rtol=1e-12)
    assert batched.dtype == jnp.float64


def test_grad_over_a_law_parameter_matches_finite_differences(block, law):
    peak = _peak_of_delta_2(block, law)
    g = float(jax.jit(jax.grad(peak))(0.2))
    fd = (float(peak(0.2 + FD_STEP)) - float(peak(0.2 - FD_STEP))) / (2 * FD_STEP)
    assert g == pytest.approx(fd, rel=FD_RTOL)


# ----------------------------------------------------------------------------- fit


def _curve(law, n=200, x_max=0.95):
    x = np.linspace(0.0, x_max, n)
    return SimpleNamespace(d_over_b=x, load_multiplier=_lam(x, *_params(law)))


def test_fit_recovers_the_deltas_of_an_exact_curve():
    true = ThreeBranchLaw(lambda_0=0.1, Delta_1=0.04, Delta_2=0.25, Delta_u=0.85)
    fit = fit_three_branch(_curve(true))
    assert isinstance(fit, ThreeBranchFit)
    np.testing.assert_allclose(_params(fit.law), _params(true), atol=FIT_EXACT_ATOL)
    assert float(fit.rmse) < 1e-6


def test_fit_is_robust_to_noise_and_an_outlier_and_can_fix_lambda_0():
    true = ThreeBranchLaw(lambda_0=0.1, Delta_1=0.04, Delta_2=0.25, Delta_u=0.85)
    cap = _curve(true)
    rng = np.random.default_rng(1)
    cap.load_multiplier = cap.load_multiplier + 1e-3 * rng.standard_normal(cap.d_over_b.size)
    cap.load_multiplier[40] += 0.05  # an impact spike of the DEM curve
    for lam0 in (None, 0.1):
        fit = fit_three_branch(cap, lambda_0=lam0)
        np.testing.assert_allclose(_params(fit.law)[1:], _params(true)[1:], atol=FIT_NOISY_ATOL)
        assert float(fit.max_error) >= 0.04  # the outlier is not fitted


def test_fit_of_a_rigid_curve_gives_the_rigid_law():
    rigid = ThreeBranchLaw(lambda_0=0.2, Delta_1=0.0, Delta_2=0.0, Delta_u=1.0)
    fit = fit_three_branch(_curve(rigid, x_max=1.0))
    np.testing.assert_allclose(_params(fit.law), (0.2, 0.0, 0.0, 1.0), atol=FIT_EXACT_ATOL)


@pytest.mark.parametrize(
    "cap, match",
    [
        (object(), "d_over_b"),
        (SimpleNamespace(d_over_b=np.arange(5.0), load_multiplier=np.arange(4.0)), "same"),
        (SimpleNamespace(d_over_b=np.arange(3.0), load_multiplier=np.arange(3.0)), "at least 6"),
        (
            SimpleNamespace(d_over_b=np.linspace(0, 1, 10), load_multiplier=np.linspace(0, 1, 10)),
            "does not descend",
        ),
    ],
)
def test_fit_bad_input_raises(cap, match):
    with pytest.raises(ValueError, match=match):
        fit_three_branch(cap)


def test_the_fit_result_can_be_passed_as_the_law():
    # rj.fit_three_branch(cap) goes straight into simulate_housner(law=...) and rj.ida(law=...)
    block = rj.Block(b=0.25, h=3.0)
    law = rj.ThreeBranchLaw(lambda_0=0.25 / 3.0, Delta_1=0.04, Delta_2=0.15, Delta_u=0.9)
    x = np.linspace(0.0, 0.95, 200)

    class Curve:
        d_over_b = x
        load_multiplier = np.asarray(law.load_multiplier(x))

    fit = rj.fit_three_branch(Curve())
    gm = rj.GroundMotion.ricker(pga=1.5, period=0.5)
    a = rj.simulate_housner(block, gm, mode="one_sided", law=fit)
    b = rj.simulate_housner(block, gm, mode="one_sided", law=fit.law)
    np.testing.assert_array_equal(np.asarray(a.theta), np.asarray(b.theta))
