"""What happens at ``theta = 0`` besides the flight: the impact map (``impact_map``), the
uplift from rest (``uplift``) and the rest and chatter rule after an impact (``rest_rule``;
docs/theory.md, "Housner rest and chatter rule")."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from ..constants import G
from ._field import restoring, wall_excess
from ._lax import clip, safe, where
from ._params import REST_A_MARGIN, REST_HOP, REST_HORIZON, Params
from ._record import Line, Record


def impact_map(theta_dot, s, e, one_sided: bool, rate=None):
    """The velocity [rad/s] and pivot just after an impact at ``theta = 0`` (or on a moving
    wall) with velocity ``theta_dot`` on pivot ``s``: two-sided the block switches corner,
    ``theta_dot -> e theta_dot``, ``s -> -s``; one-sided it rebounds about the same corner,
    ``theta_dot -> -e theta_dot``; on a wall moving at ``rate`` [rad/s] the velocity relative
    to it is restituted (the paper's rule in the wall's frame). ``e``: the restitution
    magnitude [-]."""
    if rate is not None:
        return rate - e * (theta_dot - rate), s
    if one_sided:
        return -e * theta_dot, s
    return e * theta_dot, -s


def find_uplift(ta, t1, line: Line | None, params: Params, one_sided: bool, excess=None):
    """First time in ``[ta, t1]`` the linear forcing exceeds the uplift threshold, and the pivot.

    Two-sided: ``a_g - tan(eta) g_eff > 0`` lifts onto ``s = -1``, ``-a_g - tan(eta) g_eff > 0``
    onto ``s = +1``; one-sided only the latter. Both are linear in ``t``.

    With a moving wall ``excess`` gives the excess at ``ta`` and ``t1`` instead (see
    ``wall_excess``), linear in between, and ``line`` is not read (None).

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
        frac = clip(-fa / safe(fb - fa), 0.0, 1.0)
        tau = frac * (t1 - ta)
        micro = (fa > 0) & (fb <= 0) & ((2.0 / 3.0) * k * fa * tau * tau <= hop_limit)
        t = where(fa > 0, ta, ta + tau)
        return ((fa > 0) | (fb > 0)) & ~micro, t

    if excess is not None:
        # the excess is over the law's threshold lam_up; lift-off needs lam_lift (make_params)
        shift = (params.lam_lift - params.lam_up) * G
        lifts_pos, t_pos = first_positive(excess[0] - shift, excess[1] - shift)
        return lifts_pos, t_pos, jnp.ones_like(ta)
    a_a, g_a = line.at(ta)
    a_b, g_b = line.at(t1)
    tan_eta = params.lam_lift  # tan(eta) for the rigid block; the law's threshold otherwise
    lifts_pos, t_pos = first_positive(-a_a - tan_eta * g_a, -a_b - tan_eta * g_b)
    if one_sided:
        return lifts_pos, t_pos, jnp.ones_like(ta)
    lifts_neg, t_neg = first_positive(a_a - tan_eta * g_a, a_b - tan_eta * g_b)
    neg_first = lifts_neg & (~lifts_pos | (t_neg < t_pos))
    return (
        lifts_pos | lifts_neg,
        where(neg_first, t_neg, t_pos),
        where(neg_first, -1.0, 1.0),
    )


def rest_rule(
    t_imp, w, s_new, line: Line, record: Record, params: Params, one_sided: bool, step=None
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
        ap0, am0 = restoring(*line.at(t_imp), params)
    else:  # relative to the moving wall: A_+ = -(block's free acceleration - wall's)
        ap0 = -k * wall_excess(t_imp, step.at(t_imp), params, line)
        am0 = ap0
    e = params.e
    if one_sided:
        a_new = a_other = ap0
        ok0 = ap0 > 0
        zeno = 2.0 * w / safe((1.0 - e) * ap0)
    else:
        a_new = where(s_new > 0, ap0, am0)
        a_other = where(s_new > 0, am0, ap0)
        ok0 = (ap0 > 0) & (am0 > 0)
        zeno = 2.0 * w / safe(1.0 - e * e) * (1.0 / safe(a_new) + e / safe(a_other))
    ok0 = ok0 & (e < 1.0)
    fits = ok0 & (2.0 * zeno <= REST_HORIZON * record.dt)
    t_end = t_imp + where(fits, 2.0 * zeno, 0.0)

    def keeps(ap, am, inside):
        ok = ~inside | (ap >= REST_A_MARGIN * ap0)
        return ok if one_sided else ok & (~inside | (am >= REST_A_MARGIN * am0))

    def restoring_at(t):
        if record.wall_theta is None:
            return restoring(*record.at(t), params)
        a = -k * wall_excess(t, record.wall(t), params, record)
        return a, a

    def restoring_samples(i):
        if record.wall_theta is None:
            return restoring(*record.sample(i), params)
        a = -k * record.excess_at_samples(i)
        return a, a

    stays = fits & keeps(*restoring_at(t_end), jnp.ones_like(fits))
    # the samples inside (t_imp, t_end), all at once (one gather, a small graph)
    i = jax.lax.stop_gradient(jnp.floor(t_imp / record.dt)).astype(jnp.int32)
    i = i + jnp.arange(1, REST_HORIZON + 1, dtype=jnp.int32)
    inside = i * record.dt < t_end
    stays = stays & jnp.all(keeps(*restoring_samples(i), inside))
    hop = w * w / (2.0 * safe(where(ok0, a_new, 1.0)))
    # Second clause: a rebound too small to matter (its gravity-only hop <= REST_HOP eta).
    tiny = w * w <= params.w2_tiny
    rests = stays | tiny
    return rests, where(stays, hop, 0.0)
