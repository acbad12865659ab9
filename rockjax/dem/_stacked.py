"""The step of a tall stack as array operations: the same joints, solve and update as
:func:`rockjax.dem.step`, laid out over the blocks instead of unrolled.

The unrolled step writes every block and joint out as scalars, so its program, and the time
XLA takes to compile it, grows with the number of blocks (docs/assemblies.md, "Performance").
A stack (bed joints only) of :data:`STACKED_MIN_BLOCKS` blocks or more in a batch
(:data:`STACKED_MIN_BLOCKS_ONE` in one history) runs this layout instead: the ground joint is
:func:`rockjax.dem._faces.interface` on the stack itself; the bed joints are the same
function mapped (``jax.vmap``) over the ``n - 1`` two-block views of the stack (lower block
``k - 1``, upper block ``k``, the joint's own face fields); the back faces on return walls
are mapped over the blocks; the block-tridiagonal system ``(M + dt/2 C) a = F`` is solved by
block elimination in a ``lax.scan`` over the blocks (in one history of up to
:data:`SOLVE_UNROLLED_MAX_BLOCKS` blocks, written out block by block). The state's per-block
fields are arrays of shape ``(n,)`` here (the shear springs ``(n, n_fs)``), so the program
holds one copy of each joint, whatever the height of the stack. The two layouts give the
same history to round-off (tests/test_assembly_stacked.py).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from .._fusion import computed_once
from ..constants import G
from ._algebra import inv3, mm, mv, transpose
from ._faces import face_energy, interface, pair_kinematics, wall_kinematics
from ._params import STATE_FIELDS, DemParams, DemState, span
from ._step import (
    advance,
    beyond_end,
    slid_off,
    top,
    top_energy,
    turned_off,
)

BLOCK_FIELDS = ("m", "I_c", "b", "h", "eta", "x0", "y0")
LINK_FIELDS = ("lo", "hi", "kn_line", "ks_line")
BED = ((1, 0, "bed"),)  # a two-block view's one joint: block 1 on block 0


def matrix(m):
    """A 3 x 3 nested list of scalars (Python zeros among them) as an array."""
    return jnp.stack([jnp.stack([jnp.asarray(v, float) for v in row]) for row in m])


def vector(v):
    """A sequence of scalars (Python zeros among them) as an array."""
    return jnp.stack([jnp.asarray(x, float) for x in v])


def springs_tuple(row, n_fs: int) -> tuple:
    """A face's row of shear springs as the tuple of scalars :func:`interface` reads."""
    return tuple(row[i] for i in range(n_fs))


def bed_views(p: DemParams, st: DemState):
    """The arrays of the ``n - 1`` two-block views (leading axis: the joint ``k = 1..n-1``):
    the pair of blocks ``(k - 1, k)``, joint ``k``'s face fields and shear springs."""

    def pair(a):
        return jnp.stack([a[:-1], a[1:]], axis=-1)

    blocks = {f: pair(getattr(p, f)) for f in BLOCK_FIELDS}
    links = {f: getattr(p, f)[1:, None] for f in LINK_FIELDS}
    state = {f: pair(getattr(st, f)) for f in STATE_FIELDS}
    return blocks, links, state, st.fs[1:]


def bed_view(p: DemParams, blocks, links, state, fs):
    """One two-block view: the stack's ``p`` with the pair's fields, joint ``(1, 0)``."""
    pv = dataclasses.replace(p, **blocks, **links, links=BED)
    n_fs = fs.shape[-1]
    sv = DemState(**state, fs=(springs_tuple(fs, n_fs),))
    return pv, sv


def face_ends_of(kin, face_span):
    """A face's kinematics at its two ends (:func:`rockjax.dem._faces.face_ends`'s entry)."""
    return [kin(face_span[0]), kin(face_span[1])]


def step_stacked(
    p: DemParams,
    st: DemState,
    ag,
    ag_v,
    dt,
    *,
    load=None,
    top_motion=None,
    wall=None,
    written_out: bool = False,
):
    """:func:`rockjax.dem.step` of a stack in the array layout (``st`` from
    :func:`rockjax.dem._params.as_arrays`). Returns the same ``(new, acc, power, forces)`` with arrays: ``acc``
    ``(n, 3)``, the forces' ``normal``, ``shear`` and ``wall`` ``(n,)``. ``written_out``: the
    solve written out block by block (:func:`solve_chain`;
    :data:`rockjax.dem.SOLVE_UNROLLED_MAX_BLOCKS`)."""
    n = p.n
    n_fs = st.fs.shape[-1]
    # the ground joint: interface 0 of the stack itself
    kin0 = pair_kinematics(p, st, 0)[0]
    f_g, _, c_g, _, _, fs_g, fn_g, _, ft_g = interface(
        p, st, 0, dt, face_ends_of(kin0, span(p, 0)), once=True
    )

    def bed(blocks, links, state, fs):
        pv, sv = bed_view(p, blocks, links, state, fs)
        ends = face_ends_of(pair_kinematics(pv, sv, 0)[0], span(pv, 0))
        f_u, f_l, c_uu, c_ll, c_ul, fs_new, fn, _, ft = interface(pv, sv, 0, dt, ends, once=True)
        mats = (matrix(c_uu), matrix(c_ll), matrix(c_ul))
        return vector(f_u), vector(f_l), *mats, vector(fs_new), fn, ft

    f_u, f_l, c_uu, c_ll, c_ul, fs_b, fn_b, ft_b = jax.vmap(bed)(*bed_views(p, st))
    zero_row = jnp.zeros((1, 3))
    force = jnp.concatenate([vector(f_g)[None], f_u]) + jnp.concatenate([f_l, zero_row])
    zero_block = jnp.zeros((1, 3, 3))
    cdiag = jnp.concatenate([matrix(c_g)[None], c_uu]) + jnp.concatenate([c_ll, zero_block])
    power = 0.0
    fs_wall, fn_wall = (), None
    if p.one_sided:

        def back_face(k):
            kin = wall_kinematics(p, st, k, wall)[0]
            ends = face_ends_of(kin, span(p, k, wall=True))
            f_w, _, c_w, _, _, fs_new, fn, pw, _ = interface(
                p, st, k, dt, ends, wall=True, motion=wall, once=True
            )
            return vector(f_w), matrix(c_w), vector(fs_new), fn, jnp.asarray(pw, float)

        f_w, c_w, fs_wall, fn_wall, pw = jax.vmap(back_face)(jnp.arange(n))
        force = force + f_w
        cdiag = cdiag + c_w
        power = jnp.sum(pw)
    f_top, c_top = top(p, st, dt, top_motion)
    force = force.at[n - 1].add(vector(f_top))
    if load is not None:
        force = force + jnp.asarray(load, float)
    if c_top is not None:
        cdiag = cdiag.at[n - 1].add(matrix(c_top))
    h = 0.5 * dt
    mass = jnp.stack([p.m, p.m, p.I_c], axis=-1)
    diag = h * cdiag + mass[:, :, None] * jnp.eye(3)[None]
    rhs = force - jnp.stack([p.m * ag, p.m * (G + ag_v), jnp.zeros_like(p.m)], axis=-1)
    acc = solve_chain(diag, h * c_ul, rhs, written_out)
    new = advance(*(getattr(st, f) for f in STATE_FIELDS), acc[:, 0], acc[:, 1], acc[:, 2], dt)
    d_max = ()
    if not isinstance(st.d_max, tuple):  # tracked where the driver asks
        d = st.x - p.x0 + 0.5 * p.h * st.s
        d_max = jnp.maximum(st.d_max, jnp.abs(d))
    fs = jnp.concatenate([vector(fs_g)[None], fs_b])
    out = DemState(**new, fs=fs.reshape(n, n_fs), fs_wall=fs_wall, d_max=d_max)
    forces = dict(
        normal=jnp.concatenate([jnp.asarray(fn_g, float)[None], fn_b]),
        shear=jnp.concatenate([jnp.asarray(ft_g, float)[None], ft_b]),
        restraint=f_top[0] if p.restrained else None,
        wall=fn_wall,
    )
    return out, acc, power, forces


def eliminate(inv_prev, g_prev, d_k, low_k, r_k):
    """One block of the forward elimination: block ``k``'s pivot inverse and right-hand side
    from block ``k - 1``'s and its own diagonal block, sub-diagonal block and right-hand side."""
    li = mm(low_k, inv_prev)
    corr = mm(li, transpose(low_k))
    inv_k = inv3([[d_k[i][j] - corr[i][j] for j in range(3)] for i in range(3)])
    g = mv(li, g_prev)
    return inv_k, [r_k[i] - g[i] for i in range(3)]


def substitute(x_next, inv_k, g_k, low_next):
    """One block of the back substitution: ``x_k`` from ``x_{k+1}``."""
    u = mv(transpose(low_next), x_next)
    return mv(inv_k, [g_k[i] - u[i] for i in range(3)])


def whole(inv, g):
    """A pivot inverse and right-hand side computed once each (:func:`computed_once`)."""
    flat = computed_once(*[inv[i][j] for i in range(3) for j in range(3)], *g)
    return [list(flat[3 * i : 3 * i + 3]) for i in range(3)], list(flat[9:])


def solve_chain(diag, lower, rhs, unrolled: bool = False):
    """:func:`rockjax.dem._algebra.solve_tridiagonal`'s system in arrays, by the same block
    elimination: ``diag`` ``(n, 3, 3)``, ``lower`` ``(n - 1, 3, 3)`` (``A[k, k-1]`` of
    ``k = 1..n-1``; symmetric, ``A[k-1, k] = lower^T``), ``rhs`` ``(n, 3)``; returns ``x``
    ``(n, 3)``.

    By default as a ``lax.scan`` over the blocks (forward, then back): one copy of a block's
    elimination in the program whatever ``n``. The scans carry each entry as an array of its
    own (over the blocks; in a batch, a row of the batch's values at each block), so that a
    step of the loop reads contiguous values. Block cyclic reduction (``log2 n`` levels of
    array operations) ran as fast in one history, 2.4 times slower in a batch of 16
    fifty-block stacks, and compiled slower. With ``unrolled`` the blocks are written out one
    after another, each block's results computed once (:func:`computed_once`; inlined, XLA
    copied each block's elimination into the later ones, and a step cost 1.6-2.4 times as
    much in one history of 6-10 blocks, 1.7-4.7 times in a batch of 16); see
    :data:`rockjax.dem.SOLVE_UNROLLED_MAX_BLOCKS`.

    The system's entries are computed once by entry, in two reductions with many outputs
    (:func:`rockjax._fusion.computed_once`): the diagonal blocks' and the right-hand side's
    12, the sub-diagonal blocks' 9. Kept whole one array at a time, an array of a few
    thousand values or more (``diag`` of a batch of 16 twenty-block stacks) was a reduction of
    one output, which XLA:CPU (jaxlib 0.10) hands to its YNNPACK library (``__ynn_fusion``),
    and there a batch of 16 stacks stepped at 229-236 ns a block-step from 20 to 100 blocks
    instead of 116-150 (docs/benchmarks.md, "Tall walls: the solve's reductions")."""

    def entries(a):  # (m, 3, 3) -> the (m,) arrays of its entries, row by row
        return [a[:, i, j] for i in range(3) for j in range(3)]

    def at(m, k):
        return [[v[k] for v in row] for row in m]

    # built from every joint's forces and dashpots, and read by many entries: computed once
    flat = computed_once(*entries(diag), *(rhs[:, i] for i in range(3)))
    d, r = [list(flat[3 * i : 3 * i + 3]) for i in range(3)], list(flat[9:])
    flat = computed_once(*entries(lower))
    low = [list(flat[3 * i : 3 * i + 3]) for i in range(3)]
    n = diag.shape[0]
    if unrolled:
        pivots = [whole(inv3(at(d, 0)), [v[0] for v in r])]
        for k in range(1, n):
            inv_k, g_k = eliminate(*pivots[-1], at(d, k), at(low, k - 1), [v[k] for v in r])
            pivots.append(whole(inv_k, g_k))
        x = [None] * n
        x[n - 1] = list(computed_once(*mv(*pivots[n - 1])))
        for k in range(n - 2, -1, -1):
            x[k] = list(computed_once(*substitute(x[k + 1], *pivots[k], at(low, k))))
        return jnp.stack([jnp.stack(x_k) for x_k in x])

    def forward(carry, x):
        inv_k, g = eliminate(*carry, *x)
        return (inv_k, g), (inv_k, g)

    def tail(m):
        return [[v[1:] for v in row] for row in m]

    inv0 = inv3(at(d, 0))
    g0 = [v[0] for v in r]
    xs = (tail(d), low, [v[1:] for v in r])
    _, (invs, gs) = jax.lax.scan(forward, (inv0, g0), xs)
    last = mv(at(invs, -1), [v[-1] for v in gs])

    def backward(x_next, y):
        x_k = substitute(x_next, *y)
        return x_k, x_k

    # the rows 0 .. n-2: row 0's pivot and right-hand side, then the scan's but the last
    invs = [
        [jnp.concatenate([inv0[i][j][None], invs[i][j][:-1]]) for j in range(3)] for i in range(3)
    ]
    gs = [jnp.concatenate([g0[i][None], gs[i][:-1]]) for i in range(3)]
    _, x = jax.lax.scan(backward, last, (invs, gs, low), reverse=True)
    return jnp.stack([jnp.concatenate([x[i], last[i][None]]) for i in range(3)], axis=-1)


def energy_stacked(p: DemParams, st: DemState, vel, wall=None):
    """:func:`rockjax.dem._step.energy` in the array layout (``vel`` ``(n, 3)``)."""
    kin0 = pair_kinematics(p, st, 0)[0]
    e = face_energy(p, 0, span(p, 0), face_ends_of(kin0, span(p, 0)), st.fs[0])

    def bed(blocks, links, state, fs):
        pv, sv = bed_view(p, blocks, links, state, fs)
        ends = face_ends_of(pair_kinematics(pv, sv, 0)[0], span(pv, 0))
        return face_energy(pv, 0, span(pv, 0), ends, sv.fs[0])

    e = e + jnp.sum(jax.vmap(bed)(*bed_views(p, st)))
    vx, vy, w = vel[:, 0], vel[:, 1], vel[:, 2]
    e = e + jnp.sum(0.5 * p.m * (vx**2 + vy**2) + 0.5 * p.I_c * w**2 + p.m * G * st.y)
    if p.one_sided:

        def back_face(k):
            ends = face_ends_of(wall_kinematics(p, st, k, wall)[0], span(p, k, wall=True))
            return face_energy(p, k, span(p, k, wall=True), ends, st.fs_wall[k])

        e = e + jnp.sum(jax.vmap(back_face)(jnp.arange(p.n)))
    return e + top_energy(p, st)


def collapsed_stacked(p: DemParams, st: DemState):
    """:func:`rockjax.dem._step.collapsed` of a stack in the array layout: the same rules
    (:func:`rockjax.dem._step.turned_off`, :func:`rockjax.dem._step.beyond_end`,
    :func:`rockjax.dem._step.slid_off`) over the blocks, the sub-stacks' centres of mass as
    reversed cumulative sums."""
    n = p.n
    th, w, c, s, x, y = st.theta, st.w, st.c, st.s, st.x, st.y
    # a restrained wall's top block is held at its top: it falls only off the block below
    m = n - 1 if p.restrained else n
    over = turned_off(th[0], w[0], p.eta[0])
    over = over | jnp.any(turned_off(th[1:m], w[1:m], p.eta[1:m], (th[: m - 1], w[: m - 1])))
    if not p.restrained:
        k_top = n - 1
        hq = 0.5 * p.h[k_top]
        wq = p.top_load / G  # the overburden, a weight at the top face centre Q

        def above(a):  # the sum over the blocks k..n-1, and Q's share
            return jnp.cumsum(a[::-1])[::-1]

        mass = wq + above(p.m)
        g = (
            (wq * (x[k_top] + hq * s[k_top]) + above(p.m * x)) / mass,
            (wq * (y[k_top] + hq * c[k_top]) + above(p.m * y)) / mass,
        )
        gv = (
            (wq * (st.vx[k_top] + w[k_top] * hq * c[k_top]) + above(p.m * st.vx)) / mass,
            (wq * (st.vy[k_top] - w[k_top] * hq * s[k_top]) + above(p.m * st.vy)) / mass,
        )
        body = (x, y, st.vx, st.vy, w, c, s, 0.5 * p.h)
        for end, sign in ((p.hi, 1.0), (p.lo, -1.0)):
            first = [a[0] for a in g + gv + body]
            over = over | beyond_end(*first, end[0], sign)
            rest = [a[1:] for a in g + gv + body]
            below = (c[:-1], s[:-1], w[:-1])
            over = over | jnp.any(beyond_end(*rest, end[1:], sign, below))
    lower = (x[:-1], y[:-1], c[:-1], s[:-1], 0.5 * p.b[:-1])
    return over | jnp.any(slid_off(x[1:], y[1:], c[1:], s[1:], 0.5 * p.h[1:], *lower))
