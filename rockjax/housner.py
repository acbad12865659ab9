"""The Housner rocking model with impacts, solved in one ``diffrax.diffeqsolve``.

Model (Housner 1963). A rigid rectangle of half-diagonal ``R`` and slenderness ``eta`` rocks
on one bottom corner, the pivot ``s = +1`` (the +x corner, ``theta > 0``) or ``s = -1``. With
``I_O = 4/3 m R^2`` and ``p^2 = 3 g / (4 R)`` the equation of motion on pivot ``s`` is

    theta_ddot = -(p^2 / g) [g_eff sin(s eta - theta) + a_g cos(s eta - theta)],

with ``g_eff = g + a_gv`` (base accelerating up adds to gravity). For ``theta > 0`` this reads
``I_O theta_ddot = -m g R sin(eta - theta) - m a_g R cos(eta - theta)``: gravity restores and a
positive ``a_g`` (base accelerating toward +x) drives ``theta`` negative. The pivot is carried in
the state, not taken as ``sign(theta)``, so the vector field stays smooth through ``theta = 0``
and the continuation past a crossing is smooth, which makes the crossing time a clean root.

* Two-sided (parapet): when ``s theta`` reaches 0 the block impacts and switches corner,
  ``theta_dot -> e theta_dot``, ``s -> -s``; default ``e = e_H = 1 - 1.5 sin^2 eta``, Eq. (2).
* One-sided (facade, ``theta >= 0``, return wall at -x): at ``theta = 0`` moving inward it
  rebounds about the same corner, ``theta_dot -> -|e| theta_dot``; default ``|e_1sr|``, Eq. (5).
* Rest (``s = 0``): rocking starts at the exact time ``|a_g|`` exceeds ``g_eff tan(eta)``
  (two-sided; pivot ``-sign(a_g)``) or ``a_g < -g_eff tan(eta)`` (one-sided). Chatter (Zeno):
  after an impact the block is put to rest only if the rest of its impact sequence provably
  ends with the forcing below the uplift threshold on both sides, or if its rebound is too
  small to matter (a hop below ``REST_HOP = 1e-6`` of ``eta``) (``_rests``; derivation in
  docs/theory.md, "Housner rest and chatter rule"); otherwise the impacts go on being
  resolved one by one.
* Overturning: ``|theta| > eta`` while moving outward flags ``overturned`` and freezes the state.

Design. One fixed-step ``diffeqsolve`` (``StepTo`` on the record samples, each record step split
into ``n_sub`` equal steps) with a custom solver, ``_HousnerSolver``, whose ``step`` resolves the
impacts inside the step, so a record is one solve, not one solve per impact. The record reaches
the solver as a ``_Record`` (samples on a uniform grid, linear in between) in ``args``; each
step evaluates it at its two ends and uses the exact linear forcing in between. A step runs
passes in a while loop until every record of the batch has reached the step end (at most
``max_impacts_per_step + 1``), each: (1) if at rest, the uplift time from the linear forcing;
(2) a Tsit5 step (diffrax's tableau, unrolled) to the step end; (3) if ``s theta`` crossed
zero (it changed sign, or it dipped below zero and came back: a graze, seen as a turning point
of the step's cubic Hermite fit below zero), the first crossing time from that fit
(bisection, then Newton), a Tsit5 re-step to it, one Newton correction
``tau' = tau - theta/theta_dot`` on the true trajectory with the state advanced linearly to
``tau'``, the impact map and the rest rule; the next pass continues from ``tau'``. A step that
needs more passes is reported (``STATUS_UNRESOLVED``), never silently rested. The loop is an
``equinox.internal.while_loop`` of the kind the adjoint can differentiate. Per-record
branches are ``jnp.where`` selects, so batches of records, blocks and restitution coefficients
vectorise,
and ``grad``/``jvp`` go through the root-finding (the last Newton steps carry the
implicit-function derivative of the impact times). The Tsit5 steps sit in ``lax.cond`` on
whether any record of the batch needs them, so passes without an impact cost little (the
common case for one record). The discrete state (pivot, flags, impact count, last impact
time, running max ``|theta|``) rides along in ``y``; diffrax saves it at every step.

Step-size rule: the solver step is the output step divided by
``n_sub = ceil(p dt_out / P_DT_TARGET)``, i.e. ``p dt_step <= 0.1``: Tsit5's error per step is
then about ``(p dt_step)^6 ~ 1e-6`` of the motion. Typical records (``dt <= 0.02`` s) and
parapets (``p ~ 2-4`` rad/s) give ``n_sub = 1``. When the geometry is traced (``vmap`` over
``b``, ``h``), ``p`` is unknown at trace time: pass ``dt`` to bound the step, else
``n_sub = 1`` and ``p dt_step > P_DT_LIMIT`` is reported as ``STATUS_UNSTABLE``.

Speed (see ``benchmarks/bench_housner.py``): ``sin``/``cos`` are Taylor polynomials
(``_sincos``), three times cheaper than XLA's float64 ones on CPU, where they dominated.

Accuracy (docs/verification.md, "Housner"): on 20 s broadband records (a Kanai-Tajimi record
and FEMA P695 components, two- and one-sided, up to overturning) the default step gives the
peaks of an independent event-driven solver within 1.3e-4 relative (peaks >= 0.05 eta) and
the same overturning flags; halving the step changes nothing at that level.

Limitations: a step resolves at most ``max_impacts_per_step`` impacts (default 64); more are
reported, not resolved. A graze whose dip below zero the step's cubic fit does not show (a
dip of the order of Tsit5's local error) is missed; so is a step that crosses zero twice
after starting away from it.
"""

from __future__ import annotations

import math

import diffrax
import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._checks import check_choice, concrete
from .block import Block
from .constants import G
from .motion import GroundMotion
from .relations import e_housner, e_isr
from .response import (
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_UNRESOLVED,
    STATUS_UNSTABLE,
    Response,
)

MODES = ("two_sided", "one_sided")

P_DT_TARGET = 0.1
"""Largest ``p dt_step`` [-] the automatic step subdivision allows (see the module docstring)."""

P_DT_LIMIT = 0.5
"""``p dt_step`` [-] beyond which the step is refused: a ``ValueError`` for a concrete block, and
for a traced one (``n_sub`` then cannot follow ``p``) ``STATUS_UNSTABLE`` (an error if
``throw``)."""

DEFAULT_DT = 0.005
"""Output step for free rocking [s]."""

DEFAULT_MAX_IMPACTS = 64
"""Default ``max_impacts_per_step``: impacts one solver step may resolve before the run is
reported as unresolved (``STATUS_UNRESOLVED``)."""

REST_A_MARGIN = 0.5
"""Rest rule: the restoring acceleration ``A_s`` on either pivot must stay at least this
fraction of its value at the impact over twice the chatter's Zeno time (docs/theory.md)."""

REST_HOP = 1e-6
"""Rest rule, second clause: an impact whose rebound would lift the block by less than this
fraction of ``eta`` under gravity alone (``w^2 / (2 p^2 sin eta) <= REST_HOP eta``) puts it to
rest whatever the forcing ahead; it then lifts at the exact threshold crossing. This ends
chatter that the first clause cannot (the forcing nears the threshold before the sequence
ends), which for ``e`` near 1 would otherwise take hundreds of impacts per step."""

REST_HORIZON = 8
"""Rest rule: twice the chatter's Zeno time must fit in this many record intervals (the rule
checks the forcing at every sample inside; a longer chatter is resolved impact by impact)."""

_N_BISECT = 6  # brackets the Hermite root to 1/64 of the step before Newton polishes it
_N_NEWTON = 3  # from within 1/128, three Newton steps reach ~1e-8 of the step even when sharp
_TINY = 1e-30  # guards divisions in masked branches so their (unused) gradients stay finite

# Tsit5 (5th order) is "ssal": stages 1-6 give y1, its 7th stage only serves FSAL and the
# error estimate. _A[i] weighs the slopes of stages 0..i-1 for stage i; _B gives y1.
_TABLEAU = diffrax.Tsit5.tableau
_C = np.concatenate([[0.0], _TABLEAU.c[:-1]])
_A = np.zeros((6, 6))
for _i, _row in enumerate(_TABLEAU.a_lower[:-1]):
    _A[_i + 1, : _row.size] = _row
_B = np.asarray(_TABLEAU.b_sol[:-1], dtype=float)

# Taylor coefficients of sin(x)/x and cos(x) in x^2; see _sincos.
_SIN = tuple((-1) ** k / math.factorial(2 * k + 1) for k in range(12))
_COS = tuple((-1) ** k / math.factorial(2 * k) for k in range(13))


# --------------------------------------------------------------------------- state and forcing


class _State(eqx.Module):
    """The solver state. Every field is a float64 scalar so diffrax can carry and save it."""

    theta: Array  # rotation [rad]
    theta_dot: Array  # angular velocity [rad/s]
    s: Array  # pivot: +1, -1, or 0 at rest
    overturned: Array  # 1.0 once overturned (then frozen)
    n_impacts: Array  # impacts so far
    t_last_impact: Array  # time of the latest impact [s] (-inf before the first)
    theta_max: Array  # running max |theta| [rad], refined between step ends
    n_unresolved: Array  # steps that needed more than max_impacts_per_step impacts


class _Series(eqx.Module):
    """The part of the state saved at every step (the rest is needed only at the end)."""

    theta: Array
    theta_dot: Array
    s: Array
    n_impacts: Array
    t_last_impact: Array


def _series(t, y: _State, args) -> _Series:
    del t, args
    return _Series(y.theta, y.theta_dot, y.s, y.n_impacts, y.t_last_impact)


class _Params(eqx.Module):
    """Per-run constants of the step (built once, traced or not)."""

    p2_over_g: Array  # p^2 / g [1/m]
    sin_eta: Array
    cos_eta: Array
    tan_eta: Array
    eta: Array  # [rad]
    e: Array  # restitution magnitude [-]


class _Line(eqx.Module):
    """Linear forcing inside one step: ``a_g(t) = a0 + (t - t0) da`` and the same for ``a_gv``."""

    t0: Array
    a0: Array
    da: Array
    v0: Array
    dv: Array

    def at(self, t):
        """``(a_g, g_eff)`` at time ``t`` [m/s^2]."""
        dt = t - self.t0
        return self.a0 + dt * self.da, G + self.v0 + dt * self.dv


class _Record(eqx.Module):
    """The whole record on its uniform grid ``t_i = i dt``, linear between samples.

    ``ag_v`` may be None. Evaluation indexes the grid directly (no search): the step ends and
    the rest rule's look-ahead times need the forcing at arbitrary times.
    """

    ag: Array  # [m/s^2], one value per sample
    ag_v: Array | None
    dt: float = eqx.field(static=True)  # sample spacing [s]

    def _eval(self, ys, t):
        n = ys.shape[0]
        x = jnp.clip(t / self.dt, 0.0, n - 1.0)
        i = jax.lax.stop_gradient(jnp.clip(jnp.floor(x), 0.0, n - 2.0))
        frac = x - i
        i = i.astype(jnp.int32)
        return ys[i] + frac * (ys[i + 1] - ys[i])

    def sample(self, i):
        """``(a_g, g_eff)`` at sample ``i`` (an integer array, clipped to the record) [m/s^2]."""
        i = jnp.clip(i, 0, self.ag.shape[0] - 1)
        return self.ag[i], G + (0.0 if self.ag_v is None else self.ag_v[i])

    def at(self, t):
        """``(a_g, g_eff)`` at time ``t`` [m/s^2] (held at the last sample beyond the end)."""
        v = 0.0 if self.ag_v is None else self._eval(self.ag_v, t)
        return self._eval(self.ag, t), G + v

    def line(self, t0, t1):
        """The exact linear forcing on ``[t0, t1]`` (inside one sample interval), from the two
        end values only."""
        a0, a1 = self._eval(self.ag, t0), self._eval(self.ag, t1)
        if self.ag_v is None:
            v0 = dv = jnp.zeros_like(a0)
        else:
            v0 = self._eval(self.ag_v, t0)
            dv = (self._eval(self.ag_v, t1) - v0) / (t1 - t0)
        return _Line(t0=t0, a0=a0, da=(a1 - a0) / (t1 - t0), v0=v0, dv=dv)


# --------------------------------------------------------------------------- physics


@jax.custom_jvp
def _sincos(x):
    """``(sin x, cos x)`` from Taylor polynomials in ``x^2``: within 4e-16 for ``|x| <= 2`` rad.

    XLA's float64 sin and cos cost about 10 ns each per element on CPU and dominated the
    step; these polynomials cost a third of that. Rotations in use stay below
    ``eta + p dt_step < pi/2 + 0.4`` rad: past ``eta`` the block is flagged overturned and its
    state is frozen at the end of that step. The derivative is the exact one, ``(cos, -sin)``,
    not that of the polynomials (smaller graphs under ``grad``, quicker to compile).
    """
    x2 = x * x
    s, c = _SIN[-1], _COS[-1]
    for coef in _SIN[-2::-1]:
        s = s * x2 + coef
    for coef in _COS[-2::-1]:
        c = c * x2 + coef
    return x * s, c


@_sincos.defjvp
def _sincos_jvp(primals, tangents):
    (x,), (dx,) = primals, tangents
    sin_x, cos_x = _sincos(x)
    return (sin_x, cos_x), (cos_x * dx, -sin_x * dx)


def _theta_ddot(t, theta, s, params: _Params, forcing):
    """Angular acceleration [rad/s^2] on pivot ``s = +-1`` (module docstring equation).

    Uses ``sin(s eta - theta)`` and ``cos(s eta - theta)`` expanded with ``s^2 = 1``, so each
    evaluation needs only the sine and cosine of ``theta``.
    """
    ag, g_eff = forcing.at(t)
    sin_th, cos_th = _sincos(theta)
    s_sin_eta = s * params.sin_eta
    return -params.p2_over_g * (
        cos_th * (g_eff * s_sin_eta + ag * params.cos_eta)
        + sin_th * (ag * s_sin_eta - g_eff * params.cos_eta)
    )


def _vector_field(t, y: _State, args):
    """The smooth flow between impacts, on the full state (discrete parts do not move)."""
    params, forcing = args
    moving = (y.s != 0) & (y.overturned == 0)
    acc = jnp.where(moving, _theta_ddot(t, y.theta, y.s, params, forcing), 0.0)
    zero = jnp.zeros_like(y.theta)
    return _State(
        theta=jnp.where(moving, y.theta_dot, 0.0),
        theta_dot=acc,
        s=zero,
        overturned=zero,
        n_impacts=zero,
        t_last_impact=zero,
        theta_max=zero,
        n_unresolved=zero,
    )


def _rk_step(accel, t0, h, theta0, theta_dot0):
    """One explicit Runge-Kutta step (diffrax's Tsit5 tableau, unrolled) of
    ``(theta, theta_dot)' = (theta_dot, accel(t, theta))`` from ``t0`` over ``h`` [s]."""
    k_th, k_thd = [], []  # stage slopes of theta (the stage theta_dot) and of theta_dot
    for a_i, c_i in zip(_A, _C):
        theta = theta0 + h * sum(float(a) * k for a, k in zip(a_i, k_th))
        theta_dot = theta_dot0 + h * sum(float(a) * k for a, k in zip(a_i, k_thd))
        k_th.append(theta_dot)
        k_thd.append(accel(t0 + float(c_i) * h, theta))
    return (
        theta0 + h * sum(float(b) * k for b, k in zip(_B, k_th)),
        theta_dot0 + h * sum(float(b) * k for b, k in zip(_B, k_thd)),
    )


def _safe(x):
    """``x``, or 1 where ``|x|`` is negligible (only reached in masked-out branches)."""
    return jnp.where(jnp.abs(x) > _TINY, x, 1.0)


def _hermite_coefficients(u0, du0, u1, du1):
    """``(c1, c2, c3)`` of the cubic Hermite fit ``u0 + c1 x + c2 x^2 + c3 x^3`` on [0, 1]."""
    c1 = du0
    c2 = 3.0 * (u1 - u0) - 2.0 * du0 - du1
    c3 = 2.0 * (u0 - u1) + du0 + du1
    return c1, c2, c3


def _hermite_turn(u0, du0, u1, du1):
    """Turning point ``x`` in [0, 1] of the cubic Hermite fit where ``du0 < 0 < du1``, and
    ``u`` there: a step that ends on the side it started can have crossed zero and returned
    (a graze). No gradient: it only brackets the root (``_hermite_root`` carries it)."""
    u0, du0, u1, du1 = (jax.lax.stop_gradient(v) for v in (u0, du0, u1, du1))
    c1, c2, c3 = _hermite_coefficients(u0, du0, u1, du1)
    # u'(x) = c1 + 2 c2 x + 3 c3 x^2 has exactly one root in (0, 1) when c1 < 0 < u'(1).
    a, b = 3.0 * c3, 2.0 * c2
    disc = jnp.maximum(b * b - 4.0 * a * c1, 0.0)
    q = -0.5 * (b + jnp.where(b >= 0, 1.0, -1.0) * jnp.sqrt(disc))
    x_small = c1 / _safe(q)  # the root of smaller magnitude (stable form)
    x_big = q / _safe(a)
    x = jnp.where((x_small >= 0) & (x_small <= 1), x_small, x_big)
    x = jnp.clip(x, 0.0, 1.0)
    turns = (du0 < 0) & (du1 > 0)
    u_turn = ((c3 * x + c2) * x + c1) * x + u0
    return jnp.where(turns, x, 1.0), jnp.where(turns, u_turn, u1)


def _hermite_root(u0, du0, u1, du1, xb):
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
    c1, c2, c3 = _hermite_coefficients(u0, du0, u1, du1)

    def cubic(x):
        return ((c3 * x + c2) * x + c1) * x + u0

    lo, hi = jnp.zeros_like(u0), jnp.broadcast_to(xb, jnp.shape(u0)).astype(u0.dtype)
    for _ in range(_N_BISECT):
        mid = 0.5 * (lo + hi)
        pos = cubic(mid) > 0
        lo, hi = jnp.where(pos, mid, lo), jnp.where(pos, hi, mid)
    lo, hi = jax.lax.stop_gradient(lo), jax.lax.stop_gradient(hi)
    # Roots of u0 + c1 x + c2 x^2 in the stable form: u0 / q and q / c2.
    a0, a1, a2 = (jax.lax.stop_gradient(v) for v in (u0, c1, c2))
    q = -0.5 * (
        a1 + jnp.where(a1 >= 0, 1.0, -1.0) * jnp.sqrt(jnp.maximum(a1 * a1 - 4 * a2 * a0, 0))
    )
    r1, r2 = a0 / _safe(q), q / _safe(a2)
    r1 = jnp.where((r1 > 0) & (r1 <= hi), r1, jnp.inf)
    r2 = jnp.where((r2 > 0) & (r2 <= hi), r2, jnp.inf)
    guess = jnp.minimum(r1, r2)
    x = jnp.where((lo == 0) & jnp.isfinite(guess), guess, 0.5 * (lo + hi))
    for _ in range(_N_NEWTON):
        slope = (3.0 * c3 * x + 2.0 * c2) * x + c1
        x = jnp.clip(x - cubic(x) / _safe(slope), lo, hi)
    return x


def _uplift(ta, t1, line: _Line, params: _Params, one_sided: bool):
    """First time in ``[ta, t1]`` the linear forcing exceeds the uplift threshold, and the pivot.

    Two-sided: ``a_g - tan(eta) g_eff > 0`` lifts onto ``s = -1``, ``-a_g - tan(eta) g_eff > 0``
    onto ``s = +1``; one-sided only the latter. Both are linear in ``t``.

    Returns:
        ``(lifts, t_uplift, s)``: whether it lifts in the interval, when [s], and the pivot.
    """

    def first_positive(fa, fb):
        frac = jnp.clip(-fa / _safe(fb - fa), 0.0, 1.0)
        t = jnp.where(fa > 0, ta, ta + frac * (t1 - ta))
        return (fa > 0) | (fb > 0), t

    a_a, g_a = line.at(ta)
    a_b, g_b = line.at(t1)
    tan_eta = params.tan_eta
    lifts_pos, t_pos = first_positive(-a_a - tan_eta * g_a, -a_b - tan_eta * g_b)
    if one_sided:
        return lifts_pos, t_pos, jnp.ones_like(ta)
    lifts_neg, t_neg = first_positive(a_a - tan_eta * g_a, a_b - tan_eta * g_b)
    neg_first = lifts_neg & (~lifts_pos | (t_neg < t_pos))
    return (
        lifts_pos | lifts_neg,
        jnp.where(neg_first, t_neg, t_pos),
        jnp.where(neg_first, -1.0, 1.0),
    )


def _peak(theta_a, theta_dot_a, theta_b, theta_dot_b, h):
    """Largest ``|theta|`` on a smooth segment of length ``h`` [s], from its two end states.

    A turning point inside (``theta_dot`` changes sign) is refined with a parabola of constant
    acceleration ``(theta_dot_b - theta_dot_a)/h``: ``theta_a + theta_dot_a^2 h / (2 dv)``.
    """
    dv = theta_dot_a - theta_dot_b
    turns = theta_dot_a * theta_dot_b < 0
    top = theta_a + theta_dot_a**2 * h / (2.0 * _safe(dv))
    ends = jnp.maximum(jnp.abs(theta_a), jnp.abs(theta_b))
    return jnp.where(turns, jnp.maximum(ends, jnp.abs(top)), ends)


def _flight(pred, accel, t0, h, theta0, theta_dot0):
    """``_rk_step`` where ``pred`` (one bool for the whole batch) holds, else the start state.

    The ``cond`` skips steps that no record of a ``vmap`` batch needs (``pred`` is reduced with
    ``unvmap_any``, as diffrax does for its FSAL stage). It also keeps the unrolled stages one
    XLA computation: inlined, XLA's CPU fusion copied them into every consumer of the result
    and a step ran three times slower.
    """
    return jax.lax.cond(
        eqxi.unvmap_any(pred),
        lambda: _rk_step(accel, t0, h, theta0, theta_dot0),
        lambda: (theta0, theta_dot0),
    )


def _restoring(a_g, g_eff, params: _Params):
    """``(A_+, A_-)`` [rad/s^2]: ``-s theta_ddot`` at ``theta = 0`` on pivot ``s = +-1``.

    From the equation of motion, ``A_s = (p^2 cos(eta) / g) (g_eff tan(eta) + s a_g)``: positive
    when the forcing is below the uplift threshold on that side, so a flight on pivot ``s`` that
    starts at ``theta = 0`` returns to it.
    """
    k = params.p2_over_g * params.cos_eta
    return k * (g_eff * params.tan_eta + a_g), k * (g_eff * params.tan_eta - a_g)


def _rests(t_imp, w, s_new, line: _Line, record: _Record, params: _Params, one_sided: bool):
    """The rest rule after an impact at ``t_imp`` with rebound speed ``w = |theta_dot+|`` onto
    pivot ``s_new``. See docs/theory.md, "Housner rest and chatter rule".

    With the restoring accelerations ``A_s`` frozen at their impact values the remaining
    chatter is a geometric sequence of flights that ends after the finite (Zeno) time
    ``T = 2 w / (1 - e^2) (1 / A_new + e / A_other)`` (one-sided ``2 w / ((1 - e) A_+)``),
    with ``|theta| <= w^2 / (2 A_new)``. The block is put to rest only when (a) ``A > 0`` on
    both pivots at ``t_imp``, (b) ``2 T <= REST_HORIZON`` record intervals, and (c) on
    ``[t_imp, t_imp + 2 T]`` every ``A`` stays at least ``REST_A_MARGIN`` of its impact value
    (the record is linear between samples, so the ends and the samples inside bound it).
    Then the sequence ends before the forcing can reach the uplift threshold, and rest is the
    exact limit; otherwise the impacts go on being resolved one by one.

    Second clause: a rebound whose gravity-only hop ``w^2 / (2 p^2 sin eta)`` is at most
    ``REST_HOP eta`` rests whatever the forcing ahead (the block then lifts at the exact
    threshold crossing; the motion given up is a hop of that size).

    Returns:
        ``(rests, hop)``: the decision and, for the first clause, the first hop's height
        ``w^2 / (2 A_new)`` [rad] (added to ``theta_max``).
    """
    ap0, am0 = _restoring(*line.at(t_imp), params)
    e = params.e
    if one_sided:
        a_new = a_other = ap0
        ok0 = ap0 > 0
        zeno = 2.0 * w / _safe((1.0 - e) * ap0)
    else:
        a_new = jnp.where(s_new > 0, ap0, am0)
        a_other = jnp.where(s_new > 0, am0, ap0)
        ok0 = (ap0 > 0) & (am0 > 0)
        zeno = 2.0 * w / _safe(1.0 - e * e) * (1.0 / _safe(a_new) + e / _safe(a_other))
    ok0 = ok0 & (e < 1.0)
    fits = ok0 & (2.0 * zeno <= REST_HORIZON * record.dt)
    t_end = t_imp + jnp.where(fits, 2.0 * zeno, 0.0)

    def keeps(ap, am, inside):
        ok = ~inside | (ap >= REST_A_MARGIN * ap0)
        return ok if one_sided else ok & (~inside | (am >= REST_A_MARGIN * am0))

    stays = fits & keeps(*_restoring(*record.at(t_end), params), jnp.ones_like(fits))
    i0 = jax.lax.stop_gradient(jnp.floor(t_imp / record.dt)).astype(jnp.int32)
    for j in range(1, REST_HORIZON + 1):  # the samples inside (t_imp, t_end)
        inside = (i0 + j) * record.dt < t_end
        stays = stays & keeps(*_restoring(*record.sample(i0 + j), params), inside)
    hop = w * w / (2.0 * _safe(jnp.where(ok0, a_new, 1.0)))
    # Second clause: a rebound too small to matter (its gravity-only hop <= REST_HOP eta).
    tiny = w * w <= 2.0 * REST_HOP * params.eta * params.p2_over_g * G * params.sin_eta
    rests = stays | tiny
    return rests, jnp.where(stays, hop, 0.0)


def _pass(y: _State, ta, t1, line: _Line, record: _Record, params: _Params, one_sided: bool):
    """One masked pass of a step: uplift, RK to ``t1``, and at most one impact.

    Returns the state and the time it holds at: ``t1``, or the impact time ``tau'`` when the
    block impacted on the way (the next pass continues from there).
    """
    # (1) At rest: lift off when the forcing first exceeds the threshold in [ta, t1].
    lifts, t_up, s_up = _uplift(ta, t1, line, params, one_sided)
    lift_now = (y.s == 0) & lifts & (y.overturned == 0)
    s = jnp.where(lift_now, s_up, y.s)
    ta = jnp.where(lift_now, t_up, ta)
    rocking = (s != 0) & (y.overturned == 0)

    # (2) Smooth flight to t1 on pivot s.
    def accel(t, theta):
        return _theta_ddot(t, theta, s, params, line)

    h = t1 - ta
    theta1, theta_dot1 = _flight(rocking & (h > 0), accel, ta, h, y.theta, y.theta_dot)
    u0, du0, u1, du1 = s * y.theta, h * s * y.theta_dot, s * theta1, h * s * theta_dot1
    # A crossing: u = s theta ends negative, or ends positive after dipping below zero inside
    # the step (a graze; the cubic Hermite fit of u has its turning point below zero).
    x_turn, u_turn = jax.lax.cond(
        eqxi.unvmap_any(rocking & (du0 < 0) & (du1 > 0) & (u1 >= 0)),
        lambda: _hermite_turn(u0, du0, u1, du1),
        lambda: (jnp.ones_like(u1), u1),
    )
    grazes = (u1 >= 0) & (u0 >= 0) & (u_turn < 0)
    crossed = rocking & (h > 0) & ((u1 < 0) | grazes)
    xb = jnp.where(u1 < 0, 1.0, x_turn)

    # (3) The crossing of u through 0: Hermite root, re-step, one Newton step on the true
    # trajectory with the state advanced linearly to it, then the impact map.
    x = _hermite_root(u0, du0, u1, du1, xb)
    tau = ta + x * h
    theta_tau, theta_dot_tau = _flight(crossed, accel, ta, tau - ta, y.theta, y.theta_dot)
    t_impact = jnp.clip(tau - theta_tau / _safe(theta_dot_tau), ta, ta + xb * h)
    theta_dot_tau = theta_dot_tau + accel(tau, theta_tau) * (t_impact - tau)
    if one_sided:
        theta_dot_plus, s_plus = -params.e * theta_dot_tau, s
    else:
        theta_dot_plus, s_plus = params.e * theta_dot_tau, -s
    # The rule reads the record at up to REST_HORIZON + 2 times (gathers, the costliest part
    # of a pass in a batch): only when some record of the batch impacted.
    rests, hop = jax.lax.cond(
        eqxi.unvmap_any(crossed),
        lambda: _rests(t_impact, jnp.abs(theta_dot_plus), s_plus, line, record, params, one_sided),
        lambda: (jnp.zeros_like(crossed), jnp.zeros_like(t_impact)),
    )
    rests = crossed & rests

    peak = _peak(
        y.theta,
        y.theta_dot,
        jnp.where(crossed, theta_tau, theta1),
        jnp.where(crossed, theta_dot_tau, theta_dot1),
        jnp.where(crossed, t_impact - ta, h),
    )
    peak = jnp.maximum(peak, jnp.where(rests, hop, 0.0))
    theta_dot_new = jnp.where(crossed, jnp.where(rests, 0.0, theta_dot_plus), theta_dot1)
    s_new = jnp.where(crossed, jnp.where(rests, 0.0, s_plus), s)
    t_new = jnp.where(crossed, t_impact, t1)
    # Not rocking (at rest and not lifting, or overturned): nothing moves.
    y_new = _State(
        theta=jnp.where(rocking, jnp.where(crossed, 0.0, theta1), y.theta),
        theta_dot=jnp.where(rocking, theta_dot_new, y.theta_dot),
        s=jnp.where(rocking, s_new, y.s),
        overturned=y.overturned,
        n_impacts=y.n_impacts + crossed,
        t_last_impact=jnp.where(crossed, t_impact, y.t_last_impact),
        theta_max=jnp.where(rocking, jnp.maximum(y.theta_max, peak), y.theta_max),
        n_unresolved=y.n_unresolved,
    )
    return y_new, jnp.where(rocking, t_new, t1)


class _HousnerSolver(diffrax.AbstractSolver):
    """Fixed-step diffrax solver for Housner rocking with the impacts resolved inside each step.

    ``args = (params, record)``; ``record`` is a :class:`_Record`. Each step runs passes (a
    while loop) until every record of the batch has reached the step end, at most
    ``max_impacts + 1``; ``loop_kind`` is the ``equinox.internal.while_loop`` kind that the
    adjoint can differentiate (``"checkpointed"`` for reverse mode, ``"lax"`` for
    ``ForwardMode``, ``"bounded"`` for ``DirectAdjoint``), as diffrax chooses for its own loop.
    """

    one_sided: bool = eqx.field(static=True)
    max_impacts: int = eqx.field(static=True)
    loop_kind: str = eqx.field(static=True)

    term_structure = diffrax.AbstractTerm
    interpolation_cls = diffrax.LocalLinearInterpolation

    def order(self, terms):
        return 5

    def init(self, terms, t0, t1, y0, args):
        return None

    def func(self, terms, t0, y0, args):
        return terms.vf(t0, y0, args)

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        del terms, solver_state, made_jump
        params, record = args
        line = record.line(t0, t1)

        def cond(carry):
            _, ta, k = carry
            return (ta < t1) & (k <= self.max_impacts)

        def body(carry):
            y, ta, k = carry
            y, ta = _pass(y, ta, t1, line, record, params, self.one_sided)
            return y, ta, k + 1

        y, ta, _ = eqxi.while_loop(
            cond,
            body,
            (y0, t0, jnp.zeros((), jnp.int32)),
            max_steps=self.max_impacts + 1,
            kind=self.loop_kind,
        )
        # More impacts than max_impacts in this step: stop the block (reported, never silent:
        # n_unresolved makes the status STATUS_UNRESOLVED, an error if throw).
        unresolved = ta < t1
        y = _State(
            theta=jnp.where(unresolved, 0.0, y.theta),
            theta_dot=jnp.where(unresolved, 0.0, y.theta_dot),
            s=jnp.where(unresolved, 0.0, y.s),
            overturned=y.overturned,
            n_impacts=y.n_impacts,
            t_last_impact=y.t_last_impact,
            theta_max=y.theta_max,
            n_unresolved=y.n_unresolved + unresolved,
        )
        goes_over = (y.s != 0) & (jnp.abs(y.theta) > params.eta) & (y.theta * y.theta_dot > 0)
        y = eqx.tree_at(lambda z: z.overturned, y, jnp.where(goes_over, 1.0, y.overturned))
        frozen = y0.overturned > 0
        y1 = jax.tree.map(lambda old, new: jnp.where(frozen, old, new), y0, y)
        return y1, None, dict(y0=y0, y1=y1), None, diffrax.RESULTS.successful


# --------------------------------------------------------------------------- public API


def simulate_housner(
    block: Block,
    motion: GroundMotion | None = None,
    *,
    e: Float[ArrayLike, ""] | None = None,
    mode: str = "two_sided",
    theta0: Float[ArrayLike, ""] = 0.0,
    theta_dot0: Float[ArrayLike, ""] = 0.0,
    duration: float | None = None,
    dt: float | None = None,
    max_impacts_per_step: int = DEFAULT_MAX_IMPACTS,
    adjoint: diffrax.AbstractAdjoint | None = None,
    throw: bool = True,
) -> Response:
    r"""Simulate Housner rocking with impacts (two-sided parapet or one-sided facade).

    $I_O \ddot\theta = -m g R \sin(\eta - \theta) - m a_g R \cos(\eta - \theta)$ for
    $\theta > 0$ (mirrored for $\theta < 0$), $\dot\theta \to e \dot\theta$ at each impact.

    Args:
        block: The block; only ``b`` and ``h`` (and ``m``, for the energy) matter.
        motion: Ground motion; ``None`` for free rocking (then ``duration`` is required).
        e: Coefficient of restitution [-]: two-sided ``0 < e <= 1`` (default ``e_H``, Eq. (2));
            one-sided ``0 < |e| <= 1``, its magnitude is used (default ``|e_1sr|``, Eq. (5)).
        mode: ``"two_sided"`` (parapet) or ``"one_sided"`` (facade, ``theta >= 0``).
        theta0: Initial rotation [rad], ``|theta0| < eta`` (``>= 0`` one-sided).
        theta_dot0: Initial angular velocity [rad/s].
        duration: Length of the run [s]; required for free rocking, else default the record's.
            A longer duration appends zeros (free vibration after the record); a shorter one
            truncates it.
        dt: Free rocking: the output step [s] (default 0.005), split into
            ``ceil(p dt / P_DT_TARGET)`` solver steps. With a motion: a bound on the solver step
            [s] (default ``P_DT_TARGET / p``), each record step split into ``ceil(motion.dt /
            dt)`` equal solver steps; the output stays at the record samples.
        max_impacts_per_step: Impacts one solver step may resolve (static; default 64). A step
            that needs more is counted in ``extras["n_unresolved"]``, the block is stopped
            there, and the run is an error (``throw``) or has ``STATUS_UNRESOLVED``; raise it
            or pass a smaller ``dt``. Chatter that provably dies out below the uplift
            threshold is put to rest by the rest rule and does not count.
        adjoint: diffrax adjoint; default ``RecursiveCheckpointAdjoint`` (reverse mode, ``grad``).
            Pass ``diffrax.ForwardMode()`` for ``jvp``/``jacfwd``.
        throw: Raise (also inside ``jit``) on a non-finite state or an unresolved step; if
            False report it in ``Response.status`` (for batches).

    Returns:
        A :class:`rockjax.Response` at the record samples (or every ``dt``). ``energy`` is
        $\tfrac12 I_O\dot\theta^2 + m g R(\cos(\eta-|\theta|) - \cos\eta)$ [J]. ``extras``:
        ``"n_impacts"`` (impacts up to each sample), ``"t_last_impact"`` [s] (time of the
        latest impact up to each sample, exact from the root-find; ``-inf`` before the first),
        ``"pivot"`` (``s``: +1, -1, 0 at rest), ``"n_unresolved"`` (steps with more impacts
        than ``max_impacts_per_step``; nonzero only with ``throw=False``), ``"dt"`` (solver
        step [s]).

    Raises:
        ValueError: on invalid input, with the value, its unit and the fix.

    References:
        Housner, G. W. (1963), BSSA 53(2):403-417. The paper, Eqs. (2) and (5).
    """
    check_choice("mode", mode, MODES)
    one_sided = mode == "one_sided"
    if not (isinstance(max_impacts_per_step, int) and max_impacts_per_step >= 1):
        raise ValueError(
            f"max_impacts_per_step must be an int >= 1; got {max_impacts_per_step!r}. Use the default, 64."
        )
    if dt is not None and not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive time step in s; got dt={dt}. Or leave dt=None.")
    if duration is not None and not (np.isfinite(duration) and duration > 0):
        raise ValueError(f"duration must be a positive time in s; got duration={duration}.")
    _check_theta0(theta0, theta_dot0, block, one_sided)

    if motion is None:
        if duration is None:
            raise ValueError(
                "free rocking (motion=None) needs duration, in s: e.g. duration=10.0; "
                "or pass a GroundMotion."
            )
        dt_out = DEFAULT_DT if dt is None else float(dt)
        n_out = int(math.floor(duration / dt_out + 1e-9)) + 1
        ag = jnp.zeros(n_out)
        ag_v = None
        dt_max = None
    else:
        dt_out = motion.dt
        n_out = motion.n if duration is None else int(math.floor(duration / dt_out + 1e-9)) + 1
        ag = _fit(motion.ag, n_out)
        ag_v = None if motion.ag_v is None else _fit(motion.ag_v, n_out)
        dt_max = dt
    if n_out < 2:
        raise ValueError(f"the run must span at least one step; got duration={duration} s.")
    p = concrete(block.p)
    if dt_max is None:
        dt_max = dt_out if p is None else P_DT_TARGET / float(np.max(p))
    n_sub = max(1, math.ceil(dt_out / dt_max - 1e-9))
    if p is not None and np.max(p) * dt_out / n_sub > P_DT_LIMIT:
        raise ValueError(
            f"the solver step {dt_out / n_sub:.4g} s is too coarse for this block "
            f"(p = {float(np.max(p)):.4g} rad/s, p*dt = {float(np.max(p)) * dt_out / n_sub:.3g} > "
            f"{P_DT_LIMIT}); pass dt <= {P_DT_TARGET / float(np.max(p)):.4g} s or leave dt=None."
        )

    block = jax.tree.map(lambda x: jnp.asarray(x, dtype=float), block)
    default_e = e is None
    if default_e:
        e = e_isr(block.eta) if one_sided else e_housner(block.eta)
    _check_e(e, one_sided, default=default_e)
    e = jnp.asarray(e, dtype=float)
    return _simulate(
        block,
        ag,
        ag_v,
        jnp.abs(e) if one_sided else e,
        jnp.asarray(theta0, dtype=float),
        jnp.asarray(theta_dot0, dtype=float),
        dt_out=float(dt_out),
        n_sub=n_sub,
        one_sided=one_sided,
        max_impacts=max_impacts_per_step,
        adjoint=adjoint,
        throw=throw,
    )


@eqx.filter_jit
def _simulate(
    block, ag, ag_v, e, theta0, theta_dot0, *, dt_out, n_sub, one_sided, max_impacts, adjoint, throw
):
    n_out = ag.shape[0]
    dt_step = dt_out / n_sub
    t_out = jnp.arange(n_out) * dt_out
    # Step ends: every output sample exactly, and n_sub - 1 equal steps between two samples.
    t_steps = (t_out[:-1, None] + dt_step * jnp.arange(n_sub)[None, :]).reshape(-1)
    t_steps = jnp.concatenate([t_steps, t_out[-1:]])
    n_steps = t_steps.shape[0] - 1

    eta, p = block.eta, block.p
    e = eqx.error_if(e, (e <= 0) | (e > 1), "e (restitution, dimensionless) must be in (0, 1].")
    theta0 = eqx.error_if(
        theta0,
        (jnp.abs(theta0) >= eta) | (one_sided & (theta0 < 0)),
        "theta0 must satisfy |theta0| < eta [rad] (and theta0 >= 0 one-sided).",
    )
    params = _Params(
        p2_over_g=p**2 / G,
        sin_eta=jnp.sin(eta),
        cos_eta=jnp.cos(eta),
        tan_eta=jnp.tan(eta),
        eta=eta,
        e=e,
    )
    record = _Record(ag=ag, ag_v=ag_v, dt=dt_out)
    moving = (theta0 != 0) | (theta_dot0 != 0)
    if one_sided:
        s0 = jnp.where(moving, 1.0, 0.0)
    else:
        s0 = jnp.where(theta0 != 0, jnp.sign(theta0), jnp.sign(theta_dot0))
    zero = jnp.zeros_like(theta0)
    y0 = _State(
        theta=theta0,
        theta_dot=theta_dot0,
        s=s0,
        overturned=zero,
        n_impacts=zero,
        t_last_impact=jnp.full_like(theta0, -jnp.inf),
        theta_max=jnp.abs(theta0),
        n_unresolved=zero,
    )
    adjoint = diffrax.RecursiveCheckpointAdjoint() if adjoint is None else adjoint
    if isinstance(adjoint, diffrax.ForwardMode):
        loop_kind = "lax"  # jvp cannot go through the checkpointed loop's custom_vjp
    elif isinstance(adjoint, diffrax.DirectAdjoint):
        loop_kind = "bounded"
    else:
        loop_kind = "checkpointed"
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(_vector_field),
        _HousnerSolver(one_sided=one_sided, max_impacts=max_impacts, loop_kind=loop_kind),
        t0=t_steps[0],
        t1=t_steps[-1],
        dt0=None,
        y0=y0,
        args=(params, record),
        saveat=diffrax.SaveAt(
            subs=[
                diffrax.SubSaveAt(t0=True, steps=True, fn=_series),
                diffrax.SubSaveAt(t1=True),
            ]
        ),
        stepsize_controller=diffrax.StepTo(ts=t_steps),
        adjoint=adjoint,
        max_steps=n_steps,
        throw=False,
    )
    ys, final = sol.ys
    too_coarse = p * dt_step > P_DT_LIMIT
    if throw:
        # Every output below is computed from the checked ys, so the checks cannot be
        # dropped as dead code whichever outputs the caller keeps.
        finite = jnp.all(jnp.isfinite(ys.theta)) & jnp.all(jnp.isfinite(ys.theta_dot))
        ys, final = eqx.error_if(
            (ys, final), ~finite, "simulate_housner: the state became non-finite (NaN/inf)."
        )
        ys, final = eqx.error_if(
            (ys, final),
            too_coarse,
            f"simulate_housner: p*dt_step exceeds {P_DT_LIMIT}; pass a smaller dt [s].",
        )
        ys, final = eqx.error_if(
            (ys, final),
            jnp.any(final.n_unresolved > 0),
            "simulate_housner: a solver step needed more impacts than max_impacts_per_step; "
            "raise max_impacts_per_step or pass a smaller dt [s].",
        )
    final = jax.tree.map(lambda x: x[-1], final)
    ys = jax.tree.map(lambda x: x[::n_sub], ys)
    theta, theta_dot = ys.theta, ys.theta_dot
    finite = jnp.all(jnp.isfinite(theta)) & jnp.all(jnp.isfinite(theta_dot))
    status = jnp.where(
        finite,
        jnp.where(
            too_coarse,
            STATUS_UNSTABLE,
            jnp.where(final.n_unresolved > 0, STATUS_UNRESOLVED, STATUS_OK),
        ),
        STATUS_NONFINITE,
    )

    m, R = block.m, block.R
    abs_theta = jnp.abs(theta)
    d = jnp.sign(theta) * 0.5 * block.b * (1.0 - jnp.cos(theta)) + block.h * jnp.sin(theta)
    energy = 0.5 * block.I_O * theta_dot**2 + m * G * R * (jnp.cos(eta - abs_theta) - jnp.cos(eta))
    return Response(
        t=t_out,
        theta=theta,
        theta_dot=theta_dot,
        d=d,
        overturned=final.overturned > 0,
        status=status,
        theta_max=final.theta_max,
        eta=eta,
        b=block.b,
        energy=energy,
        extras={
            "n_impacts": ys.n_impacts.astype(jnp.int32),
            "t_last_impact": ys.t_last_impact,
            "pivot": ys.s,
            "n_unresolved": final.n_unresolved.astype(jnp.int32),
            "dt": jnp.asarray(dt_step),
        },
    )


def _fit(a, n):
    """``a`` truncated or zero-padded to ``n`` samples."""
    a = jnp.asarray(a, dtype=float)
    return a[:n] if a.shape[0] >= n else jnp.pad(a, (0, n - a.shape[0]))


def _check_e(e, one_sided: bool, default: bool) -> None:
    v = concrete(e)
    if v is None:
        return
    mag = np.abs(v) if one_sided else v
    if np.all(np.isfinite(v)) and np.all(mag > 0) and np.all(mag <= 1):
        return
    if default:
        eq = "Eq. (5) e_1sr" if one_sided else "Eq. (2) e_H"
        raise ValueError(
            f"the default restitution {eq} = {float(np.min(v)):.4g} is not usable for this block "
            "(e_H <= 0 for eta >= 54.7 deg; e_1sr = 0 at eta = 35.3 deg); pass e explicitly, "
            "0 < e <= 1."
        )
    which = "0 < |e| <= 1 (its magnitude is used)" if one_sided else "0 < e <= 1"
    raise ValueError(
        f"e (coefficient of restitution, dimensionless) must satisfy {which}; got e={e}. "
        "Leave e=None for the paper's default (Eq. 2 two-sided, Eq. 5 one-sided)."
    )


def _check_theta0(theta0, theta_dot0, block: Block, one_sided: bool) -> None:
    th, thd, eta = concrete(theta0), concrete(theta_dot0), concrete(block.eta)
    if thd is not None and not np.all(np.isfinite(thd)):
        raise ValueError(f"theta_dot0 must be finite, in rad/s; got theta_dot0={theta_dot0}.")
    if th is None:
        return
    if not np.all(np.isfinite(th)):
        raise ValueError(f"theta0 must be finite, in rad; got theta0={theta0}.")
    if eta is not None and np.any(np.abs(th) >= eta):
        raise ValueError(
            f"theta0 must satisfy |theta0| < eta = {float(np.max(eta)):.6g} rad (a block released "
            f"at or beyond eta overturns); got theta0={theta0} rad. Give a smaller rotation."
        )
    if one_sided and np.any(th < 0):
        raise ValueError(
            f"a one-sided facade rotates only to theta >= 0 (away from its return walls); got "
            f"theta0={theta0} rad. Use theta0 >= 0 or mode='two_sided'."
        )
    if one_sided and thd is not None and np.any((th == 0) & (thd < 0)):
        raise ValueError(
            f"a one-sided facade at theta0 = 0 cannot move into its return walls; got "
            f"theta_dot0={theta_dot0} rad/s. Use theta_dot0 >= 0."
        )
