"""One central-difference step of the blocks with centred dashpots, the energy and the
collapse rule.

Dashpots are centred: with ``F`` the forces at the lagged half-step velocities and ``C`` the
dashpot matrix of all closed contacts, ``(M + dt/2 C) a = F``. ``C`` couples the two blocks of
each joint, and every joint couples block ``k`` to the ground or to block ``k - 1`` (a stack
or a row), so the system is block-tridiagonal (3 x 3 blocks; one block: a 3 x 3 solve); it
is solved exactly every step (no lag: the scheme stays second-order). ``cos``/``sin`` of
theta are carried and advanced by the exact rotation through ``dtheta = dt w``, with its
cosine and sine from their Taylor series: ``|dtheta| < 1e-2`` in any stable step, so the
truncation (``dtheta^6/720``) is below 1e-15, and no transcendental function is evaluated in
the loop.

The solve: every new velocity and position reads the accelerations, and XLA:CPU would copy
the solve into each of them; it is kept as one computation (:func:`rockjax._fusion.one_computation`,
a ``cond``) in a history and in batches of assemblies, and in batches of single blocks as
a reduction (:func:`rockjax._fusion.computed_once`), which needs no predicate over the batch.
Measured (docs/benchmarks.md, "Batches of single blocks: the solve without a cond"): a batch
of single blocks in chunks of 256 without the hoisting pass ran 1.1-1.2x faster that way, the
hoisted chunks of 64 as fast; a batch of 16 four-block assemblies ran 6.6x slower, so they keep
the ``cond``.

Values read by many: a face's cuts, its shear spring and the spring's dashpot, the dashpot
blocks' moments and the top restraint's force are each kept as one computation
(:func:`rockjax._fusion.computed_once`, a reduction) in batches and in assemblies, where
XLA:CPU would copy them into each reader. One history of a single block without a return
wall computes them inline: there the reductions cost more than the copies (a 20 s parapet
history under ``jax.jit`` 1.30-1.33 ms instead of 1.43-1.45 ms; docs/benchmarks.md, "One
history: values read by many"), while a two-block wall's history ran 1.3-1.45x slower
without them and a facade IDA 1.1x slower.
"""

from __future__ import annotations

import jax.numpy as jnp

from .._fusion import computed_once, one_computation
from ..constants import G
from ..contact import normal_force
from ._algebra import LDL_BATCH_MAX_BLOCKS, add, mul, plus, scale, solve_ldl, solve_tridiagonal
from ._faces import face_ends, face_energy, interface
from ._params import STATE_FIELDS, DemParams, DemState, as_arrays, as_tuples, span


def top(p: DemParams, st: DemState, dt, top_motion=None, whole: bool = True):
    """Overburden and top restraint on the top block: generalised force and dashpot block.
    ``top_motion``: the restraint's displacement [m] and velocity [m/s] relative to the base
    (``None``: it moves with the base); ``whole``: the restraint's force and dashpot kept as
    one computation each (:func:`rockjax.dem.step`)."""
    k = p.n - 1
    c, s = st.c[k], st.s[k]
    rx, ry = 0.5 * p.h[k] * s, 0.5 * p.h[k] * c  # top face centre from the centroid
    fx = 0.0
    fy = -p.top_load
    mom = rx * p.top_load  # ry * 0 - rx * (-P)
    cmat = None
    if p.restrained:
        qx = st.x[k] + rx
        qxd = st.vx[k] + st.w[k] * ry
        dt_onset = dt if p.onset == "sub_step" else None
        ref, vref = p.x0[k], 0.0
        if top_motion is not None:
            ref, vref = ref + top_motion[0], top_motion[1]
        rel_v = qxd - vref
        f_r, _, frac_r = normal_force(qx - ref - p.gap, rel_v, p.k_top, p.beta, p.dashpot, dt_onset)
        f_l, _, frac_l = normal_force(
            ref - p.gap - qx, -rel_v, p.k_top, p.beta, p.dashpot, dt_onset
        )
        fq = f_l - f_r  # horizontal force on the block at the top face centre
        wr = frac_r if p.dashpot != "clipped" else jnp.where(f_r > 0, frac_r, 0.0)
        wl = frac_l if p.dashpot != "clipped" else jnp.where(f_l > 0, frac_l, 0.0)
        cq = p.beta * p.k_top * (wr + wl)
        if whole:  # each read by several entries of the force and the dashpot matrix
            fq, cq = computed_once(fq, cq)
        fx = fx + fq
        mom = mom + ry * fq
        a = (1.0, 0.0, ry)
        cmat = [[mul(cq, mul(a[i], a[j])) for j in range(3)] for i in range(3)]
    return (fx, fy, mom), cmat


def step(
    p: DemParams,
    st: DemState,
    ag,
    ag_v,
    dt,
    *,
    load=None,
    top_motion=None,
    wall=None,
    one_history: bool = False,
    dt_next=None,
):
    """One central-difference step of the blocks with centred dashpots,
    ``(M + dt/2 C) a_n = F`` (un-jitted: the drivers scan it).

    Args:
        p: The parameters (:func:`rockjax.dem.dem_params`).
        st: The state at step ``n`` (velocities at ``n - 1/2``), in either layout (one in
            the array layout of a tall stack, :class:`rockjax.dem.DemState`, is stepped as
            its scalars and returned in its layout).
        ag: Horizontal acceleration of the base [m/s^2] (the frame of the run).
        ag_v: Vertical acceleration of the base [m/s^2].
        dt: Time step [s].
        load: Optional external load, one ``(Fx, Fy, M)`` [N, N, N m] per block (force on
            the centroid, clockwise moment, the sign of ``theta``), e.g. a control spring
            computed by the caller from ``st``, or ``None``.
        top_motion: Optional ``(u, v)``: the top restraint's horizontal displacement [m] and
            velocity [m/s] relative to the base (a floor above the base floor), or ``None``.
        wall: Optional ``(u_top, v_top)``: a moving return wall's displacement [m] and
            velocity [m/s] at the stack's height relative to the base (one-sided ``p``), or
            ``None`` for a fixed wall.
        one_history: The step of one history, not of a batch (``vmap``): the faces' end
            kinematics are computed as one XLA computation (a driver's choice, docs/assemblies.md
            "Performance").
        dt_next: The step that follows [s] where it differs from ``dt`` (the step that led to
            ``st``, which the forces use): the velocities are kicked by ``(dt + dt_next) / 2``
            and the positions drift by ``dt_next`` (central differences with a variable step,
            second order); None: ``dt``.

    Returns:
        ``(new, acc, power, forces)``: the state at ``n + 1``; the accelerations
        ``[[ax, ay, alpha], ...]`` per block at step ``n`` [m/s^2, rad/s^2] (relative to the
        base); the power of a moving return wall on the blocks [W]; and the step's contact
        forces [N] (the values the step computes anyway, none added): a dict of ``normal``,
        ``shear`` (per interface, on the upper block), ``restraint`` (the top restraint's
        horizontal force on the top block, or None) and ``wall`` (each back face's normal
        force, or None).
    """
    if not isinstance(st.x, tuple):  # a state in the array layout: stepped as its scalars
        new, acc, power, forces = step(
            p, as_tuples(st), ag, ag_v, dt, load=load, top_motion=top_motion, wall=wall,
            one_history=one_history, dt_next=dt_next,
        )  # fmt: skip
        return as_arrays(new), acc, power, forces
    ldl = one_history or p.n <= LDL_BATCH_MAX_BLOCKS
    n = p.n
    # values read by many kept whole, except in one history of a single block without a
    # return wall (module docstring, "Values read by many")
    whole = not (one_history and n == 1 and not p.one_sided)
    kept = dict(once=ldl and whole, whole=whole)
    force = [[0.0, 0.0, 0.0] for _ in range(n)]
    cdiag = [[[0.0] * 3 for _ in range(3)] for _ in range(n)]
    clow = [None] * n
    fs_all, fn_all, ft_all = [], [], []
    joint_ends, wall_ends = face_ends(p, st, wall, one_history)
    for j, (k, other, _) in enumerate(p.links):
        f_u, f_l, c_uu, c_ll, c_ul, fs_new, fn, _, ft = interface(
            p, st, j, dt, joint_ends[j], **kept
        )
        fs_all.append(fs_new)
        fn_all.append(fn)
        ft_all.append(ft)
        force[k] = [plus(force[k][i], f_u[i]) for i in range(3)]
        cdiag[k] = add(cdiag[k], c_uu)
        if f_l is not None:  # other = k - 1 (a stack or a row: a chain)
            force[other] = [plus(force[other][i], f_l[i]) for i in range(3)]
            cdiag[other] = add(cdiag[other], c_ll)
            clow[k] = c_ul
    fs_wall, fn_wall = [], []
    power = 0.0
    if p.one_sided:  # a static choice: walls without return walls run none of this
        for k in range(n):
            f_w, _, c_w, _, _, fs_new, fn, pw, _ = interface(
                p, st, k, dt, wall_ends[k], wall=True, motion=wall, **kept
            )
            power = power + pw
            fs_wall.append(fs_new)
            fn_wall.append(fn)
            force[k] = [plus(force[k][i], f_w[i]) for i in range(3)]
            cdiag[k] = add(cdiag[k], c_w)
    f_top, c_top = top(p, st, dt, top_motion, whole)
    force[n - 1] = [plus(force[n - 1][i], f_top[i]) for i in range(3)]
    if load is not None:
        force = [[plus(force[k][i], load[k][i]) for i in range(3)] for k in range(n)]
    if c_top is not None:
        cdiag[n - 1] = add(cdiag[n - 1], c_top)
    h = 0.5 * dt
    diag, lower, rhs = [], [], []
    for k in range(n):
        mk, ik = p.m[k], p.I_c[k]
        mass = (mk, mk, ik)
        diag.append(
            [
                [plus(mass[i] if i == j else 0.0, mul(h, cdiag[k][i][j])) for j in range(3)]
                for i in range(3)
            ]
        )
        lower.append(None if clow[k] is None else scale(h, clow[k]))
        rhs.append([force[k][0] - mk * ag, force[k][1] - mk * (G + ag_v), plus(force[k][2])])
    solve = solve_ldl if ldl else solve_tridiagonal
    if one_history or n > 1:
        acc = one_computation(solve, diag, lower, rhs)
    else:  # a batch of single blocks: no cond (module docstring, "The solve")
        acc = solve(diag, lower, rhs)
        acc = [computed_once(*acc[0])]
    new = {f: [] for f in (*STATE_FIELDS, "d_max")}
    for k in range(n):
        ax, ay, aw = acc[k]
        fields = advance(*(getattr(st, f)[k] for f in STATE_FIELDS), ax, ay, aw, dt, dt_next)
        for f in STATE_FIELDS:
            new[f].append(fields[f])
        if st.d_max:  # the top displacement at step n (tracked where the driver asks)
            d = st.x[k] - p.x0[k] + 0.5 * p.h[k] * st.s[k]
            new["d_max"].append(jnp.maximum(st.d_max[k], jnp.abs(d)))
    out = DemState(
        **{key: tuple(v) for key, v in new.items()}, fs=tuple(fs_all), fs_wall=tuple(fs_wall)
    )
    forces = dict(
        normal=fn_all,
        shear=ft_all,
        restraint=f_top[0] if p.restrained else None,
        wall=fn_wall if p.one_sided else None,
    )
    return out, acc, power, forces


def advance(x, y, c, s, vx, vy, w, theta, theta_max, ax, ay, aw, dt, dt_next=None) -> dict:
    """A block's (or, as arrays, every block's) :data:`STATE_FIELDS` at step ``n + 1`` from
    those at ``n`` and the accelerations ``ax, ay, aw`` [m/s^2, rad/s^2]: central differences,
    and ``cos``/``sin`` of theta turned by the exact rotation through ``dtheta = dt w`` (its
    cosine and sine as Taylor series, module docstring). With ``dt_next`` (the next step,
    where it differs from ``dt``): the velocities kicked by ``(dt + dt_next) / 2`` and the
    positions moved by ``dt_next``."""
    kick = dt
    if dt_next is not None:
        kick, dt = 0.5 * (dt + dt_next), dt_next
    vx = vx + kick * ax
    vy = vy + kick * ay
    w = w + kick * aw
    dth = dt * w
    d2 = dth * dth
    cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0 - d2 / 720.0))
    sd = dth * (1.0 - d2 * (1.0 / 6.0 - d2 / 120.0))
    return dict(
        x=x + dt * vx,
        y=y + dt * vy,
        c=c * cd - s * sd,
        s=s * cd + c * sd,
        vx=vx,
        vy=vy,
        w=w,
        theta=theta + dth,
        theta_max=jnp.maximum(theta_max, jnp.abs(theta)),
    )


# ----------------------------------------------------------------------------- energy, collapse


def energy(p: DemParams, st: DemState, vel, wall=None, one_history: bool = False):
    """Kinetic + gravity + overburden + spring energy [J] (springs integrated exactly; the
    return walls' too, moved by ``wall = (u_top, v_top)`` [m, m/s] or fixed)."""
    e = 0.0
    joint_ends, wall_ends = face_ends(p, st, wall, one_history)
    for i in range(len(p.links)):
        e = e + face_energy(p, i, span(p, i), joint_ends[i], st.fs[i])
    for k in range(p.n):
        vx, vy, w = vel[k]
        e = e + 0.5 * p.m[k] * (vx**2 + vy**2) + 0.5 * p.I_c[k] * w**2
        e = e + p.m[k] * G * st.y[k]
        if p.one_sided:
            e = e + face_energy(p, k, span(p, k, wall=True), wall_ends[k], st.fs_wall[k])
    return top_energy(p, st, e)


def top_energy(p: DemParams, st: DemState, e=0.0):
    """``e`` plus the overburden's potential energy and the top restraint spring's [J]."""
    k = p.n - 1
    qx = st.x[k] + 0.5 * p.h[k] * st.s[k]
    qy = st.y[k] + 0.5 * p.h[k] * st.c[k]
    e = e + p.top_load * qy
    if p.restrained:
        over = jnp.maximum(jnp.abs(qx - p.x0[k]) - p.gap, 0.0)
        e = e + 0.5 * p.k_top * over**2
    return e


def collapsed(p: DemParams, st: DemState):
    """The collapse rule (docs/assemblies.md, "Collapse"). On the ground (block 0, and the
    whole stack with a free top): past ``|theta| > eta``, or the centre of gravity past the
    edge of the ground joint, rotating outward (the one-block rule of
    :func:`rockjax.simulate_dem`). On a block (block ``k >= 1``, and the sub-stack ``k..N``
    with a free top): the same rule holds both under gravity and in the frame of the block
    below, moving outward in both (a block carried tilted by the one below has not turned
    off its support); the top block of a restrained wall, held at its top, is judged by the
    last rule alone. A block whose bottom face's centre has slid off the block below. A row
    (side by side, docs/assemblies.md "Blocks side by side"): a block can turn past ``eta``
    toward a neighbour only with it, so the row has collapsed when its end block on the side
    of the rotation (block ``n - 1`` for ``theta > 0``, block 0 for ``theta < 0``) is past
    ``eta`` rotating outward."""
    over = jnp.zeros((), bool)
    if p.row:
        for k, sign in ((p.n - 1, 1.0), (0, -1.0)):
            th, w = sign * st.theta[k], sign * st.w[k]
            over = over | ((th > p.eta[k]) & (w > 0))
        return over
    # a restrained wall's top block is held at its top: it falls only off the block below
    for k in range(p.n - 1 if p.restrained and p.n > 1 else p.n):
        below = None if k == 0 else (st.theta[k - 1], st.w[k - 1])
        over = over | turned_off(st.theta[k], st.w[k], p.eta[k], below)
    if p.n > 1 and not p.restrained:
        k_top = p.n - 1
        hq = 0.5 * p.h[k_top]
        wq = p.top_load / G  # the overburden, a weight at the top face centre Q
        mass = wq
        mx = wq * (st.x[k_top] + hq * st.s[k_top])
        my = wq * (st.y[k_top] + hq * st.c[k_top])
        mvx = wq * (st.vx[k_top] + st.w[k_top] * hq * st.c[k_top])
        mvy = wq * (st.vy[k_top] - st.w[k_top] * hq * st.s[k_top])
        for k in range(p.n - 1, -1, -1):
            mass = mass + p.m[k]
            mx, my = mx + p.m[k] * st.x[k], my + p.m[k] * st.y[k]
            mvx, mvy = mvx + p.m[k] * st.vx[k], mvy + p.m[k] * st.vy[k]
            g = (mx / mass, my / mass)
            gv = (mvx / mass, mvy / mass)
            body = (st.x[k], st.y[k], st.vx[k], st.vy[k], st.w[k], st.c[k], st.s[k])
            below = None if k == 0 else (st.c[k - 1], st.s[k - 1], st.w[k - 1])
            for end, sign in ((p.hi[k], 1.0), (p.lo[k], -1.0)):
                past = beyond_end(*g, *gv, *body, 0.5 * p.h[k], end, sign, below)
                over = over | past
    for k in range(1, p.n):
        lower = (st.x[k - 1], st.y[k - 1], st.c[k - 1], st.s[k - 1], 0.5 * p.b[k - 1])
        over = over | slid_off(st.x[k], st.y[k], st.c[k], st.s[k], 0.5 * p.h[k], *lower)
    return over


def turned_off(th, w, eta, below=None):
    """A block past ``|theta| > eta`` rotating outward and, on a block (``below = (theta_l,
    w_l)``, the block below's rotation [rad] and rate [rad/s]), past it relative to that
    block too, turning the same way (:func:`collapsed`). Elementwise: scalars or arrays."""
    past = (jnp.abs(th) > eta) & (th * w > 0)
    if below is not None:
        rel, w_rel = th - below[0], w - below[1]
        past = past & (jnp.abs(rel) > eta) & (rel * w_rel > 0) & (rel * th > 0)
    return past


def beyond_end(gx, gy, gvx, gvy, x, y, vx, vy, w, c, s, hh, end, sign, below=None):
    """The centre of mass ``g`` (velocity ``gv``) of the sub-stack on block ``k`` (centroid
    ``x, y``, velocity ``vx, vy, w``, ``c, s`` its rotation's cosine and sine, ``hh`` its
    half-height) past the end ``end`` (``sign`` +1: the +x end) of its support face and
    moving outward: under gravity and, on a block (``below = (c_l, s_l, w_l)`` of the block
    below), in its frame too (:func:`collapsed`). Elementwise: scalars or arrays."""
    # the end of the support face, a point of block k (body (end, -h_k/2))
    ex, ey = x + end * c - hh * s, y - end * s - hh * c
    evx = vx + w * (ey - y)
    evy = vy - w * (ex - x)
    dx, dy = gx - ex, gy - ey
    dvx, dvy = gvx - evx, gvy - evy
    # under gravity: beyond the end horizontally, moving outward
    past = (sign * dx > 0) & (sign * gvx > 0)
    if below is not None:
        # in the frame of block k - 1: along its top face e1 = (c_l, -s_l), beyond the end
        # and moving outward relative to it
        cl, sl, wl = below
        along = cl * dx - sl * dy
        rate = cl * dvx - sl * dvy - wl * (sl * dx + cl * dy)
        past = past & (sign * along > 0) & (sign * rate > 0)
    return past


def slid_off(x, y, c, s, hh, xl, yl, cl, sl, half_bl):
    """Block ``k`` (centroid ``x, y``, ``c, s`` its rotation's cosine and sine, ``hh`` its
    half-height)
    slid off the block below (centroid ``xl, yl``, rotation's ``cl, sl``, half-width
    ``half_bl``): the centre of its bottom face (body point ``(0, -hh)``), in the frame of
    the block below, beyond that block's half-width; measured at the face, not the centroid,
    because a block hinging on the edge below turns its centroid past the edge without
    leaving its support. Elementwise: scalars or arrays."""
    fx = x - hh * s - xl
    fy = y - hh * c - yl
    u = cl * fx - sl * fy
    return jnp.abs(u) > half_bl


# ----------------------------------------------------------------------------- initial state
