"""The Housner rocking model with impacts, solved in one JAX loop over the record.

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
* Three-branch law (``law=``, docs/three_branch.md): the restoring moment follows a
  ``rockjax.ThreeBranchLaw`` (uplift threshold, rest rule and overturning rotation with it);
  its kinks are events like impacts, so steps are cut there.
* Moving return wall (``wall_motion=``, one-sided; docs/three_branch.md, "Moving return
  walls"): the stop is at ``max(theta_w(t), 0)``, ``theta_w = u_top / h`` (the wall, or the
  base where the wall has receded behind it), impacts restitute the velocity relative to it,
  and a block at rest rides on it until it would accelerate away faster than it. Where the
  rigid block would rock on its heel (room behind the base) the model leaves its validity:
  ``extras["t_heel"]`` reports when.

Design. The whole record is one loop of passes (``_run``, an ``equinox.internal.while_loop``
of the kind the adjoint can differentiate: ``"checkpointed"`` for ``grad``, ``"lax"`` under
``diffrax.ForwardMode`` for ``jvp``), over fixed solver steps: the record samples, each record
step split into ``n_sub`` equal steps. The record is a ``_Record`` (samples on a uniform grid,
linear in between); each step uses the exact linear forcing between its two ends. A step is
explored and, for each crossing found, resolved by the next pass; at most
``max_impacts_per_step + 1`` explorations a step. An exploring pass: (1) if at rest, the uplift
time from the linear forcing; (2) a Tsit5 step (diffrax's tableau, unrolled) to the step end;
(3) if ``s theta`` crossed zero (it changed sign, or it dipped below zero and came back: a
graze, seen as a turning point of the step's cubic Hermite fit below zero), the first crossing
time ``tau`` from that fit (bisection, then Newton), handed to the next pass. An impact pass:
a Tsit5 step to ``tau``, one Newton correction ``tau' = tau - theta/theta_dot`` on the true
trajectory with the state advanced linearly to ``tau'``, the impact map and the rest rule; the
next pass explores on from ``tau'``. Each pass holds one Tsit5 step, so the loop body holds one
copy of it. A step that needs more explorations is reported (``STATUS_UNRESOLVED``), never
silently rested. Per-record branches are selects, so batches of records, blocks and
restitution coefficients vectorise (each record of a batch at its own step), and
``grad``/``jvp`` go through the root-finding (the last Newton steps carry the
implicit-function derivative of the impact times). The Tsit5 step sits in a ``lax.cond`` on
whether any record of the batch needs it; the solver's ``cond``s differentiate as selects of
both branches (``_cond``), which halves the time to trace ``grad``. The discrete state (pivot,
flags, impact count, last impact time, running max ``|theta|``) rides along in the loop state;
the loop saves the state at every sample into buffers written once each.

Peaks between samples: ``theta_max`` is the largest ``|theta|`` of every flight's Tsit5 dense
output (Tsitouras' quartic interpolant of the step from its seven stage slopes, the last being
the end's ``theta_dot``; ``_dense_peak``), so a turning point inside a step, and a whole flight
shorter than a step (just above the uplift threshold), counts at the solver's own accuracy. The
interpolant is sampled at five points and its turning point found by Newton steps on its slope
from the best; the turning point's location carries no derivative (the slope is zero there),
so ``grad`` of ``theta_max`` is that of the interpolant's value.

Compile once: the record's length and step are data (``n_out``, ``_Record.dt``), so an eager
call pads the record to a bucket (:func:`rockjax.compilation.bucket_length`, repeating its
last sample, which is what the forcing beyond the end holds anyway) and records of any length
and step in the bucket share one compiled program; the loop stops at the true length.

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
the same overturning flags; halving the step changes nothing at that level. Just above the
uplift threshold (50 cases of FEMA P695 far-field records at 1.05-1.3 g tan(eta), peaks of
8.6e-6 to 0.47 eta, flights often shorter than a step) ``theta_max`` is within 3.4e-5
relative of that solver's peaks, found by its own ``theta_dot = 0`` events (section "Peaks
between samples"; the former end-point parabola was up to 26 % low there).

Limitations: a step resolves at most ``max_impacts_per_step`` impacts (default 64); more are
reported, not resolved. A graze whose dip below zero the step's cubic fit does not show (a
dip of the order of Tsit5's local error) is missed; so is a step that crosses zero twice
after starting away from it.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any

import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._checks import (
    check_choice,
    check_kind,
    check_positive,
    check_samples,
    check_scalar,
    check_series_pair,
    concrete,
)
from ._lazy import lazy_module
from .block import Block
from .compilation import bucket_length, is_traced, notice_once, pad_to, persistent_jit
from .constants import G
from .motion import GroundMotion
from .relations import e_housner, e_isr
from .response import (
    STATUS_BAD_INPUT,
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_UNRESOLVED,
    STATUS_UNSTABLE,
    Response,
)
from .three_branch import ThreeBranchFit, ThreeBranchLaw
from .walls import check_wall_rotation

# loaded on first use (rockjax/_lazy.py): the solver reads diffrax's Tsit5 tableau and its
# adjoint classes, and the import (with optimistix and lineax) took a quarter of `import rockjax`
diffrax = lazy_module("diffrax")

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
ends), which for ``e`` near 1 would otherwise take hundreds of impacts per step. A block at
rest likewise does not start a flight that would rise less than this (a forcing just above the
threshold that falls back within the step; see ``_uplift``)."""

REST_HORIZON = 8
"""Rest rule: twice the chatter's Zeno time must fit in this many record intervals (the rule
checks the forcing at every sample inside; a longer chatter is resolved impact by impact)."""

HEEL_TOL = 1e-3
"""Heel motions of at most this fraction of ``eta`` [-] do not end the one-sided model's
validity (``extras["t_heel"]`` of ``simulate_housner``): a wall behind the base by at most
``HEEL_TOL eta`` (the heel's room, which bounds its rotation), and a wall passing the base
under a resting block at a rate ``w`` whose hop ``w^2 / (2 p^2 sin eta)`` is at most
``HEEL_TOL eta``. The cross-checks count a facade as lifted off its stop from the same
``1e-3 eta`` (tests/test_wall_models.py)."""

_N_BISECT = 6  # brackets the Hermite root to 1/64 of the step before Newton polishes it
_N_NEWTON = 3  # from within 1/128, three Newton steps reach ~1e-8 of the step even when sharp
_N_PEAK_NEWTON = 3  # a turning point from the best of five samples of the step's dense output
_TINY = 1e-30  # guards divisions in masked branches so their (unused) gradients stay finite


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


# Taylor coefficients of sin(x)/x and cos(x) in x^2; see _sincos.
_SIN = tuple((-1) ** k / math.factorial(2 * k + 1) for k in range(12))
_COS = tuple((-1) ** k / math.factorial(2 * k) for k in range(13))
# |x| [rad] up to which _sincos(x, small=True) holds (truncation below x^11/11! < 3e-19).
_SMALL_ANGLE = 0.1


# --------------------------------------------------------------------------- helpers
# jnp.where, jnp.clip, // and % on arrays are jitted functions: under grad each of their
# hundreds of calls in a pass is traced through as a nested jit, which made up much of the
# time to trace. The solver's per-pass code uses these bare-lax equivalents instead.


def _where(pred, a, b):
    """``jnp.where(pred, a, b)`` as one ``lax.select`` (same values, same derivatives)."""
    dtype = jnp.result_type(a, b)
    shape = jnp.broadcast_shapes(jnp.shape(pred), jnp.shape(a), jnp.shape(b))

    def fit(x, dt):
        x = jax.lax.convert_element_type(x, dt)
        if x.shape == shape:
            return x
        return jax.lax.broadcast_in_dim(x, shape, tuple(range(len(shape) - x.ndim, len(shape))))

    return jax.lax.select(fit(pred, bool), fit(a, dtype), fit(b, dtype))


def _clip(x, lo, hi):
    """``jnp.clip(x, lo, hi)`` (its definition: ``minimum(maximum(x, lo), hi)``)."""
    return jnp.minimum(jnp.maximum(x, lo), hi)


def _floordiv(k, n: int):
    """``k // n`` for ``k >= 0`` (an int array) and a static ``n >= 1``."""
    return k if n == 1 else jax.lax.div(k, jnp.asarray(n, k.dtype))


def _mod(k, n: int):
    """``k % n`` for ``k >= 0`` (an int array) and a static ``n >= 1``."""
    return jnp.zeros_like(k) if n == 1 else jax.lax.rem(k, jnp.asarray(n, k.dtype))


def _cond(pred, on_true, on_false):
    """``lax.cond(pred, on_true, on_false)`` for branches without arguments, differentiated as
    a ``select`` of both branches.

    The solver's ``cond``s only skip work (a branch's result where ``pred`` fails is never
    read), so both forms have the same values and derivatives. Linearising a ``cond`` nested
    in the checkpointed loop's backward pass made up most of the time to trace ``grad`` of a
    run; its derivative rule here is straight-line code. The run itself keeps the ``cond``.
    Under differentiation the branch not taken is evaluated too, on the same inputs, so it
    must give finite derivatives there (``tests/test_housner.py``: at rest, rocking and
    overturning).
    """
    branches = (eqx.filter_closure_convert(on_true), eqx.filter_closure_convert(on_false))
    arrays, static = eqx.partition(branches, eqx.is_array)
    leaves, treedef = jax.tree.flatten(arrays)

    def rebuild(leaves):
        return eqx.combine(jax.tree.unflatten(treedef, leaves), static)

    @jax.custom_jvp
    def run(pred, *leaves):
        on_true, on_false = rebuild(leaves)
        return jax.lax.cond(pred, lambda: on_true(), lambda: on_false())

    @run.defjvp
    def run_jvp(primals, tangents):
        a, da = jax.jvp(lambda *ls: rebuild(ls)[0](), primals[1:], tangents[1:])
        b, db = jax.jvp(lambda *ls: rebuild(ls)[1](), primals[1:], tangents[1:])

        def pick(x, y):
            if jnp.result_type(x) == jax.dtypes.float0:  # (integer outputs: no tangent)
                return x
            return _where(primals[0], x, y)

        return jax.tree.map(pick, a, b), jax.tree.map(pick, da, db)

    return run(pred, *leaves)


# --------------------------------------------------------------------------- state and forcing


class _State(eqx.Module):
    """The solver state: float64 scalars, carried by the loop and saved at the samples."""

    theta: Array  # rotation [rad]
    theta_dot: Array  # angular velocity [rad/s]
    s: Array  # pivot: +1, -1, or 0 at rest
    overturned: Array  # 1.0 once overturned (then frozen)
    n_impacts: Array  # impacts so far
    t_last_impact: Array  # time of the latest impact [s] (-inf before the first)
    theta_max: Array  # running max |theta| [rad], on each step's dense output
    n_unresolved: Array  # steps that needed more than max_impacts_per_step impacts


class _Series(eqx.Module):
    """The part of the state saved at every sample (the rest is needed only at the end). Inside
    the loop its fields are the loop's buffers, not arrays: hence no annotations to check."""

    theta: Any
    theta_dot: Any
    s: Any
    n_impacts: Any
    t_last_impact: Any


def _series(y: _State) -> _Series:
    return _Series(y.theta, y.theta_dot, y.s, y.n_impacts, y.t_last_impact)


class _Params(eqx.Module):
    """Per-run constants of the step (built once, traced or not)."""

    p2_over_g: Array  # p^2 / g [1/m]
    sin_eta: Array
    cos_eta: Array
    tan_eta: Array
    eta: Array  # [rad]
    e: Array  # restitution magnitude [-]
    theta_u: Array  # rotation [rad] past which the block overturns (eta for the rigid block)
    lam_up: Array  # static uplift threshold |a_g| / g_eff [-] at rest (tan eta, rigid block)
    w2_tiny: Array  # rebound speed^2 [rad^2/s^2] below which the rest rule's 2nd clause rests
    law: _LawTerms | None  # the three-branch law's restoring terms; None: the rigid block


class _LawTerms(eqx.Module):
    """A :class:`rockjax.ThreeBranchLaw` as the solver uses it (docs/three_branch.md): on the
    pivot's side, ``u = s theta``, the static capacity is ``Lambda(u) = alpha_k + beta_k
    tan(eta - u)`` on branch ``k`` (``u < u1``, ``u < u2``, else), so the restoring moment
    ``m g R cos(eta - u) Lambda`` is ``m g R (alpha_k cos(eta - u) + beta_k sin(eta - u))``."""

    u1: Array  # rotation at d/b = Delta_1 [rad]
    u2: Array  # rotation at d/b = Delta_2 [rad]
    alpha: Array  # (3,) [-]
    beta: Array  # (3,) [-]

    def coefficients(self, u):
        """``(alpha, beta)`` of the branch holding rotation ``u`` [rad]."""
        first, plateau = u < self.u1, u < self.u2
        alpha = _where(first, self.alpha[0], _where(plateau, self.alpha[1], self.alpha[2]))
        beta = _where(first, self.beta[0], _where(plateau, self.beta[1], self.beta[2]))
        return alpha, beta


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


def _hermite(r, terms):
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


class _WallStep(eqx.Module):
    """A moving wall on one solver step ``[t0, t0 + h]``: the cubic Hermite fit of its
    rotation and rate at the step's ends (:meth:`_Record.segment`), which is the wall's cubic
    on the sample interval holding the step (:meth:`_Record.wall`), without its gathers."""

    t0: Array  # [s]
    h: Array  # [s]
    terms: tuple  # (theta at t0, rate at t0 * h, theta at t0 + h, rate there * h)

    def at(self, t):
        """``(theta_w, theta_w', theta_w'')`` at time ``t`` in the step [rad, rad/s, rad/s^2]."""
        theta, rate, accel = _hermite((t - self.t0) / self.h, self.terms)
        return theta, rate / self.h, accel / (self.h * self.h)


class _Given(eqx.Module):
    """Forcing already evaluated where it is needed: ``at`` ignores the time."""

    a_g: Array  # [m/s^2]
    g_eff: Array | float  # [m/s^2]

    def at(self, t):
        """``(a_g, g_eff)`` [m/s^2]."""
        return self.a_g, self.g_eff


class _Record(eqx.Module):
    """The whole record on its uniform grid ``t_i = i dt``, linear between samples.

    ``ag_v`` may be None. Evaluation indexes the grid directly (no search): the step ends and
    the rest rule's look-ahead times need the forcing at arbitrary times.
    """

    ag: Array  # [m/s^2], one value per sample (padded by repeating the last one)
    ag_v: Array | None
    dt: Array  # sample spacing [s]: data, so records of any step share one compilation
    # A moving return wall (one-sided; docs/three_branch.md, "Moving return walls"): the
    # block's stop (_wall_stop: the wall's rotation theta_w = u_top / h, or the base where the
    # wall has receded behind it) [rad] and its rate [rad/s] at the samples, or None.
    wall_theta: Array | None = None
    wall_rate: Array | None = None
    # With a moving wall, computed once per run (``with_wall_steps``): for every solver step,
    # the uplift excess (``_wall_excess``) of a block resting on the wall at the step's start
    # and at its end, on the step (the wall's acceleration may jump at a sample), shape
    # (2, (n - 1) n_sub). A pass reads its uplift check from its step's column instead of
    # evaluating the wall's cubic; the rest rule's look-ahead reads the first row.
    wall_steps: Array | None = None

    def wall(self, t):
        """``(theta_w, theta_w', theta_w'')`` at time ``t`` [rad, rad/s, rad/s^2]: the cubic
        Hermite fit of the samples' rotation and rate on the interval holding ``t`` (at a
        sample: the one it starts), exact for a wall whose acceleration is linear between
        samples. (A solver step reads its own interval: :class:`_WallStep`.)"""
        n = self.wall_theta.shape[0]
        x = _clip(t / self.dt, 0.0, n - 1.0)
        i = jax.lax.stop_gradient(_clip(jnp.floor(x), 0.0, n - 2.0))
        r = x - i
        i = i.astype(jnp.int32)
        p0, p1 = self.wall_theta[i], self.wall_theta[i + 1]
        m0, m1 = self.wall_rate[i] * self.dt, self.wall_rate[i + 1] * self.dt
        theta, rate, accel = _hermite(r, (p0, m0, p1, m1))
        return theta, rate / self.dt, accel / (self.dt * self.dt)

    def with_wall_steps(self, params: _Params, n_sub: int) -> _Record:
        """This record with ``wall_steps`` filled in (a moving wall only), for ``n_sub``
        solver steps per sample interval: the wall's cubic (:meth:`wall`) and the forcing at
        every step end at once, from slices (no gathers)."""
        dt = self.dt
        terms = (  # p0, m0, p1, m1 of every interval, as in wall()
            self.wall_theta[:-1],
            self.wall_rate[:-1] * dt,
            self.wall_theta[1:],
            self.wall_rate[1:] * dt,
        )
        # (theta_w, rate, accel) at the fractions 0, 1/n_sub, ..., 1 of every interval
        at = [_hermite(q / n_sub, terms) for q in range(n_sub + 1)]

        def steps(columns):  # one value per interval and step in it: step by step
            return jnp.stack(columns, axis=1).reshape(-1)

        def ends(columns, samples):  # at the step ends (at the samples: the samples' own)
            if n_sub == 1:
                return samples
            return jnp.concatenate([steps(columns), samples[-1:]])

        def forcing(a):  # the record's linear interpolation
            return ends([a[:-1] + (q / n_sub) * (a[1:] - a[:-1]) for q in range(n_sub)], a)

        theta_w = ends([c[0] for c in at[:-1]], self.wall_theta)
        # the wall's acceleration where each step starts and ends, inside its interval
        accel_start = steps([c[2] for c in at[:-1]]) / (dt * dt)
        accel_end = steps([c[2] for c in at[1:]]) / (dt * dt)
        g_eff = G if self.ag_v is None else G + forcing(self.ag_v)
        given = _Given(a_g=forcing(self.ag), g_eff=g_eff)
        # (a wall's rotation is mostly a small angle: the sine's and cosine's shorter series)
        free = jax.lax.cond(
            jnp.max(jnp.abs(theta_w)) <= _SMALL_ANGLE,
            lambda: _theta_ddot(None, theta_w, jnp.ones_like(theta_w), params, given, True),
            lambda: _theta_ddot(None, theta_w, jnp.ones_like(theta_w), params, given),
        )
        k = params.p2_over_g * params.cos_eta
        table = jnp.stack([(free[:-1] - accel_start) / k, (free[1:] - accel_end) / k])
        return eqx.tree_at(lambda r: r.wall_steps, self, table, is_leaf=lambda x: x is None)

    @property
    def n_sub(self) -> int:
        """Solver steps per sample interval of ``wall_steps`` (static: from the shapes)."""
        return self.wall_steps.shape[1] // max(self.wall_theta.shape[0] - 1, 1)

    def segment(self, k):
        """The moving wall on solver step ``k`` (:class:`_WallStep`), from the two samples of
        the interval holding it (two slices, no search)."""
        n, n_sub = self.wall_theta.shape[0], self.n_sub
        i = jnp.minimum(_floordiv(k, n_sub), n - 2)
        theta2 = jax.lax.dynamic_slice_in_dim(self.wall_theta, i, 2)
        rate2 = jax.lax.dynamic_slice_in_dim(self.wall_rate, i, 2) * self.dt
        terms = (theta2[0], rate2[0], theta2[1], rate2[1])
        r0 = _mod(k, n_sub).astype(float) / n_sub
        dt_step = self.dt / n_sub
        ends = [_hermite(r, terms) for r in (r0, r0 + 1.0 / n_sub)]
        t0 = _step_time(k, n_sub, self.dt, dt_step)
        return _WallStep(
            t0,
            dt_step,
            (ends[0][0], ends[0][1] / n_sub, ends[1][0], ends[1][1] / n_sub),
        )

    def excess_at_samples(self, i):
        """``_wall_excess`` [m/s^2] on the interval that starts at samples ``i`` (integers,
        clipped to the record), from ``wall_steps``."""
        n = self.wall_theta.shape[0]  # (the last sample: the last interval's start)
        return self.wall_steps[0, _clip(i, 0, n - 2) * self.n_sub]

    def _eval(self, ys, t):
        n = ys.shape[0]
        x = _clip(t / self.dt, 0.0, n - 1.0)
        i = jax.lax.stop_gradient(_clip(jnp.floor(x), 0.0, n - 2.0))
        frac = x - i
        i = i.astype(jnp.int32)
        return ys[i] + frac * (ys[i + 1] - ys[i])

    def sample(self, i):
        """``(a_g, g_eff)`` at sample ``i`` (an integer array, clipped to the record) [m/s^2]."""
        i = _clip(i, 0, self.ag.shape[0] - 1)
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


@functools.partial(jax.custom_jvp, nondiff_argnums=(1,))
def _sincos(x, small: bool):
    """``(sin x, cos x)`` from Taylor polynomials in ``x^2``: within 4e-16 for ``|x| <= 2`` rad,
    or with ``small`` (five and six terms) for ``|x| <= _SMALL_ANGLE``.

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


@_sincos.defjvp
def _sincos_jvp(small, primals, tangents):
    (x,), (dx,) = primals, tangents
    sin_x, cos_x = _sincos(x, small)
    return (sin_x, cos_x), (cos_x * dx, -sin_x * dx)


@functools.partial(jax.jit, static_argnames="small")
def _theta_ddot(t, theta, s, params: _Params, forcing, small: bool = False):
    """Angular acceleration [rad/s^2] on pivot ``s = +-1`` (module docstring equation).

    Uses ``sin(s eta - theta)`` and ``cos(s eta - theta)`` expanded with ``s^2 = 1``, so each
    evaluation needs only the sine and cosine of ``theta``. Jitted although an inner helper:
    its seven calls in a pass then share one traced graph, which ``grad`` transforms once
    instead of seven times (a fifth of the time to trace; XLA inlines it, so runs are
    unchanged).
    """
    ag, g_eff = forcing.at(t)
    sin_th, cos_th = _sincos(theta, small)
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


def _rk_step(accel, t0, h, theta0, theta_dot0):
    """One explicit Runge-Kutta step (diffrax's Tsit5 tableau, unrolled) of
    ``(theta, theta_dot)' = (theta_dot, accel(t, theta))`` from ``t0`` over ``h`` [s].

    Returns:
        ``(theta1, theta_dot1, peak)``: the state at ``t0 + h`` and the largest ``|theta|``
        [rad] of the step's dense output (:func:`_dense_peak`).
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
    return theta1, theta_dot1, _dense_peak(theta0, theta1, h, (*k_th, theta_dot1))


def _dense_peak(theta0, theta1, h, k_th):
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
        best_x, best_p = _where(better, x, best_x), _where(better, p, best_p)
    # P' and P'' (no derivative: the location only)
    a1, a2, a3, a4 = (jax.lax.stop_gradient(v) for v in (c1, 2.0 * c2, 3.0 * c3, 4.0 * c4))
    b2, b3 = 3.0 * a4, 2.0 * a3
    sign = _where(best_p < 0, -1.0, 1.0)
    lo, hi = jnp.maximum(best_x - 0.25, 0.0), jnp.minimum(best_x + 0.25, 1.0)
    x = best_x
    for _ in range(_N_PEAK_NEWTON):
        dp = ((a4 * x + a3) * x + a2) * x + a1
        ddp = (b2 * x + b3) * x + a2
        x = _where(sign * ddp < 0, _clip(x - dp / _safe(ddp), lo, hi), x)
    return jnp.maximum(jnp.abs(best_p), jnp.abs(value(x)))


def _safe(x):
    """``x``, or 1 where ``|x|`` is negligible (only reached in masked-out branches)."""
    return _where(jnp.abs(x) > _TINY, x, 1.0)


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
    q = -0.5 * (b + _where(b >= 0, 1.0, -1.0) * jnp.sqrt(disc))
    x_small = c1 / _safe(q)  # the root of smaller magnitude (stable form)
    x_big = q / _safe(a)
    x = _where((x_small >= 0) & (x_small <= 1), x_small, x_big)
    x = _clip(x, 0.0, 1.0)
    turns = (du0 < 0) & (du1 > 0)
    u_turn = ((c3 * x + c2) * x + c1) * x + u0
    return _where(turns, x, 1.0), _where(turns, u_turn, u1)


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

    # The bracket carries no derivative: bisect on constants (nothing to trace under jvp).
    a0, a1, a2, a3 = (jax.lax.stop_gradient(v) for v in (u0, c1, c2, c3))
    lo = jnp.zeros_like(a0)
    hi = jnp.broadcast_to(jax.lax.stop_gradient(xb), jnp.shape(a0)).astype(a0.dtype)
    for _ in range(_N_BISECT):
        mid = 0.5 * (lo + hi)
        pos = ((a3 * mid + a2) * mid + a1) * mid + a0 > 0
        lo, hi = _where(pos, mid, lo), _where(pos, hi, mid)
    # Roots of u0 + c1 x + c2 x^2 in the stable form: u0 / q and q / c2.
    q = -0.5 * (a1 + _where(a1 >= 0, 1.0, -1.0) * jnp.sqrt(jnp.maximum(a1 * a1 - 4 * a2 * a0, 0)))
    r1, r2 = a0 / _safe(q), q / _safe(a2)
    r1 = _where((r1 > 0) & (r1 <= hi), r1, jnp.inf)
    r2 = _where((r2 > 0) & (r2 <= hi), r2, jnp.inf)
    guess = jnp.minimum(r1, r2)
    x = _where((lo == 0) & jnp.isfinite(guess), guess, 0.5 * (lo + hi))
    for _ in range(_N_NEWTON):
        slope = (3.0 * c3 * x + 2.0 * c2) * x + c1
        x = _clip(x - cubic(x) / _safe(slope), lo, hi)
    return x


def _uplift(ta, t1, line: _Line | None, params: _Params, one_sided: bool, excess=None):
    """First time in ``[ta, t1]`` the linear forcing exceeds the uplift threshold, and the pivot.

    Two-sided: ``a_g - tan(eta) g_eff > 0`` lifts onto ``s = -1``, ``-a_g - tan(eta) g_eff > 0``
    onto ``s = +1``; one-sided only the latter. Both are linear in ``t``.

    With a moving wall ``excess`` gives the excess at ``ta`` and ``t1`` instead (see
    ``_wall_excess``), linear in between, and ``line`` is not read (None).

    Returns:
        ``(lifts, t_uplift, s)``: whether it lifts in the interval, when [s], and the pivot.
    """

    # A block at rest where the excess forcing f (m/s^2 beyond the threshold) is positive but
    # falls back below zero inside the interval makes a flight from rest of at most
    # (2/3) k f(ta) tau^2 [rad] (k f the angular acceleration it starts with, tau the time
    # until f = 0; docs/theory.md, "Housner rest and chatter rule"). Below REST_HOP eta that
    # flight is not started, as the rest rule gives up a rebound of that size: otherwise a
    # block put to rest a root-finding tolerance before the forcing drops below the threshold
    # lifts again at once and chatters in place.
    k = params.p2_over_g * params.cos_eta
    hop_limit = REST_HOP * params.eta

    def first_positive(fa, fb):
        frac = _clip(-fa / _safe(fb - fa), 0.0, 1.0)
        tau = frac * (t1 - ta)
        micro = (fa > 0) & (fb <= 0) & ((2.0 / 3.0) * k * fa * tau * tau <= hop_limit)
        t = _where(fa > 0, ta, ta + tau)
        return ((fa > 0) | (fb > 0)) & ~micro, t

    if excess is not None:
        lifts_pos, t_pos = first_positive(*excess)
        return lifts_pos, t_pos, jnp.ones_like(ta)
    a_a, g_a = line.at(ta)
    a_b, g_b = line.at(t1)
    tan_eta = params.lam_up  # tan(eta) for the rigid block; the law's threshold otherwise
    lifts_pos, t_pos = first_positive(-a_a - tan_eta * g_a, -a_b - tan_eta * g_b)
    if one_sided:
        return lifts_pos, t_pos, jnp.ones_like(ta)
    lifts_neg, t_neg = first_positive(a_a - tan_eta * g_a, a_b - tan_eta * g_b)
    neg_first = lifts_neg & (~lifts_pos | (t_neg < t_pos))
    return (
        lifts_pos | lifts_neg,
        _where(neg_first, t_neg, t_pos),
        _where(neg_first, -1.0, 1.0),
    )


def _flight(pred, accel, t0, h, theta0, theta_dot0):
    """``_rk_step`` where ``pred`` (one bool for the whole batch) holds, else the start state
    (and ``|theta0|`` as the peak).

    The ``cond`` skips steps that no record of a ``vmap`` batch needs (``pred`` is reduced with
    ``unvmap_any``, as diffrax does for its FSAL stage). It also keeps the unrolled stages one
    XLA computation: inlined, XLA's CPU fusion copied them into every consumer of the result
    and a step ran three times slower.
    """
    return _cond(
        eqxi.unvmap_any(pred),
        lambda: _rk_step(accel, t0, h, theta0, theta_dot0),
        lambda: (theta0, theta_dot0, jnp.abs(theta0)),
    )


def _restoring(a_g, g_eff, params: _Params):
    """``(A_+, A_-)`` [rad/s^2]: ``-s theta_ddot`` at ``theta = 0`` on pivot ``s = +-1``.

    From the equation of motion, ``A_s = (p^2 cos(eta) / g) (g_eff tan(eta) + s a_g)`` (with a
    three-branch law ``tan(eta)`` becomes its threshold ``lambda_uplift``): positive
    when the forcing is below the uplift threshold on that side, so a flight on pivot ``s`` that
    starts at ``theta = 0`` returns to it.
    """
    k = params.p2_over_g * params.cos_eta
    return k * (g_eff * params.lam_up + a_g), k * (g_eff * params.lam_up - a_g)


def _wall_excess(t, wall, params: _Params, forcing):
    """How much faster than the wall [m/s^2, as ``theta_ddot / k``, ``k = p^2 cos(eta) / g``]
    a block resting against it at ``theta = theta_w(t)`` would accelerate away from it on its
    own (pivot +1): it leaves the wall when this turns positive. Without wall motion it is
    ``-a_g - g_eff tan(eta)``, the fixed wall's uplift excess. ``wall``: the wall's
    ``(theta_w, theta_w', theta_w'')`` at ``t``."""
    theta_w, _, accel_w = wall
    free = _theta_ddot(t, theta_w, jnp.ones_like(theta_w), params, forcing)
    return (free - accel_w) / (params.p2_over_g * params.cos_eta)


def _rests(
    t_imp, w, s_new, line: _Line, record: _Record, params: _Params, one_sided: bool, step=None
):
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
    k = params.p2_over_g * params.cos_eta
    if record.wall_theta is None:
        ap0, am0 = _restoring(*line.at(t_imp), params)
    else:  # relative to the moving wall: A_+ = -(block's free acceleration - wall's)
        ap0 = -k * _wall_excess(t_imp, step.at(t_imp), params, line)
        am0 = ap0
    e = params.e
    if one_sided:
        a_new = a_other = ap0
        ok0 = ap0 > 0
        zeno = 2.0 * w / _safe((1.0 - e) * ap0)
    else:
        a_new = _where(s_new > 0, ap0, am0)
        a_other = _where(s_new > 0, am0, ap0)
        ok0 = (ap0 > 0) & (am0 > 0)
        zeno = 2.0 * w / _safe(1.0 - e * e) * (1.0 / _safe(a_new) + e / _safe(a_other))
    ok0 = ok0 & (e < 1.0)
    fits = ok0 & (2.0 * zeno <= REST_HORIZON * record.dt)
    t_end = t_imp + _where(fits, 2.0 * zeno, 0.0)

    def keeps(ap, am, inside):
        ok = ~inside | (ap >= REST_A_MARGIN * ap0)
        return ok if one_sided else ok & (~inside | (am >= REST_A_MARGIN * am0))

    def restoring_at(t):
        if record.wall_theta is None:
            return _restoring(*record.at(t), params)
        a = -k * _wall_excess(t, record.wall(t), params, record)
        return a, a

    def restoring_samples(i):
        if record.wall_theta is None:
            return _restoring(*record.sample(i), params)
        a = -k * record.excess_at_samples(i)
        return a, a

    stays = fits & keeps(*restoring_at(t_end), jnp.ones_like(fits))
    # the samples inside (t_imp, t_end), all at once (one gather, a small graph)
    i = jax.lax.stop_gradient(jnp.floor(t_imp / record.dt)).astype(jnp.int32)
    i = i + jnp.arange(1, REST_HORIZON + 1, dtype=jnp.int32)
    inside = i * record.dt < t_end
    stays = stays & jnp.all(keeps(*restoring_samples(i), inside))
    hop = w * w / (2.0 * _safe(_where(ok0, a_new, 1.0)))
    # Second clause: a rebound too small to matter (its gravity-only hop <= REST_HOP eta).
    tiny = w * w <= params.w2_tiny
    rests = stays | tiny
    return rests, _where(stays, hop, 0.0)


class _Hit(eqx.Module):
    """A crossing found by a pass and resolved by the next one (see ``_pass``)."""

    pending: Array  # bool: the next pass resolves an impact
    tau: Array  # the crossing time from the step's cubic fit [s]
    t_hi: Array  # the end of the bracket it lies in [s]
    # With a three-branch law: the level of u = s theta crossed [rad], 0 for the wall (an
    # impact) or a kink of the law (u1, u2 > 0: the state is put on it, nothing else changes).
    level: Array | None = None


def _pass(
    y: _State,
    ta,
    hit: _Hit,
    k,
    t0,
    t1,
    record: _Record,
    params: _Params,
    one_sided: bool,
):
    """One masked pass of a step, of one of two kinds, with one Runge-Kutta step either way
    (so the loop body holds one copy of it: half the graph to trace and compile).

    * Explore (no ``hit.pending``): uplift, RK to ``t1``. Without a crossing the state moves to
      ``t1``; with one, it stays at ``ta`` and the crossing time from the step's cubic fit is
      handed to the next pass as a pending hit.
    * Impact (``hit.pending``): RK to the crossing time ``tau``, one Newton correction
      ``tau' = tau - theta/theta_dot`` on the true trajectory with the state advanced linearly
      to ``tau'``, the impact map and the rest rule; the state holds at ``tau'``.

    A pass that finds every run of the batch at rest and not lifting in ``[ta, t1]``, or
    overturned, is a quiet pass: the state moves to ``t1``; the rest of the pass
    (:func:`_active_pass`) would change nothing else. Most passes of an IDA are quiet (the low
    scales never lift), and a ``cond`` skips their flight, crossing and impact work.

    A block at rest on a moving wall rides on it, but its state in the loop keeps the rotation
    and rate it came to rest with: nothing in a pass reads them (a lift-off starts from the
    wall's state), and :func:`_on_the_wall` puts the saved samples on the wall after the loop
    (updated in every pass, they were work that a quiet pass does not need).

    ``k`` is the step in progress (from ``t0`` to ``t1``). Returns the state, the time it holds
    at and the hit for the next pass.
    """
    pending = hit.pending
    if record.wall_theta is None:
        # (1) At rest: lift off when the forcing first exceeds the threshold in [ta, t1].
        line = record.line(t0, t1)
        lifts, t_up, s_up = _uplift(ta, t1, line, params, one_sided)
        lift_now = (y.s == 0) & lifts & (y.overturned == 0) & ~pending
        quiet = ~pending & ~lift_now & ((y.s == 0) | (y.overturned != 0))
        uplift, wall = (None, t_up, s_up, lift_now), None
    else:  # one-sided with a moving return wall: the step's two columns of the wall table
        column = jax.lax.dynamic_slice_in_dim(record.wall_steps, k, 1, axis=1)
        excess_a, excess_b = column[0, 0], column[1, 0]
        # The check from the table holds for a pass that starts at the step's start; one
        # that starts later (after an impact inside the step) is never quiet.
        from_start = ta == t0
        lifts = _uplift(ta, t1, None, params, one_sided, (excess_a, excess_b))[0]
        line = None  # (the forcing on the step: only an active pass needs it)
        at_rest = (y.s == 0) & from_start & ~lifts
        quiet = ~pending & (at_rest | (y.overturned != 0))
        uplift = (excess_b, from_start, excess_a)
        wall = k
    return _cond(
        eqxi.unvmap_all(quiet),
        lambda: (y, t1 + jnp.zeros_like(ta), hit),
        lambda: _active_pass(
            y,
            ta,
            hit,
            t1,
            record.line(t0, t1) if line is None else line,
            record,
            params,
            one_sided,
            uplift,
            wall,
        ),
    )


def _active_pass(
    y: _State,
    ta,
    hit: _Hit,
    t1,
    line: _Line,
    record: _Record,
    params: _Params,
    one_sided: bool,
    uplift,
    wall,
):
    """:func:`_pass` past its quiet check. ``uplift``: with a fixed wall the check's result
    (None, the uplift time and pivot, whether the block lifts now); with a moving wall the
    wall's excess at ``t1``, whether the pass starts at the step's start, and the excess
    there. ``wall``: with a moving wall the step in progress (None for a fixed wall)."""
    pending = hit.pending
    moving_wall = wall is not None
    if moving_wall:
        # (built here, not in _pass: a quiet pass needs none of it)
        step = record.segment(wall)
        wall_t1 = (step.terms[2], step.terms[3] / step.h)
        # (1) At rest: lift off when the block's excess over the wall first turns positive.
        excess_b, from_start, excess_start = uplift
        # inside the step only after an impact (rare): the wall's excess there
        inside = ~from_start & (y.s == 0) & (y.overturned == 0) & ~pending
        excess_a = _cond(
            eqxi.unvmap_any(inside),
            lambda: _where(from_start, excess_start, _wall_excess(ta, step.at(ta), params, line)),
            lambda: excess_start,
        )
        excess = (excess_a, excess_b)
        lifts, t_up, s_up = _uplift(ta, t1, line, params, one_sided, excess)
        lift_now = (y.s == 0) & lifts & (y.overturned == 0) & ~pending
    else:
        excess, t_up, s_up, lift_now = uplift
        step = None
    s = _where(lift_now, s_up, y.s)
    ta = _where(lift_now, t_up, ta)
    rocking = (s != 0) & (y.overturned == 0)
    theta_a, theta_dot_a = y.theta, y.theta_dot
    if moving_wall:  # at rest the block rides on the wall: it lifts with the wall's state
        wall_up, rate_up, _ = step.at(ta)
        theta_a = _where(lift_now, wall_up, theta_a)
        theta_dot_a = _where(lift_now, rate_up, theta_dot_a)

    def accel(t, theta):
        return _theta_ddot(t, theta, s, params, line)

    # (2) Smooth flight on pivot s: to t1 (explore) or to tau (impact).
    h = t1 - ta
    theta_f, theta_dot_f, peak = _flight(
        pending | (rocking & (h > 0)),
        accel,
        ta,
        _where(pending, hit.tau - ta, h),
        theta_a,
        theta_dot_a,
    )

    # (3) Explore: a crossing if u = s theta ends negative, or ends positive after dipping
    # below zero inside the step (a graze; the cubic Hermite fit of u has its turning point
    # below zero). Its time: the fit's first root (bisection, then Newton).
    u0, du0, u1, du1 = s * theta_a, h * s * theta_dot_a, s * theta_f, h * s * theta_dot_f
    # the gap to the wall: g = u, or theta - theta_w(t) with a moving wall (pivot s = +1)
    g0, dg0, g1, dg1 = u0, du0, u1, du1
    if moving_wall:
        wall_a, rate_a, _ = step.at(ta)
        wall_b, rate_b = wall_t1
        g0, dg0 = theta_a - wall_a, h * (theta_dot_a - rate_a)
        g1, dg1 = theta_f - wall_b, h * (theta_dot_f - rate_b)
    x_turn, g_turn = _cond(
        eqxi.unvmap_any(~pending & rocking & (dg0 < 0) & (dg1 > 0) & (g1 >= 0)),
        lambda: _hermite_turn(g0, dg0, g1, dg1),
        lambda: (jnp.ones_like(g1), g1),
    )
    grazes = (g1 >= 0) & (g0 >= 0) & (g_turn < 0)
    crossed = ~pending & rocking & (h > 0) & ((g1 < 0) | grazes)
    if moving_wall:
        # Lifted off in this step with the excess still positive at its end: the gap's second
        # derivative stays positive (the excess is linear), so it cannot close. The gap starts
        # as (t - t_up)^3 and is the difference of two nearly equal rotations: its rounding
        # must not be taken for an impact (that chattered in place).
        clear = lift_now & (excess[1] > 0)
        crossed = crossed & ~clear
        theta_f = _where(clear, jnp.maximum(theta_f, wall_b), theta_f)
    xb = _where(g1 < 0, 1.0, x_turn)
    x = _hermite_root(g0, dg0, g1, dg1, xb)
    level = None
    if params.law is not None:
        # The law's kinks are events too: a step that straddles one loses Tsit5's order
        # (measured: energy errors of 1e-4 per crossing at p dt = 0.03), so it is cut there.
        crossed, x, xb, level = _kink_crossings(
            crossed, x, xb, u0, du0, u1, du1, ~pending & rocking & (h > 0), params.law
        )
    advance = ~pending & rocking & ~crossed

    # (4) Impact: one Newton step on the true trajectory, the impact map, the rest rule.
    theta_tau, theta_dot_tau = theta_f, theta_dot_f
    if moving_wall:
        wall_tau, rate_tau, _ = step.at(hit.tau)
        gap, closing = theta_tau - wall_tau, theta_dot_tau - rate_tau
        t_wall = _clip(hit.tau - gap / _safe(closing), ta, hit.t_hi)
    else:
        t_wall = _clip(hit.tau - theta_tau / _safe(theta_dot_tau), ta, hit.t_hi)
    if hit.level is None:
        t_impact = t_wall
        wall = pending
        theta_at = jnp.zeros_like(t_wall)
    else:  # a kink: the same Newton step to u = level, then no impact map
        wall = pending & (hit.level == 0)
        theta_kink = s * hit.level
        t_kink = _clip(hit.tau - (theta_tau - theta_kink) / _safe(theta_dot_tau), ta, hit.t_hi)
        t_impact = _where(wall, t_wall, t_kink)
        theta_at = _where(wall, 0.0, theta_kink)
    theta_dot_tau = theta_dot_tau + accel(hit.tau, theta_tau) * (t_impact - hit.tau)
    rate_at = jnp.zeros_like(t_impact)  # the wall's rate at the impact [rad/s]
    if moving_wall:
        # restitution of the velocity relative to the wall (the paper's rule in its frame)
        wall_at, rate_at, _ = step.at(t_impact)
        theta_at = _where(wall, wall_at, theta_at)
        theta_dot_plus, s_plus = rate_at - params.e * (theta_dot_tau - rate_at), s
    elif one_sided:
        theta_dot_plus, s_plus = -params.e * theta_dot_tau, s
    else:
        theta_dot_plus, s_plus = params.e * theta_dot_tau, -s
    if hit.level is not None:
        theta_dot_plus = _where(wall, theta_dot_plus, theta_dot_tau)
        s_plus = _where(wall, s_plus, s)
    # The rule reads the record at up to REST_HORIZON + 2 times (gathers, the costliest part
    # of a pass in a batch): only when some record of the batch impacts.
    rebound = jnp.abs(theta_dot_plus - rate_at) if moving_wall else jnp.abs(theta_dot_plus)
    rests, hop = _cond(
        eqxi.unvmap_any(pending),
        lambda: _rests(t_impact, rebound, s_plus, line, record, params, one_sided, step),
        lambda: (jnp.zeros_like(pending), jnp.zeros_like(t_impact)),
    )
    rests = wall & rests

    # the flight's peak on its dense output (to the crossing: the state there is within a
    # Newton step of the impact); theta_f, not the flight's end, where the wall cleared it
    peak = jnp.maximum(jnp.maximum(peak, jnp.abs(theta_f)), _where(rests, hop, 0.0))
    # Not rocking (at rest and not lifting, or overturned): nothing moves. A crossing found
    # keeps the state (and the pivot it lifted onto) at ta for the impact pass.
    theta_rest, theta_dot_rest = y.theta, y.theta_dot  # (on a moving wall: see _pass)
    theta_max = _where(pending | advance, jnp.maximum(y.theta_max, peak), y.theta_max)
    y_new = _State(
        theta=_where(pending, theta_at, _where(advance, theta_f, theta_rest)),
        theta_dot=_where(
            pending,
            _where(rests, rate_at, theta_dot_plus),
            _where(advance, theta_dot_f, theta_dot_rest),
        ),
        s=_where(pending, _where(rests, 0.0, s_plus), _where(rocking, s, y.s)),
        overturned=y.overturned,
        n_impacts=y.n_impacts + wall,
        t_last_impact=_where(wall, t_impact, y.t_last_impact),
        theta_max=theta_max,
        n_unresolved=y.n_unresolved,
    )
    ta_new = _where(pending, t_impact, _where(crossed, ta, t1))
    hit_new = _Hit(
        pending=crossed,
        tau=_where(crossed, ta + x * h, hit.tau),
        t_hi=_where(crossed, ta + xb * h, hit.t_hi),
        level=None if level is None else _where(crossed, level, hit.level),
    )
    return y_new, ta_new, hit_new


def _kink_crossings(crossed, x, xb, u0, du0, u1, du1, exploring, law: _LawTerms):
    """The first of the wall crossing (``crossed`` at ``x`` in [0, ``xb``]) and the law's kinks
    ``u = u1`` (when ``Delta_1 > 0``) and ``u = u2`` (when ``Delta_2 > Delta_1``) crossed inside
    the step (a change of sign of ``u - level`` between its ends; a kink grazed and left within
    one step is not cut), as ``(crossed, x, xb, level)`` with ``level = 0`` for the wall."""
    level = jnp.zeros_like(x)
    for c, active in ((law.u1, law.u1 > 0), (law.u2, law.u2 > law.u1)):
        sign = _where(u0 > c, 1.0, -1.0)  # so that the fit of sign (u - c) starts >= 0
        w0, w1 = sign * (u0 - c), sign * (u1 - c)
        hits = exploring & active & (w0 > 0) & (w1 < 0)
        xk = _hermite_root(w0, sign * du0, w1, sign * du1, jnp.ones_like(x))
        first = hits & (~crossed | (xk < x))
        x = _where(first, xk, x)
        xb = _where(first, 1.0, xb)
        level = _where(first, c, level)
        crossed = crossed | hits
    return crossed, x, xb, level


# --------------------------------------------------------------------------- the run


class _Carry(eqx.Module):
    """The loop state: one pass per iteration, the solver step in progress, the saved samples."""

    y: _State
    ta: Array  # the time the state holds at [s]
    k: Array  # the step in progress (int32), from _step_time(k) to _step_time(k + 1)
    passes: Array  # exploring passes made in this step (int32)
    hit: _Hit  # a crossing for the next pass to resolve
    out: _Series  # the state at the samples: loop buffers, each sample written once


def _step_time(k, n_sub: int, dt_out, dt_step):
    """End ``k`` of the solver steps [s]: the samples ``i dt_out`` exactly, and ``n_sub - 1``
    equal steps between two samples."""
    return _floordiv(k, n_sub).astype(float) * dt_out + dt_step * _mod(k, n_sub).astype(float)


def _end_step(y: _State, ta, t1, params: _Params) -> _State:
    """Close a step at ``t1``. A step that ran out of passes (``ta < t1``) stops the block:
    reported, never silent (``n_unresolved`` makes the status ``STATUS_UNRESOLVED``, an error
    if ``throw``). A block past ``eta`` moving outward is flagged overturned; its state is then
    frozen (``_pass`` moves nothing once ``overturned``)."""
    unresolved = ta < t1
    y = _State(
        theta=_where(unresolved, 0.0, y.theta),
        theta_dot=_where(unresolved, 0.0, y.theta_dot),
        s=_where(unresolved, 0.0, y.s),
        overturned=y.overturned,
        n_impacts=y.n_impacts,
        t_last_impact=y.t_last_impact,
        theta_max=y.theta_max,
        n_unresolved=y.n_unresolved + unresolved,
    )
    goes_over = (y.s != 0) & (jnp.abs(y.theta) > params.theta_u) & (y.theta * y.theta_dot > 0)
    return eqx.tree_at(lambda z: z.overturned, y, _where(goes_over, 1.0, y.overturned))


def _run(
    y0: _State,
    record: _Record,
    params: _Params,
    n_out,
    *,
    n_sub,
    one_sided,
    max_impacts,
    loop_kind,
    checkpoints,
):
    """The whole record as one loop of passes (see the module docstring, "Design").

    Each iteration is one ``_pass`` of the step in progress; a pass that reaches the step end
    closes the step (``_end_step``) and, at a sample, saves the state. The loop stops after
    ``(n_out - 1) n_sub`` steps: ``n_out`` is data, so records of any length up to the
    padded length of ``record`` share one compilation.
    """
    n_pad = record.ag.shape[0]
    dt_out = record.dt
    dt_step = dt_out / n_sub
    n_steps = (n_out - 1) * n_sub

    def cond(c):
        return c.k < n_steps

    def body(c):
        active = c.k < n_steps  # False only for a finished record of a vmap batch
        t1 = _step_time(c.k + 1, n_sub, dt_out, dt_step)
        t0 = _step_time(c.k, n_sub, dt_out, dt_step)
        y, ta, hit = _pass(c.y, c.ta, c.hit, c.k, t0, t1, record, params, one_sided)
        # A step may explore max_impacts + 1 times, each exploration that finds a crossing
        # followed by its impact pass; then it ends, resolved (ta = t1) or not.
        passes = c.passes + (~c.hit.pending).astype(jnp.int32)
        ends = ~hit.pending & ((ta >= t1) | (passes > max_impacts))
        y = jax.tree.map(lambda a, b: _where(ends, a, b), _end_step(y, ta, t1, params), y)
        k = c.k + ends.astype(jnp.int32)
        save = active & ends & (_mod(k, n_sub) == 0)
        i = jnp.minimum(_floordiv(k, n_sub), n_pad - 1)
        new = _series(y)
        # field by field: inside the loop the buffers are not ordinary pytree leaves
        out = _Series(
            *(
                eqxi.buffer_at_set(getattr(c.out, f.name), i, getattr(new, f.name), pred=save)
                for f in dataclasses.fields(_Series)
            )
        )
        return _Carry(
            y=y,
            ta=_where(ends, t1, ta),
            k=k,
            passes=_where(ends, 0, passes),
            hit=hit,
            out=out,
        )

    out0 = jax.tree.map(lambda v: jnp.zeros(n_pad, v.dtype).at[0].set(v), _series(y0))
    zero = jnp.zeros((), jnp.int32)
    t0 = jnp.zeros_like(y0.theta)
    hit0 = _Hit(
        pending=jnp.zeros((), bool),
        tau=t0,
        t_hi=t0,
        level=None if params.law is None else jnp.zeros_like(t0),
    )
    carry0 = _Carry(y=y0, ta=t0, k=zero, passes=zero, hit=hit0, out=out0)
    ag_v0 = None if record.ag_v is None else record.ag_v[0]
    wall0 = None if record.wall_theta is None else (record.wall_theta[0], record.wall_rate[0])
    carry0 = _entangle(carry0, (params, record.ag[0], ag_v0, record.dt, wall0))
    carry = eqxi.while_loop(
        cond,
        body,
        carry0,
        max_steps=(n_pad - 1) * n_sub * 2 * (max_impacts + 1),
        buffers=lambda c: c.out,
        kind=loop_kind,
        checkpoints=checkpoints,
    )
    carry = _entangle(carry)
    if record.wall_theta is None:
        return carry.out, carry.y
    return _on_the_wall(carry.out, carry.y, record, n_out)


def _on_the_wall(ys: _Series, y: _State, record: _Record, n_out):
    """The saved samples with a block at rest on its moving wall put on it (see
    :func:`_pass`): at a sample where the block rests (``s = 0``; an overturned block keeps its
    pivot) its rotation and rate are the wall's; the final state's ``theta_max`` includes
    them (at the samples: with ``n_sub > 1`` not the wall's rotation between two samples). The
    final state's rotation and rate are left as the loop ends them (nothing reads them)."""
    resting = ys.s == 0
    theta = _where(resting, record.wall_theta, ys.theta)
    theta_dot = _where(resting, record.wall_rate, ys.theta_dot)
    counted = resting & (jnp.arange(theta.shape[0]) < n_out)
    top = jnp.max(jnp.where(counted, jnp.abs(record.wall_theta), 0.0))
    ys = eqx.tree_at(lambda z: (z.theta, z.theta_dot), ys, (theta, theta_dot))
    return ys, eqx.tree_at(lambda z: z.theta_max, y, jnp.maximum(y.theta_max, top))


def _wall_stop(theta_w, rate):
    """The one-sided block's stop at the samples [rad, rad/s] (docs/three_branch.md, "Moving
    return walls"): the wall where it stands in front of the base (or leaves it forward), else
    the base itself at rest, i.e. ``max(theta_w, 0)`` with the wall's rate where the wall is
    the stop and 0 elsewhere. A wall that has receded behind the base leaves the block standing
    on its base, where it lifts at the fixed wall's threshold, instead of following the wall
    down on its toe. The solver's cubic between samples fits the stop's samples: where the
    wall passes the base inside a sample interval it bends over that interval."""
    ahead = (theta_w > 0) | ((theta_w == 0) & (rate > 0))
    return _where(ahead, theta_w, 0.0), _where(ahead, rate, 0.0)


def _heel_time(ys: _Series, wall, record: _Record, params: _Params, n_out):
    """The first sample [s] at which the rigid block, its wall behind its base by more than
    ``HEEL_TOL eta``, would rock on its heel, which the one-sided model does not (its toe is
    its only pivot): ``inf`` if never. Three ways, read from the saved samples:

    * it lands on its base (the last impact of the interval ending at the sample, with the
      wall behind the base at that time): the block would go on onto its heel;
    * it stands on its base with the ground acceleration beyond the inward uplift threshold
      (``a_g > lambda_up g_eff``);
    * it rests on its stop at two consecutive samples between which the wall passes the
      base, with a rate whose hop ``rate^2 / (2 p^2 sin eta)`` exceeds ``HEEL_TOL eta``: the
      landing on its base of a block that rode on the wall (receding) or the wall's blow on a
      block standing on its base (advancing) would throw the block; the model lets it land on
      its base, or ride on the wall, without a rebound.

    ``wall``: the wall's rotation and rate at the samples [rad, rad/s] (not the stop)."""
    theta_w, rate = (jax.lax.stop_gradient(w) for w in wall)
    ys = jax.tree.map(jax.lax.stop_gradient, ys)
    n = theta_w.shape[0]
    i = jnp.arange(n)
    gap = HEEL_TOL * jax.lax.stop_gradient(params.eta)
    w2_hop = (HEEL_TOL / REST_HOP) * jax.lax.stop_gradient(params.w2_tiny)  # hop HEEL_TOL eta
    walls = _Record(ag=record.ag, ag_v=None, dt=record.dt, wall_theta=theta_w, wall_rate=rate)
    previous = jnp.concatenate([ys.n_impacts[:1], ys.n_impacts[:-1]])
    t_impact = jnp.maximum(ys.t_last_impact, 0.0)  # (-inf before the first impact)
    landing = (ys.n_impacts > previous) & (walls.wall(t_impact)[0] < -gap)
    resting = ys.s == 0
    a_g, g_eff = record.sample(i)
    lam_up = jax.lax.stop_gradient(params.lam_up)
    inward = resting & (theta_w < -gap) & (a_g > lam_up * g_eff)
    both = resting & jnp.concatenate([resting[:1], resting[:-1]])
    theta_a, rate_a = (jnp.concatenate([w[:1], w[:-1]]) for w in (theta_w, rate))
    # from in front of the base (the block rode on the wall) to behind it, or back
    passes = ((theta_a > 0.0) & (theta_w <= 0.0)) | ((theta_a < 0.0) & (theta_w >= 0.0))
    # the wall's rate where it passes the base (both linear between the samples)
    frac = _clip(theta_a / _safe(theta_a - theta_w), 0.0, 1.0)
    rate_0 = rate_a + frac * (rate - rate_a)
    thrown = both & passes & (rate_0 * rate_0 > w2_hop)
    heel = (landing | inward | thrown) & (i < n_out)
    return jnp.min(jnp.where(heel, i * record.dt, jnp.inf))


def _entangle(tree, others=()):
    """``tree`` with a zero added to each float leaf that depends on every float leaf of
    ``tree`` and ``others``: the values are unchanged, and so are the derivatives.

    Why: under ``jvp``/``grad`` the checkpointed loop first finds which carried values depend
    on the inputs (a fixed point over traces of the body) and which receive cotangents (another
    one). Entangled before and after the loop, every carried value does so from the start and
    each search ends after one trace of the body instead of three: it halves the time to
    trace ``grad`` of a run.
    """

    def is_float(x):
        return jnp.issubdtype(jnp.result_type(x), jnp.floating)

    # Arrays (the saved series) take part through their first element: O(1), not O(length).
    total = sum(
        x if jnp.ndim(x) == 0 else x[0] for x in jax.tree.leaves((tree, others)) if is_float(x)
    )
    zero = _where(jnp.isfinite(total), 0.0 * total, 0.0)  # 0 * inf would be NaN

    def add(x):
        if not is_float(x):
            return x
        return x + zero if jnp.ndim(x) == 0 else x.at[0].add(zero)

    return jax.tree.map(add, tree)


# --------------------------------------------------------------------------- errors

_FAULT_GEOMETRY, _FAULT_E, _FAULT_START, _FAULT_RECORD = 1, 2, 3, 4


def _fault_message(code: int, one_sided: bool) -> str:
    """What is wrong with a traced input, and the fix (``code``: the first failed check)."""
    side = " (and theta0 >= 0 one-sided)" if one_sided else ""
    return {
        _FAULT_GEOMETRY: "the block's b and h [m] must be positive and finite, and its mass and "
        "inertia finite; check the b and h given to rj.Block.",
        _FAULT_E: "e (restitution, dimensionless) must be in (0, 1]; pass a smaller e.",
        _FAULT_START: f"theta0 must satisfy |theta0| < eta [rad]{side}, and theta0 and "
        "theta_dot0 be finite; give a smaller theta0.",
        _FAULT_RECORD: "the record's ag [m/s^2] has non-finite samples (NaN/inf); clean the "
        "record.",
    }[code]


_STATE_MESSAGES = {
    STATUS_NONFINITE: "the state became non-finite (NaN/inf).",
    STATUS_UNSTABLE: f"p*dt_step exceeds {P_DT_LIMIT}; pass a smaller dt [s].",
    STATUS_UNRESOLVED: "a solver step needed more impacts than max_impacts_per_step; raise "
    "max_impacts_per_step or pass a smaller dt [s].",
}


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
    law: ThreeBranchLaw | ThreeBranchFit | None = None,
    wall_motion: Any = None,
) -> Response:
    r"""Simulate Housner rocking with impacts (two-sided parapet or one-sided facade).

    $I_O \ddot\theta = -m g R \sin(\eta - \theta) - m a_g R \cos(\eta - \theta)$ for
    $\theta > 0$ (mirrored for $\theta < 0$), $\dot\theta \to e \dot\theta$ at each impact.

    Compiles once per bucket of record lengths (:mod:`rockjax.compilation`): called with
    concrete inputs, the record is padded to ``rockjax.compilation.bucket_length(n)`` samples
    and its length passed as data, so a loop over records of different lengths and steps
    compiles once. Inside ``jit``/``vmap``/``grad`` the caller's transform fixes the shapes.

    Args:
        block: The block; only ``b`` and ``h`` (and ``m``, for the energy) matter.
        motion: Ground motion, a :class:`rockjax.GroundMotion`; ``None`` for free rocking
            (then ``duration`` is required).
        e: Coefficient of restitution [-]: two-sided ``0 < e <= 1`` (default ``e_H``, Eq. (2));
            one-sided ``0 < |e| <= 1``, its magnitude is used (default ``|e_1sr|``, Eq. (5)).
        mode: ``"two_sided"`` (parapet) or ``"one_sided"`` (facade, ``theta >= 0``).
        theta0: Initial rotation [rad], ``|theta0| < eta`` (``>= 0`` one-sided).
        theta_dot0: Initial angular velocity [rad/s]. A start faster than
            ``(2 pi + |theta0|) / (|e| dt_step)`` (``dt_step`` the solver's step), which
            carries the block past overturning within that step, is run at that speed: it
            overturns all the same (docs/conventions.md, "Input checks").
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
        adjoint: ``None`` or ``diffrax.RecursiveCheckpointAdjoint()`` (reverse mode, ``grad``;
            its ``checkpoints`` is honoured), or ``diffrax.ForwardMode()`` for
            ``jvp``/``jacfwd``.
        throw: Raise (also inside ``jit``) on an invalid traced input, a non-finite state or an
            unresolved step; if False report it in ``Response.status`` (for batches: a lane
            with an invalid input, e.g. ``e > 1`` or ``|theta0| >= eta``, gets
            ``STATUS_BAD_INPUT`` and NaN histories, and the other lanes run as alone).
        law: A :class:`rockjax.ThreeBranchLaw` (or the :class:`rockjax.ThreeBranchFit` of
            :func:`rockjax.fit_three_branch`) for the restoring moment (docs/three_branch.md):
            $I_O \ddot\theta = -m g R \cos(\eta - u) [\Lambda(u) + a_g/g]$ on the pivot's side
            ($u = s\theta$), $\Lambda$ the law's load multiplier at the rigid-equivalent
            displacement $x = 1 - \tan(\eta - u)/\tan\eta$; the block overturns past the
            law's zero-capacity rotation and lifts from rest at its ``lambda_uplift``. ``None``
            (default): the rigid block, the same as ``ThreeBranchLaw.rigid(block)``.
        wall_motion: One-sided only: the return wall moves relative to the base (a facade in a
            building; docs/three_branch.md, "Moving return walls"). A ``(u_top, v_top)`` pair of
            arrays [m], [m/s] at the record samples (the wall's displacement and velocity at
            the block's height ``h``, relative to the base, positive toward the facade), or
            anything ``rockjax.building.wall_top_motion`` takes (a ``ShearBuilding``, a
            ``GroundMotion`` of the wall's absolute acceleration, or ``(height, GroundMotion)``
            pairs). The wall rotates by ``theta_w = u_top / h``; the block's stop is the wall,
            or its base where the wall has receded behind it (``theta >= max(theta_w, 0)``);
            impacts restitute the velocity relative to the stop; at rest the block rides on
            it. The block rocks on its toe only: see ``extras["t_heel"]``. Needs ``motion``.

    Returns:
        A :class:`rockjax.Response` at the record samples (or every ``dt``). ``energy`` is
        $\tfrac12 I_O\dot\theta^2 + m g R(\cos(\eta-|\theta|) - \cos\eta)$ [J] (with a ``law``,
        its potential: the work of its restoring moment). ``extras``:
        ``"n_impacts"`` (impacts up to each sample), ``"t_last_impact"`` [s] (time of the
        latest impact up to each sample, exact from the root-find; ``-inf`` before the first),
        ``"pivot"`` (``s``: +1, -1, 0 at rest), ``"n_unresolved"`` (steps with more impacts
        than ``max_impacts_per_step``; nonzero only with ``throw=False``), ``"dt"`` (solver
        step [s]); with ``wall_motion`` also ``"t_heel"`` [s]: the first sample at which the
        rigid block, its wall receded behind its base, would rock on its heel (it lands on its
        base, the ground throws it inward while it stands, or the wall passes the base under
        it fast enough to throw it), ``inf`` if never. The history is the rigid block's up to
        that time only (docs/three_branch.md, "Moving return walls").

    Raises:
        ValueError: on invalid input, with the value, its unit and the fix.

    References:
        Housner, G. W. (1963), BSSA 53(2):403-417. The paper, Eqs. (2) and (5).
    """
    check_kind(
        "block",
        block,
        (Block,),
        "simulate_housner rocks one rigid block, e.g. rj.Block(b=0.25, h=3.0); run a wall of "
        "blocks (an rj.Assembly) with rj.simulate_dem or rj.simulate_assembly.",
    )
    check_choice("mode", mode, MODES)
    one_sided = mode == "one_sided"
    if motion is not None and not isinstance(motion, GroundMotion):
        raise ValueError(
            f"motion must be a rockjax GroundMotion (or None for free rocking); got a "
            f"{type(motion).__name__}. Wrap the accelerations with their step: "
            "rj.GroundMotion(ag=ag, dt=0.01) in m/s^2, or rj.GroundMotion.from_g(ag_g, dt=0.01) "
            "in g."
        )
    if isinstance(max_impacts_per_step, bool) or not (
        isinstance(max_impacts_per_step, int) and max_impacts_per_step >= 1
    ):
        raise ValueError(
            f"max_impacts_per_step must be an int >= 1; got {max_impacts_per_step!r}. Use the default, 64."
        )
    if e is not None:
        check_scalar("e", e, "[-]", "e.g. e=0.9, or e=None for the paper's default.")
    check_scalar("theta0", theta0, "rad", "e.g. theta0=0.01.")
    check_scalar("theta_dot0", theta_dot0, "rad/s", "e.g. theta_dot0=0.0.")
    if dt is not None:
        check_positive("dt", dt, "s", "Or leave dt=None.", scalar=True)
    if duration is not None:
        check_positive("duration", duration, "s", "e.g. duration=10.0.", scalar=True)
    _check_theta0(theta0, theta_dot0, block, one_sided)
    if isinstance(law, ThreeBranchFit):  # rj.fit_three_branch(...) passed as it is
        law = law.law
    if law is not None and not isinstance(law, ThreeBranchLaw):
        raise ValueError(
            f"law must be a rockjax ThreeBranchLaw (or None for the rigid block); got a "
            f"{type(law).__name__}. Build one with rj.ThreeBranchLaw(lambda_0=b/h, Delta_1=..., "
            "Delta_2=..., Delta_u=...) (Deltas as fractions of b) or rj.fit_three_branch(...)."
        )
    loop_kind, checkpoints = _loop_kind(adjoint)
    if wall_motion is not None:
        if not one_sided:
            raise ValueError(
                f"wall_motion needs mode='one_sided' (a facade against its return walls); got "
                f"mode={mode!r}. Drop wall_motion for a parapet."
            )
        if motion is None:
            raise ValueError(
                "wall_motion needs the ground motion it is relative to: pass motion=GroundMotion "
                "(free rocking against a moving wall is not supported)."
            )

    if motion is None:
        if duration is None:
            raise ValueError(
                "free rocking (motion=None) needs duration, in s: e.g. duration=10.0; "
                "or pass a GroundMotion."
            )
        dt_out = DEFAULT_DT if dt is None else float(dt)
        n_out = check_samples(duration, dt_out)
        ag = np.zeros(n_out)
        ag_v = None
        dt_max = None
    else:
        dt_out = motion.dt
        n_out = motion.n if duration is None else check_samples(duration, dt_out)
        for label, arr in (("ag", motion.ag), ("ag_v", motion.ag_v)):
            a = None if arr is None else concrete(arr)
            if a is not None and not np.all(np.isfinite(a)):
                bad = np.flatnonzero(~np.isfinite(a))
                raise ValueError(
                    f"{label} of record {motion.name!r} has {bad.size} non-finite samples "
                    f"(first at index {bad[0]}, t={bad[0] * dt_out:.4f} s) [m/s^2]. Clean or "
                    "trim the record first."
                )
        ag = _fit(motion.ag, n_out)
        ag_v = None if motion.ag_v is None else _fit(motion.ag_v, n_out)
        dt_max = dt
    if n_out < 2:
        raise ValueError(f"the run must span at least one step; got duration={duration} s.")
    p = concrete(block.p)
    if p is not None and law is not None:
        p = _law_frequency(p, concrete(block.eta), law)
    if dt_max is None:
        dt_max = dt_out if p is None else P_DT_TARGET / float(np.max(p))
    n_sub = max(1, math.ceil(dt_out / dt_max - 1e-9))
    if p is not None and np.max(p) * dt_out / n_sub > P_DT_LIMIT:
        raise ValueError(
            f"the solver step {dt_out / n_sub:.4g} s is too coarse for this block "
            f"(p = {float(np.max(p)):.4g} rad/s, p*dt = {float(np.max(p)) * dt_out / n_sub:.3g} > "
            f"{P_DT_LIMIT}); pass dt <= {P_DT_TARGET / float(np.max(p)):.4g} s or leave dt=None."
        )

    wall = None
    if wall_motion is not None:
        if n_out > motion.n:
            raise ValueError(
                f"with wall_motion the run cannot outlast the record ({motion.n} samples, "
                f"{(motion.n - 1) * motion.dt:g} s): the wall's motion after it is unknown; got "
                f"duration={duration} s. Pad the record and the wall motion yourself."
            )
        wall = _wall_series(wall_motion, motion, block, n_out)

    default_e = e is None
    if default_e:
        e = e_isr(block.eta) if one_sided else e_housner(block.eta)
    check_restitution(e, one_sided, default=default_e)
    # Compile once per bucket: with nothing traced the record is padded (its last sample
    # repeated, which the solver's evaluation beyond the end already holds) and its length
    # passed as data. Under the caller's jit/vmap/grad their transform fixes the shapes.
    traced = is_traced(block, ag, ag_v, e, theta0, theta_dot0, law, wall)
    n_pad = n_out if traced else bucket_length(n_out)
    if not traced:
        notice_once(
            (
                "housner",
                n_pad,
                n_sub,
                one_sided,
                max_impacts_per_step,
                loop_kind,
                ag_v is None,
                law is None,
                wall is None,
            ),
            f"rockjax: compiling the Housner solver for records of <= {n_pad} samples "
            "(once per session)...",
        )
    block = jax.tree.map(lambda x: jnp.asarray(x, dtype=float), block)
    e = jnp.asarray(e, dtype=float)
    theta_dot0 = _first_step_velocity(theta_dot0, theta0, e, dt_out / n_sub)
    # An eager call checks in Python, after the run: a compiled program with error callbacks
    # (eqx.error_if) cannot go into the persistent compilation cache.
    resp, fault = _simulate(
        block,
        pad_to(ag, n_pad),
        None if ag_v is None else pad_to(ag_v, n_pad),
        jnp.abs(e) if one_sided else e,
        jnp.asarray(theta0, dtype=float),
        jnp.asarray(theta_dot0, dtype=float),
        jnp.asarray(dt_out, dtype=float),
        jnp.asarray(n_out, dtype=jnp.int32),
        None if law is None else jax.tree.map(lambda x: jnp.asarray(x, dtype=float), law),
        None if wall is None else _pad_wall(wall, n_pad, dt_out),
        n_sub=n_sub,
        one_sided=one_sided,
        max_impacts=max_impacts_per_step,
        loop_kind=loop_kind,
        checkpoints=checkpoints,
        throw=throw and traced,
    )
    if throw and not traced:
        _raise_on_failure(int(resp.status), int(fault), one_sided)
    if n_pad == n_out:
        return resp

    # Padded only when nothing is traced: the outputs are concrete, and cut on the host (an
    # eager slice of a device array would compile once per length).
    def cut(x):
        return jax.device_put(np.asarray(x)[:n_out])

    extras = dict(resp.extras)
    for key in ("n_impacts", "t_last_impact", "pivot"):
        extras[key] = cut(extras[key])
    return eqx.tree_at(
        lambda r: (r.t, r.theta, r.theta_dot, r.d, r.energy, r.extras),
        resp,
        (cut(resp.t), cut(resp.theta), cut(resp.theta_dot), cut(resp.d), cut(resp.energy), extras),
    )


def batch_runs(run, *xs):
    """``run`` over the leading axis of each of ``xs`` (one Housner simulation per element),
    the fastest way on the current backend: ``jax.lax.map`` (one run after another) on CPU,
    ``jax.vmap`` elsewhere. Use it inside ``jit`` in place of ``jax.vmap(run)(*xs)``.

    Why: the solver is a loop of passes whose branches (the flight, the impact) are taken per
    run. Under ``vmap`` every run of the batch goes through every pass that any run needs,
    each operation on a vector of a few elements; XLA:CPU then spends its time launching small
    kernels. One run after another, the loop is scalar code and skips what its own run does
    not need: 4.8x less CPU time for 64 facade runs of 40 s (0.070 s against 0.340 s,
    identical results; ``benchmarks/bench_housner_batching.py``, docs/benchmarks.md, "Batching
    on CPU: one run after another"). The DEM (a scan without such branches) is the other way
    round and stays with ``vmap``.
    """
    if jax.default_backend() == "cpu":
        return jax.lax.map(lambda x: run(*x), xs)
    return jax.vmap(run)(*xs)


def _raise_on_failure(status: int, fault: int, one_sided: bool) -> None:
    """The errors ``throw`` asks for, raised after an eager run (as ``eqx.error_if`` would)."""
    if status == STATUS_BAD_INPUT:
        raise ValueError(f"simulate_housner: {_fault_message(fault, one_sided)}")
    if status != STATUS_OK:
        raise RuntimeError(
            f"simulate_housner: {_STATE_MESSAGES[status]} Pass throw=False to get "
            "Response.status instead."
        )


def _loop_kind(adjoint) -> tuple[str, int | None]:
    """The ``equinox.internal.while_loop`` kind (and checkpoints) the adjoint differentiates."""
    if adjoint is None:
        return "checkpointed", None
    if isinstance(adjoint, diffrax.RecursiveCheckpointAdjoint):
        return "checkpointed", adjoint.checkpoints
    if isinstance(adjoint, diffrax.ForwardMode):
        return "lax", None  # jvp cannot go through the checkpointed loop's custom_vjp
    raise ValueError(
        f"adjoint must be None or diffrax.RecursiveCheckpointAdjoint() (reverse mode, grad), or "
        f"diffrax.ForwardMode() (jvp); got {type(adjoint).__name__}."
    )


@persistent_jit
def _simulate(
    block,
    ag,
    ag_v,
    e,
    theta0,
    theta_dot0,
    dt_out,
    n_out,
    law=None,
    wall=None,
    *,
    n_sub,
    one_sided,
    max_impacts,
    loop_kind,
    checkpoints,
    throw,
):
    n_pad = ag.shape[0]
    dt_step = dt_out / n_sub
    t_out = jnp.arange(n_pad) * dt_out

    # Traced inputs cannot be checked in Python. A lane with an impossible one is not run
    # (benign stand-ins below, NaN histories, STATUS_BAD_INPUT), or with throw it raises,
    # naming the input; the geometry is checked first so that b = 0 is not blamed on theta0.
    eta, p = block.eta, block.p
    geometry_ok = (block.b > 0) & (block.h > 0) & (block.m > 0) & (p > 0)
    for x in (block.b, block.h, block.m, block.I_O, p):
        geometry_ok = geometry_ok & jnp.isfinite(x)
    e_ok = jnp.isfinite(e) & (e > 0) & (e <= 1)
    start_ok = jnp.isfinite(theta0) & jnp.isfinite(theta_dot0) & (jnp.abs(theta0) < eta)
    if one_sided:
        start_ok = start_ok & (theta0 >= 0) & ((theta0 > 0) | (theta_dot0 >= 0))
    record_ok = jnp.all(jnp.isfinite(ag))
    if ag_v is not None:
        record_ok = record_ok & jnp.all(jnp.isfinite(ag_v))
    oks = (geometry_ok, e_ok, start_ok, record_ok)
    bad = ~(geometry_ok & e_ok & start_ok & record_ok)
    # the first failed check (0: none), for the message of an eager call
    fault = jnp.int32(0)
    for code in range(len(oks), 0, -1):
        fault = jnp.where(oks[code - 1], fault, jnp.int32(code))
    if throw:
        for code, ok in enumerate(oks, start=1):
            if code == _FAULT_START:  # a zero-width block is blamed on b, not on theta0
                ok = ok | ~geometry_ok
            e = eqx.error_if(e, ~ok, f"simulate_housner: {_fault_message(code, one_sided)}")

    def benign(x, stand_in):
        return jnp.where(bad, stand_in, x)

    eta, p = benign(eta, 0.1), benign(p, 1.0)
    e, theta0, theta_dot0 = benign(e, 0.5), benign(theta0, 0.0), benign(theta_dot0, 0.0)
    ag = benign(ag, 0.0)
    ag_v = None if ag_v is None else benign(ag_v, 0.0)

    params = _params(p, eta, e, law)
    if wall is None:
        record = _Record(ag=ag, ag_v=ag_v, dt=dt_out)
    else:  # the block's stop: the wall, or its base where the wall has receded behind it
        stop_theta, stop_rate = _wall_stop(*wall)
        record = _Record(ag=ag, ag_v=ag_v, dt=dt_out, wall_theta=stop_theta, wall_rate=stop_rate)
        record = record.with_wall_steps(params, n_sub)
    moving = (theta0 != 0) | (theta_dot0 != 0)
    if one_sided:
        s0 = jnp.where(moving, 1.0, 0.0)
    else:
        s0 = jnp.where(theta0 != 0, jnp.sign(theta0), jnp.sign(theta_dot0))
    if wall is not None:  # at rest against its stop: on it, with its rate
        theta0 = jnp.where(moving, theta0, record.wall_theta[0])
        theta_dot0 = jnp.where(moving, theta_dot0, record.wall_rate[0])
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
    ys, final = _run(
        y0,
        record,
        params,
        n_out,
        n_sub=n_sub,
        one_sided=one_sided,
        max_impacts=max_impacts,
        loop_kind=loop_kind,
        checkpoints=checkpoints,
    )
    too_coarse = (p if law is None else _law_frequency(p, eta, law, xp=jnp)) * dt_step > P_DT_LIMIT
    if throw:
        # Every output below is computed from the checked ys, so the checks cannot be
        # dropped as dead code whichever outputs the caller keeps.
        finite = jnp.all(jnp.isfinite(ys.theta)) & jnp.all(jnp.isfinite(ys.theta_dot))
        for failed, code in (
            (~finite, STATUS_NONFINITE),
            (too_coarse, STATUS_UNSTABLE),
            (final.n_unresolved > 0, STATUS_UNRESOLVED),
        ):
            msg = f"simulate_housner: {_STATE_MESSAGES[code]}"
            ys, final = eqx.error_if((ys, final), failed, msg)
    theta, theta_dot = ys.theta, ys.theta_dot
    finite = jnp.all(jnp.isfinite(theta)) & jnp.all(jnp.isfinite(theta_dot))
    status = jnp.where(
        bad,
        STATUS_BAD_INPUT,
        jnp.where(
            finite,
            jnp.where(
                too_coarse,
                STATUS_UNSTABLE,
                jnp.where(final.n_unresolved > 0, STATUS_UNRESOLVED, STATUS_OK),
            ),
            STATUS_NONFINITE,
        ),
    )

    # The polynomial sine and cosine (rotations stay below 2 rad) on the whole padded series;
    # cos(eta - |theta|) - cos(eta) = cos(eta) (cos(theta) - 1) + sin(eta) |sin(theta)|.
    sin_th, cos_th = _sincos(theta, False)
    d = jnp.sign(theta) * 0.5 * block.b * (1.0 - cos_th) + block.h * sin_th
    if law is None:
        potential = jnp.cos(eta) * (cos_th - 1.0) + jnp.sin(eta) * jnp.abs(sin_th)
    else:
        potential = _law_potential(jnp.abs(theta), eta, params.law)
    energy = 0.5 * block.I_O * theta_dot**2 + block.m * G * block.R * potential

    def not_run(x):
        return jnp.where(bad, jnp.nan, x)

    resp = Response(
        t=t_out,
        theta=not_run(theta),
        theta_dot=not_run(theta_dot),
        d=not_run(d),
        overturned=final.overturned > 0,
        status=status,
        theta_max=not_run(final.theta_max),
        eta=block.eta,
        b=block.b,
        energy=not_run(energy),
        extras={
            "n_impacts": ys.n_impacts.astype(jnp.int32),
            "t_last_impact": ys.t_last_impact,
            "pivot": ys.s,
            "n_unresolved": final.n_unresolved.astype(jnp.int32),
            "dt": dt_step,
        }
        | (
            {} if wall is None else {"t_heel": not_run(_heel_time(ys, wall, record, params, n_out))}
        ),
    )
    return resp, fault


def _params(p, eta, e, law) -> _Params:
    """The run's constants; with a three-branch ``law``, its restoring terms (``_LawTerms``)."""
    sin_eta, cos_eta, tan_eta = jnp.sin(eta), jnp.cos(eta), jnp.tan(eta)
    p2_over_g = p**2 / G
    w2_tiny = 2.0 * REST_HOP * eta * p2_over_g * G * sin_eta
    if law is None:
        return _Params(
            p2_over_g=p2_over_g,
            sin_eta=sin_eta,
            cos_eta=cos_eta,
            tan_eta=tan_eta,
            eta=eta,
            e=e,
            theta_u=eta,
            lam_up=tan_eta,
            w2_tiny=w2_tiny,
            law=None,
        )
    lam0, d1, d2, du = (
        jnp.asarray(v, dtype=float) for v in (law.lambda_0, law.Delta_1, law.Delta_2, law.Delta_u)
    )
    lam_p = lam0 * (1.0 - d2 / du)

    def rotation(x):  # u at the rigid-equivalent displacement x: tan(eta - u) = tan(eta)(1 - x)
        return eta - jnp.arctan(tan_eta * (1.0 - x))

    # Branch k: Lambda = alpha_k + beta_k tan(eta - u), from lambda(x) with x = 1 - tan(eta-u)/tan(eta).
    has_first = d1 > 0
    a1 = _where(has_first, lam_p / _where(has_first, d1, 1.0), lam_p)
    b1 = _where(has_first, -a1 / tan_eta, 0.0)
    a3 = lam0 * (1.0 - 1.0 / du)
    b3 = lam0 / (du * tan_eta)
    terms = _LawTerms(
        u1=rotation(d1),
        u2=rotation(d2),
        alpha=jnp.stack([a1, lam_p, a3]),
        beta=jnp.stack([b1, jnp.zeros_like(b1), b3]),
    )
    lam_up = _where(has_first, 0.0, lam_p)
    k = p2_over_g * cos_eta
    # Second rest clause: a hop of REST_HOP eta, from the threshold's restoring acceleration
    # (k g lam_up) or, on a stiff first branch (lam_up = 0), from its frequency (k g lam_p / u1).
    w2_hop = 2.0 * REST_HOP * eta * k * G * lam_up
    w2_spring = (REST_HOP * eta) ** 2 * k * G * lam_p / _where(has_first, terms.u1, 1.0)
    return _Params(
        p2_over_g=p2_over_g,
        sin_eta=sin_eta,
        cos_eta=cos_eta,
        tan_eta=tan_eta,
        eta=eta,
        e=e,
        theta_u=rotation(du),
        lam_up=lam_up,
        w2_tiny=_where(has_first, w2_spring, w2_hop),
        law=terms,
    )


def _law_frequency(p, eta, law, xp=np):
    """The larger of ``p`` and the angular frequency of the law's stiff first branch [rad/s],
    ``p sqrt(cos(eta) lambda_p / u1)`` (``u1`` its end rotation): the step-size rule's rate.
    NumPy for concrete values (``None`` if the law is traced), ``xp=jnp`` inside the solve."""
    vals = [law.lambda_0, law.Delta_1, law.Delta_2, law.Delta_u]
    if xp is np:
        vals = [concrete(v) for v in vals]
        if eta is None or any(v is None for v in vals):
            return None
    lam0, d1, d2, du = vals
    lam_p = lam0 * (1.0 - d2 / du)
    u1 = eta - xp.arctan(xp.tan(eta) * (1.0 - d1))
    stiff = xp.sqrt(xp.maximum(xp.cos(eta) * lam_p / xp.where(d1 > 0, u1, 1.0), 0.0))
    return xp.maximum(p, xp.where(d1 > 0, p * stiff, p))


def _law_potential(u, eta, terms: _LawTerms):
    """``V(u) / (m g R)`` [-]: the work of the law's restoring moment from 0 to ``u >= 0``.

    On branch ``k`` the moment over ``m g R`` is ``alpha_k cos(eta - u) + beta_k sin(eta - u)``,
    whose integral is ``F_k(u) = -alpha_k sin(eta - u) + beta_k cos(eta - u)``.
    """
    bounds = ((0.0, terms.u1), (terms.u1, terms.u2), (terms.u2, jnp.inf))
    total = jnp.zeros_like(u)
    for k, (lo, hi) in enumerate(bounds):
        lo = jnp.maximum(lo, 0.0)
        hi = jnp.maximum(hi, lo)
        uu = _clip(u, lo, hi)

        def f(v, k=k):
            return -terms.alpha[k] * jnp.sin(eta - v) + terms.beta[k] * jnp.cos(eta - v)

        total = total + f(uu) - f(lo)
    return total


def _wall_series(wall_motion, motion: GroundMotion, block: Block, n_out: int):
    """``(theta_w, theta_w')`` [rad, rad/s] at the run's ``n_out`` samples from ``wall_motion``
    (see ``simulate_housner``); beyond the record the wall stays where it ended."""
    if (
        isinstance(wall_motion, tuple | list)
        and len(wall_motion) == 2
        and all(_is_series(w) for w in wall_motion)
    ):
        u, v = wall_motion
        check_series_pair(
            "wall_motion",
            ("u_top [m]", "v_top [m/s]"),
            (u, v),
            motion.n,
            "Give the wall's displacement and velocity at t = k * motion.dt.",
        )
    else:
        from .building import ShearBuilding, wall_top_motion  # imported only when used

        ag = concrete(motion.ag)
        if isinstance(wall_motion, ShearBuilding) and ag is not None and not is_traced(wall_motion):
            # the building's solve compiles per record length: run it on the record padded to
            # its bucket (the last sample repeated; the solve is causal, so the record's own
            # samples are unchanged) and cut on the host, one compilation per bucket
            n = ag.shape[0]
            padded = GroundMotion(
                ag=np.pad(ag, (0, bucket_length(n) - n), mode="edge"), dt=motion.dt
            )
            u, v = wall_top_motion(wall_motion, padded, block.h)
            u, v = np.asarray(u)[:n], np.asarray(v)[:n]
        else:
            u, v = wall_top_motion(wall_motion, motion, block.h)
    check_wall_rotation(u, block.h)
    # NumPy when concrete: eager jnp ops on a new length would each compile once.
    vals = [concrete(x) for x in (u, v, block.h)]
    xp = jnp if any(x is None for x in vals) else np
    if xp is np:
        u, v, h = vals
    else:
        h = jnp.asarray(block.h, dtype=float)
    u, v = xp.asarray(u, dtype=float) / h, xp.asarray(v, dtype=float) / h
    n = u.shape[0]
    if n >= n_out:
        return u[:n_out], v[:n_out]
    return xp.pad(u, (0, n_out - n), mode="edge"), xp.pad(v, (0, n_out - n))


def _pad_wall(wall, n_pad: int, dt: float):
    """The wall's samples padded to ``n_pad`` (concrete only; traced runs are not padded) as a
    wall moving on at its last velocity: its cubic stays consistent (no acceleration spike)
    where the rest rule looks past the end."""
    theta, rate = wall
    n = theta.shape[0]
    if n_pad == n:
        return jnp.asarray(theta), jnp.asarray(rate)
    theta, rate = np.asarray(theta, dtype=float), np.asarray(rate, dtype=float)
    extra = np.arange(1, n_pad - n + 1) * dt
    theta = np.concatenate([theta, theta[-1] + rate[-1] * extra])
    rate = np.concatenate([rate, np.full(n_pad - n, rate[-1])])
    return jax.device_put(theta), jax.device_put(rate)


def _is_series(w) -> bool:
    """A 1-D array (or list) of numbers, as opposed to a ``(height, GroundMotion)`` pair."""
    if isinstance(w, jax.Array | np.ndarray):
        return w.ndim == 1
    if isinstance(w, list | tuple):
        try:
            return np.asarray(w, dtype=float).ndim == 1
        except (TypeError, ValueError):
            return False
    return False


def _fit(a, n: int):
    """``a`` truncated or zero-padded to ``n`` samples (in NumPy when concrete: no compile per
    length)."""
    v = concrete(a)
    if v is None:
        a = jnp.asarray(a, dtype=float)
        return a[:n] if a.shape[0] >= n else jnp.pad(a, (0, n - a.shape[0]))
    return v[:n] if v.shape[0] >= n else np.pad(v, (0, n - v.shape[0]))


def check_restitution(e, one_sided: bool, default: bool) -> None:
    """Refuse a concrete restitution ``e`` [-] outside (0, 1] (one-sided: its magnitude), naming
    the paper's default (Eq. 2, Eq. 5) when ``default`` (it leaves that range for squat blocks).
    A traced ``e`` is checked in-graph by the solver."""
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


def _first_step_velocity(theta_dot0, theta0, e, dt_step: float):
    """``theta_dot0`` [rad/s] limited to ``(2 pi + |theta0|) / (|e| dt_step)``: a start that
    carries the block through ``2 pi`` rad (past any overturning rotation, ``theta_u <= 2 eta
    < pi``, even after an impact that keeps ``|e|`` of its speed) within the first solver step
    ``dt_step`` [s]: gravity and a record of up to 10 g take at most ``11 (p dt_step)^2 / 2``
    rad of that swing, 1.4 rad at the coarsest step allowed (``p dt_step = 0.5``). A faster
    start overturns in that step all the same, while the solver's rotation polynomials would
    overflow to NaN on it (1e6 rad/s)."""
    vals = [concrete(x) for x in (theta_dot0, theta0, e)]
    if all(v is not None for v in vals):  # NumPy: an eager jnp op would compile
        w, th, e_c = vals
        cap = (2.0 * np.pi + np.abs(th)) / (np.abs(e_c) * dt_step)
        return np.clip(w, -cap, cap)
    cap = (2.0 * jnp.pi + jnp.abs(theta0)) / (jnp.abs(e) * dt_step)
    return jnp.clip(jnp.asarray(theta_dot0, dtype=float), -cap, cap)


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
