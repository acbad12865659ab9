"""Tests of rockjax.relations: the paper's Eqs. 1-7 and the linearised Housner closed forms.

Independent references: the paper's equations evaluated by hand (the arithmetic is written
out below), and the numbers of docs/verification.md "Reference facts" (computed with an independent
solver).
"""

import inspect
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax.relations as rel
from rockjax.block import Block
from rockjax.constants import G
from rockjax.response import e_exp as response_e_exp

# Same float64 expression evaluated two ways: only rounding differs.
EXACT_RTOL = 1e-12
# docs/verification.md prints 6 decimals: half a unit in the last place.
REF6_ATOL = 5e-7
# docs/verification.md prints the pulse ratios with 5 decimals: half a unit in the last place.
REF5_ATOL = 5e-6
# Hand arithmetic below is carried to ~10 significant digits.
HAND_RTOL = 1e-9
# Inverting a formula (a difference e0 - e, or 1 - (1 - theta/eta)^2) cancels a few digits.
ROUNDTRIP_RTOL = 1e-10
# t_p = 1e-7 s with p = 2 rad/s: the impulse limit's first-order error p t_p / 2 = 1e-7.
IMPULSE_RTOL = 1e-6
# Central differences with relative step 1e-6: truncation O(1e-12), round-off O(1e-10).
FD_RTOL = 1e-6
FD_STEP = 1e-6

# docs/verification.md "Reference facts", Housner numbers: eta = 0.2, R = 1 m, and p = 2 exactly.
# The tabulated periods for R = 1 m follow from p = sqrt(3 g / 4) with g = 9.81 m/s^2
# (p = 2.712471 rad/s); the p = 2.712510 printed beside them is inconsistent with them by
# 1.5e-5 relative, so we rebuild p from R and g = 9.81 instead.
P_R1 = math.sqrt(3.0 * 9.81 / 4.0)


def _close(actual, expected, rtol=0.0, atol=0.0):
    np.testing.assert_allclose(np.asarray(actual), expected, rtol=rtol, atol=atol)


def _is_f64(x):
    return jnp.asarray(x).dtype == jnp.float64


# ----------------------------------------------------------------------------- Eq. (1)


def test_rayleigh_zeta_formula_and_round_trip():
    # Eq. (1) by hand: alpha = 3 1/s, beta = 0.01 s, omega = 20 rad/s
    # -> 3/40 + 0.01*20/2 = 0.075 + 0.1 = 0.175.
    zeta = rel.rayleigh_zeta(20.0, alpha=3.0, beta=0.01)
    _close(zeta, 0.175, rtol=EXACT_RTOL)
    assert _is_f64(zeta)
    omega = jnp.array([1.0, 50.0, 400.0])
    beta = rel.beta_from_zeta(0.3, omega)
    _close(rel.rayleigh_zeta(omega, beta=beta), np.full(3, 0.3), rtol=EXACT_RTOL)


# ----------------------------------------------------------------------------- Eqs. (2), (5)


@pytest.mark.parametrize("eta, expected", [(0.10, 0.985050), (0.20, 0.940796), (0.25, 0.908187)])
def test_e_housner_matches_references(eta, expected):
    # docs/verification.md "Reference facts", e_H numbers.
    e = rel.e_housner(eta)
    _close(e, expected, atol=REF6_ATOL)
    assert _is_f64(e)


def test_e_housner_accepts_block_or_eta():
    block = Block(b=0.25, h=3.0)
    _close(rel.e_housner(block), rel.e_housner(math.atan(0.25 / 3.0)), rtol=EXACT_RTOL)
    _close(rel.e_isr(block), rel.e_isr(math.atan(0.25 / 3.0)), rtol=EXACT_RTOL)


def test_e_isr_is_product_of_three_factors():
    # Eq. (5) = (1 - 1.5 sin^2)(1 - 1.5 sin^2)(1 - 1.5 cos^2), with numpy as the reference.
    eta = np.linspace(0.02, 0.7, 15)
    f = 1.0 - 1.5 * np.sin(eta) ** 2
    g = 1.0 - 1.5 * np.cos(eta) ** 2
    _close(rel.e_isr(jnp.asarray(eta)), f * f * g, rtol=EXACT_RTOL)


def test_e_isr_hand_value_eta_0p2():
    # sin^2(0.2) = 0.0394695030, cos^2(0.2) = 0.9605304970
    # 1 - 1.5*0.0394695030 = 0.9407957455; squared = 0.8850966348
    # 1 - 1.5*0.9605304970 = -0.4407957455
    # product = 0.8850966348 * -0.4407957455 = -0.3901468310
    _close(rel.e_isr(0.2), -0.3901468310, rtol=HAND_RTOL)


def test_e_isr_negative_for_slender_blocks():
    # The last factor of Eq. (5) changes sign at cos^2(eta) = 2/3, i.e. eta = 0.6155 rad.
    slender = jnp.linspace(0.01, 0.6, 30)
    assert bool(jnp.all(rel.e_isr(slender) < 0.0))
    assert float(rel.e_isr(0.65)) > 0.0


# ----------------------------------------------------------------------------- Eqs. (3), (4)


def test_eq3_inverse_pair_round_trips():
    e0 = rel.e_housner(0.1)
    x = jnp.array([5.0, 20.0, 80.0])
    beta = jnp.array([1e-4, 2e-3, 5e-3])
    e = rel.e_from_beta(beta, x, e0)
    # Eq. (3) by hand for the first entry: e0 - 5 * 1e-4 = e0 - 5e-4.
    _close(e[0], float(e0) - 5e-4, rtol=EXACT_RTOL)
    _close(rel.beta_from_e(e, x, e0), beta, rtol=ROUNDTRIP_RTOL)
    _close(rel.e_from_beta(0.0, 7.0, e0), e0, rtol=EXACT_RTOL)


def test_x_from_y_hand_value():
    # Eq. (4) by hand: y = 0.5, h/b = 10: 10^-0.37 = 0.4265795188 -> x = 0.2132897594.
    _close(rel.x_from_y(0.5, 10.0), 0.2132897594, rtol=HAND_RTOL)
    # h/b = 1 leaves y unchanged, for any exponent.
    _close(rel.x_from_y(0.5, 1, exponent=-1.2), 0.5, rtol=EXACT_RTOL)


# ----------------------------------------------------------------------------- Eq. (7)


def test_beta_isr_hand_value():
    # Eq. (7) by hand, b = 0.11 m, h = 2.4 m, E = 1800 MPa (the paper's Fig. 6 facade):
    #   b/384          = 0.000286458333
    #   E/5.6e6        = 0.000321428571
    #   prefactor      = 0.000286458333 - 0.000321428571 + 0.00074 = 0.000705029762
    #   h/b            = 21.8181818182
    #   (6572 - E)/1.2e5 = 4772/1.2e5 = 0.0397666667
    #   exponent       = 21.8181818182 * 0.0397666667 = 0.8676363636
    #   exp(exponent)  = 2.3812757266
    #   beta_1SR       = 0.000705029762 * 2.3812757266 = 0.0016788702585 s
    expected = 0.0016788702585
    _close(rel.beta_isr_from(0.11, 2.4, 1800.0), expected, rtol=HAND_RTOL)
    # The Block variant converts E from Pa to MPa.
    _close(rel.beta_isr(Block(b=0.11, h=2.4, E=1.8e9)), expected, rtol=HAND_RTOL)


def test_beta_isr_between_hcrit_and_dejong_bounds():
    # The paper, Sect. 2.2 / Fig. 5A: the best-fit facade beta lies between the beta of
    # omega_Hcrit (lower bound) and DeJong's omega_crit (upper bound).
    for b, h, E in [(0.11, 2.4, 1.8e9), (0.30, 3.0, 4.05e9), (0.11, 1.0, 1.8e9)]:
        block = Block(b=b, h=h, E=E)
        assert float(rel.beta_hcrit(block)) < float(rel.beta_isr(block))
        assert float(rel.beta_isr(block)) < float(rel.beta_dejong(block))


# ----------------------------------------------------------------------------- omega_crit


def test_omega_crit_dejong_hand_value():
    # b = 0.25 m, h = 3 m, E = 1.8e9 Pa, rho = 1800 kg/m^3:
    #   m = rho b h = 1800 * 0.25 * 3 = 1350 kg/m
    #   E b^2 = 1.8e9 * 0.0625 = 1.125e8;  m h = 1350 * 3 = 4050
    #   omega_crit^2 = 1.125e8 / 4050 = 250000/9  ->  omega_crit = 500/3 = 166.67 rad/s
    block = Block(b=0.25, h=3.0, E=1.8e9, rho=1800.0)
    omega = rel.omega_crit(block)
    _close(omega, 500.0 / 3.0, rtol=EXACT_RTOL)
    assert _is_f64(omega)
    # Eq. (1) with zeta = 1, alpha = 0: beta = 2/omega = 0.012 s.
    _close(rel.beta_dejong(block), 0.012, rtol=EXACT_RTOL)


def test_omega_hcrit_hand_value():
    # omega_Hcrit^2 = 2 E h^2 / (m b) = 2 * 1.8e9 * 9 / (1350 * 0.25) = 3.24e10 / 337.5 = 9.6e7
    block = Block(b=0.25, h=3.0, E=1.8e9, rho=1800.0)
    _close(rel.omega_hcrit(block), math.sqrt(9.6e7), rtol=EXACT_RTOL)
    _close(rel.beta_hcrit(block), 2.0 / math.sqrt(9.6e7), rtol=EXACT_RTOL)


def test_omega_crit_independent_of_out_of_plane_length():
    # The paper, Sect. 2.1: changing the length leaves the rocking (and beta) unchanged.
    short, long_ = Block(b=0.2, h=2.0, length=0.5), Block(b=0.2, h=2.0, length=4.0)
    _close(rel.omega_crit(short), rel.omega_crit(long_), rtol=EXACT_RTOL)


# ----------------------------------------------------------------------------- Housner


def test_rocking_energy():
    eta = 0.2
    assert float(rel.rocking_energy(0.0, eta)) == 0.0  # cos(eta) - cos(eta), exactly
    theta = jnp.linspace(0.0, eta, 9)
    _close(rel.rocking_energy(-theta, eta), rel.rocking_energy(theta, eta), rtol=EXACT_RTOL)
    # At the overturning limit the centroid rises by R (1 - cos eta).
    _close(rel.rocking_energy(eta, eta), 1.0 - math.cos(eta), rtol=EXACT_RTOL)
    assert bool(jnp.all(jnp.diff(rel.rocking_energy(theta, eta)) > 0.0))


@pytest.mark.parametrize(
    "p, eta, ratio, expected",
    [
        (P_R1, 0.2, 0.5, 1.942078),
        (P_R1, 0.2, 0.9, 4.414016),
        (2.0, 0.25, 0.5, 2.633916),
    ],
)
def test_free_rocking_period_matches_references(p, eta, ratio, expected):
    # docs/verification.md "Reference facts", free-rocking full period, linear formula column.
    T = rel.free_rocking_period(p, eta, ratio * eta)
    _close(T, expected, atol=REF6_ATOL)
    assert _is_f64(T)
    # Symmetric in the release direction.
    _close(rel.free_rocking_period(p, eta, -ratio * eta), T, rtol=EXACT_RTOL)


def test_amplitude_after_impacts_matches_references():
    # docs/verification.md "Reference facts", decay: eta = 0.2, theta0/eta = 0.5, e = e_H.
    eta = 0.2
    n = jnp.arange(1, 5)
    theta_n = rel.amplitude_after_impacts(0.5 * eta, eta, rel.e_housner(eta), n)
    _close(theta_n / eta, [0.420192, 0.357775, 0.307206, 0.265345], atol=REF6_ATOL)
    _close(rel.amplitude_after_impacts(0.5 * eta, eta, 0.9, 0), 0.5 * eta, rtol=EXACT_RTOL)


def test_amplitude_after_impacts_inverts_eq6():
    # The paper's Eq. (6), as implemented in rockjax.response, recovers e from the decay.
    eta, theta0 = 0.15, 0.11
    for e in (0.95, 0.8, rel.e_isr(eta)):
        for n in (1, 2, 3):
            theta_n = rel.amplitude_after_impacts(theta0, eta, e, n)
            _close(rel.e_exp(theta_n, theta0, eta, n), abs(float(e)), rtol=ROUNDTRIP_RTOL)


@pytest.mark.parametrize(
    "pt, psi_lin",
    [(0.25, 4.52081), (0.5, 2.54149), (1.0, 1.58198), (2.0, 1.15652), (3.0, 1.05240)],
)
def test_rectangular_pulse_matches_references(pt, psi_lin):
    # docs/verification.md "Reference facts", rectangular pulse, linearised a_p/(g eta) against p t_p.
    eta, p = 0.2, P_R1
    a_p = rel.rectangular_pulse_min_accel(p, eta, pt / p)
    _close(a_p / (G * eta), psi_lin, atol=REF5_ATOL)


def test_rectangular_pulse_limits():
    eta, p = 0.2, 2.0
    # Long pulse: the linearised uplift threshold g eta.
    _close(rel.rectangular_pulse_min_accel(p, eta, 100.0), G * eta, rtol=EXACT_RTOL)
    # Short pulse: the impulse a_p t_p -> g eta / p (first-order error p t_p / 2).
    t_p = 1e-7
    _close(rel.rectangular_pulse_min_accel(p, eta, t_p) * t_p, G * eta / p, rtol=IMPULSE_RTOL)


def test_uplift_acceleration_is_g_b_over_h():
    # tan(atan(b/h)) = b/h: a block uplifts at g b / h.
    block = Block(b=0.25, h=3.0)
    _close(rel.uplift_acceleration(block), G * 0.25 / 3.0, rtol=EXACT_RTOL)
    _close(rel.uplift_acceleration(block.eta, g=9.81), 9.81 * 0.25 / 3.0, rtol=EXACT_RTOL)


def test_release_beyond_eta_is_an_error_also_under_jit_and_vmap():
    errors = (eqx.EquinoxRuntimeError, jax.errors.JaxRuntimeError)
    with pytest.raises(errors, match="theta0 must satisfy"):
        rel.free_rocking_period(2.0, 0.2, 0.25)
    with pytest.raises(errors, match="theta0 must satisfy"):
        eqx.filter_jit(rel.free_rocking_period)(2.0, 0.2, 0.2)
    with pytest.raises(errors, match="theta0 must satisfy"):
        jax.vmap(rel.amplitude_after_impacts, in_axes=(0, None, None, None))(
            jnp.array([0.1, 0.3]), 0.2, 0.9, 1
        )


# ----------------------------------------------------------------------------- transforms


def test_grad_e_housner():
    # d/d eta (1 - 1.5 sin^2 eta) = -3 sin(eta) cos(eta).
    for eta in (0.05, 0.2, 0.4):
        _close(jax.grad(rel.e_housner)(eta), -3.0 * math.sin(eta) * math.cos(eta), rtol=EXACT_RTOL)


def test_grad_matches_central_differences():
    def fd(f, x):
        step = FD_STEP * max(1.0, abs(x))
        return (f(x + step) - f(x - step)) / (2.0 * step)

    cases = [
        (lambda th: rel.free_rocking_period(2.0, 0.2, th), 0.1),
        (lambda e: rel.amplitude_after_impacts(0.1, 0.2, e, 3), 0.9),
        (lambda E: rel.beta_isr_from(0.11, 2.4, E), 1800.0),
        (lambda E: rel.beta_dejong(Block(b=0.25, h=3.0, E=E)), 1.8e9),
        (rel.e_isr, 0.3),
    ]
    for f, x in cases:
        _close(jax.grad(f)(x), float(fd(f, x)), rtol=FD_RTOL)


def test_grad_beta_dejong_wrt_E_analytic():
    # beta = 2/sqrt(E b^2/(m h)) ~ E^(-1/2): d beta / dE = -beta / (2 E).
    E = 1.8e9
    grad = jax.grad(lambda E: rel.beta_dejong(Block(b=0.25, h=3.0, E=E)))(E)
    _close(grad, -0.012 / (2.0 * E), rtol=EXACT_RTOL)


def test_vmap_equals_loop():
    eta = jnp.linspace(0.05, 0.5, 7)
    for f in (rel.e_housner, rel.e_isr, rel.uplift_acceleration):
        _close(jax.vmap(f)(eta), [float(f(x)) for x in eta], rtol=EXACT_RTOL)
    blocks = [Block(b=b, h=h) for b, h in [(0.11, 2.4), (0.3, 3.0), (0.25, 1.5)]]
    stacked = jax.tree.map(lambda *xs: jnp.asarray(xs), *blocks)
    for f in (rel.omega_crit, rel.beta_isr, rel.beta_hcrit):
        _close(jax.vmap(f)(stacked), [float(f(b)) for b in blocks], rtol=EXACT_RTOL)


def test_jit_equals_eager():
    block = Block(b=0.11, h=2.4)
    for f in (rel.beta_isr, rel.beta_dejong, rel.beta_hcrit, rel.e_isr):
        _close(eqx.filter_jit(f)(block), f(block), rtol=EXACT_RTOL)
    args = (2.0, 0.2, 0.13)
    _close(jax.jit(rel.free_rocking_period)(*args), rel.free_rocking_period(*args), rtol=EXACT_RTOL)


# ----------------------------------------------------------------------------- API


def test_required_names_exist():
    # rockjax/__init__.py imports these.
    for name in (
        "beta_dejong",
        "beta_hcrit",
        "beta_isr",
        "e_housner",
        "e_isr",
        "omega_crit",
        "omega_hcrit",
    ):
        assert callable(getattr(rel, name))
    # Eq. (6) is re-exported, not duplicated.
    assert rel.e_exp is response_e_exp


def test_every_public_function_is_documented():
    functions = [getattr(rel, name) for name in rel.__all__ if callable(getattr(rel, name))]
    assert len(functions) >= 19
    for f in functions:
        doc = inspect.getdoc(f)
        assert doc, f"{f.__name__} has no docstring"
        for param in inspect.signature(f).parameters:
            assert param in doc, f"{f.__name__}: argument {param!r} is not documented"
