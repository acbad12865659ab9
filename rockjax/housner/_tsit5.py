"""The fixed-step Tsit5 step of the Housner solver: Tsitouras' 5(4) tableau and dense output,
one unrolled step (``rk_step``), the largest ``|theta|`` on a step's dense output
(``dense_peak``) and the step behind a ``cond`` that a whole batch may skip (``flight``).

Peaks between samples: ``theta_max`` is the largest ``|theta|`` of every flight's Tsit5 dense
output (Tsitouras' quartic interpolant of the step from its seven stage slopes, the last being
the end's ``theta_dot``; ``dense_peak``), so a turning point inside a step, and a whole flight
shorter than a step (just above the uplift threshold), counts at the solver's own accuracy. The
interpolant is sampled at five points and its turning point found by Newton steps on its slope
from the best; the turning point's location carries no derivative (the slope is zero there),
so ``grad`` of ``theta_max`` is that of the interpolant's value.
"""

from __future__ import annotations

import functools

import equinox.internal as eqxi
import jax
import jax.numpy as jnp
import numpy as np

from ._lax import clip, cond, safe, where

# Tsitouras' 5(4) pair (Tsit5; docs/verification.md, "Tsit5 tableau"),
# the numbers diffrax's Tsit5 tableau holds (tests/test_housner.py checks them bit for bit;
# written here so that tracing the solver does not import diffrax, about 0.5 s). Tsit5 is
# "ssal": stages 1-6 give y1, its 7th stage only serves FSAL and the error estimate.
_TSIT5_C = (0.0, 0.161, 0.327, 0.9, 0.9800255409045097, 1.0)


_TSIT5_A = (
    (0.161,),
    (-0.008480655492356989, 0.335480655492357),
    (2.8971530571054935, -6.359448489975075, 4.3622954328695815),
    (5.325864828439257, -11.748883564062828, 7.4955393428898365, -0.09249506636175525),
    (
        5.86145544294642,
        -12.92096931784711,
        8.159367898576159,
        -0.071584973281401,
        -0.028269050394068383,
    ),
)


_TSIT5_B = (
    0.09646076681806523,
    0.01,
    0.4798896504144996,
    1.379008574103742,
    -3.290069515436081,
    2.324710524099774,
)


@functools.cache
def tsit5_tableau():
    """``(A, C, B)`` of the Tsit5 tableau: ``A[i]`` weighs the slopes of stages 0..i-1 for
    stage i, ``C[i]`` is its time, ``B`` gives y1."""
    a = np.zeros((6, 6))
    for i, row in enumerate(_TSIT5_A):
        a[i + 1, : len(row)] = row
    return a, np.asarray(_TSIT5_C), np.asarray(_TSIT5_B)


@functools.cache
def tsit5_dense():
    """``(7, 4)``: the coefficients of ``x, x^2, x^3, x^4`` in the weights ``b_i(x)`` of Tsit5's
    dense output ``y(t0 + x h) = y0 + h sum_i b_i(x) f_i`` over the step's seven stage slopes
    (the 7th is the slope at the step's end, ``f(t1, y1)``). The polynomials are Tsitouras'
    (2011) as diffrax's Tsit5 interpolation holds them; ``b_i(1)`` are the weights ``B`` and the
    fit matches the end slopes, so it joins the steps with a continuous derivative."""
    x = np.polynomial.Polynomial([0.0, 1.0])
    weights = (
        -1.0530884977290216
        * x
        * (x - 1.3299890189751412)
        * (x**2 - 1.4364028541716351 * x + 0.7139816917074209),
        0.1017 * x**2 * (x**2 - 2.1966568338249754 * x + 1.2949852507374631),
        2.490627285651252793 * x**2 * (x**2 - 2.38535645472061657 * x + 1.57803468208092486),
        -16.54810288924490272 * (x - 1.21712927295533244) * (x - 0.61620406037800089) * x**2,
        47.37952196281928122 * (x - 1.203071208372362603) * (x - 0.658047292653547382) * x**2,
        -34.87065786149660974 * (x - 1.2) * (x - 0.666666666666666667) * x**2,
        2.5 * (x - 1) * (x - 0.6) * x**2,
    )
    return np.array([np.pad(w.coef, (0, 5 - w.coef.size))[1:] for w in weights])


_N_PEAK_NEWTON = 3  # a turning point from the best of five samples of the step's dense output


def rk_step(accel, t0, h, theta0, theta_dot0):
    """One explicit Runge-Kutta step (diffrax's Tsit5 tableau, unrolled) of
    ``(theta, theta_dot)' = (theta_dot, accel(t, theta))`` from ``t0`` over ``h`` [s].

    Returns:
        ``(theta1, theta_dot1, peak)``: the state at ``t0 + h`` and the largest ``|theta|``
        [rad] of the step's dense output (:func:`dense_peak`).
    """
    k_th, k_thd = [], []  # stage slopes of theta (the stage theta_dot) and of theta_dot
    tab_a, tab_c, tab_b = tsit5_tableau()
    for a_i, c_i in zip(tab_a, tab_c):
        theta = theta0 + h * sum(float(a) * k for a, k in zip(a_i, k_th))
        theta_dot = theta_dot0 + h * sum(float(a) * k for a, k in zip(a_i, k_thd))
        k_th.append(theta_dot)
        k_thd.append(accel(t0 + float(c_i) * h, theta))
    theta1 = theta0 + h * sum(float(b) * k for b, k in zip(tab_b, k_th))
    theta_dot1 = theta_dot0 + h * sum(float(b) * k for b, k in zip(tab_b, k_thd))
    # theta's 7th (FSAL) stage slope is theta_dot1: the dense output needs no more accel calls
    return theta1, theta_dot1, dense_peak(theta0, theta1, h, (*k_th, theta_dot1))


def dense_peak(theta0, theta1, h, k_th):
    """Largest ``|theta|`` [rad] on one Tsit5 step of length ``h`` [s] from ``theta0`` to
    ``theta1``, on the step's dense output ``P(x) = theta0 + c1 x + c2 x^2 + c3 x^3 + c4 x^4``
    (:func:`tsit5_dense`, ``x = (t - t0) / h``; ``k_th``: the seven stage slopes of theta).

    ``|P|`` is sampled at ``x = 0, 1/4, 1/2, 3/4, 1``; Newton steps on ``P' = 0`` from the best
    sample, kept within a quarter of it and taken only toward a maximum of ``|P|`` (``P''`` of
    the sign opposite to ``P`` at the best sample), find the turning point. The location
    carries no derivative: at a turning point ``P' = 0``, so the peak's derivative is ``P``'s
    at fixed ``x`` (and at an end, the end state's), which is what ``grad`` gets.
    """
    dense = tsit5_dense()
    c1, c2, c3, c4 = (
        h * sum(float(w) * k for w, k in zip(dense[:, j], k_th) if w != 0.0) for j in range(4)
    )

    def value(x, c1=c1, c2=c2, c3=c3, c4=c4):
        return (((c4 * x + c3) * x + c2) * x + c1) * x + theta0

    best_x, best_p = jnp.zeros_like(theta0), theta0
    for x in (0.25, 0.5, 0.75, 1.0):
        p = theta1 if x == 1.0 else value(x)
        better = jnp.abs(p) > jnp.abs(best_p)
        best_x, best_p = where(better, x, best_x), where(better, p, best_p)
    # P' and P'' (no derivative: the location only)
    a1, a2, a3, a4 = (jax.lax.stop_gradient(v) for v in (c1, 2.0 * c2, 3.0 * c3, 4.0 * c4))
    b2, b3 = 3.0 * a4, 2.0 * a3
    sign = where(best_p < 0, -1.0, 1.0)
    lo, hi = jnp.maximum(best_x - 0.25, 0.0), jnp.minimum(best_x + 0.25, 1.0)
    x = best_x
    for _ in range(_N_PEAK_NEWTON):
        dp = ((a4 * x + a3) * x + a2) * x + a1
        ddp = (b2 * x + b3) * x + a2
        x = where(sign * ddp < 0, clip(x - dp / safe(ddp), lo, hi), x)
    return jnp.maximum(jnp.abs(best_p), jnp.abs(value(x)))


def flight(pred, accel, t0, h, theta0, theta_dot0):
    """``rk_step`` where ``pred`` (one bool for the whole batch) holds, else the start state
    (and ``|theta0|`` as the peak).

    The ``cond`` skips steps that no record of a ``vmap`` batch needs (``pred`` is reduced with
    ``unvmap_any``, as diffrax does for its FSAL stage). It also keeps the unrolled stages one
    XLA computation: inlined, XLA's CPU fusion copied them into every consumer of the result
    and a step ran three times slower.
    """
    return cond(
        eqxi.unvmap_any(pred),
        lambda: rk_step(accel, t0, h, theta0, theta_dot0),
        lambda: (theta0, theta_dot0, jnp.abs(theta0)),
    )
