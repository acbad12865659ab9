"""One pass of a solver step (``one_pass``): a quiet check, then either an exploring pass
(uplift, one Tsit5 step, the first crossing of the wall or of a kink of a three-branch law)
or an impact pass (one Tsit5 step to the crossing, the impact map and the rest rule)."""

from __future__ import annotations

import equinox.internal as eqxi
import jax
import jax.numpy as jnp

from ._field import theta_ddot, wall_excess
from ._hermite import hermite_root, hermite_turn
from ._impact import find_uplift, impact_map, rest_rule
from ._lax import clip, cond, safe, where
from ._params import LawTerms, Params
from ._record import Line, Record
from ._state import Hit, State
from ._tsit5 import flight


def one_pass(
    y: State,
    ta,
    hit: Hit,
    k,
    t0,
    t1,
    record: Record,
    params: Params,
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
    (:func:`active_pass`) would change nothing else. Most passes of an IDA are quiet (the low
    scales never lift), and a ``cond`` skips their flight, crossing and impact work.

    A block at rest on a moving wall rides on it, but its state in the loop keeps the rotation
    and rate it came to rest with: nothing in a pass reads them (a lift-off starts from the
    wall's state), and :func:`on_the_wall` puts the saved samples on the wall after the loop
    (updated in every pass, they were work that a quiet pass does not need).

    ``k`` is the step in progress (from ``t0`` to ``t1``). Returns the state, the time it holds
    at and the hit for the next pass.
    """
    pending = hit.pending
    if record.wall_theta is None:
        # (1) At rest: lift off when the forcing first exceeds the threshold in [ta, t1].
        line = record.line(t0, t1)
        lifts, t_up, s_up = find_uplift(ta, t1, line, params, one_sided)
        lift_now = (y.s == 0) & lifts & (y.overturned == 0) & ~pending
        quiet = ~pending & ~lift_now & ((y.s == 0) | (y.overturned != 0))
        uplift, wall = (None, t_up, s_up, lift_now), None
    else:  # one-sided with a moving return wall: the step's two columns of the wall table
        column = jax.lax.dynamic_slice_in_dim(record.wall_steps, k, 1, axis=1)
        excess_a, excess_b = column[0, 0], column[1, 0]
        # The check from the table holds for a pass that starts at the step's start; one
        # that starts later (after an impact inside the step) is never quiet.
        from_start = ta == t0
        lifts = find_uplift(ta, t1, None, params, one_sided, (excess_a, excess_b))[0]
        line = None  # (the forcing on the step: only an active pass needs it)
        at_rest = (y.s == 0) & from_start & ~lifts
        quiet = ~pending & (at_rest | (y.overturned != 0))
        uplift = (excess_b, from_start, excess_a)
        wall = k
    return cond(
        eqxi.unvmap_all(quiet),
        lambda: (y, t1 + jnp.zeros_like(ta), hit),
        lambda: active_pass(
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


def active_pass(
    y: State,
    ta,
    hit: Hit,
    t1,
    line: Line,
    record: Record,
    params: Params,
    one_sided: bool,
    uplift,
    wall,
):
    """:func:`one_pass` past its quiet check. ``uplift``: with a fixed wall the check's result
    (None, the uplift time and pivot, whether the block lifts now); with a moving wall the
    wall's excess at ``t1``, whether the pass starts at the step's start, and the excess
    there. ``wall``: with a moving wall the step in progress (None for a fixed wall)."""
    pending = hit.pending
    # (1) At rest: lift off.
    step = None if wall is None else record.segment(wall)  # (a quiet pass needs none of it)
    s, ta, theta_a, theta_dot_a, lift_now, excess = lift_off(
        y, ta, pending, t1, line, params, one_sided, uplift, step
    )
    rocking = (s != 0) & (y.overturned == 0)

    def accel(t, theta):
        return theta_ddot(t, theta, s, params, line)

    # (2) Smooth flight on pivot s: to t1 (explore) or to tau (impact).
    h = t1 - ta
    theta_f, theta_dot_f, peak = flight(
        pending | (rocking & (h > 0)),
        accel,
        ta,
        where(pending, hit.tau - ta, h),
        theta_a,
        theta_dot_a,
    )
    # (3) Explore: the first crossing in the step.
    crossed, x, xb, level, theta_f = find_crossing(
        (theta_a, theta_dot_a, theta_f, theta_dot_f),
        s,
        ta,
        h,
        ~pending & rocking,
        lift_now,
        excess,
        params,
        step,
    )
    advance = ~pending & rocking & ~crossed
    # (4) Impact: one Newton step on the true trajectory, the impact map, the rest rule.
    t_impact, theta_at, theta_dot_plus, s_plus, rate_at, wall, rests, hop = resolve_impact(
        hit, theta_f, theta_dot_f, s, ta, accel, line, record, params, one_sided, step
    )

    # the flight's peak on its dense output (to the crossing: the state there is within a
    # Newton step of the impact); theta_f, not the flight's end, where the wall cleared it
    peak = jnp.maximum(jnp.maximum(peak, jnp.abs(theta_f)), where(rests, hop, 0.0))
    # Not rocking (at rest and not lifting, or overturned): nothing moves. A crossing found
    # keeps the state (and the pivot it lifted onto) at ta for the impact pass.
    theta_rest, theta_dot_rest = y.theta, y.theta_dot  # (on a moving wall: see one_pass)
    theta_max = where(pending | advance, jnp.maximum(y.theta_max, peak), y.theta_max)
    y_new = State(
        theta=where(pending, theta_at, where(advance, theta_f, theta_rest)),
        theta_dot=where(
            pending,
            where(rests, rate_at, theta_dot_plus),
            where(advance, theta_dot_f, theta_dot_rest),
        ),
        s=where(pending, where(rests, 0.0, s_plus), where(rocking, s, y.s)),
        overturned=y.overturned,
        n_impacts=y.n_impacts + wall,
        t_last_impact=where(wall, t_impact, y.t_last_impact),
        theta_max=theta_max,
        n_unresolved=y.n_unresolved,
    )
    ta_new = where(pending, t_impact, where(crossed, ta, t1))
    hit_new = Hit(
        pending=crossed,
        tau=where(crossed, ta + x * h, hit.tau),
        t_hi=where(crossed, ta + xb * h, hit.t_hi),
        level=None if level is None else where(crossed, level, hit.level),
    )
    return y_new, ta_new, hit_new


def lift_off(y: State, ta, pending, t1, line: Line, params: Params, one_sided, uplift, step):
    """Step (1) of :func:`active_pass`: a block at rest lifts off where the forcing first
    exceeds the uplift threshold in ``[ta, t1]`` (with a moving wall ``step``, a
    :class:`WallStep`: where its excess over the wall first turns positive; it lifts with the
    wall's state).

    Returns:
        ``(s, ta, theta_a, theta_dot_a, lift_now, excess)``: the pivot, the time and state the
        flight starts from, whether the block lifts in this pass, and (moving wall) the excess
        at both ends of ``[ta, t1]``.
    """
    if step is not None:
        excess_b, from_start, excess_start = uplift
        # inside the step only after an impact (rare): the wall's excess there
        inside = ~from_start & (y.s == 0) & (y.overturned == 0) & ~pending
        excess_a = cond(
            eqxi.unvmap_any(inside),
            lambda: where(from_start, excess_start, wall_excess(ta, step.at(ta), params, line)),
            lambda: excess_start,
        )
        excess = (excess_a, excess_b)
        lifts, t_up, s_up = find_uplift(ta, t1, line, params, one_sided, excess)
        lift_now = (y.s == 0) & lifts & (y.overturned == 0) & ~pending
    else:
        excess, t_up, s_up, lift_now = uplift
    s = where(lift_now, s_up, y.s)
    ta = where(lift_now, t_up, ta)
    theta_a, theta_dot_a = y.theta, y.theta_dot
    if step is not None:  # at rest the block rides on the wall: it lifts with the wall's state
        wall_up, rate_up, _ = step.at(ta)
        theta_a = where(lift_now, wall_up, theta_a)
        theta_dot_a = where(lift_now, rate_up, theta_dot_a)
    return s, ta, theta_a, theta_dot_a, lift_now, excess


def find_crossing(states, s, ta, h, exploring, lift_now, excess, params: Params, step):
    """Step (3) of :func:`active_pass`, an exploring pass of a rocking block over ``[ta, ta +
    h]``: a crossing if ``u = s theta`` (with a moving wall ``step``: the gap ``theta -
    theta_w``) ends negative, or ends positive after dipping below zero inside the step (a
    graze; the cubic Hermite fit of ``u`` has its turning point below zero). Its time: the
    fit's first root (bisection, then Newton). With a three-branch law the law's kinks count
    too (:func:`kink_crossings`).

    ``states``: ``(theta, theta_dot)`` at ``ta`` and at the flight's end.

    Returns:
        ``(crossed, x, xb, level, theta_f)``: whether a crossing was found, its time and the
        bracket's end as fractions of ``h``, the level crossed (None without a law) and the
        flight's end rotation (held on the wall where the block cleared it).
    """
    theta_a, theta_dot_a, theta_f, theta_dot_f = states
    u0, du0, u1, du1 = s * theta_a, h * s * theta_dot_a, s * theta_f, h * s * theta_dot_f
    # the gap to the wall: g = u, or theta - theta_w(t) with a moving wall (pivot s = +1)
    g0, dg0, g1, dg1 = u0, du0, u1, du1
    if step is not None:
        wall_a, rate_a, _ = step.at(ta)
        wall_b, rate_b = step.terms[2], step.terms[3] / step.h
        g0, dg0 = theta_a - wall_a, h * (theta_dot_a - rate_a)
        g1, dg1 = theta_f - wall_b, h * (theta_dot_f - rate_b)
    x_turn, g_turn = cond(
        eqxi.unvmap_any(exploring & (dg0 < 0) & (dg1 > 0) & (g1 >= 0)),
        lambda: hermite_turn(g0, dg0, g1, dg1),
        lambda: (jnp.ones_like(g1), g1),
    )
    grazes = (g1 >= 0) & (g0 >= 0) & (g_turn < 0)
    crossed = exploring & (h > 0) & ((g1 < 0) | grazes)
    if step is not None:
        # Lifted off in this step with the excess still positive at its end: the gap's second
        # derivative stays positive (the excess is linear), so it cannot close. The gap starts
        # as (t - t_up)^3 and is the difference of two nearly equal rotations: its rounding
        # must not be taken for an impact (that chattered in place).
        clear = lift_now & (excess[1] > 0)
        crossed = crossed & ~clear
        theta_f = where(clear, jnp.maximum(theta_f, wall_b), theta_f)
    xb = where(g1 < 0, 1.0, x_turn)
    x = hermite_root(g0, dg0, g1, dg1, xb)
    level = None
    if params.law is not None:
        # The law's kinks are events too: a step that straddles one loses Tsit5's order
        # (measured: energy errors of 1e-4 per crossing at p dt = 0.03), so it is cut there.
        crossed, x, xb, level = kink_crossings(
            crossed, x, xb, u0, du0, u1, du1, exploring & (h > 0), params.law
        )
    return crossed, x, xb, level, theta_f


def resolve_impact(
    hit: Hit, theta_tau, theta_dot_tau, s, ta, accel, line, record, params, one_sided, step
):
    """Step (4) of :func:`active_pass`, an impact pass that flew to the crossing time
    ``hit.tau`` (state ``theta_tau``, ``theta_dot_tau`` there): one Newton step on the true
    trajectory to the wall (or to a kink of the law, ``hit.level > 0``: then no impact map),
    the impact map (:func:`impact_map`; relative to a moving wall ``step``) and the rest rule.

    Returns:
        ``(t_impact, theta_at, theta_dot_plus, s_plus, rate_at, wall, rests, hop)``: the
        impact (or kink) time [s] and rotation there [rad], the velocity and pivot after it,
        the wall's rate there [rad/s] (0 for a fixed wall), whether it is an impact on the
        wall, whether the block rests and the rest rule's hop [rad].
    """
    pending = hit.pending
    if step is not None:
        wall_tau, rate_tau, _ = step.at(hit.tau)
        gap, closing = theta_tau - wall_tau, theta_dot_tau - rate_tau
        t_wall = clip(hit.tau - gap / safe(closing), ta, hit.t_hi)
    else:
        t_wall = clip(hit.tau - theta_tau / safe(theta_dot_tau), ta, hit.t_hi)
    if hit.level is None:
        t_impact = t_wall
        wall = pending
        theta_at = jnp.zeros_like(t_wall)
    else:  # a kink: the same Newton step to u = level, then no impact map
        wall = pending & (hit.level == 0)
        theta_kink = s * hit.level
        t_kink = clip(hit.tau - (theta_tau - theta_kink) / safe(theta_dot_tau), ta, hit.t_hi)
        t_impact = where(wall, t_wall, t_kink)
        theta_at = where(wall, 0.0, theta_kink)
    theta_dot_tau = theta_dot_tau + accel(hit.tau, theta_tau) * (t_impact - hit.tau)
    rate_at = jnp.zeros_like(t_impact)  # the wall's rate at the impact [rad/s]
    if step is not None:
        wall_at, rate_at, _ = step.at(t_impact)
        theta_at = where(wall, wall_at, theta_at)
        theta_dot_plus, s_plus = impact_map(theta_dot_tau, s, params.e, one_sided, rate_at)
    else:
        theta_dot_plus, s_plus = impact_map(theta_dot_tau, s, params.e, one_sided)
    if hit.level is not None:
        theta_dot_plus = where(wall, theta_dot_plus, theta_dot_tau)
        s_plus = where(wall, s_plus, s)
    # The rule reads the record at up to REST_HORIZON + 2 times (gathers, the costliest part
    # of a pass in a batch): only when some record of the batch impacts.
    rebound = jnp.abs(theta_dot_plus - rate_at) if step is not None else jnp.abs(theta_dot_plus)
    rests, hop = cond(
        eqxi.unvmap_any(pending),
        lambda: rest_rule(t_impact, rebound, s_plus, line, record, params, one_sided, step),
        lambda: (jnp.zeros_like(pending), jnp.zeros_like(t_impact)),
    )
    return t_impact, theta_at, theta_dot_plus, s_plus, rate_at, wall, wall & rests, hop


def kink_crossings(crossed, x, xb, u0, du0, u1, du1, exploring, law: LawTerms):
    """The first of the wall crossing (``crossed`` at ``x`` in [0, ``xb``]) and the law's kinks
    ``u = u1`` (when ``Delta_1 > 0``) and ``u = u2`` (when ``Delta_2 > Delta_1``) crossed inside
    the step (a change of sign of ``u - level`` between its ends; a kink grazed and left within
    one step is not cut), as ``(crossed, x, xb, level)`` with ``level = 0`` for the wall."""
    level = jnp.zeros_like(x)
    for c, active in ((law.u1, law.u1 > 0), (law.u2, law.u2 > law.u1)):
        sign = where(u0 > c, 1.0, -1.0)  # so that the fit of sign (u - c) starts >= 0
        w0, w1 = sign * (u0 - c), sign * (u1 - c)
        hits = exploring & active & (w0 > 0) & (w1 < 0)
        xk = hermite_root(w0, sign * du0, w1, sign * du1, jnp.ones_like(x))
        first = hits & (~crossed | (xk < x))
        x = where(first, xk, x)
        xb = where(first, 1.0, xb)
        level = where(first, c, level)
        crossed = crossed | hits
    return crossed, x, xb, level
