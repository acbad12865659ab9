"""The paper's closed forms (Eqs. 1-7) and the classic linearised Housner results.

Every function is pure ``jax.numpy``: it works elementwise on broadcastable arrays and under
``jit``, ``vmap`` and ``grad``. Functions that depend only on the slenderness accept either a
:class:`~rockjax.Block` or the angle ``eta`` [rad] itself.

Notation follows the paper: ``eta = atan(b/h)`` is the slenderness angle (the classic texts'
alpha); ``alpha`` and ``beta`` are only the Rayleigh coefficients of Eq. (1).

References:
    "Seismic rocking simulation of unreinforced masonry parapets and facades using the
    discrete element method" (the paper; Eqs. 1-7 are numbered as there).
    Housner, G. W. (1963), BSSA 53(2):403-417.
    DeJong, M. J. (2009), PhD thesis, MIT.
    Sorrentino, L., AlShawa, O., Decanini, L. D. (2011), Bull. Earthq. Eng. 9:1617-1642.
"""

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float, Real

from .block import Block
from .constants import MPA, G
from .response import e_exp as e_exp

_In = Real[ArrayLike, "..."]
_Out = Float[Array, "..."]
_BlockOrEta = Block | Real[ArrayLike, "..."]

# Eq. (4): fitted exponent of h/b in x = y (h/b)^(-0.37).
X_EXPONENT = -0.37

__all__ = [
    "X_EXPONENT",
    "amplitude_after_impacts",
    "beta_dejong",
    "beta_from_e",
    "beta_from_zeta",
    "beta_hcrit",
    "beta_isr",
    "beta_isr_from",
    "e_exp",
    "e_from_beta",
    "e_housner",
    "e_isr",
    "free_rocking_period",
    "omega_crit",
    "omega_hcrit",
    "rayleigh_zeta",
    "rectangular_pulse_min_accel",
    "rocking_energy",
    "uplift_acceleration",
    "x_from_y",
]


def _eta_of(block_or_eta: _BlockOrEta) -> Float[Array, "..."]:
    if hasattr(block_or_eta, "eta"):
        return jnp.asarray(block_or_eta.eta, dtype=float)
    return jnp.asarray(block_or_eta, dtype=float)


def _f(x: _In) -> Float[Array, "..."]:
    # Python ints would otherwise stay integer arrays; every closed form here is real-valued.
    return jnp.asarray(x, dtype=float)


def _check_release(theta0: Float[Array, "..."], eta: Float[Array, "..."]) -> Float[Array, "..."]:
    theta0 = jnp.abs(theta0)
    return eqx.error_if(
        theta0,
        theta0 >= eta,
        "theta0 must satisfy |theta0| < eta (a block released at or beyond eta overturns); "
        "give a smaller release rotation in radians.",
    )


# --------------------------------------------------------------------------- Eq. (1)


def rayleigh_zeta(omega: _In, alpha: _In = 0.0, beta: _In = 0.0) -> _Out:
    r"""Rayleigh damping ratio at a circular frequency, Eq. (1).

    $$\zeta_n = \frac{\alpha}{2\omega_n} + \frac{\beta\,\omega_n}{2}$$

    Args:
        omega: Circular frequency ``omega_n`` [rad/s], Eq. (1).
        alpha: Mass-proportional Rayleigh coefficient [1/s], Eq. (1); 0 in the paper.
        beta: Stiffness-proportional Rayleigh coefficient [s], Eq. (1).

    Returns:
        The damping ratio ``zeta_n`` [-].
    """
    omega = _f(omega)
    return _f(alpha) / (2.0 * omega) + _f(beta) * omega / 2.0


def beta_from_zeta(zeta: _In, omega: _In) -> _Out:
    r"""Stiffness-proportional coefficient giving a damping ratio at one frequency, Eq. (1).

    Eq. (1) with ``alpha = 0`` (the paper's stiffness-proportional damping):

    $$\beta = \frac{2\,\zeta_n}{\omega_n}$$

    Args:
        zeta: Target damping ratio ``zeta_n`` [-], Eq. (1).
        omega: Circular frequency ``omega_n`` at which it applies [rad/s], Eq. (1).

    Returns:
        ``beta`` [s].
    """
    return 2.0 * _f(zeta) / _f(omega)


# --------------------------------------------------------------------------- Eqs. (2), (5)


def e_housner(block_or_eta: _BlockOrEta) -> _Out:
    r"""Housner's coefficient of restitution of a two-sided rocking block, Eq. (2).

    $$e_H = 1 - \tfrac{3}{2}\sin^2\eta$$

    From conservation of angular momentum about the new pivot for a homogeneous rectangle.

    Args:
        block_or_eta: A ``Block``, or the slenderness angle ``eta = atan(b/h)`` [rad], Eq. (2).

    Returns:
        ``e_H`` [-]: the ratio of angular velocities after / before an impact.

    References:
        Housner (1963), BSSA 53(2):403-417.
    """
    eta = _eta_of(block_or_eta)
    return 1.0 - 1.5 * jnp.sin(eta) ** 2


def e_isr(block_or_eta: _BlockOrEta) -> _Out:
    r"""Coefficient of restitution of a one-sided rocking facade (1SR), Eq. (5).

    $$e_{1SR} = \left(1 - \tfrac{3}{2}\sin^2\eta\right)^2\left(1 - \tfrac{3}{2}\cos^2\eta\right)$$

    The value is returned as written, with its sign: it is **negative** for every block with
    ``eta < arccos(sqrt(2/3))`` (about 35 degrees, i.e. all walls), because its last factor
    is. A one-sided rebound keeps ``theta >= 0``, so a simulator should use the magnitude
    ``|e_1SR|`` as the ratio of angular-velocity magnitudes after / before the impact.

    Args:
        block_or_eta: A ``Block``, or the slenderness angle ``eta = atan(b/h)`` [rad], Eq. (5).

    Returns:
        ``e_1SR`` [-] (signed; see above).

    References:
        Sorrentino, AlShawa, Decanini (2011), Bull. Earthq. Eng. 9:1617-1642; the paper, Eq. (5).
    """
    eta = _eta_of(block_or_eta)
    s2 = jnp.sin(eta) ** 2
    c2 = jnp.cos(eta) ** 2
    return (1.0 - 1.5 * s2) ** 2 * (1.0 - 1.5 * c2)


# --------------------------------------------------------------------------- Eqs. (3), (4)


def e_from_beta(beta: _In, x: _In, e0: _In) -> _Out:
    r"""Equivalent coefficient of restitution of a DEM block with damping ``beta``, Eq. (3).

    $$e = e_H - x\,\beta$$

    Args:
        beta: Stiffness-proportional Rayleigh coefficient [s], Eq. (1).
        x: Slope of the fitted line [1/s], Eq. (3); from ``x_from_y``, Eq. (4).
        e0: Intercept at ``beta = 0`` [-], Eq. (3); the paper uses ``e_H`` of Eq. (2).

    Returns:
        ``e`` [-].
    """
    return _f(e0) - _f(x) * _f(beta)


def beta_from_e(e: _In, x: _In, e0: _In) -> _Out:
    r"""Stiffness-proportional ``beta`` that reproduces a coefficient of restitution, Eq. (3).

    $$\beta = \frac{e_H - e}{x}$$

    The inverse of ``e_from_beta``.

    Args:
        e: Target coefficient of restitution [-], Eq. (3).
        x: Slope of the fitted line [1/s], Eq. (3); from ``x_from_y``, Eq. (4).
        e0: Intercept at ``beta = 0`` [-], Eq. (3); the paper uses ``e_H`` of Eq. (2).

    Returns:
        ``beta`` [s].
    """
    return (_f(e0) - _f(e)) / _f(x)


def x_from_y(y: _In, h_over_b: _In, exponent: _In = X_EXPONENT) -> _Out:
    r"""Slope ``x`` of Eq. (3) from the thickness-dependent factor ``y``, Eq. (4).

    $$x = y\left(\frac{h}{b}\right)^{-0.37}$$

    Args:
        y: Fitting factor [1/s], Eq. (4); read from the paper's Fig. 2B for the thickness ``b``.
        h_over_b: Aspect ratio ``h/b`` [-], Eq. (4).
        exponent: Exponent of ``h/b`` [-], Eq. (4); the paper's fit is -0.37.

    Returns:
        ``x`` [1/s].
    """
    return _f(y) * _f(h_over_b) ** _f(exponent)


# --------------------------------------------------------------------------- Eq. (7)


def beta_isr_from(b: _In, h: _In, E_mpa: _In) -> _Out:
    r"""Stiffness-proportional ``beta`` for a one-sided rocking facade, Eq. (7).

    $$\beta_{1SR} = \left(\frac{b}{384} - \frac{E}{5.6\times10^6} + 0.00074\right)
      \exp\!\left(\frac{h}{b}\cdot\frac{-E + 6572}{1.2\times10^5}\right)$$

    An empirical fit: ``b`` must be in metres and ``E`` in **MPa** (fitted for
    ``b = 0.11, 0.30`` m and ``E = 1800, 4050`` MPa).

    Args:
        b: Full thickness [m], Eq. (7).
        h: Full height [m], Eq. (7).
        E_mpa: Young's modulus [MPa], Eq. (7).

    Returns:
        ``beta_1SR`` [s].
    """
    b, h, E_mpa = _f(b), _f(h), _f(E_mpa)
    # The coefficients 384, 5.6e6, 0.00074, 6572 and 1.2e5 are the paper's fit (Fig. 5B).
    return (b / 384.0 - E_mpa / 5.6e6 + 0.00074) * jnp.exp((h / b) * (-E_mpa + 6572.0) / 1.2e5)


def beta_isr(block: Block) -> _Out:
    r"""Stiffness-proportional ``beta`` for a one-sided rocking facade ``block``, Eq. (7).

    ``beta_isr_from(block.b, block.h, block.E / 1e6)``: converts ``block.E`` from Pa to the
    MPa that the fit takes.

    Args:
        block: The facade; uses ``b`` [m], ``h`` [m] and ``E`` [Pa], Eq. (7).

    Returns:
        ``beta_1SR`` [s].
    """
    return beta_isr_from(block.b, block.h, _f(block.E) / MPA)


# --------------------------------------------------------------------------- DeJong omega_crit


def omega_crit(block: Block) -> _Out:
    r"""DeJong's impact frequency of a block on the ground, the paper's ``omega_crit``.

    $$\omega_{crit} = \sqrt{\frac{E\,b^2}{m\,h}}$$

    with ``m = rho b h`` the mass per unit out-of-plane length (``block.m_per_length``), as in
    the paper. The expression is evaluated numerically in SI units, exactly as the paper does
    (with ``m`` per unit length it is not dimensionally homogeneous; keep the inputs in SI).

    Args:
        block: The block; uses ``E`` [Pa], ``b`` [m], ``h`` [m] and ``rho`` [kg/m^3].

    Returns:
        ``omega_crit`` [rad/s].

    References:
        DeJong (2009), PhD thesis, MIT; the paper, Sect. 2.1.
    """
    E, b, h = _f(block.E), _f(block.b), _f(block.h)
    return jnp.sqrt(E * b**2 / (_f(block.m_per_length) * h))


def beta_dejong(block: Block) -> _Out:
    r"""DeJong's ``beta``: critical damping at ``omega_crit``, from Eq. (1).

    Eq. (1) with ``zeta_n = 1`` and ``alpha = 0`` at ``omega_n = omega_crit``:

    $$\beta = \frac{2}{\omega_{crit}}$$

    Args:
        block: The block; see ``omega_crit``.

    Returns:
        ``beta`` [s].
    """
    return beta_from_zeta(1.0, omega_crit(block))


def omega_hcrit(block: Block) -> _Out:
    r"""Impact frequency of a facade against its return walls, the paper's ``omega_Hcrit``.

    $$\omega_{Hcrit} = \sqrt{\frac{2\,E\,h^2}{m\,b}}$$

    DeJong's ``omega_crit`` for horizontally stacked blocks (``h`` and ``b`` swapped, times
    ``sqrt(2)``), with ``m = rho b h`` per unit out-of-plane length (``block.m_per_length``).

    Args:
        block: The facade; uses ``E`` [Pa], ``b`` [m], ``h`` [m] and ``rho`` [kg/m^3].

    Returns:
        ``omega_Hcrit`` [rad/s].

    References:
        The paper, Sect. 2.2.
    """
    E, b, h = _f(block.E), _f(block.b), _f(block.h)
    return jnp.sqrt(2.0 * E * h**2 / (_f(block.m_per_length) * b))


def beta_hcrit(block: Block) -> _Out:
    r"""``beta`` critically damping ``omega_Hcrit``, from Eq. (1): the lower bound for facades.

    $$\beta = \frac{2}{\omega_{Hcrit}}$$

    Args:
        block: The facade; see ``omega_hcrit``.

    Returns:
        ``beta`` [s].
    """
    return beta_from_zeta(1.0, omega_hcrit(block))


# --------------------------------------------------------------------------- Housner (1963)


def rocking_energy(theta: _In, eta: _In) -> _Out:
    r"""Potential energy of a rocking block over ``m g R``.

    $$\frac{V(\theta)}{m g R} = \cos(\eta - |\theta|) - \cos\eta$$

    Zero at rest; ``1 - cos(eta)`` at the overturning limit ``|theta| = eta``.

    Args:
        theta: Rotation [rad].
        eta: Slenderness angle ``atan(b/h)`` [rad], Eq. (2).

    Returns:
        ``V / (m g R)`` [-].

    References:
        Housner (1963), BSSA 53(2):403-417.
    """
    eta = _f(eta)
    return jnp.cos(eta - jnp.abs(_f(theta))) - jnp.cos(eta)


def free_rocking_period(p: _In, eta: _In, theta0: _In) -> _Out:
    r"""Full period of linearised free rocking released from rest at ``theta0``.

    $$T = \frac{4}{p}\cosh^{-1}\!\left(\frac{1}{1 - |\theta_0|/\eta}\right)$$

    Small-angle (``O(eta^2)``) solution of Housner's equation, with no energy loss; the period
    grows with amplitude and tends to infinity as ``|theta0| -> eta``.

    Args:
        p: Frequency parameter ``sqrt(3 g / (4 R))`` [rad/s] (``block.p``).
        eta: Slenderness angle ``atan(b/h)`` [rad], Eq. (2).
        theta0: Release rotation [rad], ``|theta0| < eta``.

    Returns:
        ``T`` [s].

    Raises:
        EquinoxRuntimeError: If ``|theta0| >= eta`` (checked in-graph, also under jit).

    References:
        Housner (1963), BSSA 53(2):403-417.
    """
    eta = _f(eta)
    theta0 = _check_release(_f(theta0), eta)
    return 4.0 / _f(p) * jnp.arccosh(1.0 / (1.0 - theta0 / eta))


def amplitude_after_impacts(theta0: _In, eta: _In, e: _In, n: _In) -> _Out:
    r"""Peak rotation after ``n`` impacts of linearised free rocking.

    $$\frac{\theta_n}{\eta} = 1 - \sqrt{1 - e^{2n}\left[1 - \left(1 - \frac{|\theta_0|}{\eta}
      \right)^2\right]}$$

    Each impact multiplies the angular velocity by ``e``; this is the forward form of
    Eq. (6), so ``e_exp(amplitude_after_impacts(theta0, eta, e, n), theta0, eta, n) == e``.

    Args:
        theta0: Release rotation, from rest [rad], ``|theta0| < eta``.
        eta: Slenderness angle ``atan(b/h)`` [rad], Eq. (2).
        e: Coefficient of restitution [-], e.g. ``e_housner``, Eq. (2).
        n: Number of impacts (0, 1, 2, ...) [-], Eq. (6).

    Returns:
        ``|theta_n|`` [rad].

    Raises:
        EquinoxRuntimeError: If ``|theta0| >= eta`` (checked in-graph, also under jit).

    References:
        Housner (1963), BSSA 53(2):403-417; the paper, Eq. (6).
    """
    eta = _f(eta)
    theta0 = _check_release(_f(theta0), eta)
    energy0 = 1.0 - (1.0 - theta0 / eta) ** 2
    # (e^2)^n rather than e^(2n): stays real and differentiable for a signed e (e.g. e_isr).
    return eta * (1.0 - jnp.sqrt(1.0 - (_f(e) ** 2) ** _f(n) * energy0))


def rectangular_pulse_min_accel(p: _In, eta: _In, t_p: _In, g: _In = G) -> _Out:
    r"""Least rectangular-pulse acceleration that overturns a block at rest (linearised).

    $$a_p = \frac{g\,\eta}{1 - e^{-p\,t_p}}$$

    A constant ground acceleration ``a_p`` lasting ``t_p``; for ``t_p -> inf`` it tends to the
    linearised uplift threshold ``g eta``, for ``t_p -> 0`` to the impulse ``a_p t_p = g eta/p``.
    The nonlinear equation of motion gives slightly different values of
    ``psi = a_p / (g tan(eta))``: for ``eta = 0.2``, ``R = 1`` m and
    ``p t_p = 0.25, 0.5, 1, 2, 3``, ``psi = 4.53476, 2.54595, 1.58234, 1.15575, 1.05177``
    against the linearised ``a_p / (g eta) = 4.52081, 2.54149, 1.58198, 1.15652, 1.05240``.

    Args:
        p: Frequency parameter ``sqrt(3 g / (4 R))`` [rad/s] (``block.p``).
        eta: Slenderness angle ``atan(b/h)`` [rad], Eq. (2).
        t_p: Pulse duration [s].
        g: Gravitational acceleration [m/s^2].

    Returns:
        ``a_p`` [m/s^2] (a magnitude; the pulse may act in either direction).

    References:
        Housner (1963), BSSA 53(2):403-417.
    """
    return _f(g) * _f(eta) / -jnp.expm1(-_f(p) * _f(t_p))


def uplift_acceleration(block_or_eta: _BlockOrEta, g: _In = G) -> _Out:
    r"""Ground acceleration at which a block at rest starts to rock.

    $$a_{uplift} = g\tan\eta$$

    Args:
        block_or_eta: A ``Block``, or the slenderness angle ``eta = atan(b/h)`` [rad], Eq. (2).
        g: Gravitational acceleration [m/s^2].

    Returns:
        ``a_uplift`` [m/s^2] (a magnitude).

    References:
        Housner (1963), BSSA 53(2):403-417.
    """
    return _f(g) * jnp.tan(_eta_of(block_or_eta))
