"""The Housner vector field: the angular acceleration on a pivot (``theta_ddot``), rigid or
with a three-branch restoring moment, the restoring accelerations at ``theta = 0`` (``restoring``) and a block's
excess over a moving wall (``wall_excess``).

Speed (see ``benchmarks/bench_housner.py``): ``sin``/``cos`` are Taylor polynomials
(``sincos``), three times cheaper than XLA's float64 ones on CPU, where they dominated.
"""

from __future__ import annotations

import functools
import math

import jax
import jax.numpy as jnp

from ._params import Params

# Taylor coefficients of sin(x)/x and cos(x) in x^2; see sincos.
_SIN = tuple((-1) ** k / math.factorial(2 * k + 1) for k in range(12))


_COS = tuple((-1) ** k / math.factorial(2 * k) for k in range(13))


# |x| [rad] up to which sincos(x, small=True) holds (truncation below x^11/11! < 3e-19).
SMALL_ANGLE = 0.1


@functools.partial(jax.custom_jvp, nondiff_argnums=(1,))
def sincos(x, small: bool):
    """``(sin x, cos x)`` from Taylor polynomials in ``x^2``: within 4e-16 for ``|x| <= 2`` rad,
    or with ``small`` (five and six terms) for ``|x| <= SMALL_ANGLE``.

    XLA's float64 sin and cos cost about 10 ns each per element on CPU and dominated the
    step; these polynomials cost a third of that. Rotations in use stay below
    ``eta + p dt_step < pi/2 + 0.4`` rad: past ``eta`` the block is flagged overturned and its
    state is frozen at the end of that step. The derivative is the exact one, ``(cos, -sin)``,
    not that of the polynomials (smaller graphs under ``grad``, quicker to compile).
    """
    sin_coefs, cos_coefs = (_SIN[:5], _COS[:6]) if small else (_SIN, _COS)
    x2 = x * x
    s, c = sin_coefs[-1], cos_coefs[-1]
    for coef in sin_coefs[-2::-1]:
        s = s * x2 + coef
    for coef in cos_coefs[-2::-1]:
        c = c * x2 + coef
    return x * s, c


@sincos.defjvp
def _sincos_jvp(small, primals, tangents):
    (x,), (dx,) = primals, tangents
    sin_x, cos_x = sincos(x, small)
    return (sin_x, cos_x), (cos_x * dx, -sin_x * dx)


@functools.partial(jax.jit, static_argnames="small")
def theta_ddot(t, theta, s, params: Params, forcing, small: bool = False):
    """Angular acceleration [rad/s^2] on pivot ``s = +-1`` (the equation of
    :mod:`rockjax.housner`'s docstring).

    Uses ``sin(s eta - theta)`` and ``cos(s eta - theta)`` expanded with ``s^2 = 1``, so each
    evaluation needs only the sine and cosine of ``theta``. Jitted although an inner helper:
    its seven calls in a pass then share one traced graph, which ``grad`` transforms once
    instead of seven times (a fifth of the time to trace; XLA inlines it, so runs are
    unchanged).
    """
    ag, g_eff = forcing.at(t)
    sin_th, cos_th = sincos(theta, small)
    s_sin_eta = s * params.sin_eta
    if params.law is None:
        return -params.p2_over_g * (
            cos_th * (g_eff * s_sin_eta + ag * params.cos_eta)
            + sin_th * (ag * s_sin_eta - g_eff * params.cos_eta)
        )
    # Three-branch law (docs/three_branch.md): with u = s theta and v = eta - u,
    # theta_ddot = -(p^2/g) [s g_eff (alpha cos v + beta sin v) + a_g cos v].
    alpha, beta = params.law.coefficients(s * theta)
    cos_v = params.cos_eta * cos_th + s_sin_eta * sin_th
    sin_v = params.sin_eta * cos_th - s * params.cos_eta * sin_th
    return -params.p2_over_g * (s * g_eff * (alpha * cos_v + beta * sin_v) + ag * cos_v)


def restoring(a_g, g_eff, params: Params):
    """``(A_+, A_-)`` [rad/s^2]: ``-s theta_ddot`` at ``theta = 0`` on pivot ``s = +-1``.

    From the equation of motion, ``A_s = (p^2 cos(eta) / g) (g_eff tan(eta) + s a_g)`` (with a
    three-branch law ``tan(eta)`` becomes its threshold ``lambda_uplift``): positive
    when the forcing is below the uplift threshold on that side, so a flight on pivot ``s`` that
    starts at ``theta = 0`` returns to it.
    """
    k = params.p2_over_g * params.cos_eta
    return k * (g_eff * params.lam_up + a_g), k * (g_eff * params.lam_up - a_g)


def wall_excess(t, wall, params: Params, forcing):
    """How much faster than the wall [m/s^2, as ``theta_ddot / k``, ``k = p^2 cos(eta) / g``]
    a block resting against it at ``theta = theta_w(t)`` would accelerate away from it on its
    own (pivot +1): it leaves the wall when this turns positive. Without wall motion it is
    ``-a_g - g_eff tan(eta)``, the fixed wall's uplift excess. ``wall``: the wall's
    ``(theta_w, theta_w', theta_w'')`` at ``t``."""
    theta_w, _, accel_w = wall
    free = theta_ddot(t, theta_w, jnp.ones_like(theta_w), params, forcing)
    return (free - accel_w) / (params.p2_over_g * params.cos_eta)
