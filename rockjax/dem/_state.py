"""The DEM's initial states: at rest under gravity and the overburden, tilted rigidly about
block 0's pivot corner, or a restrained two-block wall in its hinge mechanism; and the checks
of ``theta0``."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from .._checks import check_scalar, concrete
from ..assembly import Assembly
from ..block import Block
from ..compilation import memoized, persistent_jit, strong_scalars
from ..constants import G
from ..contact import Joint
from ..modes import Mode, Parapet
from ._params import (
    DemParams,
    DemState,
    as_assembly,
    build_params,
    params_args,
    params_options,
    stacked,
    steps,
)


@jax.jit(static_argnames=("n_sub",))
def rest_pose(block: Block, theta0, n_sub):
    """``(x, y, c, s)``: the centroid [m] and ``cos, sin(theta0)`` of ``block`` at rest on the
    ground, flat (``theta0 = 0``) or tilted by ``theta0`` [rad] about its pivot corner, sunk so
    that the closed contacts carry its weight (vertical equilibrium; the moment is what
    releases it).

    With sub-contacts the pivot corner alone carries the weight while its sink is below the
    height of the next sub-contact; with many sub-contacts (small tributary areas) several
    carry it, and the sink solves ``sum_i k_i max(sink - d_i, 0) = m g``, ``d_i`` the height
    of sub-contact ``i`` above the pivot (a corner spring alone would be compressed far
    beyond equilibrium and launch the block). On the integrated face (a Winkler joint): a
    triangle of contact from the pivot corner, or the whole face (a trapezoid) when the tilt
    is below ``sink / b``."""
    b, h = jnp.asarray(block.b, float), jnp.asarray(block.h, float)
    m = jnp.asarray(block.m, float)
    theta0 = jnp.asarray(theta0, float)
    side = jnp.sign(theta0)
    up = side * 0.5 * b  # pivot corner, body coordinates (up, -h/2)
    vp = -0.5 * h
    if n_sub == "exact":
        # the weight on a Winkler joint
        w_line = m * G / jnp.asarray(block.j_kn * block.length, float)
        tilt = jnp.abs(jnp.sin(theta0))
        # (the square root's derivative is infinite at zero tilt: keep it out of the graph)
        tri = jnp.sqrt(2.0 * w_line * jnp.where(tilt > 0.0, tilt, 1.0))
        tri = jnp.where(tilt > 0.0, tri, 0.0)
        trap = w_line / b + 0.5 * tilt * b
        sink = jnp.where(tri < tilt * b, tri, trap)
    else:
        n = n_sub
        w = np.ones(n)
        w[0] = w[-1] = 0.5
        u_base = jnp.linspace(-0.5, 0.5, n) * b
        kn_base = block.j_kn * (jnp.asarray(w) * b * block.length / (n - 1))
        # piecewise-linear vertical equilibrium, solved exactly bracket by bracket
        d = jnp.abs(jnp.sin(theta0)) * jnp.abs(up - u_base) * jnp.where(side == 0, 0.0, 1.0)
        order = jnp.argsort(d)
        d, k = d[order], kn_base[order]
        cand = (m * G + jnp.cumsum(k * d)) / jnp.cumsum(k)
        upper = jnp.concatenate([d[1:], jnp.full((1,), jnp.inf)])
        sink = cand[jnp.argmax(cand <= upper)]
    c, s = jnp.cos(theta0), jnp.sin(theta0)
    x0 = jnp.where(side == 0, 0.0, up - (up * c + vp * s))
    y0 = -sink - (-up * s + vp * c)
    return x0, y0, c, s


def initial_state(body: Block | Assembly, p: DemParams, theta0=0.0) -> DemState:
    """At rest under gravity and the overburden: the block, or the whole stack, tilted rigidly
    by ``theta0`` [rad] about the pivot corner of block 0 (or flat for ``theta0 = 0``); a
    restrained two-block wall in its hinge mechanism instead (:func:`hinge_pose`); a row
    upright, each block on its own ground joint.

    The ground joint settles as under one block carrying the whole weight
    (:func:`rest_pose` of a block of block 0's shape and the total weight); each bed joint
    settles uniformly under the weight above it. The return walls (one-sided ``p``) just
    touch the back faces at ``gap = 0``."""
    assembly = Assembly.stack([body]) if isinstance(body, Block) else body
    return settled(assembly, p, theta0, is_hinged(assembly, theta0))


def is_hinged(assembly: Assembly, theta0) -> bool:
    """Whether the run starts in the hinge mechanism (a restrained wall released tilted)."""
    return bool(assembly.top == "restrained" and concrete(theta0) != 0.0)


def set_up(body: Block | Assembly, beta, mode: Mode, joint: Joint, phi_deg, accuracy, theta0):
    """``(p, (critical_dt, default_step, open_ratio), st0)``: :func:`rockjax.dem.dem_params`,
    the steps (:func:`rockjax.dem.default_step`; a one-block facade's open step over it) and
    :func:`initial_state` of inputs already checked (``phi_deg`` given), as one compiled
    program: a run's set-up compiles once with its
    solver, not as three programs."""
    assembly = as_assembly(body)
    # a facade's step with its return wall out of reach: its mode's open accuracy, scaled
    # with a given accuracy (both steps scale alike)
    if joint.face:
        open_accuracy = accuracy * mode.dt_accuracy_open / mode.dt_accuracy
    else:
        open_accuracy = accuracy * mode.dt_accuracy_open_sub / mode.dt_accuracy_sub
    args = params_args(assembly, beta, mode, phi_deg)
    args += strong_scalars((accuracy, open_accuracy, theta0))
    options = params_options(mode, joint)
    return remembered_set_up(*args, hinge=is_hinged(assembly, theta0), **options)


@persistent_jit
def set_up_program(
    assembly, beta, gap, phi_deg, accuracy, open_accuracy, theta0, *, one_sided, joint, hinge
):
    """:func:`set_up`'s program."""
    p = build_params(assembly, beta, gap, phi_deg, one_sided=one_sided, joint=joint)
    return p, steps(p, accuracy, open_accuracy), settled(assembly, p, theta0, hinge)


remembered_set_up = memoized(set_up_program)
""":func:`set_up_program` with its recent results kept by value: a loop of eager runs of one
block and ``beta`` (a record set) sets up once (about 0.3 ms a call otherwise)."""


# Compiled: one call instead of ~30 eager operations (~0.5 ms a call).
@jax.jit(static_argnames=("hinge",))
def settled(assembly: Assembly, p: DemParams, theta0, hinge: bool) -> DemState:
    """:func:`initial_state` of an assembly (``hinge``: released in its hinge mechanism)."""
    n_fs = 1 if p.face else p.n_sub
    zero = jnp.zeros(())
    n = p.n
    rest = dict(
        vx=(zero,) * n,
        vy=(zero,) * n,
        w=(zero,) * n,
        d_max=(zero,) * n,
        fs_wall=tuple((zero,) * n_fs for _ in range(n)) if p.one_sided else (),
    )
    if p.row:  # each block on its own ground joint, upright (theta0 = 0, checked)
        poses = [rest_pose(blk, 0.0, p.n_sub) for blk in assembly.blocks]
        return DemState(
            x=tuple(q[0] + p.x0[k] for k, q in enumerate(poses)),
            y=tuple(q[1] for q in poses),
            c=tuple(q[2] for q in poses),
            s=tuple(q[3] for q in poses),
            theta=(zero,) * n,
            theta_max=(zero,) * n,
            fs=tuple((zero,) * n_fs for _ in p.links),
            **rest,
        )
    if stacked(p):
        return settled_stacked(assembly, p, theta0)
    weight = sum(b.m for b in assembly.blocks) * G + assembly.top_load
    pose = rest_pose(carrying(assembly.blocks[0], weight), theta0, p.n_sub)
    if hinge:
        return hinge_pose(assembly, p, pose, theta0)
    theta0 = jnp.asarray(theta0, float)
    x_0, y_0, c, s = pose
    xs, ys = [x_0 + p.x0[0]], [y_0]
    load = weight
    for k in range(1, n):
        load = load - p.m[k - 1] * G
        sink = load / (p.kn_line[k] * (p.hi[k] - p.lo[k]))
        du = p.x0[k] - p.x0[k - 1]
        dv = 0.5 * p.h[k - 1] + 0.5 * p.h[k] - sink
        xs.append(xs[-1] + du * c + dv * s)
        ys.append(ys[-1] - du * s + dv * c)
    return DemState(
        x=tuple(xs),
        y=tuple(ys),
        c=(c,) * n,
        s=(s,) * n,
        theta=(theta0,) * n,
        theta_max=(jnp.abs(theta0),) * n,
        fs=tuple((zero,) * n_fs for _ in range(n)),
        **rest,
    )


def settled_stacked(assembly: Assembly, p: DemParams, theta0) -> DemState:
    """:func:`settled` of a stack in the array layout (:func:`rockjax.dem._params.stacked`):
    the same pose, its sums over the blocks as cumulative sums, and the state's per-block
    fields as arrays (written out block by block, the set-up's program would grow with the
    stack, and take as long to compile as the run)."""
    n = p.n
    n_fs = 1 if p.face else p.n_sub
    weight = jnp.sum(p.m) * G + assembly.top_load
    x_0, y_0, c, s = rest_pose(carrying(assembly.blocks[0], weight), theta0, p.n_sub)
    # each bed joint settles uniformly under the weight above it
    load = weight - jnp.cumsum(p.m[:-1]) * G
    sink = load / (p.kn_line[1:] * (p.hi[1:] - p.lo[1:]))
    du = p.x0[1:] - p.x0[:-1]
    dv = 0.5 * p.h[:-1] + 0.5 * p.h[1:] - sink
    x = x_0 + p.x0[0] + jnp.concatenate([jnp.zeros(1), jnp.cumsum(du * c + dv * s)])
    y = y_0 + jnp.concatenate([jnp.zeros(1), jnp.cumsum(-du * s + dv * c)])
    theta0 = jnp.asarray(theta0, float)
    zeros = jnp.zeros(n)

    def every(v):
        return jnp.full(n, v)

    return DemState(
        x=x,
        y=y,
        c=every(c),
        s=every(s),
        vx=zeros,
        vy=zeros,
        w=zeros,
        theta=every(theta0),
        theta_max=every(jnp.abs(theta0)),
        fs=jnp.zeros((n, n_fs)),
        fs_wall=jnp.zeros((n, n_fs)) if p.one_sided else (),
        d_max=zeros,
    )


def hinge_angle(theta, x_b, x_c, u1, v1):
    """The rotation [rad] of the upper block of a restrained two-block wall in its hinge
    mechanism: the block turns about the hinge ``B`` (world x ``x_b``; ``(u1, v1)`` [m] the
    body vector from ``B`` to the top face centre ``C``) until ``C`` is at ``x_c``:
    ``u1 cos t + v1 sin t = x_c - x_b``, the root ``asin((x_c - x_b) / r) - atan2(u1, v1)``,
    ``r = hypot(u1, v1)``, the branch through ``t = 0`` at rest (NaN where ``C`` cannot
    reach ``x_c``). ``theta`` (block 0's rotation) only sets the dtype."""
    ratio = (x_c - x_b) / jnp.hypot(u1, v1)
    ok = jnp.abs(ratio) <= 1.0
    return jnp.where(
        ok, jnp.arcsin(jnp.where(ok, ratio, 0.0)) - jnp.arctan2(u1, v1), jnp.nan * theta
    )


def hinge_geometry(assembly: Assembly, side):
    """The hinge mechanism's body geometry of a restrained two-block wall turning toward
    ``side`` (+1: block 0 about its +x toe): block 0's pivot corner ``(u_a, -h_0/2)``, the
    hinge ``B`` at the bed joint's other end, ``(u_b, h_0/2)`` in block 0's frame and
    ``(e_1, -h_1/2)`` in block 1's, and the body vector ``(u1, v1)`` from ``B`` to the top
    face centre."""
    b0, b1 = assembly.blocks
    lo, hi = assembly.overlap(1)
    e_1 = jnp.where(side > 0, lo, hi)
    u_b = assembly.x_offset[1] + e_1 - assembly.x_offset[0]
    return side * 0.5 * b0.b, u_b, e_1, -e_1, b1.h


def hinge_pose(assembly: Assembly, p: DemParams, pose, theta0) -> DemState:
    """A restrained two-block wall released in its hinge mechanism (docs/assemblies.md,
    "Initial state"): block 0 tilted by ``theta0`` about its pivot corner as a free stack's
    (``pose``: its :func:`rest_pose` under the whole weight), block 1 on the hinge ``B`` at
    the bed joint's far end, turned so that the top face centre bears on the stop the upper
    block leans on (``x0_1 + gap`` for ``theta0 > 0``): :func:`hinge_angle`. The bed joint
    settles on its corner as :func:`rest_pose` sinks a block of block 1's shape carrying
    block 1 and the overburden, tilted by the relative rotation."""
    theta = jnp.asarray(theta0, float)
    side = jnp.sign(theta)
    _, u_b, _, u1, v1 = hinge_geometry(assembly, side)
    x_0, y_0, c, s = pose
    x_0 = x_0 + p.x0[0]
    x_b = x_0 + u_b * c + 0.5 * p.h[0] * s
    x_c = p.x0[1] + side * p.gap
    theta1 = hinge_angle(theta, x_b, x_c, u1, v1)
    upper = assembly.blocks[1]
    proxy = carrying(upper, upper.m * G + assembly.top_load)

    def placed(theta1):
        # block 1's centroid in block 0's frame, its corner sunk into the bed joint
        x1, y1, _, _ = rest_pose(proxy, theta1 - theta, p.n_sub)
        du, dv = p.x0[1] - p.x0[0] + x1, 0.5 * p.h[0] + y1
        c1, s_1 = jnp.cos(theta1), jnp.sin(theta1)
        miss = x_c - (x_0 + du * c + dv * s + 0.5 * p.h[1] * s_1)
        return du, dv, c1, s_1, miss

    for _ in range(2):  # Newton on C's position: the joints' sinks moved it (~1e-5 m)
        _, _, c1, s_1, miss = placed(theta1)
        theta1 = theta1 + miss / (v1 * c1 - u1 * s_1)
    du, dv, c1, s_1, _ = placed(theta1)
    zero = jnp.zeros(())
    n_fs = 1 if p.face else p.n_sub
    return DemState(
        x=(x_0, x_0 + du * c + dv * s),
        y=(y_0, y_0 - du * s + dv * c),
        c=(c, c1),
        s=(s, s_1),
        vx=(zero, zero),
        vy=(zero, zero),
        w=(zero, zero),
        theta=(theta, theta1),
        theta_max=(jnp.abs(theta), jnp.abs(theta1)),
        fs=tuple((zero,) * n_fs for _ in range(2)),
        fs_wall=tuple((zero,) * n_fs for _ in range(2)) if p.one_sided else (),
        d_max=(zero, zero),
    )


def carrying(blk: Block, weight) -> Block:
    """A block of ``blk``'s shape and joint whose own weight is ``weight`` [N]: its joint then
    settles as ``blk``'s under that load (:func:`rest_pose`)."""
    return Block(
        b=blk.b,
        h=blk.h,
        length=blk.length,
        rho=weight / (G * blk.b * blk.h * blk.length),
        E=blk.E,
        nu=blk.nu,
    )


def check_theta0(theta0, assembly: Assembly, mode: Mode = Parapet()):
    check_scalar("theta0", theta0, "rad", "e.g. theta0=0.01.")
    th = concrete(theta0)
    if assembly.layout == "row" and mode.one_sided:
        raise ValueError(
            "mode='one_sided' puts every block's back face on a return wall, which a row of "
            "blocks side by side does not have (only its first block's back face would meet "
            "it); use mode='two_sided' for a row, or stack the blocks (rj.Assembly.stack)."
        )
    if th is None:
        return
    if assembly.layout == "row" and th != 0.0:
        raise ValueError(
            f"theta0={float(th):.4g} rad: a row of blocks side by side starts upright, each "
            "block on its own ground joint (a rigid tilt would lift the blocks off the "
            "ground); leave theta0=0 and set it rocking with a ground motion, e.g. "
            "rj.GroundMotion.ricker(...)."
        )
    if mode.one_sided and th < 0:
        raise ValueError(
            f"theta0={float(th):.4g} rad: a facade (mode='one_sided') leans on its return walls "
            "at -x and can only rotate outward, theta0 >= 0."
        )
    if th != 0.0 and assembly.top == "restrained":
        check_hinge_theta0(float(th), assembly)
        return
    blocks = assembly.blocks
    vals = [concrete(b.b) for b in blocks] + [concrete(b.h) for b in blocks]
    if any(v is None for v in vals):
        return
    # the stack's own overturning angle about block 0's corner (aligned stack)
    heights = np.cumsum([0.0] + [float(b.h) for b in blocks])
    masses = np.array([float(concrete(b.m)) for b in blocks])
    y_g = np.sum(masses * 0.5 * (heights[:-1] + heights[1:])) / masses.sum()
    eta_stack = math.atan2(0.5 * float(blocks[0].b), y_g)
    if len(blocks) == 1 and not (np.isfinite(th) and abs(th) < eta_stack):
        raise ValueError(
            f"theta0={float(th):.4g} rad must satisfy |theta0| < eta = {eta_stack:.4g} rad "
            "(beyond eta the block is already overturning). Try theta0 = 0.5 * block.eta."
        )
    if not np.isfinite(th) or abs(th) >= eta_stack:
        raise ValueError(
            f"theta0={float(th):.4g} rad must satisfy |theta0| < {eta_stack:.4g} rad, the "
            "overturning angle of the whole stack about its base corner. Try half of it."
        )


def check_hinge_theta0(th: float, assembly: Assembly):
    """``theta0`` of a restrained wall: its hinge mechanism needs two blocks, the upper one's
    bottom face wholly on the lower one, and rotations below each block's ``eta``."""
    blocks = assembly.blocks
    if len(blocks) != 2:
        raise ValueError(
            f"theta0={th:.4g} rad releases a restrained wall from its hinge mechanism, which is "
            f"defined for two blocks; got {len(blocks)} block(s). Use theta0=0, or top='free' "
            "(a rigid tilt of the whole stack)."
        )
    vals = [concrete(v) for v in (blocks[0].b, blocks[0].h, blocks[1].b, blocks[1].h)]
    vals += [concrete(v) for v in (*assembly.x_offset, assembly.gap)]
    if any(v is None for v in vals):
        return
    lo, hi = (float(v) for v in assembly.overlap(1))
    half = 0.5 * float(blocks[1].b)
    if not (np.isclose(lo, -half) and np.isclose(hi, half)):
        raise ValueError(
            f"theta0={th:.4g} rad: the hinge mechanism of a restrained wall needs the upper "
            f"block's bottom face wholly on the lower block (overlap ({lo:.4g}, {hi:.4g}) m of "
            f"({-half:.4g}, {half:.4g}) m); place it within the lower block with x_offset, or "
            "use theta0=0."
        )
    side = float(np.sign(th))
    u_a, u_b, _, u1, v1 = (float(v) for v in hinge_geometry(assembly, side))
    h0 = float(blocks[0].h)
    x_b = float(assembly.x_offset[0]) + u_a + (u_b - u_a) * math.cos(th) + h0 * math.sin(th)
    x_c = float(assembly.x_offset[1]) + side * float(assembly.gap)
    th1 = float(hinge_angle(th, x_b, x_c, u1, v1))
    eta0, eta1 = (math.atan2(float(b.b), float(b.h)) for b in blocks)
    if not (np.isfinite(th1) and abs(th) < eta0 and abs(th1) < eta1):
        raise ValueError(
            f"theta0={th:.4g} rad is beyond the hinge mechanism of this restrained wall "
            f"(lower block eta = {eta0:.4g} rad; the upper block would turn by {th1:.4g} rad, "
            f"eta = {eta1:.4g} rad). Try a tenth of eta."
        )
