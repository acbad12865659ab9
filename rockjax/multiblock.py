"""The multi-block DEM: an :class:`rockjax.assembly.Assembly` of rigid blocks (3 DOF each) on
penalty joints, stepped by explicit central differences with centred dashpots inside
``jax.lax.scan`` (the scheme of :mod:`rockjax.dem`, generalised to several bodies).

Contact between two rigid bodies (docs/assemblies.md, "Two-body joints"): a point ``P`` of the
upper block's bottom face, at body coordinate ``t`` along the face, penetrates the lower body
(the block below, or the ground) by ``delta = h_l/2 - e2 . (P - X_l)``, ``e2`` the lower
body's normal; the penetration rate and the slip rate are the normal and tangential parts of
the velocity of ``P`` relative to the coincident material point of the lower body. For rigid
bodies all of these are affine in ``t``, so the face law of :mod:`rockjax.dem` (the contact
law of :func:`rockjax.contact.normal_force` integrated in closed form over the face, cut at
the breakpoints of its onset window, two-point Gauss per piece; one resultant elastic-plastic
shear spring per face) carries over unchanged: forces act along the lower body's normal and
tangent, equal and opposite on the two bodies. ``Joint(n_sub=k)`` puts ``k`` point
sub-contacts on each face instead (trapezoidal tributary areas). A head joint between blocks
side by side (a row) is the same with the frames turned by a right angle: block ``k``'s -x
face against block ``k - 1``'s +x face; it is smooth (no shear spring or dashpot,
docs/assemblies.md "Blocks side by side").

Dashpots are centred, as in :mod:`rockjax.dem`: with ``F`` the forces at the lagged half-step
velocities and ``C`` the dashpot matrix of all closed contacts, ``(M + dt/2 C) a = F``. ``C``
couples the two blocks of each joint, and every joint couples block ``k`` to the ground or to
block ``k - 1`` (a stack or a row), so the system is block-tridiagonal (3 x 3 blocks); it is
solved exactly every step by block elimination (no lag: the scheme stays second-order and the
one-block assembly reproduces :func:`rockjax.simulate_dem`).
"""

from __future__ import annotations

import dataclasses
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

from ._checks import (
    GAP_HINT,
    check_choice,
    check_gap,
    check_kind,
    check_nonnegative,
    check_positive,
    check_scalar,
    check_series_pair,
    concrete,
    is_array_pair,
)
from ._fusion import computed_once, one_computation, sum_together
from .assembly import ASSEMBLY_GAP_UNUSED, Assembly
from .block import Block
from .building import ShearBuilding
from .compilation import is_batched, persistent_jit
from .constants import G
from .contact import (
    Joint,
    closed_interval,
    coulomb,
    crossing,
    face_integrands,
    insert_cut,
    normal_force,
    shear_force,
)
from .dem import (
    DT_ACCURACY,
    DT_ACCURACY_SUB,
    DT_SAFETY,
    MODES,
    dem_params,
    initial_state,
    prepare_motion,
)
from .motion import GroundMotion
from .response import (
    STATUS_BAD_INPUT,
    STATUS_MESSAGES,
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_UNSTABLE,
)
from .walls import check_wall_rotation, wall_arrays, wall_line, wall_pivot, wall_rise

SAVE_OPTIONS = ("energy", "forces")

_GAUSS = (-1.0 / math.sqrt(3.0), 1.0 / math.sqrt(3.0))

LDL_BATCH_MAX_BLOCKS = 3
"""Batches of assemblies of up to this many blocks solve their step as a single history does,
by :func:`_solve_ldl` with the dashpot moments computed once; larger ones by block elimination,
which ran faster from four blocks up (docs/assemblies.md, "Performance")."""


class AssemblyParams(eqx.Module):
    """Everything the multi-block step needs, as arrays (built by :func:`assembly_params`).

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
    restrained: bool = eqx.field(static=True)
    one_sided: bool = eqx.field(static=True)
    links: tuple = eqx.field(static=True, default=())
    row: bool = eqx.field(static=True, default=False)
    # one history, not a batch (vmap): each face's end kinematics are computed as one XLA
    # computation (docs/assemblies.md, "Performance")
    single_history: bool = eqx.field(static=True, default=False)

    @property
    def n(self) -> int:
        return self.m.shape[0]

    @property
    def face(self) -> bool:
        return self.n_sub == "exact"


class AssemblyState(eqx.Module):
    """Central-difference state of the blocks, one scalar per block in each tuple: centroid
    ``x, y`` [m] (base frame, ground surface ``y = 0``), ``c, s`` (cos, sin theta), ``vx, vy``
    [m/s] and ``w`` [rad/s] at the half step, ``theta`` [rad], ``theta_max`` (running max of
    ``|theta|``); ``fs``: per interface, the shear spring force(s) [N] (one per face with the
    integrated face law, one per sub-contact with integer ``n_sub``); ``fs_wall``: those of
    each block's back face on the return wall (empty without return walls)."""

    x: tuple
    y: tuple
    c: tuple
    s: tuple
    vx: tuple
    vy: tuple
    w: tuple
    theta: tuple
    theta_max: tuple
    fs: tuple
    fs_wall: tuple = ()


class AssemblyResponse(eqx.Module):
    """A simulated history of an assembly, sampled at ``t``; the last axis of the per-block
    series is the block (bottom to top; from -x to +x in a row).

    Attributes:
        t: Sample times [s].
        theta: Rotation of each block [rad] (positive clockwise: the top toward +x).
        theta_dot: Angular velocity of each block [rad/s].
        x: Horizontal displacement of each centroid from its rest position [m].
        y: Height of each centroid above the ground surface [m].
        overturned: True once the assembly collapsed (a block or a sub-stack past its unstable
            point, or a block off its support); the state is frozen from then on.
        status: 0 if the run is valid, else a code in ``rockjax.response.STATUS_MESSAGES``.
        theta_max: Largest ``|theta|`` of each block over the run, between samples too [rad].
        eta: Slenderness ``atan(b/h)`` of each block [rad].
        energy: Total mechanical energy [J] (kinetic + gravity + overburden + contact springs),
            or None when not requested.
        dt: The time step used [s].
        work_wall: With a moving return wall (``wall_motion``) and ``save=("energy",)``: the
            work done on the blocks by the wall since ``t = 0`` [J], so that
            ``energy - work_wall`` is conserved without damping, slip or ground motion;
            zeros for a fixed wall; else None.
        normal_forces: With ``save=("forces",)``: the normal force of each interface [N]
            (``time x interface``; in a stack interface 0 the ground joint, ``k`` the bed
            joint between blocks ``k - 1`` and ``k``; in a row the order of
            :attr:`rockjax.Assembly.interfaces`), the resultant over the face of springs and
            dashpots, positive in compression, along the lower body's normal (the ground's:
            vertical); else None.
        shear_forces: With ``"forces"``: the shear force of each interface [N] (springs and
            dashpots), along the lower body's tangent (the ground's: +x), on the upper block;
            else None.
        restraint_force: With ``"forces"`` and a restrained top: the top restraint's
            horizontal force on the top block [N] (positive toward +x); else None.
        wall_forces: With ``"forces"`` on return walls (``mode="one_sided"``): the normal
            force of each block's back face on its wall [N] (``time x block``, positive in
            compression; a moving wall's horizontal component); else None.

    The forces are those of the step taken at each sample (the state at the sample, the
    dashpots at the lagged half-step velocity, as ``extras["normal_forces"]`` of
    :func:`rockjax.simulate_dem`); the centred dashpots that move the blocks differ from
    them by ``dt/2`` times the dashpot matrix times the accelerations (nothing at rest or at
    ``beta = 0``).
    """

    t: Float[Array, " time"]
    theta: Float[Array, "time block"]
    theta_dot: Float[Array, "time block"]
    x: Float[Array, "time block"]
    y: Float[Array, "time block"]
    overturned: Bool[Array, ""]
    status: Int[Array, ""]
    theta_max: Float[Array, " block"]
    eta: Float[Array, " block"]
    energy: Float[Array, " time"] | None
    dt: Float[Array, ""]
    work_wall: Float[Array, " time"] | None = None
    normal_forces: Float[Array, "time interface"] | None = None
    shear_forces: Float[Array, "time interface"] | None = None
    restraint_force: Float[Array, " time"] | None = None
    wall_forces: Float[Array, "time block"] | None = None


# ----------------------------------------------------------------------------- parameters


def assembly_params(
    assembly: Assembly,
    beta=0.0,
    *,
    joint: Joint = Joint(),
    phi_deg=50.0,
    mode: str = "two_sided",
    gap=0.0,
) -> AssemblyParams:
    """Collect the assembly, joint and damping into :class:`AssemblyParams` (traceable).

    Args:
        assembly: The assembly.
        beta: Stiffness-proportional Rayleigh damping coefficient [s], Eq. (1).
        joint: The joint of every interface (:class:`rockjax.Joint`).
        phi_deg: Friction angle of every interface [deg].
        mode: ``"two_sided"``, or ``"one_sided"``: a facade, every block's back face (-x)
            against a return wall ``gap`` behind it.
        gap: Distance between the back faces and the return wall at rest [m] (one-sided).
    """
    check_choice("mode", mode, MODES)
    check_gap(gap, used=mode == "one_sided", unused=ASSEMBLY_GAP_UNUSED, hint=GAP_HINT)
    check_kind(
        "assembly",
        assembly,
        (Assembly,),
        "Build one with rj.Assembly.stack([rj.Block(b=0.23, h=1.5)] * 2); run one block with "
        "rj.simulate_dem(block, ...).",
    )
    if not isinstance(joint, Joint):
        raise ValueError(
            f"joint must be a rockjax.Joint, e.g. rj.Joint(n_sub=2); got {type(joint).__name__}."
        )
    check_nonnegative(
        "beta", beta, "s", "beta is the stiffness-proportional Rayleigh coefficient.", scalar=True
    )
    check_scalar("phi_deg", phi_deg, "deg", "e.g. phi_deg=50.")
    phi = concrete(phi_deg)
    if phi is not None and not (0.0 < phi < 90.0):
        raise ValueError(f"phi_deg (friction angle, degrees) must be in (0, 90); got {phi_deg}.")
    blocks = assembly.blocks

    def arr(values):
        return jnp.stack([jnp.asarray(v, float) for v in values])

    links = assembly.interfaces
    # the dashpot solve is block-tridiagonal: each joint couples block k to the ground or to
    # block k - 1 (a stack or a row)
    assert all(other in (-1, k - 1) for k, other, _ in links)
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
    top = blocks[-1]
    return AssemblyParams(
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
        restrained=assembly.top == "restrained",
        one_sided=mode == "one_sided",
        links=links,
        row=assembly.layout == "row",
    )


def _span(p: AssemblyParams, k: int, wall: bool = False):
    """The face coordinates ``(lo, hi)`` [m] of interface ``k``'s face, or with ``wall`` of
    block ``k``'s back face on the return wall (``t`` up the face from its centre)."""
    return (-0.5 * p.h[k], 0.5 * p.h[k]) if wall else (p.lo[k], p.hi[k])


def _springs(p: AssemblyParams, k: int, wall: bool = False):
    """The springs of interface ``k`` (or of block ``k``'s back face on the return wall) for
    the all-closed stiffness: positions ``t`` along the face [m] and the normal and shear
    stiffnesses [N/m] (the two-point Gauss rule of the face for the integrated law: it gives
    the continuous joint's all-closed stiffness exactly)."""
    lo, hi = _span(p, k, wall)
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


def omega_max(p: AssemblyParams):
    """Highest circular frequency [rad/s] of the assembly at rest with every spring closed
    (an upper bound over contact states, as :func:`rockjax.dem.omega_max` for one block)."""
    n = p.n
    k_mat = jnp.zeros((3 * n, 3 * n))

    def rows(e, rx, ry):
        # a unit force along e at offset (rx, ry) from a centroid: (Fx, Fy, clockwise moment)
        one = jnp.ones_like(rx)
        return jnp.stack([e[0] * one, e[1] * one, ry * e[0] - rx * e[1]], axis=-1)

    for i, (k, other, kind) in enumerate(p.links):
        t, kn, ks = _springs(p, i)
        # the face point at rest from block k's centroid, the joint's normal and tangent
        if kind == "bed":
            rx, ry, nrm, tng = t, -0.5 * p.h[k] + 0.0 * t, (0.0, 1.0), (1.0, 0.0)
        else:
            rx, ry, nrm, tng = -0.5 * p.b[k] + 0.0 * t, t, (1.0, 0.0), (0.0, 1.0)
        a_n, a_s = rows(nrm, rx, ry), rows(tng, rx, ry)
        cols = list(range(3 * k, 3 * k + 3))
        if other >= 0:
            lx = p.x0[k] + rx - p.x0[other]
            ly = p.y0[k] + ry - p.y0[other]
            a_n = jnp.concatenate([-rows(nrm, lx, ly), a_n], axis=-1)
            a_s = jnp.concatenate([-rows(tng, lx, ly), a_s], axis=-1)
            cols = list(range(3 * other, 3 * other + 3)) + cols
        sub = jnp.einsum("i,ij,ik->jk", kn, a_n, a_n) + jnp.einsum("i,ij,ik->jk", ks, a_s, a_s)
        idx = jnp.asarray(cols)
        k_mat = k_mat.at[idx[:, None], idx[None, :]].add(sub)
    for k in range(n):
        if p.one_sided:
            # the back face (-b/2, t): horizontal motion (1, 0, t), vertical (0, 1, b/2)
            t, kn, ks = _springs(p, k, wall=True)
            zero, one = jnp.zeros_like(t), jnp.ones_like(t)
            a_n = jnp.stack([one, zero, t], axis=-1)
            a_s = jnp.stack([zero, one, 0.5 * p.b[k] * one], axis=-1)
            sub = jnp.einsum("i,ij,ik->jk", kn, a_n, a_n) + jnp.einsum("i,ij,ik->jk", ks, a_s, a_s)
            idx = jnp.arange(3 * k, 3 * k + 3)
            k_mat = k_mat.at[idx[:, None], idx[None, :]].add(sub)
    if p.restrained:
        a = jnp.zeros(3 * n).at[3 * n - 3].set(1.0).at[3 * n - 1].set(0.5 * p.h[-1])
        k_mat = k_mat + p.k_top * jnp.outer(a, a)
    mass = jnp.stack([p.m, p.m, p.I_c], axis=-1).reshape(-1)
    inv = 1.0 / jnp.sqrt(mass)
    return jnp.sqrt(jnp.max(jnp.linalg.eigvalsh(k_mat * inv[:, None] * inv[None, :])))


def _steps(p: AssemblyParams, accuracy):
    w = omega_max(p)
    zeta = 0.5 * p.beta * w
    return 2.0 / w, jnp.minimum(accuracy / (w * (1.0 + zeta)), DT_SAFETY * 2.0 / w)


_steps_program = persistent_jit(_steps)


def _steps_jit(p, accuracy):
    """:func:`_steps` compiled once for every assembly of a shape and every accuracy (kept on
    disk with the persistent cache)."""
    return _steps_program(p, np.float64(accuracy))


def stable_dt_assembly(
    assembly: Assembly,
    beta=0.0,
    *,
    joint: Joint = Joint(),
    accuracy: float | None = None,
    mode: str = "two_sided",
) -> float:
    """The default time step [s] of :func:`simulate_assembly` (before rounding to divide the
    output step): the rule of :func:`rockjax.stable_dt`, ``accuracy / (omega_max (1 + zeta))``,
    ``zeta = beta omega_max / 2``, at most ``DT_SAFETY`` times the stability limit, with
    ``omega_max`` the highest frequency of the whole assembly on all its springs closed (the
    return walls' included, one-sided).

    Args:
        assembly: The assembly.
        beta: Stiffness-proportional damping coefficient [s], Eq. (1).
        joint: The joint (:class:`rockjax.Joint`).
        accuracy: ``omega_max dt (1 + zeta)`` [-]; default that of
            :func:`rockjax.simulate_dem` for the ``mode`` (``DT_ACCURACY`` /
            ``DT_ACCURACY_SUB``).
        mode: ``"two_sided"`` or ``"one_sided"`` (a facade against return walls).
    """
    p = assembly_params(assembly, beta, joint=joint, mode=mode)
    return float(_steps_jit(p, _check_accuracy(accuracy, joint, mode))[1])


def _check_accuracy(accuracy, joint, mode="two_sided"):
    default = (DT_ACCURACY if joint.face else DT_ACCURACY_SUB)[mode]
    if accuracy is None:
        return default
    if not (isinstance(accuracy, (int, float)) and np.isfinite(accuracy) and accuracy > 0):
        raise ValueError(
            f"accuracy (omega_max dt (1 + zeta), dimensionless) must be a positive float; got "
            f"accuracy={accuracy!r}. Leave accuracy=None for the default ({default})."
        )
    return float(accuracy)


# ----------------------------------------------------------------------------- 3 x 3 algebra


def _zero(x) -> bool:
    return isinstance(x, float) and x == 0.0


def _mul(a, b):
    """``a * b`` with Python zeros and ones folded (XLA keeps ``x * 0.0`` for NaN semantics)."""
    if _zero(a) or _zero(b):
        return 0.0
    if isinstance(a, float) and a == 1.0:
        return b
    if isinstance(b, float) and b == 1.0:
        return a
    return a * b


def _plus(*terms):
    """Sum with Python zeros dropped."""
    out = 0.0
    for t in terms:
        if not _zero(t):
            out = t if _zero(out) else out + t
    return out


def _inv3(a):
    """Inverse of a 3 x 3 matrix given as nested lists of scalars (adjugate / determinant)."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a

    def det2(p, q, r, s_):
        return _plus(_mul(p, q), -_mul(r, s_) if not _zero(_mul(r, s_)) else 0.0)

    c00 = det2(a11, a22, a12, a21)
    c01 = det2(a12, a20, a10, a22)
    c02 = det2(a10, a21, a11, a20)
    det = _plus(_mul(a00, c00), _mul(a01, c01), _mul(a02, c02))
    r = 1.0 / det
    return [
        [_mul(c00, r), _mul(det2(a02, a21, a01, a22), r), _mul(det2(a01, a12, a02, a11), r)],
        [_mul(c01, r), _mul(det2(a00, a22, a02, a20), r), _mul(det2(a02, a10, a00, a12), r)],
        [_mul(c02, r), _mul(det2(a01, a20, a00, a21), r), _mul(det2(a00, a11, a01, a10), r)],
    ]


def _mv(a, v):
    return [_plus(*(_mul(a[i][j], v[j]) for j in range(3))) for i in range(3)]


def _mm(a, b):
    return [
        [_plus(*(_mul(a[i][j], b[j][k]) for j in range(3))) for k in range(3)] for i in range(3)
    ]


def _tr(a):
    return [[a[j][i] for j in range(3)] for i in range(3)]


def _solve_tridiagonal(diag, lower, rhs):
    """Solve the symmetric block-tridiagonal system with diagonal blocks ``diag[k]``,
    ``A[k, k-1] = lower[k]`` (``lower[0]`` unused) and right-hand sides ``rhs[k]`` by block
    elimination (3 x 3 blocks). Used by batches of more than ``LDL_BATCH_MAX_BLOCKS`` blocks;
    the others use :func:`_solve_ldl`."""
    n = len(diag)
    dp, gp, inv = [diag[0]], [rhs[0]], [_inv3(diag[0])]
    for k in range(1, n):
        lk = lower[k]
        li = _mm(lk, inv[k - 1])
        lt = _tr(lk)
        corr = _mm(li, lt)
        dk = [[_plus(diag[k][i][j], _mul(-1.0, corr[i][j])) for j in range(3)] for i in range(3)]
        g = _mv(li, gp[k - 1])
        dp.append(dk)
        gp.append([_plus(rhs[k][i], _mul(-1.0, g[i])) for i in range(3)])
        inv.append(_inv3(dk))
    out = [None] * n
    out[n - 1] = _mv(inv[n - 1], gp[n - 1])
    for k in range(n - 2, -1, -1):
        u = _mv(_tr(lower[k + 1]), out[k + 1])
        out[k] = _mv(inv[k], [_plus(gp[k][i], _mul(-1.0, u[i])) for i in range(3)])
    return out


def _uses_ldl(p: AssemblyParams) -> bool:
    """Whether a step solves by :func:`_solve_ldl` (see ``LDL_BATCH_MAX_BLOCKS``)."""
    return p.single_history or p.n <= LDL_BATCH_MAX_BLOCKS


def _solve_ldl(diag, lower, rhs):
    """:func:`_solve_tridiagonal`'s system as a single history and small batches solve it
    (symmetric positive definite, ``M + dt/2 C``: no pivoting; the lower triangles of ``diag``
    are read): a scalar ``L D L^T`` of its band, then the two triangular solves.

    Each multiplier is a division by its pivot, and XLA:CPU does not copy a division into
    its consumers: each factor is computed once, where the adjugate inverses' shared products
    were copied into each output (docs/assemblies.md, "Performance"). In a batch the divisions
    are vector operations of their own, and from four blocks up the block elimination ran
    faster.
    """
    n = len(diag)
    size = 3 * n
    a = {}  # the lower triangle of the band, (row, column) -> entry
    for k in range(n):
        for i in range(3):
            for j in range(i + 1):
                a[3 * k + i, 3 * k + j] = diag[k][i][j]
            if k > 0:
                for j in range(3):
                    a[3 * k + i, 3 * (k - 1) + j] = lower[k][i][j]
    last = [min(size, 3 * (r // 3 + 2)) for r in range(size)]  # the band's rows below a column
    d, low = [], {}
    for j in range(size):
        d.append(a[j, j])
        rows = range(j + 1, last[j])
        col = {i: a[i, j] for i in rows if not _zero(a[i, j])}
        for i, v in col.items():
            low[i, j] = v / d[j]
        for i in col:  # the trailing update (its entries stay in the band)
            for k in range(j + 1, i + 1):
                if k in col:
                    a[i, k] = _plus(a[i, k], -_mul(low[i, j], col[k]))
    b = [v for k in range(n) for v in rhs[k]]
    y = []
    for i in range(size):
        y.append(_plus(b[i], *(-_mul(low[i, j], y[j]) for j in range(i) if (i, j) in low)))
    z = [yi / di for yi, di in zip(y, d)]
    x = [0.0] * size
    for i in range(size - 1, -1, -1):
        x[i] = _plus(z[i], *(-_mul(low[k, i], x[k]) for k in range(i + 1, size) if (k, i) in low))
    return [x[3 * k : 3 * k + 3] for k in range(n)]


# ----------------------------------------------------------------------------- contact


def _pair_kinematics(p: AssemblyParams, st: AssemblyState, i: int):
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


def _wall_kinematics(p: AssemblyParams, st: AssemblyState, k: int, motion=None):
    """The back face of block ``k`` against the return wall, as :func:`_pair_kinematics`
    gives a joint: the point ``(-b_k/2, t)`` (``t`` up the face) penetrates the wall line by
    ``delta``; the wall's normal is ``+x``, its tangent ``+y`` (the slip is the point's
    vertical velocity less the wall's), as on the back face of :func:`rockjax.simulate_dem`'s
    facade. ``kin(t)`` returns ``(rx, ry, x_pt, y_pt, delta, delta_dot, slip)``.

    A fixed wall (``motion`` None) is the line ``x = x0_k - b_k/2 - gap`` (the block's back
    face at rest, ``gap`` behind it), ``delta = x_wall - x``. A moving wall (``motion =
    (u_top, v_top)`` [m, m/s] at the stack's height ``H``) is those lines turned rigidly to
    ``theta_w = u_top / H`` about block 0's toe ``(x0_0 + b_0/2 - gap, 0)`` (its heel for
    ``theta_w < 0``): :func:`rockjax.walls.wall_line`, whose line ``x = x0 + slope y`` gives
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


def _dashpot_blocks(c, moments, e, arm, kappa, ground: bool, once: bool):
    """The dashpot blocks ``c int w r r^T`` of one direction of a face: ``(C_uu, C_ll,
    C_ul)`` (the last two None for the ground), for the upper row ``r_u = (e, a(tau))`` and the
    lower ``r_l = -(e, a(tau) + kappa)``, ``a`` affine in ``tau`` from ``arm`` (its values at
    the face's two ends), ``moments = int w (1, tau, tau^2)``.

    Each entry is one or two products of ``c M0``, ``c M1``, ``c M2`` (``M0 = int w``,
    ``M1 = int w a``, ``M2 = int w a^2``) and the components of ``e``."""
    m0, m1, m2 = moments
    a0, da = arm[0], arm[1] - arm[0]
    big1 = _plus(_mul(m0, a0), _mul(m1, da))
    big2 = _plus(_mul(_mul(m0, a0), a0), _mul(2.0, _mul(_mul(m1, a0), da)), _mul(_mul(m2, da), da))
    cm0, cm1, cm2 = _mul(c, m0), _mul(c, big1), _mul(c, big2)
    if once:  # (read by every entry below: XLA:CPU would copy them into each)
        if ground:
            cm0, cm1, cm2 = computed_once(cm0, cm1, cm2)
        else:
            cm0, cm1, cm2, kappa = computed_once(cm0, cm1, cm2, kappa)

    uu = [[_mul(cm0, _mul(e[i], e[j])) for j in range(2)] + [_mul(cm1, e[i])] for i in range(2)]
    uu.append([_mul(cm1, e[0]), _mul(cm1, e[1]), cm2])
    if ground:
        return uu, None, None
    cm1_l = _plus(cm1, _mul(kappa, cm0))  # c int w (a + kappa)
    cm2_l = _plus(cm2, _mul(2.0, _mul(kappa, cm1)), _mul(_mul(kappa, kappa), cm0))
    cm2_ul = _plus(cm2, _mul(kappa, cm1))  # c int w a (a + kappa)
    ll = [[_mul(cm0, _mul(e[i], e[j])) for j in range(2)] + [_mul(cm1_l, e[i])] for i in range(2)]
    ll.append([_mul(cm1_l, e[0]), _mul(cm1_l, e[1]), cm2_l])
    ul = [
        [_mul(-1.0, _mul(cm0, _mul(e[i], e[j]))) for j in range(2)]
        + [_mul(-1.0, _mul(cm1_l, e[i]))]
        for i in range(2)
    ]
    ul.append([_mul(-1.0, _mul(cm1, e[0])), _mul(-1.0, _mul(cm1, e[1])), _mul(-1.0, cm2_ul)])
    return uu, ll, ul


def _sum_terms(wfn, wf_el, wn, wf, tau, slip, fs):
    """The 13 quantities a face sums over its points (weights ``w`` included):
    :func:`rockjax.contact.face_integrands` in the face coordinate ``tau`` and the point
    shear springs ``fs (1, tau)``; Python zeros where a joint has none (the face law's point
    springs, the sub-contacts' ``f_el``)."""
    return face_integrands(wfn, wf_el, wn, wf, slip, tau, tau) + [fs, _mul(fs, tau)]


def _point_sums(p: AssemblyParams, k, pts, lo, width, ends, hist, kn, beta, dt, dt_onset, clipped):
    """The sums over a face's points ``pts`` (``(t, weight)``, :func:`_sum_terms`) and the
    point shear springs (None for the face law): see :func:`_interface`.

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
        ws = wf  # the face's shear dashpot: weighted by its one spring's stick in _interface
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
    terms = _sum_terms(wfn, wf_el, wn, ws, tau, slip, fs_sum)
    live = [i for i, term in enumerate(terms) if not _zero(term)]
    sums = [0.0] * len(terms)
    for i, total in zip(live, sum_together(*(terms[i] for i in live))):
        sums[i] = total
    return sums, fs_arr


def _face_ends(p: AssemblyParams, st: AssemblyState, motion=None):
    """Each face's kinematics at its two ends, ``[kin(lo), kin(hi)]``: a list for the joints
    (:func:`_pair_kinematics`) and one for the blocks' back faces on the return walls
    (:func:`_wall_kinematics`, ``motion`` as there; empty without return walls).

    Most of a step reads them. A history that is not batched computes them all as one XLA
    computation (:func:`rockjax._fusion.one_computation`): XLA:CPU would copy them into each
    consumer, and one computation for every face ran faster than one per face
    (docs/assemblies.md, "Performance")."""

    def ends(kin, span):
        return [kin(span[0]), kin(span[1])]

    def compute(_):
        joints = [ends(_pair_kinematics(p, st, j)[0], _span(p, j)) for j in range(len(p.links))]
        walls = []
        if p.one_sided:
            walls = [
                ends(_wall_kinematics(p, st, k, motion)[0], _span(p, k, wall=True))
                for k in range(p.n)
            ]
        return joints, walls

    if p.single_history:
        return one_computation(compute, st.x[0])
    return compute(None)


def _interface(
    p: AssemblyParams, st: AssemblyState, k: int, dt, ends, wall: bool = False, motion=None
):
    """Forces of interface ``k`` (integrated face law or point sub-contacts), or with ``wall``
    of block ``k``'s back face on the return wall (a body moved by ``motion``, see
    :func:`_wall_kinematics`; None: fixed, as the ground); ``ends``: the face's kinematics at
    its ends (:func:`_face_ends`).

    Returns ``(F_u, F_l, C_uu, C_ll, C_ul, fs_new, fn, power, ft)``: generalised forces
    ``(Fx, Fy, M)`` on the upper and lower block (``F_l`` None for the ground and the wall),
    the dashpot matrix blocks, the new shear springs, the total normal force [N] (along the
    lower body's normal; a moving wall's: its horizontal component), the power of a moving
    wall on the block [W] (0 otherwise) and the total shear force [N] (spring and dashpot,
    along the lower body's tangent), both on the upper block, dashpots at the lagged
    velocity."""
    line = None
    if wall:
        _, e1, e2, rel, line = _wall_kinematics(p, st, k, motion)
        hist = st.fs_wall[k]
    else:
        _, e1, e2, rel = _pair_kinematics(p, st, k)
        hist = st.fs[k]
    lo, hi = _span(p, k, wall)
    width = hi - lo
    ground = rel is None
    dt_onset = dt if p.onset == "sub_step" else None
    clipped = p.dashpot == "clipped"
    beta = p.beta

    def arms(e, r):
        rx, ry = r
        # clockwise moment of a unit force along e at offset r
        return _plus(_mul(ry, e[0]), _mul(-1.0, _mul(rx, e[1])))

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
        cuts = [lo, *computed_once(*cuts[1:-1]), hi]
        pts = []
        for a, b_ in zip(cuts[:-1], cuts[1:]):
            mid, half = 0.5 * (a + b_), 0.5 * (b_ - a)
            for xg in _GAUSS:
                pts.append((mid + half * xg, half))
    else:
        n_sub = p.n_sub
        wts = [1.0] * n_sub
        wts[0] = wts[-1] = 0.5
        step = width / (n_sub - 1)
        pts = [(lo + step * i, wts[i] * step) for i in range(n_sub)]
    sums, fs_arr = _point_sums(
        p, k, pts, lo, width, ends, hist, p.kn_line[k], beta, dt, dt_onset, clipped
    )
    fn, fn_el, fn1, n0, n1, n2, s0, s1, s2, v0, v1, fs_tot, fs_tau = (sums[i] for i in range(13))
    if p.face:
        kn_c = kn
        (f_s,) = hist
        # the resultant shear spring keeps the share of its closed length that stays closed
        # (rockjax.dem's "uniform" release); the previous penetration is delta - dt delta_dot
        ca_old, cb_old = closed_interval(lo, hi, d_lo - dt * r_lo, d_hi - dt * r_hi)
        ca, cb = closed_interval(lo, hi, d_lo, d_hi)
        ka, kb = jnp.maximum(ca, ca_old), jnp.minimum(cb, cb_old)
        kb = jnp.maximum(kb, ka)
        whole, kept = cb_old - ca_old, kb - ka
        safe = jnp.where(whole > 0.0, whole, 1.0)
        f_s = f_s * jnp.where(whole > 0.0, jnp.clip(kept / safe, 0.0, 1.0), 0.0)
        # the shear dashpot acts only while the face sticks (rockjax.contact.coulomb)
        f_s, stick = coulomb(f_s - ks * v0 * dt, p.tan_phi * fn_el)
        # the shear dashpot's stiffness: state-dependent now, and read by the forces and the
        # dashpot blocks, so computed once with the spring
        f_s, ks_d = computed_once(f_s, stick * ks)
        tau_bar = jnp.where(s0 > 0.0, s1 / jnp.where(s0 > 0.0, s0, 1.0), 0.0)
        fs_new = (f_s,)
        fs_mom_tau = f_s * tau_bar  # int of the spring force times tau
    else:
        # the weights above carry the areas, and the shear sums each point's stick
        kn_c, ks_d = p.kn_line[k], p.ks_line[k]
        f_s, fs_mom_tau = fs_tot, fs_tau
        fs_new = tuple(fs_arr[i] for i in range(len(pts)))
    ft = f_s - beta * ks_d * v0
    # a moving wall's normal force acts along its normal (1, -slope) (not normalised: fn is
    # the horizontal component, as in rockjax.simulate_dem); the dashpot matrix keeps the
    # fixed wall's rows, as simulate_dem's does
    e2_f = e2 if line is None else (1.0, -line[0])
    an_f = an_u if line is None else [arms(e2_f, end[0:2]) for end in ends]
    fx = _plus(_mul(fn, e2_f[0]), _mul(ft, e1[0]))
    fy = _plus(_mul(fn, e2_f[1]), _mul(ft, e1[1]))

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
        kappa_n = _plus(_mul(y_rel, e2[0]), _mul(-1.0, _mul(x_rel, e2[1])))
        kappa_s = _plus(_mul(y_rel, e1[0]), _mul(-1.0, _mul(x_rel, e1[1])))
    blocks = [
        _dashpot_blocks(cn, (n0, n1, n2), e2, an_u, kappa_n, ground, _uses_ldl(p)),
        _dashpot_blocks(cs, (s0, s1, s2), e1, as_u, kappa_s, ground, _uses_ldl(p)),
    ]
    c_uu = _add(blocks[0][0], blocks[1][0])
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
    c_ll = _add(blocks[0][1], blocks[1][1])
    c_ul = _add(blocks[0][2], blocks[1][2])
    return f_u, f_l, c_uu, c_ll, c_ul, fs_new, fn_out, power, ft


def _scale(a, m):
    return [[_mul(a, m[i][j]) for j in range(3)] for i in range(3)]


def _add(a, b):
    return [[_plus(a[i][j], b[i][j]) for j in range(3)] for i in range(3)]


def _top(p: AssemblyParams, st: AssemblyState, dt, top_motion=None):
    """Overburden and top restraint on the top block: generalised force and dashpot block.
    ``top_motion``: the restraint's displacement [m] and velocity [m/s] relative to the base
    (``None``: it moves with the base)."""
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
        # each read by several entries of the force and the dashpot matrix
        fq, cq = computed_once(fq, cq)
        fx = fx + fq
        mom = mom + ry * fq
        a = (1.0, 0.0, ry)
        cmat = [[_mul(cq, _mul(a[i], a[j])) for j in range(3)] for i in range(3)]
    return (fx, fy, mom), cmat


def step(
    p: AssemblyParams, st: AssemblyState, ag, ag_v, dt, *, load=None, top_motion=None, wall=None
):
    """One central-difference step of the assembly with centred dashpots (the scheme of
    :mod:`rockjax.dem`: ``(M + dt/2 C) a_n = F``, solved by block elimination).

    Args:
        p: The parameters (:func:`assembly_params`).
        st: The state at step ``n`` (velocities at ``n - 1/2``).
        ag: Horizontal acceleration of the base [m/s^2] (the frame of the run).
        ag_v: Vertical acceleration of the base [m/s^2].
        dt: Time step [s].
        load: Optional external load, one ``(Fx, Fy, M)`` [N, N, N m] per block (force on
            the centroid, clockwise moment), or ``None``.
        top_motion: Optional ``(u, v)``: the top restraint's horizontal displacement [m] and
            velocity [m/s] relative to the base (a floor above the base floor), or ``None``.
        wall: Optional ``(u_top, v_top)``: a moving return wall's displacement [m] and
            velocity [m/s] at the stack's height relative to the base (one-sided ``p``), or
            ``None`` for a fixed wall.

    Returns:
        The state at ``n + 1`` and the accelerations ``[[ax, ay, alpha], ...]`` per block at
        step ``n`` [m/s^2, rad/s^2] (relative to the base).
    """
    new, acc, *_ = _step(p, st, ag, ag_v, dt, load=load, top_motion=top_motion, wall=wall)
    return new, acc


def _step(p: AssemblyParams, st: AssemblyState, ag, ag_v, dt, *, load, top_motion, wall):
    """:func:`step`, also returning the power of a moving return wall on the blocks [W] and
    the step's contact forces [N] (the values the step computes anyway, none added): a dict
    of ``normal``, ``shear`` (per interface, on the upper block), ``restraint`` (the top
    restraint's horizontal force on the top block, or None) and ``wall`` (each back face's
    normal force, or None)."""
    n = p.n
    force = [[0.0, 0.0, 0.0] for _ in range(n)]
    cdiag = [[[0.0] * 3 for _ in range(3)] for _ in range(n)]
    clow = [None] * n
    fs_all, fn_all, ft_all = [], [], []
    joint_ends, wall_ends = _face_ends(p, st, wall)
    for j, (k, other, _) in enumerate(p.links):
        f_u, f_l, c_uu, c_ll, c_ul, fs_new, fn, _, ft = _interface(p, st, j, dt, joint_ends[j])
        fs_all.append(fs_new)
        fn_all.append(fn)
        ft_all.append(ft)
        force[k] = [_plus(force[k][i], f_u[i]) for i in range(3)]
        cdiag[k] = _add(cdiag[k], c_uu)
        if f_l is not None:  # other = k - 1 (a stack or a row: a chain)
            force[other] = [_plus(force[other][i], f_l[i]) for i in range(3)]
            cdiag[other] = _add(cdiag[other], c_ll)
            clow[k] = c_ul
    fs_wall, fn_wall = [], []
    power = 0.0
    if p.one_sided:  # a static choice: walls without return walls run none of this
        for k in range(n):
            f_w, _, c_w, _, _, fs_new, fn, pw, _ = _interface(
                p, st, k, dt, wall_ends[k], wall=True, motion=wall
            )
            power = power + pw
            fs_wall.append(fs_new)
            fn_wall.append(fn)
            force[k] = [_plus(force[k][i], f_w[i]) for i in range(3)]
            cdiag[k] = _add(cdiag[k], c_w)
    f_top, c_top = _top(p, st, dt, top_motion)
    force[n - 1] = [_plus(force[n - 1][i], f_top[i]) for i in range(3)]
    if load is not None:
        force = [[_plus(force[k][i], load[k][i]) for i in range(3)] for k in range(n)]
    if c_top is not None:
        cdiag[n - 1] = _add(cdiag[n - 1], c_top)
    h = 0.5 * dt
    diag, lower, rhs = [], [], []
    for k in range(n):
        mk, ik = p.m[k], p.I_c[k]
        mass = (mk, mk, ik)
        diag.append(
            [
                [_plus(mass[i] if i == j else 0.0, _mul(h, cdiag[k][i][j])) for j in range(3)]
                for i in range(3)
            ]
        )
        lower.append(None if clow[k] is None else _scale(h, clow[k]))
        rhs.append([force[k][0] - mk * ag, force[k][1] - mk * (G + ag_v), _plus(force[k][2])])
    solve = _solve_ldl if _uses_ldl(p) else _solve_tridiagonal
    acc = one_computation(solve, diag, lower, rhs)
    new = {f: [] for f in ("x", "y", "c", "s", "vx", "vy", "w", "theta", "theta_max")}
    for k in range(n):
        ax, ay, aw = acc[k]
        vx = st.vx[k] + dt * ax
        vy = st.vy[k] + dt * ay
        w = st.w[k] + dt * aw
        dth = dt * w
        d2 = dth * dth
        cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0 - d2 / 720.0))
        sd = dth * (1.0 - d2 * (1.0 / 6.0 - d2 / 120.0))
        c, s = st.c[k], st.s[k]
        new["x"].append(st.x[k] + dt * vx)
        new["y"].append(st.y[k] + dt * vy)
        new["c"].append(c * cd - s * sd)
        new["s"].append(s * cd + c * sd)
        new["vx"].append(vx)
        new["vy"].append(vy)
        new["w"].append(w)
        new["theta"].append(st.theta[k] + dth)
        new["theta_max"].append(jnp.maximum(st.theta_max[k], jnp.abs(st.theta[k])))
    out = AssemblyState(
        **{key: tuple(v) for key, v in new.items()}, fs=tuple(fs_all), fs_wall=tuple(fs_wall)
    )
    forces = dict(
        normal=fn_all,
        shear=ft_all,
        restraint=f_top[0] if p.restrained else None,
        wall=fn_wall if p.one_sided else None,
    )
    return out, acc, power, forces


# ----------------------------------------------------------------------------- energy, collapse


def _face_energy(p: AssemblyParams, k: int, span, ends, hist):
    """Spring energy [J] of one face of block ``k`` (``span = (lo, hi)`` its face coordinates,
    ``ends`` its kinematics there (:func:`_face_ends`), ``hist`` its shear springs):
    ``kn delta^2 / 2`` integrated exactly over the closed part, and ``f_s^2 / (2 k_s)`` of the
    shear springs."""
    e = 0.0
    lo, hi = span
    d_lo, d_hi = ends[0][4], ends[1][4]
    if p.face:
        ca, cb = closed_interval(lo, hi, d_lo, d_hi)
        mid, half = 0.5 * (ca + cb), 0.5 * (cb - ca)
        for xg in _GAUSS:
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


def _energy(p: AssemblyParams, st: AssemblyState, vel, wall=None):
    """Kinetic + gravity + overburden + spring energy [J] (springs integrated exactly; the
    return walls' too, moved by ``wall = (u_top, v_top)`` [m, m/s] or fixed)."""
    e = 0.0
    joint_ends, wall_ends = _face_ends(p, st, wall)
    for i in range(len(p.links)):
        e = e + _face_energy(p, i, _span(p, i), joint_ends[i], st.fs[i])
    for k in range(p.n):
        vx, vy, w = vel[k]
        e = e + 0.5 * p.m[k] * (vx**2 + vy**2) + 0.5 * p.I_c[k] * w**2
        e = e + p.m[k] * G * st.y[k]
        if p.one_sided:
            e = e + _face_energy(p, k, _span(p, k, wall=True), wall_ends[k], st.fs_wall[k])
    k = p.n - 1
    qx = st.x[k] + 0.5 * p.h[k] * st.s[k]
    qy = st.y[k] + 0.5 * p.h[k] * st.c[k]
    e = e + p.top_load * qy
    if p.restrained:
        over = jnp.maximum(jnp.abs(qx - p.x0[k]) - p.gap, 0.0)
        e = e + 0.5 * p.k_top * over**2
    return e


def _collapsed(p: AssemblyParams, st: AssemblyState):
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
        th, w = st.theta[k], st.w[k]
        past = (jnp.abs(th) > p.eta[k]) & (th * w > 0)
        if k > 0:  # and relative to the block below
            rel, w_rel = th - st.theta[k - 1], w - st.w[k - 1]
            past = past & (jnp.abs(rel) > p.eta[k]) & (rel * w_rel > 0) & (rel * th > 0)
        over = over | past
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
            c, s = st.c[k], st.s[k]
            hh = 0.5 * p.h[k]
            for end, sign in ((p.hi[k], 1.0), (p.lo[k], -1.0)):
                # the end of the support face, a point of block k (body (end, -h_k/2))
                ex, ey = st.x[k] + end * c - hh * s, st.y[k] - end * s - hh * c
                evx = st.vx[k] + st.w[k] * (ey - st.y[k])
                evy = st.vy[k] - st.w[k] * (ex - st.x[k])
                dx, dy = g[0] - ex, g[1] - ey
                dvx, dvy = gv[0] - evx, gv[1] - evy
                # under gravity: beyond the end horizontally, moving outward
                past = (sign * dx > 0) & (sign * gv[0] > 0)
                if k > 0:
                    # in the frame of block k - 1: along its top face e1 = (c_l, -s_l),
                    # beyond the end and moving outward relative to it
                    cl, sl, wl = st.c[k - 1], st.s[k - 1], st.w[k - 1]
                    along = cl * dx - sl * dy
                    rate = cl * dvx - sl * dvy - wl * (sl * dx + cl * dy)
                    past = past & (sign * along > 0) & (sign * rate > 0)
                over = over | past
    for k in range(1, p.n):
        # slid off: the centre of block k's bottom face (body point (0, -h_k/2)), in the frame
        # of block k - 1, beyond that block's half-width; measured at the face, not the
        # centroid, because a block hinging on the edge below turns its centroid past the
        # edge without leaving its support
        cl, sl = st.c[k - 1], st.s[k - 1]
        hh = 0.5 * p.h[k]
        fx = st.x[k] - hh * st.s[k] - st.x[k - 1]
        fy = st.y[k] - hh * st.c[k] - st.y[k - 1]
        u = cl * fx - sl * fy
        over = over | (jnp.abs(u) > 0.5 * p.b[k - 1])
    return over


# ----------------------------------------------------------------------------- initial state


def initial_assembly_state(
    assembly: Assembly, p: AssemblyParams, theta0=0.0, joint: Joint = Joint()
) -> AssemblyState:
    """At rest under gravity and the overburden: the whole stack tilted rigidly by ``theta0``
    [rad] about the pivot corner of block 0 (or flat for ``theta0 = 0``); a restrained
    two-block wall in its hinge mechanism instead (:func:`_hinge_pose`).

    The ground joint settles as under one block carrying the whole weight (the equilibrium
    sink of :func:`rockjax.dem.initial_state`, computed by it for a block of block 0's shape
    and the total weight); each bed joint settles uniformly under the weight above it. The
    return walls (one-sided ``p``) just touch the back faces at ``gap = 0``."""
    n_fs = 1 if joint.face else joint.n_sub
    zero = jnp.zeros(())
    if p.row:  # each block on its own ground joint, upright (theta0 = 0, checked)
        states = [
            initial_state(dem_params(blk, joint=joint, phi_deg=45.0), 0.0)
            for blk in assembly.blocks
        ]
        n = p.n
        return AssemblyState(
            x=tuple(s0.x + p.x0[k] for k, s0 in enumerate(states)),
            y=tuple(s0.y for s0 in states),
            c=tuple(s0.c for s0 in states),
            s=tuple(s0.s for s0 in states),
            vx=(zero,) * n,
            vy=(zero,) * n,
            w=(zero,) * n,
            theta=(zero,) * n,
            theta_max=(zero,) * n,
            fs=tuple((zero,) * n_fs for _ in p.links),
        )
    weight = sum(b.m for b in assembly.blocks) * G + assembly.top_load
    proxy = _carrying(assembly.blocks[0], weight)
    s0 = initial_state(dem_params(proxy, joint=joint, phi_deg=45.0), theta0)
    if p.restrained and concrete(theta0) != 0.0:
        return _hinge_pose(assembly, p, s0, joint)
    theta0 = jnp.asarray(theta0, float)
    c, s = s0.c, s0.s
    xs, ys = [s0.x + p.x0[0]], [s0.y]
    load = weight
    for k in range(1, p.n):
        load = load - p.m[k - 1] * G
        sink = load / (p.kn_line[k] * (p.hi[k] - p.lo[k]))
        du = p.x0[k] - p.x0[k - 1]
        dv = 0.5 * p.h[k - 1] + 0.5 * p.h[k] - sink
        xs.append(xs[-1] + du * c + dv * s)
        ys.append(ys[-1] - du * s + dv * c)
    n = p.n
    return AssemblyState(
        x=tuple(xs),
        y=tuple(ys),
        c=(c,) * n,
        s=(s,) * n,
        vx=(zero,) * n,
        vy=(zero,) * n,
        w=(zero,) * n,
        theta=(theta0,) * n,
        theta_max=(jnp.abs(theta0),) * n,
        fs=tuple((zero,) * n_fs for _ in range(n)),
        fs_wall=tuple((zero,) * n_fs for _ in range(n)) if p.one_sided else (),
    )


def _hinge_angle(theta, x_b, x_c, u1, v1):
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


def _hinge_geometry(assembly: Assembly, side):
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


def _hinge_pose(assembly: Assembly, p: AssemblyParams, s0, joint: Joint) -> AssemblyState:
    """A restrained two-block wall released in its hinge mechanism (docs/assemblies.md,
    "Initial state"): block 0 tilted by ``theta0`` about its pivot corner as a free stack's
    (``s0``: its pose and ground sink under the whole weight), block 1 on the hinge ``B`` at
    the bed joint's far end, turned so that the top face centre bears on the stop the upper
    block leans on (``x0_1 + gap`` for ``theta0 > 0``): :func:`_hinge_angle`. The bed joint
    settles on its corner as :func:`rockjax.dem.initial_state` sinks a block of block 1's
    shape carrying block 1 and the overburden, tilted by the relative rotation."""
    theta = s0.theta
    side = jnp.sign(theta)
    _, u_b, _, u1, v1 = _hinge_geometry(assembly, side)
    c, s = s0.c, s0.s
    x_0, y_0 = s0.x + p.x0[0], s0.y
    x_b = x_0 + u_b * c + 0.5 * p.h[0] * s
    x_c = p.x0[1] + side * p.gap
    theta1 = _hinge_angle(theta, x_b, x_c, u1, v1)
    upper = assembly.blocks[1]
    proxy = _carrying(upper, upper.m * G + assembly.top_load)
    params1 = dem_params(proxy, joint=joint, phi_deg=45.0)

    def pose(theta1):
        # block 1's centroid in block 0's frame, its corner sunk into the bed joint
        s1 = initial_state(params1, theta1 - theta)
        du, dv = p.x0[1] - p.x0[0] + s1.x, 0.5 * p.h[0] + s1.y
        c1, s_1 = jnp.cos(theta1), jnp.sin(theta1)
        miss = x_c - (x_0 + du * c + dv * s + 0.5 * p.h[1] * s_1)
        return du, dv, c1, s_1, miss

    for _ in range(2):  # Newton on C's position: the joints' sinks moved it (~1e-5 m)
        _, _, c1, s_1, miss = pose(theta1)
        theta1 = theta1 + miss / (v1 * c1 - u1 * s_1)
    du, dv, c1, s_1, _ = pose(theta1)
    zero = jnp.zeros(())
    n_fs = 1 if joint.face else joint.n_sub
    return AssemblyState(
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
    )


# ----------------------------------------------------------------------------- driver


@persistent_jit
def _run(
    p: AssemblyParams,
    st0: AssemblyState,
    ag,
    ag_v,
    dt,
    dt_out,
    n_in: int,
    save,
    throw,
    top,
    wall=None,
):
    """``top``: ``None``, or the top restraint's displacement [m] and velocity [m/s] relative
    to the base at the samples, linear between them as ``ag``; ``wall``: ``None`` (fixed
    return walls, or none), or a moving wall's ``(u_top, v_top)`` [m, m/s] likewise."""

    def nxt(a):
        return jnp.concatenate([a[1:], a[-1:]])

    ag_next, agv_next = nxt(ag), nxt(ag_v)
    if top is None:
        zeros = jnp.zeros_like(ag)
        top_xs = (zeros, zeros, zeros, zeros)
    else:
        top_xs = (top[0], nxt(top[0]), top[1], nxt(top[1]))
    moving = wall is not None
    work = moving and "energy" in save
    # the forces ride in the carry only when asked for (a static choice: no cost otherwise)
    forces = "forces" in save
    n_acc = 3 * p.n + (1 if work else 0)  # accelerations, then the wall's power, then forces
    wall_xs = () if not moving else (wall[0], nxt(wall[0]), wall[1], nxt(wall[1]))
    w_max = omega_max(p)
    unstable = dt > 2.0 / w_max * (1.0 + 1e-9)
    positive = jnp.concatenate([p.m, p.I_c, p.b, p.h, p.kn_line, p.hi - p.lo, p.tan_phi[None]])
    bad_input = ~(
        jnp.all(jnp.isfinite(positive))
        & jnp.all(positive > 0)
        & jnp.isfinite(p.beta)
        & (p.beta >= 0)
        & jnp.isfinite(p.gap)
        & (p.gap >= 0)
        & jnp.isfinite(p.top_load)
        & jnp.all(jnp.isfinite(ag))
        & jnp.all(jnp.isfinite(ag_v))
        & jnp.all(jnp.stack([jnp.all(jnp.isfinite(a)) for a in top_xs]))
    )
    if p.one_sided:
        bad_input = bad_input | ~(jnp.isfinite(p.wall_gap) & (p.wall_gap >= 0))
    if moving:
        bad_input = bad_input | ~jnp.all(jnp.stack([jnp.all(jnp.isfinite(a)) for a in wall]))

    def outer(carry, xs):
        st, overturned, status = carry[:3]
        a0, a1, v0, v1, u0, u1, w0, w1 = xs[:8]
        da, dv = (a1 - a0) / n_in, (v1 - v0) / n_in
        du, dw = (u1 - u0) / n_in, (w1 - w0) / n_in
        zero = jnp.zeros_like(a0)
        if moving:
            p0, p1, q0, q1 = xs[8:]
            dp, dq = (p1 - p0) / n_in, (q1 - q0) / n_in

        # one scan over the n_in substeps (one copy of the step in the program); the
        # accelerations of the first substep, at the sample time, travel in the carry (with
        # a moving wall, its power at the sample time and its work summed over the steps)
        def inner(c, _):
            s_, j, first = c[:3]
            tm = None if top is None else (u0 + j * du, w0 + j * dw)
            wm = (p0 + j * dp, q0 + j * dq) if moving else None
            s_, acc, power, rec = _step(
                p, s_, a0 + j * da, v0 + j * dv, dt, load=None, top_motion=tm, wall=wm
            )
            # scalars, not a stacked vector: XLA:CPU would build a vector element by element,
            # each element's fusion recomputing the step
            flat = [v for row in acc for v in row]
            if work:
                flat.append(power)
            if forces:
                flat += [*rec["normal"], *rec["shear"]]
                flat += [rec["restraint"]] if p.restrained else []
                flat += rec["wall"] if p.one_sided else []
            first = tuple(jnp.where(j == 0.0, v, f) for v, f in zip(flat, first))
            if work:
                return (s_, j + 1.0, first, c[3] + dt * power), None
            return (s_, j + 1.0, first), None

        n_forces = (2 * p.n + p.restrained + (p.n if p.one_sided else 0)) if forces else 0
        first0 = tuple(zero for _ in range(n_acc + n_forces))
        init = (st, zero, first0) + ((carry[3],) if work else ())
        done, _ = jax.lax.scan(inner, init, length=n_in)
        new, first = done[0], done[2]
        vel = [
            (
                st.vx[k] + 0.5 * dt * first[3 * k],
                st.vy[k] + 0.5 * dt * first[3 * k + 1],
                st.w[k] + 0.5 * dt * first[3 * k + 2],
            )
            for k in range(p.n)
        ]
        out = {
            "theta": jnp.stack(st.theta, axis=-1),
            "theta_dot": jnp.stack([v[2] for v in vel], axis=-1),
            "x": jnp.stack(st.x, axis=-1) - p.x0,
            "y": jnp.stack(st.y, axis=-1),
        }
        if "energy" in save:
            out["energy"] = _energy(p, st, vel, (p0, q0) if moving else None)
        if work:
            # as rockjax.simulate_dem: the steps' power x dt summed, half a step past the
            # sample (the constant half step of the first sample is taken off at the end)
            out["work_wall"] = carry[3] + 0.5 * dt * first[3 * p.n]
        if forces:
            # the forces of the sample's step (its state, the dashpots at the lagged
            # half-step velocity), as rockjax.simulate_dem records its base normal forces
            rec = first[n_acc:]
            n = p.n
            out["normal_forces"] = jnp.stack(rec[:n], axis=-1)
            out["shear_forces"] = jnp.stack(rec[n : 2 * n], axis=-1)
            if p.restrained:
                out["restraint_force"] = rec[2 * n]
            if p.one_sided:
                out["wall_forces"] = jnp.stack(rec[2 * n + p.restrained :], axis=-1)
        over = overturned | _collapsed(p, new)
        leaves = jax.tree_util.tree_leaves(new)
        bad = ~jnp.all(jnp.stack([jnp.all(jnp.isfinite(v)) for v in leaves]))
        status = jnp.where(
            status != STATUS_OK,
            status,
            jnp.where(unstable, STATUS_UNSTABLE, jnp.where(bad, STATUS_NONFINITE, STATUS_OK)),
        )
        keep = overturned | (status != STATUS_OK)
        new = jax.tree_util.tree_map(lambda a, b: jnp.where(keep, a, b), st, new)
        if work:
            return (new, over, status, jnp.where(keep, carry[3], done[3])), out
        return (new, over, status), out

    outer = jax.checkpoint(outer, prevent_cse=False)
    status0 = jnp.where(bad_input, STATUS_BAD_INPUT, STATUS_OK)
    carry0 = (st0, jnp.zeros((), bool), status0) + ((jnp.zeros(()),) if work else ())
    (st, overturned, status, *_), out = jax.lax.scan(
        outer, carry0, (ag, ag_next, ag_v, agv_next, *top_xs, *wall_xs)
    )
    work_wall = None
    if work:
        work_wall = out["work_wall"] - out["work_wall"][0]
    elif p.one_sided and "energy" in save:  # a fixed wall does no work
        work_wall = jnp.zeros_like(out["energy"])
    if throw:
        for code in (STATUS_BAD_INPUT, STATUS_UNSTABLE, STATUS_NONFINITE):
            msg = (
                f"rockjax.simulate_assembly: {STATUS_MESSAGES[code]}. "
                "Pass throw=False to get a per-run status instead."
            )
            out["theta"] = eqx.error_if(out["theta"], status == code, msg)
    return AssemblyResponse(
        t=jnp.arange(ag.shape[0]) * dt_out,
        theta=out["theta"],
        theta_dot=out["theta_dot"],
        x=out["x"],
        y=out["y"],
        overturned=overturned,
        status=status,
        theta_max=jnp.stack(st.theta_max),
        eta=p.eta,
        energy=out.get("energy"),
        dt=jnp.asarray(dt, float),
        work_wall=work_wall,
        normal_forces=out.get("normal_forces"),
        shear_forces=out.get("shear_forces"),
        restraint_force=out.get("restraint_force"),
        wall_forces=out.get("wall_forces"),
    )


def simulate_assembly(
    assembly: Assembly,
    motion: GroundMotion | None = None,
    *,
    beta=0.0,
    mode: str = "two_sided",
    gap=0.0,
    theta0=0.0,
    duration: float | None = None,
    dt: float | None = None,
    accuracy: float | None = None,
    joint: Joint = Joint(),
    phi_deg=None,
    save_dt: float | None = None,
    save: tuple[str, ...] = (),
    beta_max=None,
    throw: bool = True,
    support_motion: ShearBuilding | tuple | None = None,
    storey: int = 1,
    wall_motion=None,
) -> AssemblyResponse:
    """Simulate an assembly of rigid blocks on penalty joints under a ground motion and/or a
    free release (the DEM of :func:`rockjax.simulate_dem`, block by block).

    In a building (``support_motion=bldg``), the wall of storey ``storey`` stands on floor
    ``storey - 1`` (0 the ground) and its top restraint is held by floor ``storey``: the run
    is in the frame of the base floor (the ground acceleration is the base floor's absolute
    acceleration) and the restraint moves by the storey's drift (floor ``storey`` less floor
    ``storey - 1``, relative displacement and velocity of :meth:`rockjax.ShearBuilding.response`,
    linear between samples), docs/assemblies.md "Supports in a building".

    A facade (``mode="one_sided"``) leans on return walls: every block's back face (its -x
    face) meets a wall ``gap`` behind it with the joint's contact law, as the back face of
    :func:`rockjax.simulate_dem`'s facade (docs/assemblies.md, "Return walls"). The walls are
    fixed, or move with ``wall_motion`` as one rigid body: the line of the back faces at rest
    turned to ``theta_w = u_top / H`` (``H`` the stack's height) about block 0's toe (its heel
    for ``theta_w < 0``), as :func:`rockjax.simulate_dem` turns a block's wall.

    Args:
        assembly: The :class:`rockjax.assembly.Assembly`.
        motion: Ground motion (the supports, ground and top restraint, move with it); ``None``
            for free motion (then ``duration`` is required).
        beta: Stiffness-proportional Rayleigh damping coefficient [s], Eq. (1), all joints.
        mode: ``"two_sided"`` (default), or ``"one_sided"``: a facade whose blocks' back
            faces (-x) meet fixed return walls.
        gap: Distance between each block's back face at rest and the return wall [m]
            (one-sided only; the top restraint's clearance is ``Assembly.gap``).
        theta0: Initial rotation of block 0 about its pivot corner [rad], released from
            rest: the whole stack tilted rigidly (``top="free"``), or a restrained two-block
            wall in its hinge mechanism (the upper block turned about the bed joint's far end
            so that its top bears on the restraint); ``theta0 >= 0`` one-sided.
        duration: Length of the run [s]; default the record's (longer appends zeros).
        dt: Time step [s]; default :func:`stable_dt_assembly` (the accuracy rule of
            :func:`rockjax.stable_dt` on the stiffest mode of the whole assembly). The step
            used is the largest divisor of the output step not above ``dt``.
        accuracy: ``omega_max dt (1 + zeta)`` of the default step [-] (ignored with ``dt``);
            default that of :func:`rockjax.simulate_dem` for the ``mode``.
        joint: The joint of every interface, :class:`rockjax.Joint` (default the integrated
            face law; ``Joint(n_sub=2)`` the paper's corner sub-contacts).
        phi_deg: Friction angle of every interface [deg]; default 50 (two-sided) or 30
            (one-sided), as in :func:`rockjax.simulate_dem`.
        save_dt: Output interval for free motion [s] (default 0.002); with a record, its ``dt``.
        save: Extra outputs: ``"energy"`` (total mechanical energy [J]), ``"forces"``
            (the interfaces' normal and shear forces, the top restraint's and the return
            walls' forces [N]: :class:`AssemblyResponse`).
        beta_max: Largest ``beta`` to size the default step for, when ``beta`` is traced.
        throw: Raise (also inside ``jit``) if the run fails; if False, report ``status``.
        support_motion: A :class:`rockjax.ShearBuilding` whose floors carry the wall (needs
            ``motion``, the ground motion under the building); or a pair ``(u, v)`` of arrays,
            shape ``(time,)`` at the run's samples: the top restraint's displacement [m] and
            velocity [m/s] relative to the base, linear between samples (``top="restrained"``;
            ``motion`` is then the base's absolute acceleration, e.g. a floor's, and
            ``storey`` stays 1): a building's response computed once and reused, e.g. scaled
            with the record in an IDA; ``None``: the ground.
        storey: The storey the wall stands in (1-based, with ``support_motion``): base on
            floor ``storey - 1``, top restraint at floor ``storey``; ``n_storeys + 1`` for a
            wall on the roof (free top only).
        wall_motion: Return walls that move relative to the base (``mode="one_sided"``;
            None: fixed): a pair ``(u_top, v_top)`` of arrays [m], [m/s] with one value per
            record sample (the walls' displacement and velocity relative to the base at the
            stack's height ``H``, ``u_top > 0`` toward the facade; traceable), or what
            :func:`rockjax.wall_top_motion` accepts (a ``ShearBuilding``, the walls' absolute
            acceleration as a ``GroundMotion``, or ``(height, GroundMotion)`` pairs), taken
            at ``H``; as ``wall_motion`` of :func:`rockjax.simulate_dem`. With
            ``support_motion`` (a facade in a building): the same ``ShearBuilding`` (the
            walls move with the storey: the storey's drift interpolated linearly in height,
            ``(u_i - u_{i-1}) H / h_i`` relative to the base floor, and its rate;
            :func:`storey_supports`; not on the roof), or a pair relative to the base floor.

    Returns:
        An :class:`AssemblyResponse` with per-block ``theta``, ``x``, ``y`` (time x block);
        ``x`` relative to the base (the base floor in a building); with ``"energy"`` saved on
        return walls, ``work_wall`` (the walls' work [J]); with ``"forces"``,
        ``normal_forces``, ``shear_forces`` (time x interface), ``restraint_force`` and
        ``wall_forces`` [N].

    Raises:
        ValueError: on invalid input, with the value, its unit and the fix.
    """
    if isinstance(save, str):
        raise ValueError(
            f"save must be a tuple of output names, e.g. save=({save!r},); got save={save!r}."
        )
    for key in save:
        check_choice("save entry", key, SAVE_OPTIONS)
    check_choice("mode", mode, MODES)
    if phi_deg is None:
        phi_deg = 50.0 if mode == "two_sided" else 30.0
    p = assembly_params(assembly, beta, joint=joint, phi_deg=phi_deg, mode=mode, gap=gap)
    _check_theta0(theta0, assembly, mode)
    if wall_motion is not None and mode != "one_sided":
        raise ValueError(
            f"wall_motion (moving return walls) needs mode='one_sided' (a facade against its "
            f"return walls); got mode={mode!r}. Pass mode='one_sided', or drop wall_motion."
        )
    # walls that move with the building the facade stands in: solved with its supports
    with_building = check_walls_in_building(wall_motion, support_motion, storey)
    ag, ag_v, dt_out = prepare_motion(motion, duration, save_dt)
    wall = None
    if wall_motion is not None and not with_building:  # fixed walls: no wall arrays
        n_record = None if motion is None else np.shape(motion.ag)[0]
        wall = wall_arrays(wall_motion, motion, assembly.height, ag, dt_out, n_record)
    wall_height = assembly.height if with_building else None
    ag, top, *walls = _in_building(
        support_motion, storey, assembly, motion, ag, dt_out, wall_height
    )
    if with_building:
        wall = walls[0]
    accuracy = _check_accuracy(accuracy, joint, mode)
    limit, dt_default = _concrete_steps(p, assembly, beta_max, joint, dt, accuracy, mode)
    if dt is None:
        dt_target = dt_default
    else:
        check_positive("dt", dt, "s", "Or leave dt=None (chosen for accuracy).", scalar=True)
        if limit is not None and dt > limit * (1 + 1e-9):
            raise ValueError(
                f"dt={dt:.4g} s exceeds the explicit stability limit {limit:.4g} s of this "
                f"assembly. Use dt <= {limit:.4g} s or leave dt=None (default "
                f"{dt_default:.4g} s, chosen for accuracy)."
            )
        dt_target = float(dt)
    n_in = max(1, math.ceil(dt_out / dt_target - 1e-9))
    step = dt_out / n_in
    st0 = initial_assembly_state(assembly, p, theta0, joint)
    if not is_batched(p, st0, ag, ag_v, top, wall):
        p = dataclasses.replace(p, single_history=True)
    # the steps as arrays: traced, so a new step does not recompile (n_in is static)
    return _run(
        p, st0, ag, ag_v, np.asarray(step), np.asarray(dt_out), n_in, tuple(save), throw, top, wall
    )


def _in_building(building, storey, assembly: Assembly, motion, ag, dt_out, wall_height=None):
    """The base floor's absolute acceleration [m/s^2] and the top restraint's motion
    relative to it (``(u [m], v [m/s])`` or ``None``), from the building's exact response
    to the (padded) ground acceleration ``ag``; with ``wall_height`` [m] (a building), also
    the return walls' ``(u_top, v_top)`` relative to the base floor at that height
    (:func:`storey_supports`)."""
    if building is None:
        if storey != 1:
            raise ValueError(
                f"storey={storey!r} needs support_motion=<rockjax.ShearBuilding> (the floors "
                "that carry the wall); leave storey=1 for a wall on the ground."
            )
        return ag, None
    if is_array_pair(building):
        return ag, _restraint_arrays(building, storey, assembly, ag)
    if not isinstance(building, ShearBuilding):
        raise ValueError(
            f"support_motion must be a rockjax.ShearBuilding (the floors carrying the wall) or "
            f"a pair (u, v) of arrays, the top restraint's motion relative to the base [m, "
            f"m/s]; got {type(building).__name__}. Build one with rj.ShearBuilding.uniform(...)."
        )
    if motion is None:
        raise ValueError(
            "support_motion needs motion=<rockjax.GroundMotion>, the ground motion under the "
            "building (its floors move only under a record)."
        )
    check_storey(building, storey, assembly.top)
    restrained = assembly.top == "restrained"
    return storey_supports(building, ag, dt_out, storey, restrained, wall_height=wall_height)


def check_walls_in_building(wall_motion, support_motion, storey) -> bool:
    """Whether the return walls move with the building the wall stands in
    (``wall_motion=bldg, support_motion=bldg``: their motion is the storey's drift,
    :func:`storey_supports`); raises ValueError, naming the argument and the fix, for the
    combinations that do not define the walls' motion relative to the base floor. Without
    ``support_motion`` (or ``wall_motion``): False, nothing checked."""
    if wall_motion is None or support_motion is None:
        return False
    if is_array_pair(wall_motion):
        return False  # (u_top, v_top) relative to the base floor, as given
    if not isinstance(wall_motion, ShearBuilding):
        raise ValueError(
            "wall_motion with support_motion (a wall standing in a building) must be the "
            "same rockjax.ShearBuilding as support_motion (the walls move with the storey), or "
            "a pair (u_top, v_top) of arrays relative to the base floor [m, m/s]; got "
            f"{type(wall_motion).__name__}. Accelerations are relative to the ground, not to "
            "the base floor: pass wall_motion=support_motion or the pair."
        )
    if not isinstance(support_motion, ShearBuilding):
        raise ValueError(
            "wall_motion=<ShearBuilding> needs support_motion=<the same ShearBuilding>: with "
            "support_motion=(u, v), motion is the base floor's acceleration and the building "
            "cannot be solved from it. Pass wall_motion=(u_top, v_top), the walls' motion "
            "relative to the base floor at the facade's height [m, m/s]."
        )
    if not _same_building(wall_motion, support_motion):
        raise ValueError(
            "wall_motion and support_motion must be the same rockjax.ShearBuilding (the "
            "return walls move with the storey the facade stands in); got two different "
            "buildings. Pass wall_motion=support_motion, or wall_motion=(u_top, v_top) "
            "relative to the base floor."
        )
    if storey == support_motion.n_storeys + 1:
        raise ValueError(
            f"wall_motion=<ShearBuilding> moves the return walls with the storey the facade "
            f"stands in; on the roof (storey={storey}) no storey is above it. Drop wall_motion "
            "(walls fixed to the roof), or give wall_motion=(u_top, v_top) relative to it."
        )
    return True


def _same_building(a: ShearBuilding, b: ShearBuilding) -> bool:
    if a is b:
        return True
    try:
        return bool(eqx.tree_equal(a, b))
    except (jax.errors.ConcretizationTypeError, jax.errors.TracerBoolConversionError):
        return False  # traced buildings: only the same object is known to be the same


def check_storey(building: ShearBuilding, storey, top: str) -> int:
    """``storey`` checked for a wall with a ``top`` ("free" or "restrained") in ``building``:
    an integer, 1 to ``n_storeys`` for a restrained top (it needs the floor above), up to
    ``n_storeys + 1`` (the roof) for a free one. Raises ValueError with the fix."""
    n = building.n_storeys
    top_max = n if top == "restrained" else n + 1
    if not (isinstance(storey, int) and not isinstance(storey, bool) and 1 <= storey <= top_max):
        raise ValueError(
            f"storey (1-based storey the wall stands in) must be an integer in 1..{top_max} "
            f"for this {n}-storey building and a {top} top; got storey={storey!r}. "
            f"Storey i stands on floor i - 1 (0 the ground); a restrained top needs floor i."
        )
    return storey


def storey_supports(
    building: ShearBuilding, ag, dt, storey: int, restrained: bool, *, wall_height=None
):
    """What a wall in storey ``storey`` of ``building`` stands on and is held by, under the
    ground acceleration ``ag`` [m/s^2] at step ``dt`` [s]: the base floor's absolute
    acceleration [m/s^2] (``ag`` itself for storey 1) and, for a restrained top, the top
    floor's displacement [m] and velocity [m/s] relative to the base floor (else None), from
    the building's exact response (:meth:`rockjax.ShearBuilding.response`).

    With ``wall_height`` [m] (a facade's height ``H``), a third value: the return walls'
    ``(u_top, v_top)`` [m, m/s] relative to the base floor at ``H`` above it. A shear
    building's storey deforms linearly between its floors, so the walls' displacement is the
    floors' interpolated linearly in height, ``(u_i - u_{i-1}) H / h_i`` within storey ``i``
    of height ``h_i`` (above floor ``i``, the next storey's; above the roof, the roof's), and
    their velocity likewise."""
    resp = building.response(GroundMotion(ag=ag, dt=dt))
    base = storey - 1
    ag_base = ag if base == 0 else resp.acceleration[base - 1]
    top = None
    if restrained:
        u, v = resp.displacement[storey - 1], resp.velocity[storey - 1]
        if base > 0:
            u, v = u - resp.displacement[base - 1], v - resp.velocity[base - 1]
        top = (u, v)
    if wall_height is None:
        return ag_base, top
    nodes = jnp.concatenate([jnp.zeros(1), jnp.cumsum(building.storey_heights)])
    z = nodes[base] + jnp.asarray(wall_height, float)
    # the weights of the floors (the ground first) in the piecewise-linear profile at z
    weights = jax.vmap(lambda f: jnp.interp(z, nodes, f))(jnp.eye(nodes.shape[0]))
    weights = weights.at[base].add(-1.0)  # relative to the base floor
    u_w, v_w = weights[1:] @ resp.displacement, weights[1:] @ resp.velocity
    return ag_base, top, (u_w, v_w)


def _restraint_arrays(pair, storey, assembly: Assembly, ag):
    """The top restraint's ``(u [m], v [m/s])`` relative to the base, given as arrays at the
    run's samples (``support_motion=(u, v)``), checked."""
    if storey not in (1, None):  # None: rj.simulate_dem's default
        raise ValueError(
            f"storey={storey!r} applies to support_motion=<rockjax.ShearBuilding>; with "
            "support_motion=(u, v) (the restraint's motion relative to the base) the base is "
            "motion itself: leave storey=1."
        )
    if assembly.top != "restrained":
        raise ValueError(
            "support_motion=(u, v) moves the top restraint and needs an Assembly with "
            "top='restrained'; got top='free'. Drop support_motion for a free top (the base "
            "is motion)."
        )
    check_series_pair(
        "support_motion",
        ("u [m]", "v [m/s]"),
        pair,
        ag.shape[0],
        "Sample it at motion's dt over the run's duration (pad the record first).",
    )
    check_wall_rotation(pair[0], assembly.height, "support_motion", ("u", "v"))
    return tuple(jnp.asarray(a, float) for a in pair)


def _carrying(blk: Block, weight) -> Block:
    """A block of ``blk``'s shape and joint whose own weight is ``weight`` [N]: its joint then
    settles as ``blk``'s under that load (the equilibrium sink of ``dem.initial_state``)."""
    return Block(
        b=blk.b,
        h=blk.h,
        length=blk.length,
        rho=weight / (G * blk.b * blk.h * blk.length),
        E=blk.E,
        nu=blk.nu,
    )


def _check_theta0(theta0, assembly: Assembly, mode: str = "two_sided"):
    check_scalar("theta0", theta0, "rad", "e.g. theta0=0.01.")
    th = concrete(theta0)
    if assembly.layout == "row" and mode == "one_sided":
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
    if mode == "one_sided" and th < 0:
        raise ValueError(
            f"theta0={float(th):.4g} rad: a facade (mode='one_sided') leans on its return walls "
            "at -x and can only rotate outward, theta0 >= 0."
        )
    if th != 0.0 and assembly.top == "restrained":
        _check_hinge_theta0(float(th), assembly)
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
    if not np.isfinite(th) or abs(th) >= eta_stack:
        raise ValueError(
            f"theta0={float(th):.4g} rad must satisfy |theta0| < {eta_stack:.4g} rad, the "
            "overturning angle of the whole stack about its base corner. Try half of it."
        )


def _check_hinge_theta0(th: float, assembly: Assembly):
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
    u_a, u_b, _, u1, v1 = (float(v) for v in _hinge_geometry(assembly, side))
    h0 = float(blocks[0].h)
    x_b = float(assembly.x_offset[0]) + u_a + (u_b - u_a) * math.cos(th) + h0 * math.sin(th)
    x_c = float(assembly.x_offset[1]) + side * float(assembly.gap)
    th1 = float(_hinge_angle(th, x_b, x_c, u1, v1))
    eta0, eta1 = (math.atan2(float(b.b), float(b.h)) for b in blocks)
    if not (np.isfinite(th1) and abs(th) < eta0 and abs(th1) < eta1):
        raise ValueError(
            f"theta0={th:.4g} rad is beyond the hinge mechanism of this restrained wall "
            f"(lower block eta = {eta0:.4g} rad; the upper block would turn by {th1:.4g} rad, "
            f"eta = {eta1:.4g} rad). Try a tenth of eta."
        )


def _concrete_steps(p, assembly, beta_max, joint, dt, accuracy, mode):
    if beta_max is not None:
        try:
            with jax.ensure_compile_time_eval():
                p_max = assembly_params(assembly, beta_max, joint=joint, phi_deg=45.0, mode=mode)
                return tuple(map(float, _steps_jit(p_max, accuracy)))
        except (jax.errors.ConcretizationTypeError, jax.errors.TracerArrayConversionError):
            raise ValueError(
                "beta_max cannot size the time step when the assembly itself is traced; pass "
                "dt=stable_dt_assembly(assembly, beta_max) computed outside the transform."
            ) from None
    try:
        return tuple(map(float, _steps_jit(p, accuracy)))
    except (jax.errors.ConcretizationTypeError, jax.errors.TracerArrayConversionError):
        if dt is not None:
            return None, None
        raise ValueError(
            "simulate_assembly was called with traced inputs (inside jit/vmap/grad), so the "
            "time step cannot be chosen automatically. Pass dt=stable_dt_assembly(assembly, "
            "beta_max) computed outside the transform, or beta_max=<largest beta> [s]."
        ) from None
