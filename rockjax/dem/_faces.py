"""The joints' forces: a face of a block against the body below it (the ground or a block),
the block beside it (a row) or a return wall, integrated over the face (the contact law of
:mod:`rockjax.contact`, the one home of the point law and its face integrands) or summed over
point sub-contacts; their dashpot matrices and spring energies.

Contact between two rigid bodies (docs/assemblies.md, "Two-body joints"): a point ``P`` of the
upper block's bottom face, at body coordinate ``t`` along the face, penetrates the lower body
(the block below, or the ground) by ``delta = h_l/2 - e2 . (P - X_l)``, ``e2`` the lower
body's normal; the penetration rate and the slip rate are the normal and tangential parts of
the velocity of ``P`` relative to the coincident material point of the lower body. For rigid
bodies all of these are affine in ``t``, so the contact law of a point
(:func:`rockjax.contact.normal_force`, with its onset window) is piecewise polynomial in
``t``, with breakpoints where the penetration at the ends of the step window,
``delta -+ delta_dot dt/2``, changes sign: the face is cut there and each piece integrated by
two-point Gauss-Legendre (exact on the closed part, degree <= 2; on the onset band exact to
``O(dt^2)`` of a force that lasts a fraction of a step). Shear: one resultant elastic-plastic
spring per face (docs/theory.md, "Integrated face contact"); forces act along the lower body's
normal and tangent, equal and opposite on the two bodies. ``Joint(n_sub=k)`` puts ``k`` point
sub-contacts on each face instead (trapezoidal tributary areas). A head joint between blocks
side by side (a row) is the same with the frames turned by a right angle: block ``k``'s -x
face against block ``k - 1``'s +x face; it is smooth (no shear spring or dashpot,
docs/assemblies.md "Blocks side by side").
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp

from .._fusion import computed_once, one_computation, sum_together
from .._walls import wall_line, wall_pivot, wall_rise
from ..contact import (
    closed_interval,
    coulomb,
    crossing,
    face_integrands,
    insert_cut,
    normal_force,
    shear_force,
)
from ._algebra import add, is_zero, mul, plus
from ._params import DemParams, DemState, span

GAUSS = (-1.0 / math.sqrt(3.0), 1.0 / math.sqrt(3.0))
"""Two-point Gauss-Legendre nodes on [-1, 1] (weights 1): exact for cubics. Each piece of a
face between the breakpoints of the contact law gets this rule, so the closed part's
polynomials (degree <= 2 in the face coordinate) are integrated exactly."""


SPRINGS_SUMMED = 2
"""Faces of at most this many point sub-contacts (the two corners) return their points' new
shear springs from the reduction that sums the point law (:func:`point_sums`); faces of more
points slice them out of the points' array. Measured (docs/benchmarks.md, "Two corners: the
springs in the sums"): the two corners' batch 1.2x faster, one history the same; with 4 or
8 points the extra sums cost more than they save (a batch 2x and 1.3x slower), and one
history of 3 or 8 points ran 1.1x and 1.6x slower."""


def pair_kinematics(p: DemParams, st: DemState, i: int):
    """The geometry of interface ``i`` as a function of the face coordinate ``t``: returns
    ``kin(t) -> (rx_u, ry_u, dx, dy, delta, delta_dot, slip)`` (arms of the point from the
    face block's and the other body's centroids, penetration, its rate, slip rate), the
    other body's unit tangent ``e1`` and normal ``e2`` (world), and the centroids' offset
    ``X_u - X_l`` (None for the ground).

    A bed joint: block ``k``'s bottom face point ``(t, -h_k/2)`` against the top face of the
    body below (normal its body +y). A head joint: block ``k``'s -x face point
    ``(-b_k/2, t)`` against the +x face of block ``other`` (normal that block's body +x,
    tangent its body +y), the same formulas with the frames turned by a right angle."""
    k, other, kind = p.links[i]
    cu, su, xu, yu = st.c[k], st.s[k], st.x[k], st.y[k]
    vxu, vyu, wu = st.vx[k], st.vy[k], st.w[k]
    head = kind == "head"
    half = 0.5 * (p.b[k] if head else p.h[k])
    if other < 0:  # the ground: fixed, normal +y, surface y = 0

        def kin(t):
            rx = t * cu - half * su
            ry = -t * su - half * cu
            return rx, ry, xu + rx, yu + ry, -(yu + ry), -(vyu - wu * rx), vxu + wu * ry

        return kin, (1.0, 0.0), (0.0, 1.0), None
    cl, sl, xl, yl = st.c[other], st.s[other], st.x[other], st.y[other]
    vxl, vyl, wl = st.vx[other], st.vy[other], st.w[other]
    if head:
        hl = 0.5 * p.b[other]
        e1, e2 = (sl, cl), (cl, -sl)
    else:
        hl = 0.5 * p.h[other]
        e1, e2 = (cl, -sl), (sl, cl)
    x_rel, y_rel = xu - xl, yu - yl

    def kin(t):
        if head:  # body point (-b_k/2, t)
            rx = -half * cu + t * su
            ry = half * su + t * cu
        else:  # body point (t, -h_k/2)
            rx = t * cu - half * su
            ry = -t * su - half * cu
        dx, dy = x_rel + rx, y_rel + ry
        gx = vxu + wu * ry - vxl - wl * dy
        gy = vyu - wu * rx - vyl + wl * dx
        return (
            rx,
            ry,
            dx,
            dy,
            hl - (e2[0] * dx + e2[1] * dy),
            -(e2[0] * gx + e2[1] * gy),
            e1[0] * gx + e1[1] * gy,
        )

    return kin, e1, e2, (x_rel, y_rel)


def wall_kinematics(p: DemParams, st: DemState, k: int | jax.Array, motion=None):
    """The back face of block ``k`` against the return wall, as :func:`pair_kinematics`
    gives a joint: the point ``(-b_k/2, t)`` (``t`` up the face) penetrates the wall line by
    ``delta``; the wall's normal is ``+x``, its tangent ``+y`` (the slip is the point's
    vertical velocity less the wall's), as on the back face of :func:`rockjax.simulate_dem`'s
    facade. ``kin(t)`` returns ``(rx, ry, x_pt, y_pt, delta, delta_dot, slip)``.

    A fixed wall (``motion`` None) is the line ``x = x0_k - b_k/2 - gap`` (the block's back
    face at rest, ``gap`` behind it), ``delta = x_wall - x``. A moving wall (``motion =
    (u_top, v_top)`` [m, m/s] at the stack's height ``H``) is those lines turned rigidly to
    ``theta_w = u_top / H`` about block 0's toe ``(x0_0 + b_0/2 - gap, 0)`` (its heel for
    ``theta_w < 0``): ``wall_line`` (``rockjax/_walls.py``), whose line ``x = x0 + slope y`` gives
    ``delta = x0 + slope y - x``. The last value returned is then ``(slope, x0', slope',
    x_pivot, theta_w')`` (None for a fixed wall)."""
    c, s, x, y = st.c[k], st.s[k], st.x[k], st.y[k]
    vx, vy, w = st.vx[k], st.vy[k], st.w[k]
    hb = 0.5 * p.b[k]
    x_wall = p.x0[k] - hb - p.wall_gap
    if motion is None:

        def kin(t):
            rx = t * s - hb * c
            ry = t * c + hb * s
            return rx, ry, x + rx, y + ry, x_wall - (x + rx), -(vx + w * ry), vy - w * rx

        return kin, (0.0, 1.0), (1.0, 0.0), None, None
    height = jnp.sum(p.h)
    theta_w, rate = motion[0] / height, motion[1] / height
    toe = p.x0[0] + 0.5 * p.b[0] - p.wall_gap
    heel = p.x0[0] - 0.5 * p.b[0] - p.wall_gap
    x_pivot = wall_pivot(theta_w, toe, heel)
    x0, slope, x0_dot, slope_dot = wall_line(x_wall, x_pivot - x_wall, theta_w, rate)

    def kin_moving(t):
        rx = t * s - hb * c
        ry = t * c + hb * s
        x_pt, y_pt = x + rx, y + ry
        xd, yd = vx + w * ry, vy - w * rx
        delta = x0 + slope * y_pt - x_pt
        delta_dot = -xd + x0_dot + slope_dot * y_pt + slope * yd
        return rx, ry, x_pt, y_pt, delta, delta_dot, yd - wall_rise(x_pivot, rate, x_pt)

    return kin_moving, (0.0, 1.0), (1.0, 0.0), None, (slope, x0_dot, slope_dot, x_pivot, rate)


def wall_reach(p: DemParams, st: DemState, reach, motion=None):
    """Whether a block's back face is within ``reach`` [s] of its return wall: at either end
    of a back face, the penetration ``delta`` plus ``reach`` times its rate's magnitude is
    positive (where the wall's force can be nonzero within ``reach`` of now, at the present
    rate; a step ``dt`` sees the force once ``delta > -|delta_dot| dt / 2``). ``motion``: a
    moving wall's ``(u_top, v_top)`` now, as :func:`wall_kinematics`."""
    near = jnp.zeros((), bool)
    for k in range(p.n):
        kin = wall_kinematics(p, st, k, motion)[0]
        for t in span(p, k, wall=True):
            end = kin(t)
            near = near | (end[4] + reach * jnp.abs(end[5]) > 0.0)
    return near


def dashpot_blocks(c, moments, e, arm, kappa, ground: bool, once: bool):
    """The dashpot blocks ``c int w r r^T`` of one direction of a face: ``(C_uu, C_ll,
    C_ul)`` (the last two None for the ground), for the upper row ``r_u = (e, a(tau))`` and the
    lower ``r_l = -(e, a(tau) + kappa)``, ``a`` affine in ``tau`` from ``arm`` (its values at
    the face's two ends), ``moments = int w (1, tau, tau^2)``.

    Each entry is one or two products of ``c M0``, ``c M1``, ``c M2`` (``M0 = int w``,
    ``M1 = int w a``, ``M2 = int w a^2``) and the components of ``e``."""
    m0, m1, m2 = moments
    a0, da = arm[0], arm[1] - arm[0]
    big1 = plus(mul(m0, a0), mul(m1, da))
    big2 = plus(mul(mul(m0, a0), a0), mul(2.0, mul(mul(m1, a0), da)), mul(mul(m2, da), da))
    cm0, cm1, cm2 = mul(c, m0), mul(c, big1), mul(c, big2)
    if once:  # (read by every entry below: XLA:CPU would copy them into each)
        if ground:
            cm0, cm1, cm2 = computed_once(cm0, cm1, cm2)
        else:
            cm0, cm1, cm2, kappa = computed_once(cm0, cm1, cm2, kappa)

    uu = [[mul(cm0, mul(e[i], e[j])) for j in range(2)] + [mul(cm1, e[i])] for i in range(2)]
    uu.append([mul(cm1, e[0]), mul(cm1, e[1]), cm2])
    if ground:
        return uu, None, None
    cm1_l = plus(cm1, mul(kappa, cm0))  # c int w (a + kappa)
    cm2_l = plus(cm2, mul(2.0, mul(kappa, cm1)), mul(mul(kappa, kappa), cm0))
    cm2_ul = plus(cm2, mul(kappa, cm1))  # c int w a (a + kappa)
    ll = [[mul(cm0, mul(e[i], e[j])) for j in range(2)] + [mul(cm1_l, e[i])] for i in range(2)]
    ll.append([mul(cm1_l, e[0]), mul(cm1_l, e[1]), cm2_l])
    ul = [
        [mul(-1.0, mul(cm0, mul(e[i], e[j]))) for j in range(2)] + [mul(-1.0, mul(cm1_l, e[i]))]
        for i in range(2)
    ]
    ul.append([mul(-1.0, mul(cm1, e[0])), mul(-1.0, mul(cm1, e[1])), mul(-1.0, cm2_ul)])
    return uu, ll, ul


def sum_terms(wfn, wf_el, wn, wf, tau, slip, fs):
    """The 13 quantities a face sums over its points (weights ``w`` included):
    :func:`rockjax.contact.face_integrands` in the face coordinate ``tau`` and the point
    shear springs ``fs (1, tau)``; Python zeros where a joint has none (the face law's point
    springs, the sub-contacts' ``f_el``)."""
    return face_integrands(wfn, wf_el, wn, wf, slip, tau, tau) + [fs, mul(fs, tau)]


def point_sums(p: DemParams, k, pts, lo, width, ends, hist, kn, beta, dt, dt_onset, clipped):
    """The sums over a face's points ``pts`` (``(t, weight)``, :func:`sum_terms`) and the
    point shear springs (None for the face law): see :func:`interface`.

    The points are one array and the sums one reduction (:func:`rockjax._fusion.sum_together`),
    which evaluates the point law once per point for all the sums and keeps the sums whole for
    the many consumers that read them, in a history and in a batch alike."""
    d_lo, d_hi = ends[0][4], ends[1][4]
    r_lo, r_hi = ends[0][5], ends[1][5]
    t = jnp.stack([jnp.asarray(q[0], float) for q in pts])
    wgt = jnp.stack([jnp.asarray(q[1], float) for q in pts])
    tau = (t - lo) / width
    delta = d_lo + tau * (d_hi - d_lo)
    rate = r_lo + tau * (r_hi - r_lo)
    slip = ends[0][6] + tau * (ends[1][6] - ends[0][6])
    if p.face:
        f, f_el, frac = normal_force(delta, rate, kn, beta, p.dashpot, dt_onset)
        wf, wfn, wf_el = wgt * frac, wgt * f, wgt * f_el
        ws = wf  # the face's shear dashpot: weighted by its one spring's stick in interface
        fs_arr, fs_sum = None, 0.0
    else:
        kn_i, ks_i = p.kn_line[k] * wgt, p.ks_line[k] * wgt
        f, f_el, frac = normal_force(delta, rate, kn_i, beta, p.dashpot, dt_onset)
        fs_old = jnp.stack([jnp.asarray(v, float) for v in hist])
        # a sliding point's shear dashpot is off (rockjax.contact.coulomb)
        _, fs_arr, w_s = shear_force(fs_old, slip, dt, ks_i, f_el, p.tan_phi, beta, frac)
        wf, wfn, wf_el, fs_sum = wgt * frac, f, 0.0, fs_arr
        ws = wgt * w_s
    wn = jnp.where(f > 0, wf, 0.0) if clipped else wf
    terms = sum_terms(wfn, wf_el, wn, ws, tau, slip, fs_sum)
    live = [i for i, term in enumerate(terms) if not is_zero(term)]
    springs = []
    if fs_arr is not None and len(pts) <= SPRINGS_SUMMED:
        # each point's new spring as one more sum, the other point's masked out: the point
        # law is then evaluated once for the sums and the springs alike (sliced out of the
        # points' array, each spring's fusion evaluated it again)
        index = jnp.arange(len(pts))
        springs = [jnp.where(index == i, fs_arr, 0.0) for i in range(len(pts))]
    totals = sum_together(*(terms[i] for i in live), *springs)
    sums = [0.0] * len(terms)
    for i, total in zip(live, totals):
        sums[i] = total
    if springs:
        return sums, tuple(totals[len(live) :])
    return sums, None if fs_arr is None else tuple(fs_arr[i] for i in range(len(pts)))


def face_ends(p: DemParams, st: DemState, motion=None, one_history: bool = False):
    """Each face's kinematics at its two ends, ``[kin(lo), kin(hi)]``: a list for the joints
    (:func:`pair_kinematics`) and one for the blocks' back faces on the return walls
    (:func:`wall_kinematics`, ``motion`` as there; empty without return walls).

    Most of a step reads them. A history that is not batched computes them all as one XLA
    computation (:func:`rockjax._fusion.one_computation`): XLA:CPU would copy them into each
    consumer, and one computation for every face ran faster than one per face
    (docs/assemblies.md, "Performance")."""

    def ends(kin, span):
        return [kin(span[0]), kin(span[1])]

    def compute(_):
        joints = [ends(pair_kinematics(p, st, j)[0], span(p, j)) for j in range(len(p.links))]
        walls = []
        if p.one_sided:
            walls = [
                ends(wall_kinematics(p, st, k, motion)[0], span(p, k, wall=True))
                for k in range(p.n)
            ]
        return joints, walls

    if one_history:
        return one_computation(compute, st.x[0])
    return compute(None)


def interface(
    p: DemParams,
    st: DemState,
    k: int | jax.Array,
    dt,
    ends,
    wall: bool = False,
    motion=None,
    once: bool = False,
    whole: bool = True,
):
    """Forces of interface ``k`` (integrated face law or point sub-contacts), or with ``wall``
    of block ``k``'s back face on the return wall (a body moved by ``motion``, see
    :func:`wall_kinematics`; None: fixed, as the ground); ``ends``: the face's kinematics at
    its ends (:func:`face_ends`).

    Returns ``(F_u, F_l, C_uu, C_ll, C_ul, fs_new, fn, power, ft)``: generalised forces
    ``(Fx, Fy, M)`` on the upper and lower block (``F_l`` None for the ground and the wall),
    the dashpot matrix blocks, the new shear springs, the total normal force [N] (along the
    lower body's normal; a moving wall's: its horizontal component), the power of a moving
    wall on the block [W] (0 otherwise) and the total shear force [N] (spring and dashpot,
    along the lower body's tangent), both on the upper block, dashpots at the lagged
    velocity.

    ``whole``: keep the values that many others read (the face's cuts, its shear spring and
    the spring's dashpot) as one computation each (:func:`rockjax._fusion.computed_once`);
    ``once``: the dashpot blocks' moments too. The step of one history of a single block
    without a return wall passes neither (:func:`rockjax.dem.step`)."""
    line = None
    if wall:
        _, e1, e2, rel, line = wall_kinematics(p, st, k, motion)
        hist = st.fs_wall[k]
    else:
        _, e1, e2, rel = pair_kinematics(p, st, k)
        hist = st.fs[k]
    lo, hi = span(p, k, wall)
    width = hi - lo
    ground = rel is None
    dt_onset = dt if p.onset == "sub_step" else None
    clipped = p.dashpot == "clipped"
    beta = p.beta

    def arms(e, r):
        rx, ry = r
        # clockwise moment of a unit force along e at offset r
        return plus(mul(ry, e[0]), mul(-1.0, mul(rx, e[1])))

    an_u = [arms(e2, end[0:2]) for end in ends]
    as_u = [arms(e1, end[0:2]) for end in ends]

    d_lo, d_hi = ends[0][4], ends[1][4]
    r_lo, r_hi = ends[0][5], ends[1][5]
    if p.face:
        kn, ks = p.kn_line[k], p.ks_line[k]
        if dt_onset is not None:
            hw = 0.5 * dt
            z1 = crossing(lo, hi, d_lo - hw * r_lo, d_hi - hw * r_hi)
            z2 = crossing(lo, hi, d_lo + hw * r_lo, d_hi + hw * r_hi)
            cuts = [lo, jnp.minimum(z1, z2), jnp.maximum(z1, z2), hi]
        else:
            cuts = [lo, crossing(lo, hi, d_lo, d_hi), hi]
        if clipped:
            cuts = insert_cut(cuts, crossing(lo, hi, d_lo + beta * r_lo, d_hi + beta * r_hi))
        # each cut is read by the positions and weights of the points either side of it
        if whole:
            cuts = [lo, *computed_once(*cuts[1:-1]), hi]
        pts = []
        for a, b_ in zip(cuts[:-1], cuts[1:]):
            mid, half = 0.5 * (a + b_), 0.5 * (b_ - a)
            for xg in GAUSS:
                pts.append((mid + half * xg, half))
    else:
        n_sub = p.n_sub
        wts = [1.0] * n_sub
        wts[0] = wts[-1] = 0.5
        step = width / (n_sub - 1)
        pts = [(lo + step * i, wts[i] * step) for i in range(n_sub)]
    sums, fs_points = point_sums(
        p, k, pts, lo, width, ends, hist, p.kn_line[k], beta, dt, dt_onset, clipped
    )
    fn, fn_el, fn1, n0, n1, n2, s0, s1, s2, v0, v1, fs_tot, fs_tau = (sums[i] for i in range(13))
    if p.face:
        kn_c = kn
        (f_s,) = hist
        # the resultant shear spring keeps the share of the stress over the closed part that
        # stays closed (Joint.shear_release); the previous penetration is delta - dt delta_dot
        if p.shear_release != "none":
            f_s = f_s * kept_share(lo, hi, d_lo, d_hi, dt * r_lo, dt * r_hi, p.shear_release)
        # the shear dashpot acts only while the face sticks (rockjax.contact.coulomb)
        f_s, stick = coulomb(f_s - ks * v0 * dt, p.tan_phi * fn_el)
        # the shear dashpot's stiffness: state-dependent now, and read by the forces and the
        # dashpot blocks, so computed once with the spring
        ks_d = stick * ks
        if whole:
            f_s, ks_d = computed_once(f_s, ks_d)
        tau_bar = jnp.where(s0 > 0.0, s1 / jnp.where(s0 > 0.0, s0, 1.0), 0.0)
        fs_new = (f_s,)
        fs_mom_tau = f_s * tau_bar  # int of the spring force times tau
    else:
        # the weights above carry the areas, and the shear sums each point's stick
        kn_c, ks_d = p.kn_line[k], p.ks_line[k]
        f_s, fs_mom_tau = fs_tot, fs_tau
        fs_new = fs_points
    ft = f_s - beta * ks_d * v0
    # a moving wall's normal force acts along its normal (1, -slope) (not normalised: fn is
    # the horizontal component, as in rockjax.simulate_dem); the dashpot matrix keeps the
    # fixed wall's rows, as simulate_dem's does
    e2_f = e2 if line is None else (1.0, -line[0])
    an_f = an_u if line is None else [arms(e2_f, end[0:2]) for end in ends]
    fx = plus(mul(fn, e2_f[0]), mul(ft, e1[0]))
    fy = plus(mul(fn, e2_f[1]), mul(ft, e1[1]))

    def moment(an, as_):
        # int f arm_n + shear spring force arm_s - shear dashpot arm_s, arms affine in tau
        dn, ds = an[1] - an[0], as_[1] - as_[0]
        return (
            an[0] * fn
            + dn * fn1
            + as_[0] * f_s
            + ds * fs_mom_tau
            - beta * ks_d * (as_[0] * v0 + ds * v1)
        )

    f_u = (fx, fy, moment(an_f, as_u))
    cn, cs = beta * kn_c, beta * ks_d
    # dashpot rows: upper (e, arm_u), lower -(e, arm_l), arms affine in tau; the lower arm is
    # the upper one shifted by kappa = (X_u - X_l) x e, a constant
    kappa_n = kappa_s = 0.0
    if not ground:
        x_rel, y_rel = rel
        kappa_n = plus(mul(y_rel, e2[0]), mul(-1.0, mul(x_rel, e2[1])))
        kappa_s = plus(mul(y_rel, e1[0]), mul(-1.0, mul(x_rel, e1[1])))
    blocks = [
        dashpot_blocks(cn, (n0, n1, n2), e2, an_u, kappa_n, ground, once),
        dashpot_blocks(cs, (s0, s1, s2), e1, as_u, kappa_s, ground, once),
    ]
    c_uu = add(blocks[0][0], blocks[1][0])
    fn_out = fn
    power = 0.0
    if line is not None:
        _, x0_dot, slope_dot, x_pivot, rate = line
        # the line moves at x0' + slope' y_pt under the normal force (y_pt affine in tau:
        # int f y_pt = y_lo fn + (y_hi - y_lo) int f tau); the wall's material rises at
        # rate (x_pivot - x_pt) under the shear force (int f_t tau: the shear's moment sums)
        y_lo, dy = ends[0][3], ends[1][3] - ends[0][3]
        x_lo, dx = ends[0][2], ends[1][2] - ends[0][2]
        ft_tau = fs_mom_tau - beta * ks_d * v1
        power = x0_dot * fn + slope_dot * (y_lo * fn + dy * fn1)
        power = power + rate * ((x_pivot - x_lo) * ft - dx * ft_tau)
    if ground:
        return f_u, None, c_uu, None, None, fs_new, fn_out, power, ft
    # the lower body: the opposite forces, with arms shifted by X_u - X_l
    f_l = (-fx, -fy, -(f_u[2] + y_rel * fx - x_rel * fy))
    c_ll = add(blocks[0][1], blocks[1][1])
    c_ul = add(blocks[0][2], blocks[1][2])
    return f_u, f_l, c_uu, c_ll, c_ul, fs_new, fn_out, power, ft


def kept_share(lo, hi, d_lo, d_hi, dd_lo, dd_hi, release: str):
    """The share of a face's shear spring kept as its closed part moves from the previous
    step's (penetration ``d - dd`` at the ends ``lo``, ``hi``) to this one's (``d``): the
    part closed then and now, weighted uniformly (``release="uniform"``) or by the previous
    penetration (``"pressure"``); 0 if nothing was closed."""
    o_lo, o_hi = d_lo - dd_lo, d_hi - dd_hi
    ca_old, cb_old = closed_interval(lo, hi, o_lo, o_hi)
    ca, cb = closed_interval(lo, hi, d_lo, d_hi)
    ka, kb = jnp.maximum(ca, ca_old), jnp.minimum(cb, cb_old)
    kb = jnp.maximum(kb, ka)
    if release == "pressure":

        def old_pen(x):
            return o_lo + (x - lo) / (hi - lo) * (o_hi - o_lo)

        def integral(a, b):
            return 0.5 * (b - a) * (old_pen(a) + old_pen(b))

        whole, kept = integral(ca_old, cb_old), integral(ka, kb)
    else:
        whole, kept = cb_old - ca_old, kb - ka
    safe = jnp.where(whole > 0.0, whole, 1.0)
    return jnp.where(whole > 0.0, jnp.clip(kept / safe, 0.0, 1.0), 0.0)


def face_energy(p: DemParams, k: int | jax.Array, span, ends, hist):
    """Spring energy [J] of one face of block ``k`` (``span = (lo, hi)`` its face coordinates,
    ``ends`` its kinematics there (:func:`face_ends`), ``hist`` its shear springs):
    ``kn delta^2 / 2`` integrated exactly over the closed part, and ``f_s^2 / (2 k_s)`` of the
    shear springs."""
    e = 0.0
    lo, hi = span
    d_lo, d_hi = ends[0][4], ends[1][4]
    if p.face:
        ca, cb = closed_interval(lo, hi, d_lo, d_hi)
        mid, half = 0.5 * (ca + cb), 0.5 * (cb - ca)
        for xg in GAUSS:
            tau = (mid + half * xg - lo) / (hi - lo)
            d = d_lo + tau * (d_hi - d_lo)
            e = e + 0.5 * p.kn_line[k] * half * jnp.maximum(d, 0.0) ** 2
        length = cb - ca
        safe = jnp.where(length > 0.0, length, 1.0)
        ks = p.ks_line[k]
        ok = (length > 0.0) & (ks > 0.0)  # (a smooth head joint has no shear spring)
        return e + jnp.where(ok, 0.5 * hist[0] ** 2 / jnp.where(ok, ks * safe, 1.0), 0.0)
    n_sub = p.n_sub
    step = (hi - lo) / (n_sub - 1)
    for i in range(n_sub):
        wgt = (0.5 if i in (0, n_sub - 1) else 1.0) * step
        d = d_lo + i / (n_sub - 1) * (d_hi - d_lo)
        e = e + 0.5 * p.kn_line[k] * wgt * jnp.maximum(d, 0.0) ** 2
        ks = p.ks_line[k] * wgt
        e = e + jnp.where(ks > 0.0, 0.5 * hist[i] ** 2 / jnp.where(ks > 0.0, ks, 1.0), 0.0)
    return e
