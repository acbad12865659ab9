"""The DEM's parameters and state: one family for a block (an assembly of one) and for
assemblies, the time-step rule and its stiffest mode."""

from __future__ import annotations

import dataclasses
import functools
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._checks import (
    GAP_NEEDS_ONE_SIDED,
    check_kind,
    check_nonnegative,
    check_scalar,
    concrete,
)
from ..assembly import ASSEMBLY_GAP_UNUSED, Assembly
from ..block import Block
from ..compilation import strong_scalars
from ..contact import Joint
from ..modes import MODE_NAMES, Facade, Mode, Parapet, as_mode

MODES = MODE_NAMES

DT_SAFETY = 0.5
"""Largest fraction of the explicit stability limit a default step may take."""

DT_ACCURACY = {m.name: m.dt_accuracy for m in (Parapet, Facade)}
"""Default ``accuracy`` per mode (each mode's ``dt_accuracy``, :mod:`rockjax.modes`) for the integrated face law (``n_sub="exact"``): the step is
``accuracy / (omega_max (1 + zeta))`` [s]. With these the first-impact restitution of parapets
with h/b 4-24 at beta up to 1.5 beta_DeJong is within 1e-3 of its dt -> 0 limit (measured
4.6e-4), and the rebound peaks of damped facades above 1 % of eta within 2 % of a 16x finer
step (measured 1.8 %; undamped, bounces 1-2 within 0.5 %, while a third undamped bounce of
0.2 x 1.5 m is 3.7 % off: the contact modes ring; docs/verification.md, "DEM time step:
convergence"). Facades need the finer step for their later, small bounces (at 0.7: bounce 2
of 0.11 x 2.4 m undamped 2.7 % off, of 0.2 x 1.5 m at beta_Hcrit 4 %)."""

DT_ACCURACY_SUB = {m.name: m.dt_accuracy_sub for m in (Parapet, Facade)}
"""Default ``accuracy`` per mode with integer ``n_sub`` (each mode's ``dt_accuracy_sub``) (point sub-contacts: a point's force
switches on whole as it closes, so parapets need half the face law's step)."""


STACKED_MIN_BLOCKS = 6
"""Stacks of at least this many blocks run in the array layout (:mod:`rockjax.dem._stacked`,
:func:`stacked`) in a batch or a transform (``jax.vmap``, :func:`rockjax.ida`, ``jax.jit``,
``jax.grad``); smaller stacks, single blocks and rows of blocks side by side unrolled (every
block and joint written out), whose program, and the time XLA takes to compile it, grow with
the number of blocks (docs/assemblies.md, "Performance"). A batch of 16 records of 6-10
unrolled blocks took 12-24 s to compile, the reverse-mode program of an 8-block stack 69 s
against 22 s stacked (docs/benchmarks.md, "Tall walls: one history and batches")."""

STACKED_MIN_BLOCKS_ONE = 9
"""The same threshold for one history outside any transform (:func:`rockjax.dem.run`'s
``one_history``, as the eager :func:`rockjax.simulate_dem` runs): there the unrolled step of
6-8 blocks is 1.1-1.3 times cheaper than the stacked one and compiles in 4-6 s; from 9 blocks
its compile nears or passes 10 s, while the stacked step with its solve written out
(:data:`SOLVE_UNROLLED_MAX_BLOCKS`) costs 0.93-0.97 times the unrolled one and compiles in
4 s (docs/benchmarks.md, "Tall walls: the solve written out")."""

SOLVE_UNROLLED_MAX_BLOCKS = 16
"""One history by the default rule (:func:`rockjax.dem.run` with ``one_history`` and no
``layout``, as the eager :func:`rockjax.simulate_dem` runs) of a stacked stack of up to this
many blocks solves its step's system block by block, written out
(:func:`rockjax.dem._stacked.solve_chain` with ``unrolled``); a taller stack, a batch, or a
run whose caller names the layout (:func:`rockjax.simulate_dem` inside a transform), by the
elimination as a ``lax.scan``. Written out, a one-history step cost 174-179 ns a block-step
at 9-16 blocks, against 201-207 with the scan and 180-241 unrolled, and compiled in 3.7-5.7 s
against 2.4-3.7 s; its reverse-mode program compiled in 123 s against 22 s with the scan (10
blocks), hence not inside a transform; in a batch of 16 it cost the same as the scan
(docs/benchmarks.md, "Tall walls: the solve written out")."""


def stacked(p: DemParams, layout: str | None = None, one_history: bool = False) -> bool:
    """Whether a run of ``p`` takes the array layout: ``layout`` ``"stacked"`` or
    ``"unrolled"`` forces one (a stack of two blocks or more only), None chooses by
    :data:`STACKED_MIN_BLOCKS` (:data:`STACKED_MIN_BLOCKS_ONE` for ``one_history``)."""
    if layout is None:
        return stacked_layout(p.n, p.row, one_history)
    if layout not in LAYOUTS:
        raise ValueError(
            f"layout must be one of {list(LAYOUTS)} or None (chosen by the stack's height); "
            f"got layout={layout!r}."
        )
    return layout == "stacked" and not p.row and p.n > 1


LAYOUTS = ("stacked", "unrolled")
"""The DEM step's layouts (:func:`rockjax.dem.run`'s ``layout``)."""


def stacked_layout(n: int, row: bool, one_history: bool = False) -> bool:
    """Whether ``n`` blocks (side by side: ``row``) take the array layout by default, in one
    history outside any transform (``one_history``) or else."""
    return not row and n >= (STACKED_MIN_BLOCKS_ONE if one_history else STACKED_MIN_BLOCKS)


def check_joint(joint) -> None:
    if not isinstance(joint, Joint):
        raise TypeError(
            f"joint must be a rockjax.Joint, e.g. rj.Joint(n_sub=2); got {type(joint).__name__}."
        )


class DemParams(eqx.Module):
    """Everything the DEM step needs, as arrays (built by :func:`dem_params`); a single block
    is an assembly of one.

    Per block (shape ``(n_blocks,)``): ``m`` [kg], ``I_c`` [kg m^2], ``b``, ``h``, ``eta``,
    ``x0``, ``y0`` (centre at rest [m]). Per interface ``i`` (``links[i] = (k, other, kind)``,
    :attr:`rockjax.assembly.Assembly.interfaces`): ``lo``, ``hi`` (ends of the contact face in
    block ``k``'s frame [m]), ``kn_line``, ``ks_line`` (stiffness per unit face length
    [N/m^2]; in a stack interface ``k`` is under block ``k``, and its stiffness is also that
    of block ``k``'s back face on a return wall). Scalars: ``beta`` [s], ``tan_phi``,
    ``top_load`` [N], ``gap`` [m], ``k_top`` (top restraint spring [N/m]), ``wall_gap``
    (return wall behind the back faces [m]). ``one_sided``: the blocks' back faces meet
    return walls (a facade); ``row``: the blocks stand side by side."""

    m: jax.Array
    I_c: jax.Array
    b: jax.Array
    h: jax.Array
    eta: jax.Array
    x0: jax.Array
    y0: jax.Array
    lo: jax.Array
    hi: jax.Array
    kn_line: jax.Array
    ks_line: jax.Array
    beta: jax.Array
    tan_phi: jax.Array
    top_load: jax.Array
    gap: jax.Array
    k_top: jax.Array
    wall_gap: jax.Array
    n_sub: int | str = eqx.field(static=True)
    dashpot: str = eqx.field(static=True)
    onset: str = eqx.field(static=True)
    shear_release: str = eqx.field(static=True)
    restrained: bool = eqx.field(static=True)
    one_sided: bool = eqx.field(static=True)
    links: tuple = eqx.field(static=True, default=())
    row: bool = eqx.field(static=True, default=False)

    @property
    def n(self) -> int:
        return self.m.shape[0]

    @property
    def face(self) -> bool:
        return self.n_sub == "exact"


class DemState(eqx.Module):
    """Central-difference state of the blocks, one scalar per block in each tuple: centroid
    ``x, y`` [m] (base frame, ground surface ``y = 0``), ``c, s`` (cos, sin theta), ``vx, vy``
    [m/s] and ``w`` [rad/s] at the half step, ``theta`` [rad], ``theta_max`` (running max of
    ``|theta|``); ``fs``: per interface, the shear spring force(s) [N] (one per face with the
    integrated face law, one per sub-contact with integer ``n_sub``); ``fs_wall``: those of
    each block's back face on the return wall (empty without return walls); ``d_max``: the
    running max of each block's top displacement ``|x - x0 + (h/2) sin(theta)|`` [m].

    A stack in the array layout (:func:`stacked`) holds each per-block field as an array of
    shape ``(n,)`` instead, and ``fs``, ``fs_wall`` as arrays ``(faces, n_fs)``."""

    x: tuple | jax.Array
    y: tuple | jax.Array
    c: tuple | jax.Array
    s: tuple | jax.Array
    vx: tuple | jax.Array
    vy: tuple | jax.Array
    w: tuple | jax.Array
    theta: tuple | jax.Array
    theta_max: tuple | jax.Array
    fs: tuple | jax.Array
    fs_wall: tuple | jax.Array = ()
    d_max: tuple | jax.Array = ()


STATE_FIELDS = ("x", "y", "c", "s", "vx", "vy", "w", "theta", "theta_max")
"""The state's per-block fields that a step advances."""


def as_arrays(st: DemState) -> DemState:
    """The state in the array layout of a tall stack (:func:`stacked`), from either: its
    per-block fields as arrays ``(n,)``, each face's shear springs a row of an array
    ``(faces, n_fs)``."""
    if not isinstance(st.x, tuple):
        return st

    def rows(faces):
        return jnp.stack([jnp.stack(f) for f in faces]) if faces else ()

    fields = {f: jnp.stack(getattr(st, f)) for f in STATE_FIELDS}
    d_max = jnp.stack(st.d_max) if st.d_max else ()
    return DemState(**fields, fs=rows(st.fs), fs_wall=rows(st.fs_wall), d_max=d_max)


def as_tuples(st: DemState) -> DemState:
    """The state in the unrolled layout (one scalar per block in each field), from either."""
    if isinstance(st.x, tuple):
        return st

    def scalars(a):
        return tuple(a[k] for k in range(a.shape[0]))

    def rows(faces):
        return tuple(scalars(row) for row in faces) if len(faces) else ()

    fields = {f: scalars(getattr(st, f)) for f in STATE_FIELDS}
    d_max = scalars(st.d_max) if len(st.d_max) else ()
    return DemState(**fields, fs=rows(st.fs), fs_wall=rows(st.fs_wall), d_max=d_max)


def as_assembly(body: Block | Assembly) -> Assembly:
    """A block as the assembly of one it is (an assembly unchanged); else a ValueError."""
    check_kind(
        "block",
        body,
        (Block, Assembly),
        "Build one with rj.Block(b=0.25, h=3.0), or a wall of blocks with "
        "rj.Assembly.stack([...]).",
    )
    if not isinstance(body, Block):
        return body
    if all(type(v) in (float, int) for v in jax.tree.leaves(body)):
        return assembly_of(body)
    return Assembly.stack([body])  # (numbers of other types, arrays, tracers: built anew)


@functools.lru_cache(maxsize=64)
def assembly_of(block: Block) -> Assembly:
    """The assembly of one ``block`` whose numbers are Python numbers, kept for later calls
    with an equal block: building and checking it cost about 0.07 ms of every eager run."""
    return Assembly.stack([block])


def dem_params(
    body: Block | Assembly,
    beta=0.0,
    *,
    mode: Mode | str = "two_sided",
    gap=None,
    joint: Joint = Joint(),
    phi_deg=None,
) -> DemParams:
    """Collect the block (or assembly), joint and damping into :class:`DemParams` (traceable).

    Args:
        body: A :class:`rockjax.Block` (an assembly of one) or a :class:`rockjax.Assembly`.
        beta: Stiffness-proportional Rayleigh damping coefficient [s], Eq. (1).
        mode: :class:`rockjax.Parapet` (``"two_sided"``), or :class:`rockjax.Facade`
            (``"one_sided"``): every block's back face (-x) against a return wall its ``gap``
            behind it (:func:`rockjax.as_mode`).
        gap: With ``mode="one_sided"``: the distance between the back faces and the return
            wall at rest [m]; default None (0, or the Facade's own).
        joint: The joint of every interface (:class:`rockjax.Joint`).
        phi_deg: Friction angle of every interface [deg]; default the mode's ``phi_deg``
            (the paper's 50 for parapets, 30 for facades).
    """
    mode = mode_of(body, mode, gap)
    phi_deg = check_params(beta, mode, joint, phi_deg)
    return build_params(*params_args(body, beta, mode, phi_deg), **params_options(mode, joint))


def check_params(beta, mode: Mode, joint: Joint, phi_deg):
    """:func:`dem_params`'s checks of its inputs; returns ``phi_deg`` (the mode's default
    for None)."""
    check_joint(joint)
    if phi_deg is None:
        phi_deg = mode.phi_deg
    check_nonnegative(
        "beta", beta, "s", "beta is the stiffness-proportional Rayleigh coefficient.", scalar=True
    )
    check_scalar("phi_deg", phi_deg, "deg", "e.g. phi_deg=50.")
    phi = concrete(phi_deg)
    if phi is not None and not (0.0 < phi < 90.0):
        raise ValueError(f"phi_deg (friction angle, degrees) must be in (0, 90); got {phi_deg}.")
    return phi_deg


def params_args(body: Block | Assembly, beta, mode: Mode, phi_deg) -> tuple:
    """The array arguments of :func:`build_params` for checked inputs: one program for
    Python and NumPy numbers alike (strong_scalars)."""
    return strong_scalars((as_assembly(body), beta, mode.gap, phi_deg))


def params_options(mode: Mode, joint: Joint) -> dict:
    """The static arguments of :func:`build_params`."""
    return dict(one_sided=mode.one_sided, joint=joint)


def mode_of(body: Block | Assembly, mode, gap=None) -> Mode:
    """:func:`rockjax.as_mode` of a DEM entry point: a gap given to a parapet assembly names
    the assembly's own restraint clearance as the fix."""
    unused = ASSEMBLY_GAP_UNUSED if isinstance(body, Assembly) else GAP_NEEDS_ONE_SIDED
    return as_mode(mode, gap, unused=unused)


# Compiled: one call instead of ~40 eager operations (~1 ms a call).
@jax.jit(static_argnames=("one_sided", "joint"))
def build_params(
    assembly: Assembly, beta, gap, phi_deg, *, one_sided: bool, joint: Joint
) -> DemParams:
    """:func:`dem_params` without its checks."""
    blocks = assembly.blocks

    def arr(values):
        return jnp.stack([jnp.asarray(v, float) for v in values])

    links = assembly.interfaces
    # the dashpot solve is block-tridiagonal: each joint couples block k to the ground or to
    # block k - 1 (a stack or a row)
    assert all(other in (-1, k - 1) for k, other, _ in links)
    if stacked_layout(len(blocks), assembly.layout == "row"):
        return stack_params(assembly, beta, gap, phi_deg, one_sided=one_sided, joint=joint)
    ends = [assembly.face(i) for i in range(len(links))]
    # a bed joint takes j_kn = E/h of the block above it (the paper's rule); a head joint is
    # smooth (no shear spring, no shear dashpot: docs/assemblies.md "Blocks side by side")
    # with j_kn = E/b of its block, the block's deformability across the joint
    kn, ks = [], []
    for k, _, kind in links:
        blk = blocks[k]
        if kind == "bed":
            kn.append(blk.j_kn * blk.length)
            ks.append(blk.j_ks * blk.length)
        else:
            kn.append(blk.E / blk.b * blk.length)
            ks.append(0.0 * blk.length)
    if assembly.layout == "row":
        y0 = [0.5 * b.h for b in blocks]
    else:
        y0, base = [], 0.0
        for b in blocks:
            y0.append(base + 0.5 * b.h)
            base = base + b.h
    return DemParams(
        m=arr([b.m for b in blocks]),
        I_c=arr([b.I_c for b in blocks]),
        b=arr([b.b for b in blocks]),
        h=arr([b.h for b in blocks]),
        eta=arr([b.eta for b in blocks]),
        x0=arr(assembly.x_offset),
        y0=arr(y0),
        lo=arr([e[0] for e in ends]),
        hi=arr([e[1] for e in ends]),
        kn_line=arr(kn),
        ks_line=arr(ks),
        **common_params(assembly, beta, gap, phi_deg, one_sided, joint),
    )


def common_params(assembly: Assembly, beta, gap, phi_deg, one_sided: bool, joint: Joint) -> dict:
    """:func:`build_params`'s fields that are not per block or per joint."""
    top = assembly.blocks[-1]
    return dict(
        beta=jnp.asarray(beta, float),
        tan_phi=jnp.tan(jnp.deg2rad(jnp.asarray(phi_deg, float))),
        top_load=jnp.asarray(assembly.top_load, float),
        gap=jnp.asarray(assembly.gap, float),
        # the top restraint is as stiff as the top block's whole bed joint in compression
        k_top=jnp.asarray(top.j_kn * top.b * top.length, float),
        wall_gap=jnp.asarray(gap, float),
        n_sub=joint.n_sub,
        dashpot=joint.dashpot,
        onset=joint.onset,
        shear_release=joint.shear_release,
        restrained=assembly.top == "restrained",
        one_sided=one_sided,
        links=assembly.interfaces,
        row=assembly.layout == "row",
    )


def stack_params(assembly: Assembly, beta, gap, phi_deg, *, one_sided: bool, joint: Joint):
    """:func:`build_params` of a stack in the array layout (:func:`stacked`): the blocks'
    fields stacked into arrays first, and each per-block quantity computed once over them
    (block by block, the set-up's program would grow with the stack)."""
    blocks = jax.tree.map(
        lambda *v: jnp.stack([jnp.asarray(x, float) for x in v]), *assembly.blocks
    )
    x0 = jnp.stack([jnp.asarray(x, float) for x in assembly.x_offset])
    half = 0.5 * blocks.b
    # the overlap of each bed joint (Assembly.overlap); the whole face on the ground
    rel = x0[:-1] - x0[1:]
    lo = jnp.maximum(-half[1:], rel - half[:-1])
    hi = jnp.minimum(half[1:], rel + half[:-1])
    # a bed joint takes j_kn = E/h of the block above it, as build_params
    return DemParams(
        m=blocks.m,
        I_c=blocks.I_c,
        b=blocks.b,
        h=blocks.h,
        eta=blocks.eta,
        x0=x0,
        y0=jnp.cumsum(blocks.h) - 0.5 * blocks.h,
        lo=jnp.concatenate([-half[:1], lo]),
        hi=jnp.concatenate([half[:1], hi]),
        kn_line=blocks.j_kn * blocks.length,
        ks_line=blocks.j_ks * blocks.length,
        **common_params(assembly, beta, gap, phi_deg, one_sided, joint),
    )


def span(p: DemParams, k: int | jax.Array, wall: bool = False):
    """The face coordinates ``(lo, hi)`` [m] of interface ``k``'s face, or with ``wall`` of
    block ``k``'s back face on the return wall (``t`` up the face from its centre)."""
    return (-0.5 * p.h[k], 0.5 * p.h[k]) if wall else (p.lo[k], p.hi[k])


def springs(p: DemParams, k: int | jax.Array, wall: bool = False):
    """The springs of interface ``k`` (or of block ``k``'s back face on the return wall) for
    the all-closed stiffness: positions ``t`` along the face [m] and the normal and shear
    stiffnesses [N/m] (the two-point Gauss rule of the face for the integrated law: it gives
    the continuous joint's all-closed stiffness exactly)."""
    lo, hi = span(p, k, wall)
    width = hi - lo
    if p.face:
        tau = np.array([0.5 - 0.5 / math.sqrt(3.0), 0.5 + 0.5 / math.sqrt(3.0)])
        wts = np.array([0.5, 0.5])
    else:
        tau = np.linspace(0.0, 1.0, p.n_sub)
        wts = np.ones(p.n_sub) / (p.n_sub - 1)
        wts[0] = wts[-1] = 0.5 / (p.n_sub - 1)
    t = lo + width * jnp.asarray(tau)
    w = jnp.asarray(wts) * width
    return t, p.kn_line[k] * w, p.ks_line[k] * w


def unit_rows(e, rx, ry):
    """A unit force along ``e`` at offsets ``(rx, ry)`` [m] from a centroid: its generalised
    force ``(Fx, Fy, clockwise moment)``, one row per offset."""
    one = jnp.ones_like(rx)
    return jnp.stack([e[0] * one, e[1] * one, ry * e[0] - rx * e[1]], axis=-1)


def joint_stiffness(p: DemParams, i, k, other, kind: str):
    """The all-closed stiffness of interface ``i`` (block ``k`` on block ``other``, or on the
    ground for ``other < 0``; a static ``kind``): a 3 x 3 matrix on block ``k``'s degrees of
    freedom, or 6 x 6 on ``other``'s then ``k``'s. ``i``, ``k`` and a block ``other`` may be
    traced (a stack's bed joints mapped over)."""
    t, kn, ks = springs(p, i)
    # the face point at rest from block k's centroid, the joint's normal and tangent
    if kind == "bed":
        rx, ry, nrm, tng = t, -0.5 * p.h[k] + 0.0 * t, (0.0, 1.0), (1.0, 0.0)
    else:
        rx, ry, nrm, tng = -0.5 * p.b[k] + 0.0 * t, t, (1.0, 0.0), (0.0, 1.0)
    a_n, a_s = unit_rows(nrm, rx, ry), unit_rows(tng, rx, ry)
    if not isinstance(other, int) or other >= 0:
        lx = p.x0[k] + rx - p.x0[other]
        ly = p.y0[k] + ry - p.y0[other]
        a_n = jnp.concatenate([-unit_rows(nrm, lx, ly), a_n], axis=-1)
        a_s = jnp.concatenate([-unit_rows(tng, lx, ly), a_s], axis=-1)
    return jnp.einsum("i,ij,ik->jk", kn, a_n, a_n) + jnp.einsum("i,ij,ik->jk", ks, a_s, a_s)


def wall_stiffness(p: DemParams, k):
    """The all-closed stiffness of block ``k``'s back face on its return wall (3 x 3)."""
    # the back face (-b/2, t): horizontal motion (1, 0, t), vertical (0, 1, b/2)
    t, kn, ks = springs(p, k, wall=True)
    zero, one = jnp.zeros_like(t), jnp.ones_like(t)
    a_n = jnp.stack([one, zero, t], axis=-1)
    a_s = jnp.stack([zero, one, 0.5 * p.b[k] * one], axis=-1)
    return jnp.einsum("i,ij,ik->jk", kn, a_n, a_n) + jnp.einsum("i,ij,ik->jk", ks, a_s, a_s)


def stiffness_stacked(p: DemParams):
    """:func:`omega_max`'s stiffness matrix (less the top restraint) of a stack in the array
    layout (:data:`STACKED_MIN_BLOCKS`): the bed joints mapped over, the matrix assembled
    from its diagonal and lower blocks, so that its program does not grow with the stack."""
    n = p.n
    beds = jax.vmap(lambda k: joint_stiffness(p, k, k, k - 1, "bed"))(jnp.arange(1, n))
    diag = jnp.zeros((n, 3, 3)).at[0].add(joint_stiffness(p, 0, 0, -1, "bed"))
    diag = diag.at[1:].add(beds[:, 3:, 3:]).at[:-1].add(beds[:, :3, :3])
    if p.one_sided:
        diag = diag + jax.vmap(lambda k: wall_stiffness(p, k))(jnp.arange(n))
    k4 = jnp.zeros((n, 3, n, 3))
    idx = jnp.arange(n)
    k4 = k4.at[idx, :, idx, :].set(diag)
    k4 = k4.at[idx[1:], :, idx[:-1], :].set(beds[:, 3:, :3])
    k4 = k4.at[idx[:-1], :, idx[1:], :].set(beds[:, :3, 3:])
    return k4.reshape(3 * n, 3 * n)


def omega_max(p: DemParams):
    """Highest circular frequency [rad/s] of the block or assembly at rest with every spring
    closed. Every subset of closed contacts has a smaller stiffness matrix (in the PSD order),
    so this bounds the frequency of any contact state."""
    n = p.n
    if stacked(p):
        k_mat = stiffness_stacked(p)
    else:
        k_mat = jnp.zeros((3 * n, 3 * n))
        for i, (k, other, kind) in enumerate(p.links):
            cols = list(range(3 * k, 3 * k + 3))
            if other >= 0:
                cols = list(range(3 * other, 3 * other + 3)) + cols
            idx = jnp.asarray(cols)
            k_mat = k_mat.at[idx[:, None], idx[None, :]].add(joint_stiffness(p, i, k, other, kind))
        for k in range(n):
            if p.one_sided:
                idx = jnp.arange(3 * k, 3 * k + 3)
                k_mat = k_mat.at[idx[:, None], idx[None, :]].add(wall_stiffness(p, k))
    if p.restrained:
        a = jnp.zeros(3 * n).at[3 * n - 3].set(1.0).at[3 * n - 1].set(0.5 * p.h[-1])
        k_mat = k_mat + p.k_top * jnp.outer(a, a)
    mass = jnp.stack([p.m, p.m, p.I_c], axis=-1).reshape(-1)
    inv = 1.0 / jnp.sqrt(mass)
    return jnp.sqrt(jnp.max(jnp.linalg.eigvalsh(k_mat * inv[:, None] * inv[None, :])))


@jax.jit
def critical_dt(p: DemParams):
    """Stability limit [s] of central differences with centred dashpots: ``2 / omega_max``
    (damping does not lower it)."""
    return 2.0 / omega_max(p)


@jax.jit
def default_step(p: DemParams, accuracy):
    """The default step [s] before rounding: ``accuracy / (omega_max (1 + zeta))``,
    ``zeta = beta omega_max / 2``, at most ``DT_SAFETY * critical_dt(p)``.

    The step resolves the stiffest contact mode (``omega_max dt = accuracy`` at ``beta = 0``:
    central differences err by ``(omega dt)^2 / 24`` in its frequency) and, when that mode is
    overdamped, the relaxation time ``~1 / (2 zeta omega_max)`` of its dashpot, which the
    centred (trapezoidal) dashpot resolves only while ``2 zeta omega_max dt`` is small. The
    impact velocity drops out: the penalty contact is linear, so the penetration and the
    onset band scale together with it.
    """
    return steps(p, accuracy)[1]


def steps(p: DemParams, accuracy, accuracy_open=None):
    """``(critical_dt, default_step, open_ratio)`` [s, s, -]: the first two from one eigenvalue
    solve; ``open_ratio`` >= 1 the step a one-block facade takes while its return wall is out
    of reach (the rule at ``accuracy_open`` without the wall's springs) over
    ``default_step`` (1 without ``accuracy_open``, for every other body)."""
    w = omega_max(p)
    dt = rule(p, w, accuracy)
    ratio = jnp.ones(())
    if accuracy_open is not None and p.one_sided and p.n == 1:
        ratio = jnp.maximum(
            rule(p, omega_max(dataclasses.replace(p, one_sided=False)), accuracy_open) / dt, 1.0
        )
    return 2.0 / w, dt, ratio


def rule(p: DemParams, w, accuracy):
    """The step rule [s]: ``accuracy / (w (1 + zeta))``, ``zeta = beta w / 2``, at most
    ``DT_SAFETY`` times the stability limit ``2 / w`` (``w`` [rad/s] the highest frequency)."""
    zeta = 0.5 * p.beta * w
    return jnp.minimum(accuracy / (w * (1.0 + zeta)), DT_SAFETY * 2.0 / w)


def check_accuracy(accuracy, mode: Mode, joint: Joint) -> float:
    """``accuracy`` checked, or the default for the ``mode`` and ``joint``."""
    default = mode.dt_accuracy if joint.face else mode.dt_accuracy_sub
    if accuracy is None:
        return default
    if not (isinstance(accuracy, (int, float)) and np.isfinite(accuracy) and accuracy > 0):
        raise ValueError(
            f"accuracy (omega_max dt (1 + zeta), dimensionless) must be a positive float; got "
            f"accuracy={accuracy!r}. Leave accuracy=None for the default ({default}); smaller "
            "is finer."
        )
    return float(accuracy)
