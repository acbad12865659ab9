"""Assemblies of rigid blocks: a wall of blocks stacked vertically on the ground, with an
optional horizontal restraint at the top and an overburden, or a row of blocks side by side
on the ground (the leaves of a multi-leaf wall), docs/assemblies.md.

The topology is static. A stack (:meth:`Assembly.stack`): block ``0`` stands on the ground,
block ``k`` on block ``k - 1``; interface ``0`` is the ground joint under block 0, interface
``k`` the bed joint between blocks ``k - 1`` and ``k``: the overlap of the top face of the
lower block and the bottom face of the upper one at rest, fixed in the upper block's frame.
Every bed joint takes the joint stiffness of the block above it (``j_kn = E/h``,
``j_ks = j_kn / (2 (1 + nu))`` of that block), so the ground joint of a one-block assembly is
that of :func:`rockjax.simulate_dem`. A row (:meth:`Assembly.row`): every block stands on the
ground (interfaces ``0 .. n-1``, its ground joint), and block ``k`` meets block ``k - 1`` on a
head joint (interface ``n - 1 + k``): the overlap of block ``k``'s -x face with block
``k - 1``'s +x face, fixed in block ``k``'s frame, normal stiffness ``E/b`` of block ``k``
(the block's deformability across the joint, as ``E/h`` across a bed joint), smooth (no
shear).
"""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ._checks import (
    GAP_NEEDS_ONE_SIDED,
    check_choice,
    check_gap,
    check_kind,
    check_nonnegative,
    check_number,
    concrete,
)
from ._types import ScalarLike
from .block import Block
from .constants import G

TOPS = ("free", "restrained")
LAYOUTS = ("stack", "row")

ASSEMBLY_GAP_UNUSED = (
    f"{GAP_NEEDS_ONE_SIDED} The top restraint's clearance is the Assembly's own: "
    "rj.Assembly.stack(blocks, top='restrained', gap=...)."
)
"""Why a facade ``gap`` is refused for a two-sided assembly (its restraint has its own)."""

TOP_GAP_UNUSED = (
    "gap is the top restraint's clearance, and top='free' has no restraint. Pass "
    "top='restrained' for a wall held at its top (e.g. by a floor), or leave gap=0; a facade's "
    "distance to its return walls is simulate_assembly's gap= (with mode='one_sided')."
)
"""Why a restraint ``gap`` is refused for a free top."""


def block_tuple(blocks) -> tuple:
    """``blocks`` as a tuple; a single block or anything not a sequence of blocks is refused
    with the fix (a list of one block)."""
    if isinstance(blocks, Block) or not hasattr(blocks, "__iter__") or isinstance(blocks, str):
        got = "None" if blocks is None else f"a {type(blocks).__name__}"
        raise ValueError(
            f"blocks must be a sequence of rockjax.Block (a list or tuple), bottom to top; got "
            f"{got}. For one block pass a list of one: rj.Assembly.stack([block])."
        )
    return tuple(blocks)


class Assembly(eqx.Module):
    """A wall of rigid blocks stacked vertically, or standing side by side (static topology).

    Block ``k`` stands on block ``k - 1`` (block 0 on the ground), its centre at the
    horizontal position ``x_offset[k]`` [m] at rest, so a block may be narrower than the one
    below and placed off-centre; each bottom face must overlap the top face below. All blocks
    share one out-of-plane ``length``.

    The top (``top="restrained"``) may be held horizontally, e.g. by a floor diaphragm that
    moves with the ground: two frictionless stops at ``+-gap`` [m] from the rest position of
    the top face centre, so the top can move only ``gap`` either way and is free vertically.
    The ``overburden`` [N/m] (the load of the storeys above, per unit length of wall) is a dead
    vertical force ``overburden * length`` [N] at the top face centre of the top block, which
    follows that point as the block moves (docs/assemblies.md, "Loads and supports").

    Build it with :meth:`Assembly.stack`::

        wall = rj.Assembly.stack([rj.Block(b=0.23, h=1.5)] * 2, top="restrained",
                                 overburden=5e3)

    or, blocks side by side on the ground (``layout="row"``, free tops, no overburden), with
    :meth:`Assembly.row`::

        leaves = rj.Assembly.row([rj.Block(b=0.11, h=2.0), rj.Block(b=0.11, h=2.0)])

    Attributes:
        blocks: The blocks, bottom to top (a stack) or from -x to +x (a row).
        x_offset: Horizontal position of each block's centre at rest [m].
        top: ``"free"`` or ``"restrained"``.
        gap: Clearance of the top restraint on either side [m] (``top="restrained"`` only).
        overburden: Vertical load on the top face per unit length of wall [N/m].
        layout: ``"stack"`` (default) or ``"row"``.
    """

    blocks: tuple[Block, ...]
    x_offset: tuple
    top: str = eqx.field(static=True, default="free")
    gap: ScalarLike = 0.0
    overburden: ScalarLike = 0.0
    layout: str = eqx.field(static=True, default="stack")

    def __check_init__(self):
        if not isinstance(self.blocks, tuple) or len(self.blocks) == 0:
            raise ValueError(
                "blocks must be a non-empty tuple of rockjax.Block, bottom to top; got "
                f"blocks={self.blocks!r}. Use rj.Assembly.stack([rj.Block(b=0.23, h=1.5), ...])."
            )
        for k, blk in enumerate(self.blocks):
            if not isinstance(blk, Block):
                raise ValueError(f"blocks[{k}] must be a rockjax.Block; got {type(blk).__name__}.")
        if len(self.x_offset) != len(self.blocks):
            raise ValueError(
                f"x_offset must give one horizontal position [m] per block ({len(self.blocks)});"
                f" got {len(self.x_offset)} values. Leave x_offset=None for all 0."
            )
        check_choice("top", self.top, TOPS)
        check_choice("layout", self.layout, LAYOUTS)
        check_gap(
            self.gap,
            used=self.top == "restrained",
            unused=TOP_GAP_UNUSED,
            hint="gap is the top restraint's clearance, e.g. 0.002.",
        )
        check_nonnegative(
            "overburden",
            self.overburden,
            "N/m",
            "overburden is the vertical load per metre of wall, e.g. 5e3 (5 kN/m).",
            scalar=True,
        )
        for k, x in enumerate(self.x_offset):
            check_number(f"x_offset[{k}]", x, "m", "e.g. 0.0 (centred on the block below).")
        lengths = [concrete(b.length) for b in self.blocks]
        if all(v is not None for v in lengths) and not np.allclose(lengths, lengths[0]):
            raise ValueError(
                f"all blocks of an assembly must share one out-of-plane length [m]; got "
                f"lengths={[float(v) for v in lengths]}. Give every Block the same length."
            )
        if self.layout == "row":
            self._check_row()
            return
        for k in range(1, len(self.blocks)):
            lo, hi = (concrete(v) for v in self.overlap(k))
            if lo is not None and hi is not None and not hi > lo:
                raise ValueError(
                    f"blocks[{k}] does not rest on blocks[{k - 1}]: their faces do not overlap "
                    f"(x_offset[{k}]={self.x_offset[k]} m, x_offset[{k - 1}]="
                    f"{self.x_offset[k - 1]} m). Move x_offset[{k}] within (b[{k}] + b[{k - 1}])/2 "
                    f"of x_offset[{k - 1}]."
                )

    def _check_row(self):
        if self.top != "free" or concrete(self.overburden) not in (None, 0.0):
            raise ValueError(
                f"a row of blocks side by side stands free: top='free' and overburden=0; got "
                f"top={self.top!r}, overburden={self.overburden!r}. Stack the blocks "
                "(rj.Assembly.stack) for a restrained or loaded wall."
            )
        for k in range(1, len(self.blocks)):
            vals = [concrete(v) for v in (self.x_offset[k - 1], self.x_offset[k])]
            vals += [concrete(self.blocks[j].b) for j in (k - 1, k)]
            if any(v is None for v in vals):
                continue
            x_l, x_r, b_l, b_r = (float(v) for v in vals)
            clear = x_r - x_l - 0.5 * (b_l + b_r)
            if clear < -1e-12 * max(b_l, b_r):
                raise ValueError(
                    f"blocks[{k}] overlaps blocks[{k - 1}] in the row by {-clear:.4g} m "
                    f"(x_offset[{k}]={x_r} m, x_offset[{k - 1}]={x_l} m, b={b_r} and {b_l} m). "
                    f"Place block centres at least (b[{k - 1}] + b[{k}])/2 apart, from -x to "
                    "+x (x_offset=None: touching)."
                )

    @classmethod
    def row(cls, blocks, *, x_offset=None) -> Assembly:
        """Stand ``blocks`` side by side on the ground, from -x to +x: the leaves of a
        multi-leaf wall, or blocks leaning on each other. Each block has its ground joint;
        neighbours touch (or, with ``x_offset``, face each other across a gap) on a smooth head
        joint: the normal contact law of every joint, no shear spring or shear dashpot
        (docs/assemblies.md, "Blocks side by side", says why).

        Args:
            blocks: A sequence of :class:`rockjax.Block`, from -x to +x.
            x_offset: Horizontal position of each block's centre at rest [m]; default: block 0
                at 0 and each next block touching the one before.

        Returns:
            The :class:`Assembly` (``layout="row"``, free tops, no overburden).

        Raises:
            ValueError: on an empty row, a non-Block, or blocks that overlap.
        """
        blocks = block_tuple(blocks)
        if x_offset is None and blocks and all(isinstance(b, Block) for b in blocks):
            x_offset = [0.0]
            for k in range(1, len(blocks)):
                x_offset.append(x_offset[-1] + 0.5 * (blocks[k - 1].b + blocks[k].b))
        elif x_offset is None:
            x_offset = (0.0,) * len(blocks)
        return cls(blocks=blocks, x_offset=tuple(x_offset), layout="row")

    @property
    def interfaces(self) -> tuple[tuple[int, int, str], ...]:
        """The joints, a static tuple of ``(block, other, kind)``: the joint on ``block``'s
        face meeting ``other`` (``-1``: the ground), ``kind`` ``"bed"`` (``block``'s bottom
        face on a top face) or ``"head"`` (``block``'s -x face on ``other``'s +x face).
        A stack: interface ``k`` under block ``k``; a row: the ground joints of blocks
        ``0 .. n-1``, then the head joints of blocks ``1 .. n-1``."""
        n = len(self.blocks)
        if self.layout == "row":
            return tuple((k, -1, "bed") for k in range(n)) + tuple(
                (k, k - 1, "head") for k in range(1, n)
            )
        return ((0, -1, "bed"),) + tuple((k, k - 1, "bed") for k in range(1, n))

    def face(self, i: int):
        """The contact face of interface ``i`` (:attr:`interfaces`) in its block's frame:
        ``(lo, hi)`` [m], body coordinates of its ends, along the bottom face (x) for a bed
        joint (:meth:`overlap` for a stack) and up the -x face (y) for a head joint (the
        height both blocks share: both stand on the ground)."""
        k, other, kind = self.interfaces[i]
        blk = self.blocks[k]
        if kind == "head":
            below = self.blocks[other]
            return -0.5 * blk.h, jnp.minimum(0.5 * blk.h, below.h - 0.5 * blk.h)
        if other < 0:
            return -0.5 * blk.b, 0.5 * blk.b
        return self.overlap(k)

    @classmethod
    def stack(
        cls,
        blocks,
        *,
        top: str = "free",
        overburden: ScalarLike = 0.0,
        gap: ScalarLike = 0.0,
        x_offset=None,
    ) -> Assembly:
        """Stack ``blocks`` (bottom to top) on the ground.

        Args:
            blocks: A sequence of :class:`rockjax.Block`, bottom to top.
            top: ``"free"`` (default) or ``"restrained"`` (a horizontal restraint at the top
                face centre of the top block, e.g. a floor diaphragm).
            overburden: Vertical load on the top face [N/m of wall] (default 0).
            gap: Clearance of the top restraint on either side [m] (default 0).
            x_offset: Horizontal position of each block's centre at rest [m]; default all 0.

        Returns:
            The :class:`Assembly`.

        Raises:
            ValueError: on an empty stack, a non-Block, faces that do not overlap, an unknown
                ``top``, a negative ``gap`` or ``overburden``.
        """
        blocks = block_tuple(blocks)
        if x_offset is None:
            x_offset = (0.0,) * len(blocks)
        return cls(
            blocks=blocks,
            x_offset=tuple(x_offset),
            top=top,
            gap=gap,
            overburden=overburden,
        )

    @property
    def n_blocks(self) -> int:
        """Number of blocks."""
        return len(self.blocks)

    @property
    def length(self):
        """Out-of-plane length, shared by the blocks [m]."""
        return self.blocks[0].length

    @property
    def height(self):
        """Height of the wall [m]: the stack's total, or a row's tallest block."""
        if self.layout == "row":
            return jnp.max(jnp.stack([jnp.asarray(b.h, float) for b in self.blocks]))
        return sum(b.h for b in self.blocks)

    @property
    def mass(self):
        """Total mass of the blocks [kg]."""
        return sum(b.m for b in self.blocks)

    @property
    def top_load(self):
        """The overburden force on the top face [N] (``overburden * length``)."""
        return self.overburden * self.length

    def overlap(self, k: int):
        """The contact face of the bed joint under block ``k`` of a stack, in block ``k``'s
        frame: ``(lo, hi)`` [m], the horizontal body coordinates of its ends on the bottom face
        (the whole face on the ground, ``k = 0`` or any block of a row; else the overlap with
        the top face of block ``k - 1``)."""
        blk = self.blocks[k]
        half = 0.5 * blk.b
        if k == 0 or self.layout == "row":
            return -half, half
        below = self.blocks[k - 1]
        rel = self.x_offset[k - 1] - self.x_offset[k]
        return jnp.maximum(-half, rel - 0.5 * below.b), jnp.minimum(half, rel + 0.5 * below.b)


MECHANISMS = ("limit", "stack", "top", "hinge", "row")

PHI_DEG_LIMIT = 50.0
"""Default friction angle of the joints in limit analysis [deg]: that of
:func:`rockjax.simulate_assembly` and :func:`rockjax.pushover` for a parapet."""


class LimitAnalysis(eqx.Module):
    """The collapse of an assembly under a uniform horizontal acceleration (limit analysis,
    :func:`limit_analysis`).

    Attributes:
        load_multiplier: ``lambda`` [-]: the horizontal acceleration in g (toward +x) at
            which the assembly becomes a mechanism.
        velocity: The mechanism (sample of virtual velocities), per block ``(u, v, omega)``:
            the horizontal and vertical velocity of its centroid [m/s] and its angular
            velocity [rad/s] (clockwise positive, as ``theta``), scaled so that the largest
            horizontal velocity of a block's top face centre (a stack) or top (a row) is 1 m/s
            and the horizontal loads do positive work; shape ``(block, 3)``.
        phi_deg: The joints' friction angle used [deg].
    """

    load_multiplier: Float[Array, ""]
    velocity: Float[Array, "block 3"]
    phi_deg: float = PHI_DEG_LIMIT


def limit_analysis(assembly: Assembly, phi_deg: float = PHI_DEG_LIMIT) -> LimitAnalysis:
    """Limit analysis of an assembly of rigid blocks under a uniform horizontal acceleration
    ``lambda g`` toward +x: the largest ``lambda`` [-] for which the blocks can stand in
    equilibrium with admissible joint forces (the static theorem, a linear programme;
    Livesley 1978), and the collapse mechanism (its dual), docs/assemblies.md "Limit
    analysis".

    Every joint of :attr:`Assembly.interfaces` that touches at rest (the bed joints of a
    stack, the ground joints and the head joints of touching blocks of a row) is rigid, has
    no tensile strength (its normal force is two non-negative forces at the ends of the
    contact face: the resultant anywhere on the face) and Coulomb friction on its resultant,
    ``|T| <= tan(phi) N`` (the head joints of a row are smooth, as in the DEM). Loads: the
    weights ``W_k``, horizontal loads ``lambda W_k`` at the centroids, the overburden
    ``P = overburden length`` at the top face centre of the top block (dead, not
    multiplied); a restrained top (``top="restrained"``) is a horizontal bilateral support
    there (its ``gap`` taken as closed: the wall bears on it once it has moved ``gap``).
    Rocking, sliding and their combinations in all blocks and sub-stacks are covered.

    The programme treats friction as associative (a slip dilates by ``tan(phi)``): exact for
    mechanisms of rocking alone and for sliding along one joint; where a mechanism mixes
    sliding with rocking it is the associative bound, above the collapse load of the
    non-associative Coulomb joint (Gilbert, Casapulla, Ahmed 2006). Solved by HiGHS's dual
    simplex (``scipy.optimize.linprog``): an exact vertex, to round-off.

    Args:
        assembly: The assembly (a stack or a row).
        phi_deg: Friction angle of every bed and ground joint [deg], ``0 < phi_deg <= 90``
            (90: no sliding); default ``PHI_DEG_LIMIT`` (50, the DEM's parapet default).

    Returns:
        The :class:`LimitAnalysis` (its ``load_multiplier`` is :func:`collapse_multiplier`).

    Raises:
        ValueError: for a traced assembly (call it outside ``jit``), a ``phi_deg`` outside
            ``(0, 90]``, or an assembly that no horizontal acceleration holds in equilibrium.

    References:
        Livesley, R. K. (1978). Limit analysis of structures formed from rigid blocks.
        Int. J. Numer. Meth. Eng. 12, 1853-1871. Gilbert, M., Casapulla, C., Ahmed, H. M.
        (2006). Limit analysis of masonry block structures with non-associative frictional
        joints using linear programming. Computers & Structures 84, 873-887.
    """
    from scipy.optimize import linprog

    check_number("phi_deg", phi_deg, "degrees", "e.g. phi_deg=50.0; 90 for no sliding.")
    phi = float(phi_deg)
    if not 0.0 < phi <= 90.0:
        raise ValueError(
            f"phi_deg (the joints' friction angle, in degrees) must lie in (0, 90]; got "
            f"phi_deg={phi_deg}. Use e.g. 50.0, or 90 for joints that cannot slide."
        )
    geo = _concrete_geometry(assembly)
    n = len(assembly.blocks)
    w, xs, ys, hs = geo["w"], geo["x"], geo["y"], geo["h"]
    scale = sum(w)  # forces in units of the total weight: a well-scaled programme
    rows = np.zeros((3 * n, 1))  # variable 0: lambda
    rows[0::3, 0] = np.asarray(w) / scale
    cols = []  # each further variable: its column of the equilibrium equations
    bounds = [(None, None)]
    friction = []  # (shear column, [normal columns]) of each frictional joint

    def force(k, fx, fy, px, py):
        """The column of a unit force ``(fx, fy)`` at ``(px, py)`` on block ``k``: its
        horizontal, vertical and clockwise moment rows (moments about the centroid)."""
        col = np.zeros(3 * n)
        col[3 * k : 3 * k + 3] = (fx, fy, (py - ys[k]) * fx - (px - xs[k]) * fy)
        return col

    def joint(k, other, fx, fy, px, py):
        """A joint's force: ``(fx, fy)`` on block ``k``, its reaction on ``other``."""
        col = force(k, fx, fy, px, py)
        return col - force(other, fx, fy, px, py) if other >= 0 else col

    for k, other, kind, ends in geo["joints"]:
        if kind == "head":  # smooth: a normal force along +x on block k at each end
            x_face = xs[k] - 0.5 * geo["b"][k]
            for y_end in ends:
                cols.append(joint(k, other, 1.0, 0.0, x_face, y_end))
                bounds.append((0.0, None))
            continue
        y_face = ys[k] - 0.5 * hs[k]
        normals = []
        for x_end in ends:
            cols.append(joint(k, other, 0.0, 1.0, x_end, y_face))
            bounds.append((0.0, None))
            normals.append(len(cols))
        cols.append(joint(k, other, 1.0, 0.0, ends[0], y_face))
        bounds.append((None, None))
        if phi < 90.0:
            friction.append((len(cols), normals))
    top = n - 1
    q = (xs[top], ys[top] + 0.5 * hs[top])  # the top face centre
    if assembly.layout == "stack" and assembly.top == "restrained":
        cols.append(force(top, 1.0, 0.0, *q))
        bounds.append((None, None))
    a_eq = np.hstack([rows, np.stack(cols, axis=1)])
    b_eq = np.zeros(3 * n)
    for k in range(n):
        b_eq[3 * k + 1] = w[k] / scale  # the supports carry the weight
    b_eq += -force(top, 0.0, -geo["p"] / scale, *q)  # the overburden, a dead load
    n_var = a_eq.shape[1]
    mu = math.tan(math.radians(phi))
    a_ub = np.zeros((2 * len(friction), n_var))
    for j, (t, normals) in enumerate(friction):
        for sign, r in ((1.0, 2 * j), (-1.0, 2 * j + 1)):
            a_ub[r, t] = sign
            a_ub[r, normals] = -mu
    cost = np.zeros(n_var)
    cost[0] = -1.0
    res = linprog(
        cost,
        A_ub=a_ub if friction else None,
        b_ub=np.zeros(len(a_ub)) if friction else None,
        A_eq=a_eq,
        b_eq=b_eq,
        bounds=bounds,
        method="highs-ds",
    )
    if res.status == 3:  # unbounded: no mechanism under any horizontal load
        lam, vel = math.inf, np.zeros((n, 3))
    elif res.status != 0:
        raise ValueError(
            "the assembly has no equilibrium under any uniform horizontal acceleration "
            f"(linear programme: {res.message}); check the blocks' x_offset: every block's "
            "centre of gravity must be able to rest on the joints below it."
        )
    else:
        lam = float(res.x[0])
        vel = _mechanism(np.asarray(res.eqlin.marginals).reshape(n, 3), w, hs, assembly.layout)
    return LimitAnalysis(
        load_multiplier=jnp.asarray(lam, float), velocity=jnp.asarray(vel, float), phi_deg=phi
    )


def _concrete_geometry(assembly: Assembly) -> dict:
    """The assembly's numbers at rest for :func:`limit_analysis`: weights ``w`` [N],
    centroids ``x``, ``y`` [m], ``b``, ``h`` [m], the overburden force ``p`` [N] and the
    joints touching at rest, ``(block, other, kind, ends)`` with ``ends`` the absolute x
    (bed) or y (head) coordinates of the contact face's ends [m]."""
    vals = {}
    for name, get in (
        ("w", lambda b: b.m * G),
        ("b", lambda b: b.b),
        ("h", lambda b: b.h),
    ):
        vals[name] = [concrete(get(b)) for b in assembly.blocks]
    vals["x"] = [concrete(x) for x in assembly.x_offset]
    vals["p"] = concrete(assembly.top_load)
    flat = [v for key in ("w", "b", "h", "x") for v in vals[key]] + [vals["p"]]
    if any(v is None or np.ndim(v) != 0 for v in flat):
        raise ValueError(
            "limit analysis needs an assembly of concrete scalar blocks (a linear programme "
            "solved by scipy, not traceable): call rj.collapse_multiplier / rj.limit_analysis "
            "outside jit, vmap and grad, or name a closed-form mechanism, e.g. "
            "rj.collapse_multiplier(wall, 'stack')."
        )
    geo = {key: [float(v) for v in vals[key]] for key in ("w", "b", "h", "x")}
    geo["p"] = float(vals["p"])
    n = len(assembly.blocks)
    if assembly.layout == "row":
        geo["y"] = [0.5 * h for h in geo["h"]]
    else:
        base = np.concatenate([[0.0], np.cumsum(geo["h"])])
        geo["y"] = [float(base[k]) + 0.5 * geo["h"][k] for k in range(n)]
    joints = []
    for i, (k, other, kind) in enumerate(assembly.interfaces):
        lo, hi = (float(v) for v in assembly.face(i))
        if kind == "head":
            clear = geo["x"][k] - geo["x"][other] - 0.5 * (geo["b"][k] + geo["b"][other])
            if clear > 1e-9 * max(geo["b"][k], geo["b"][other]):
                continue  # apart at rest: no contact at the onset of a mechanism
            joints.append((k, other, kind, (geo["y"][k] + lo, geo["y"][k] + hi)))
        else:
            joints.append((k, other, kind, (geo["x"][k] + lo, geo["x"][k] + hi)))
    geo["joints"] = joints
    return geo


def _mechanism(duals, w, hs, layout):
    """The collapse mechanism from the equilibrium equations' duals (per block ``(u, v,
    omega)``, the virtual velocities conjugate to the horizontal force, vertical force and
    clockwise moment rows), with the horizontal loads doing positive work and the largest
    horizontal velocity of a block's top 1."""
    vel = np.array(duals, float)
    if np.dot(w, vel[:, 0]) < 0:
        vel = -vel
    top = vel[:, 0] + 0.5 * np.asarray(hs) * vel[:, 2]
    size = np.max(np.abs(top))
    return vel / size if size > 0 else vel


def collapse_multiplier(
    assembly: Assembly, mechanism: str = "limit", *, phi_deg: float = PHI_DEG_LIMIT
):
    """Horizontal load multiplier at the onset of collapse, docs/assemblies.md "Limit
    analysis": the ground acceleration ``lambda g`` [-] at which the assembly becomes a
    mechanism, with the blocks' weights as horizontal loads ``lambda W_k`` and the
    overburden a dead vertical load (not multiplied).

    ``"limit"`` (the default): the lowest over all mechanisms of rocking and sliding, by
    :func:`limit_analysis` (a linear programme; concrete assemblies only, not traceable).
    The named mechanisms are the closed forms of one mechanism each (virtual work;
    traceable and differentiable), upper bounds of ``"limit"``.

    With ``W_k`` the block weights, ``x_k, y_k`` their centroids at rest and ``P`` the top load:

    * ``"stack"`` (free top): the whole stack about the toe ``O`` of the ground joint,
      ``lambda = (sum_k W_k (x_O - x_k) + P (x_O - x_top)) / sum_k W_k y_k``;
    * ``"top"`` (free top): the top block alone about the toe ``O`` of its bed joint,
      ``lambda = (W + P) (x_O - x_N) / (W h_N / 2)``;
    * ``"hinge"`` (``top="restrained"``, two blocks): block 0 about its ground toe ``A``,
      block 1 about the restraint point ``C`` (top face centre, held horizontally), a hinge
      ``B`` at the heel of the bed joint; ``lambda = (W_0 (x_A - x_0) + W_1 (a - (x_B - x_1)
      r) + P (a - (x_B - x_C) r)) / ((W_0 + W_1) h_0 / 2)`` with ``a = x_A - x_B`` and
      ``r = h_0 / h_1`` (both centroids move ``h_0 / 2`` per unit rotation of block 0);
    * ``"row"`` (a row of touching blocks side by side, :meth:`Assembly.row`): the blocks
      ``j .. n-1`` at the +x end each turn about their own +x toe by the same angle (the
      smooth head joints between them slide, their faces neither open nor close to first
      order; a block turning faster than the one at its +x side would enter it), the others
      stay: ``lambda_j = sum_{k >= j} W_k b_k / sum_{k >= j} W_k h_k``, and the smallest over
      ``j`` is returned.

    The mechanism toward +x is returned (mirror the assembly for -x).

    Args:
        assembly: The assembly.
        mechanism: ``"limit"`` (default), ``"stack"``, ``"top"``, ``"hinge"`` or ``"row"``.
        phi_deg: Friction angle of the joints [deg] (``"limit"`` only; the named mechanisms
            are of rocking alone); default ``PHI_DEG_LIMIT`` (50).

    Returns:
        The multiplier ``lambda`` [-] (a JAX scalar).

    Raises:
        ValueError: on something other than an Assembly, an unknown mechanism or one the
            supports do not allow, and as :func:`limit_analysis`.
    """
    check_kind(
        "assembly",
        assembly,
        (Assembly,),
        "For one block the multiplier is b/h (its tan eta, no overburden); or wrap it as "
        "rj.Assembly.stack([block]).",
    )
    check_choice("mechanism", mechanism, MECHANISMS)
    if mechanism == "limit":
        return limit_analysis(assembly, phi_deg).load_multiplier

    blocks = assembly.blocks
    n = len(blocks)
    w = [b.m * G for b in blocks]
    p = assembly.top_load
    heights = [0.0]
    for b in blocks:
        heights.append(heights[-1] + b.h)
    xs = assembly.x_offset
    ys = [heights[k] + 0.5 * blocks[k].h for k in range(n)]
    restrained = assembly.top == "restrained"
    if (mechanism == "row") != (assembly.layout == "row"):
        raise ValueError(
            f"mechanism={mechanism!r} does not apply to a {assembly.layout} of blocks: use "
            "mechanism='row' for rj.Assembly.row(...), and 'stack', 'top' or 'hinge' for "
            "rj.Assembly.stack(...)."
        )
    if mechanism == "row":
        return _row_multiplier(assembly)
    if mechanism in ("stack", "top") and restrained:
        raise ValueError(
            f"mechanism={mechanism!r} needs a free top (the restraint holds the top); use "
            "mechanism='hinge' for a restrained wall, or top='free'."
        )
    if mechanism == "stack":
        x_o = xs[0] + 0.5 * blocks[0].b
        num = sum(w[k] * (x_o - xs[k]) for k in range(n)) + p * (x_o - xs[-1])
        den = sum(w[k] * ys[k] for k in range(n))
        return jnp.asarray(num / den, float)
    if mechanism == "top":
        k = n - 1
        x_o = xs[k] + assembly.overlap(k)[1]
        return jnp.asarray((w[k] + p) * (x_o - xs[k]) / (w[k] * 0.5 * blocks[k].h), float)
    if n != 2 or not restrained:
        raise ValueError(
            "mechanism='hinge' is the two-block wall with a top restraint: build it with "
            f"Assembly.stack([b0, b1], top='restrained'); got {n} block(s), top={assembly.top!r}."
        )
    b0, b1 = blocks
    x_a = xs[0] + 0.5 * b0.b
    x_b = xs[1] + assembly.overlap(1)[0]
    x_c = xs[1]
    a = x_a - x_b
    r = b0.h / b1.h
    num = w[0] * (x_a - xs[0]) + w[1] * (a - (x_b - xs[1]) * r) + p * (a - (x_b - x_c) * r)
    den = 0.5 * b0.h * (w[0] + w[1])
    return jnp.asarray(num / den, float)


def _row_multiplier(assembly: Assembly):
    """The ``"row"`` mechanism of :func:`collapse_multiplier` (a JAX scalar)."""
    return jnp.min(jnp.stack(row_multipliers(assembly)))


def row_multipliers(assembly: Assembly) -> list:
    """The multipliers ``lambda_j`` [-] of the row's sub-mechanisms, ``j = 0 .. n-1`` (the
    blocks ``j..n-1`` each about its own +x toe, :func:`collapse_multiplier`'s ``"row"``), as
    JAX scalars. Raises ValueError for a row with gaps between its blocks."""
    blocks = assembly.blocks
    for k in range(1, len(blocks)):
        vals = [concrete(v) for v in (assembly.x_offset[k - 1], assembly.x_offset[k])]
        vals += [concrete(blocks[j].b) for j in (k - 1, k)]
        if any(v is None for v in vals):
            continue
        clear = vals[1] - vals[0] - 0.5 * (vals[2] + vals[3])
        if clear > 1e-9 * max(vals[2], vals[3]):
            raise ValueError(
                f"mechanism='row' is the mechanism of touching blocks; blocks[{k - 1}] and "
                f"blocks[{k}] are {clear:.4g} m apart (x_offset), a gap they close only at "
                "finite rotation. Build the row with rj.Assembly.row(blocks) (x_offset=None)."
            )
    w = [b.m * G for b in blocks]
    lams = []
    for j in range(len(blocks)):
        num = sum(w[k] * blocks[k].b for k in range(j, len(blocks)))
        den = sum(w[k] * blocks[k].h for k in range(j, len(blocks)))
        lams.append(jnp.asarray(num / den, float))
    return lams
