"""Cubic Hermite fits on one solver step: their values and derivatives (``hermite``), the
turning point of a graze (``hermite_turn``) and the first root (``hermite_root``: bisection,
then Newton steps that carry the implicit-function derivative of the crossing time)."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from ._lax import clip, safe, where

_N_BISECT = 6  # brackets the Hermite root to 1/64 of the step before Newton polishes it


_N_NEWTON = 3  # from within 1/128, three Newton steps reach ~1e-8 of the step even when sharp


def hermite(r, terms):
    """The cubic Hermite interpolant of ``terms = (p0, m0, p1, m1)`` (values at ``r = 0, 1``
    and slopes in ``r``) and its first two derivatives in ``r``, at ``r``. A Python float
    ``r`` drops the terms whose weight is zero (a table of whole arrays costs less)."""
    r2, r3 = r * r, r * r * r
    weights = (
        (2 * r3 - 3 * r2 + 1, r3 - 2 * r2 + r, 3 * r2 - 2 * r3, r3 - r2),
        (6 * r2 - 6 * r, 3 * r2 - 4 * r + 1, 6 * r - 6 * r2, 3 * r2 - 2 * r),
        (12 * r - 6, 6 * r - 4, 6 - 12 * r, 6 * r - 2),
    )

    def combine(ws):
        if not isinstance(r, float):
            return sum(w * x for w, x in zip(ws, terms))
        return sum(x if w == 1.0 else w * x for w, x in zip(ws, terms) if w != 0.0)

    return tuple(combine(ws) for ws in weights)


def hermite_coefficients(u0, du0, u1, du1):
    """``(c1, c2, c3)`` of the cubic Hermite fit ``u0 + c1 x + c2 x^2 + c3 x^3`` on [0, 1]."""
    c1 = du0
    c2 = 3.0 * (u1 - u0) - 2.0 * du0 - du1
    c3 = 2.0 * (u0 - u1) + du0 + du1
    return c1, c2, c3


def hermite_turn(u0, du0, u1, du1):
    """Turning point ``x`` in [0, 1] of the cubic Hermite fit where ``du0 < 0 < du1``, and
    ``u`` there: a step that ends on the side it started can have crossed zero and returned
    (a graze). No gradient: it only brackets the root (``hermite_root`` carries it)."""
    u0, du0, u1, du1 = (jax.lax.stop_gradient(v) for v in (u0, du0, u1, du1))
    c1, c2, c3 = hermite_coefficients(u0, du0, u1, du1)
    # u'(x) = c1 + 2 c2 x + 3 c3 x^2 has exactly one root in (0, 1) when c1 < 0 < u'(1).
    a, b = 3.0 * c3, 2.0 * c2
    disc = jnp.maximum(b * b - 4.0 * a * c1, 0.0)
    q = -0.5 * (b + where(b >= 0, 1.0, -1.0) * jnp.sqrt(disc))
    x_small = c1 / safe(q)  # the root of smaller magnitude (stable form)
    x_big = q / safe(a)
    x = where((x_small >= 0) & (x_small <= 1), x_small, x_big)
    x = clip(x, 0.0, 1.0)
    turns = (du0 < 0) & (du1 > 0)
    u_turn = ((c3 * x + c2) * x + c1) * x + u0
    return where(turns, x, 1.0), where(turns, u_turn, u1)


def hermite_root(u0, du0, u1, du1, xb):
    """First root ``x`` in [0, xb] of the cubic Hermite fit of ``u`` with ``u(0) = u0 >= 0`` and
    ``u(xb) < 0`` (``xb = 1``, or the turning point of a graze).

    ``du0``, ``du1`` are the end slopes in the unit variable (``h u'``). Bisection on the sign
    brackets the root to ``2^-_N_BISECT`` of ``xb`` (robust when ``u0 = 0``, right after an
    impact or an uplift), then Newton polishes it from the bracket's midpoint or, in the
    first sub-bracket, from the first positive root of the fit's quadratic part (a chatter
    flight can be far shorter than the bracket, where Newton from the midpoint would only
    halve its distance per iteration); the Newton steps carry the implicit-function
    derivative for ``grad``.
    """
    c1, c2, c3 = hermite_coefficients(u0, du0, u1, du1)

    def cubic(x):
        return ((c3 * x + c2) * x + c1) * x + u0

    # The bracket carries no derivative: bisect on constants (nothing to trace under jvp).
    a0, a1, a2, a3 = (jax.lax.stop_gradient(v) for v in (u0, c1, c2, c3))
    lo = jnp.zeros_like(a0)
    hi = jnp.broadcast_to(jax.lax.stop_gradient(xb), jnp.shape(a0)).astype(a0.dtype)
    for _ in range(_N_BISECT):
        mid = 0.5 * (lo + hi)
        pos = ((a3 * mid + a2) * mid + a1) * mid + a0 > 0
        lo, hi = where(pos, mid, lo), where(pos, hi, mid)
    # Roots of u0 + c1 x + c2 x^2 in the stable form: u0 / q and q / c2.
    q = -0.5 * (a1 + where(a1 >= 0, 1.0, -1.0) * jnp.sqrt(jnp.maximum(a1 * a1 - 4 * a2 * a0, 0)))
    r1, r2 = a0 / safe(q), q / safe(a2)
    r1 = where((r1 > 0) & (r1 <= hi), r1, jnp.inf)
    r2 = where((r2 > 0) & (r2 <= hi), r2, jnp.inf)
    guess = jnp.minimum(r1, r2)
    x = where((lo == 0) & jnp.isfinite(guess), guess, 0.5 * (lo + hi))
    for _ in range(_N_NEWTON):
        slope = (3.0 * c3 * x + 2.0 * c2) * x + c1
        x = clip(x - cubic(x) / safe(slope), lo, hi)
    return x
