"""The DEM model: a rigid block (3 DOF) on a rigid base with penalty sub-contacts, stepped by
explicit central differences inside ``jax.lax.scan``.

Model (paper Section 2): the joint under the base face (:class:`rockjax.Joint`), by default
the contact law integrated over the face (``Joint()``, the ``n_sub -> infinity`` limit of the
sub-contacts: a continuous Winkler joint with one resultant shear spring per face; see
:func:`_face` and docs/theory.md, "Integrated face contact"), or ``n_sub`` >= 2 sub-contact
points (trapezoidal tributary areas; ``Joint(n_sub=2)`` puts them at the corners, the paper's
model); normal stiffness ``j_kn = E/h`` and shear stiffness ``j_ks = j_kn / (2 (1 + nu))`` per
unit area, Mohr-Coulomb with zero tension and cohesion, stiffness-proportional Rayleigh
damping ``beta`` as a dashpot ``c = beta k`` on the closed joint (see :mod:`rockjax.contact`
for the two damping conventions). A facade (``mode="one_sided"``) also has a rigid return
wall at its -x face, a distance ``gap`` behind it, meeting the block's back face through the
same joint; the wall may move relative to the base (``simulate_dem(..., wall_motion=...)``: the
block's own back face rocked rigidly to ``theta_w = u_top / h``, about its toe for
``theta_w > 0``, its heel otherwise, so the contact line is
``x = -b/2 - gap - d (1 / cos(theta_w) - 1) + y tan(theta_w)``, ``d = b`` or 0, and the face
rises with that rotation; docs/pushover.md "Moving return walls"). A few
sub-contacts differ from the converged joint by 1e-2 in the restitution of a parapet and by a
factor of two in a facade's rebound (docs/verification.md).

Integration: central differences with centred dashpots (the dashpot force uses the velocity
at the step, the mean of the two half-step velocities, so the scheme is second-order accurate;
one 3 x 3 solve per step). Its stability limit is ``dt <= 2 / omega_max`` whatever ``beta``,
where ``omega_max`` is the highest frequency of the block on all its springs closed (an upper
bound for any subset of closed contacts). The default step is chosen for accuracy:
``dt = accuracy / (omega_max (1 + zeta))``, ``zeta = beta omega_max / 2``, ``accuracy`` from
:data:`DT_ACCURACY` (the derivation and the convergence study are in docs/theory.md and
docs/verification.md), capped at ``DT_SAFETY`` times the stability limit and rounded down to
divide the record step, so the ground motion is sampled exactly at the record samples and
interpolated linearly in between.

Scan layout: an outer scan over record samples (one output sample each, the carry
checkpointed for reverse mode) and an inner scan over the substeps between two samples.

Compile once per bucket of record lengths (:mod:`rockjax.compilation`): called with concrete
inputs, :func:`simulate_dem` pads the record (and a moving wall's history) to
:func:`padded_length` samples, repeating the last sample, and passes the true length as data;
the outer scan then runs in chunks, skipping the chunks past the true length and freezing the
state from there (:func:`run_prepared` with ``n``), and the outputs are cut on the host.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._checks import (
    GAP_HINT,
    GAP_NEEDS_ONE_SIDED,
    check_choice,
    check_gap,
    check_kind,
    check_nonnegative,
    check_positive,
    check_samples,
    check_scalar,
    concrete,
)
from ._fusion import computed_once, one_computation, sum_together
from .assembly import Assembly
from .block import Block
from .compilation import (
    batch_size,
    bucket_length,
    is_traced,
    notice_once,
    pad_to,
    persistent_jit,
)
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
from .motion import GroundMotion
from .response import (
    STATUS_BAD_INPUT,
    STATUS_MESSAGES,
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_UNSTABLE,
    Response,
)
from .walls import wall_arrays, wall_line, wall_pivot, wall_rise

MODES = ("two_sided", "one_sided")

DT_SAFETY = 0.5
"""Largest fraction of the explicit stability limit a default step may take."""

DT_ACCURACY = {"two_sided": 1.0, "one_sided": 0.35}
"""Default ``accuracy`` per mode for the integrated face law (``n_sub="exact"``): the step is
``accuracy / (omega_max (1 + zeta))`` [s]. With these the first-impact restitution of parapets
with h/b 4-24 at beta up to 1.5 beta_DeJong is within 1e-3 of its dt -> 0 limit (measured
4.6e-4), and the rebound peaks of damped facades above 1 % of eta within 2 % of a 16x finer
step (measured 1.8 %; undamped, bounces 1-2 within 0.5 %, while a third undamped bounce of
0.2 x 1.5 m is 3.7 % off: the contact modes ring; docs/verification.md, "DEM time step:
convergence"). Facades need the finer step for their later, small bounces (at 0.7: bounce 2
of 0.11 x 2.4 m undamped 2.7 % off, of 0.2 x 1.5 m at beta_Hcrit 4 %)."""

DT_ACCURACY_SUB = {"two_sided": 0.5, "one_sided": 0.35}
"""Default ``accuracy`` per mode with integer ``n_sub`` (point sub-contacts: a point's force
switches on whole as it closes, so parapets need half the face law's step)."""

DEFAULT_SAVE_DT = 0.002
"""Output interval [s] for free rocking (no record)."""

SAVE_OPTIONS = ("energy", "forces")

SCAN_CHUNK = 256
"""Samples per chunk of the outer scan when a record is padded to its bucket
(:func:`run_prepared` with ``n``): a chunk wholly past the true length is skipped, so a record
padded from 2 000 to 32 768 samples runs 120 empty chunks instead of 30 768 samples."""


POINTWISE_BATCH = 128
"""Batches (``vmap``) of this many lanes or more sum the face law's Gauss points one by one:
under ``vmap`` the single reduction works on ``(batch, points)`` rows of six or eight points,
slower than per-point vectors at 512-8192 lanes and as fast at 64; smaller batches (the
calibration's, of 1-9 lanes) keep the reduction, which compiles and runs faster there
(docs/benchmarks.md, "One reduction per face")."""


class DemParams(eqx.Module):
    """Everything the DEM step needs, as arrays (built by :func:`dem_params`)."""

    m: jax.Array
    I_c: jax.Array
    b: jax.Array
    h: jax.Array
    eta: jax.Array
    beta: jax.Array
    tan_phi: jax.Array
    gap: jax.Array
    u_base: jax.Array  # body coordinates of the base sub-contacts [m], shape (n_sub,)
    v_base: jax.Array
    kn_base: jax.Array  # spring stiffnesses [N/m], shape (n_sub,)
    ks_base: jax.Array
    u_wall: jax.Array  # back-face sub-contacts (one-sided only), shape (n_wall,)
    v_wall: jax.Array
    kn_wall: jax.Array
    ks_wall: jax.Array
    kn_line: jax.Array  # joint stiffness per unit face length, j_kn * length [N/m^2]
    ks_line: jax.Array
    dashpot: str = eqx.field(static=True)
    onset: str = eqx.field(static=True, default="sub_step")
    face: bool = eqx.field(static=True, default=False)  # the integrated face law (n_sub="exact")
    # one history outside any transform: the contact forces are computed as one XLA
    # computation (docs/benchmarks.md, "One history")
    single_history: bool = eqx.field(static=True, default=False)
    # a large batch (vmap, POINTWISE_BATCH lanes or more): the face law sums its points one
    # by one (docs/benchmarks.md, "One reduction per face")
    pointwise_sums: bool = eqx.field(static=True, default=False)


class DemState(eqx.Module):
    """Central-difference state: positions at step n, velocities at step n - 1/2.

    ``x, y`` locate the centroid in the base frame [m] (the base surface is ``y = 0``, the
    block's rest position is ``x = 0``); ``theta`` [rad] with ``c, s = cos, sin(theta)``;
    ``vx, vy`` [m/s]; ``w`` [rad/s]; ``fs_base``, ``fs_wall``: shear spring force per
    sub-contact [N] (one per face with ``n_sub="exact"``); ``theta_max``, ``d_max``: running
    maxima of ``|theta|`` and ``|d|``.

    The outer scan (one step per record sample) carries the state packed in one vector (see
    :func:`_pack`) for its freeze and finiteness checks; the inner scan over the substeps
    carries the fields themselves, which XLA:CPU compiles to ~200 arithmetic ops per step.
    """

    x: jax.Array
    y: jax.Array
    c: jax.Array
    s: jax.Array
    vx: jax.Array
    vy: jax.Array
    w: jax.Array
    theta: jax.Array
    theta_max: jax.Array
    d_max: jax.Array
    fs_base: tuple
    fs_wall: tuple


_SCALARS = ("x", "y", "c", "s", "vx", "vy", "w", "theta", "theta_max", "d_max")


def _pack(state: DemState):
    parts = [getattr(state, k) for k in _SCALARS] + list(state.fs_base) + list(state.fs_wall)
    return jnp.stack(parts, axis=-1)


def _unpack(z, n_base: int, n_wall: int) -> DemState:
    k = len(_SCALARS)
    vals = {name: z[..., i] for i, name in enumerate(_SCALARS)}
    fs_base = tuple(z[..., k + i] for i in range(n_base))
    fs_wall = tuple(z[..., k + n_base + j] for j in range(n_wall))
    return DemState(**vals, fs_base=fs_base, fs_wall=fs_wall)


def _trapezoid_areas(n: int, width, length):
    w = np.ones(n)
    w[0] = w[-1] = 0.5
    return jnp.asarray(w) * width * length / (n - 1)


def dem_params(
    block: Block,
    beta=0.0,
    *,
    mode: str = "two_sided",
    gap=0.0,
    joint: Joint = Joint(),
    phi_deg=None,
) -> DemParams:
    """Collect the block, interface and damping into a :class:`DemParams` (traceable)."""
    check_choice("mode", mode, MODES)
    _check_joint(joint)
    check_nonnegative(
        "beta", beta, "s", "beta is the stiffness-proportional Rayleigh coefficient.", scalar=True
    )
    check_gap(gap, used=mode == "one_sided", unused=GAP_NEEDS_ONE_SIDED, hint=GAP_HINT)
    if phi_deg is None:
        phi_deg = 50.0 if mode == "two_sided" else 30.0
    phi = concrete(phi_deg)
    if phi is not None and not (0.0 < phi < 90.0):
        raise ValueError(f"phi_deg (friction angle, degrees) must be in (0, 90); got {phi_deg}.")
    return _build_params(block, beta, gap, phi_deg, mode=mode, joint=joint)


def _check_joint(joint):
    if not isinstance(joint, Joint):
        raise TypeError(
            f"joint must be a rockjax.Joint, e.g. rj.Joint(n_sub=2); got {type(joint).__name__}."
        )


# Compiled: one call instead of ~40 eager ops (~1.5 ms a call; docs/benchmarks.md).
@jax.jit(static_argnames=("mode", "joint"))
def _build_params(block: Block, beta, gap, phi_deg, *, mode: str, joint: Joint):
    b, h = jnp.asarray(block.b, float), jnp.asarray(block.h, float)
    face, n_sub = joint.face, joint.n_sub
    if face:
        # the two-point Gauss rule of the face: its springs give the all-closed stiffness
        # matrix of the continuous joint exactly (omega_max, the settlement at rest)
        s = jnp.array([-0.5, 0.5]) / math.sqrt(3.0)
        area_base = 0.5 * b * block.length * jnp.ones(2)
        area_wall = 0.5 * h * block.length * jnp.ones(2)
    else:
        s = jnp.linspace(-0.5, 0.5, n_sub)
        area_base = _trapezoid_areas(n_sub, b, block.length)
        area_wall = _trapezoid_areas(n_sub, h, block.length)
    if mode == "one_sided":
        u_wall = -0.5 * b * jnp.ones(s.shape[0])
        v_wall = s * h
    else:
        u_wall = v_wall = area_wall = jnp.zeros(0)
    return DemParams(
        m=jnp.asarray(block.m, float),
        I_c=jnp.asarray(block.I_c, float),
        b=b,
        h=h,
        eta=jnp.asarray(block.eta, float),
        beta=jnp.asarray(beta, float),
        tan_phi=jnp.tan(jnp.deg2rad(jnp.asarray(phi_deg, float))),
        gap=jnp.asarray(gap, float),
        u_base=s * b,
        v_base=-0.5 * h * jnp.ones(s.shape[0]),
        kn_base=block.j_kn * area_base,
        ks_base=block.j_ks * area_base,
        u_wall=u_wall,
        v_wall=v_wall,
        kn_wall=block.j_kn * area_wall,
        ks_wall=block.j_ks * area_wall,
        kn_line=jnp.asarray(block.j_kn * block.length, float),
        ks_line=jnp.asarray(block.j_ks * block.length, float),
        dashpot=joint.dashpot,
        onset=joint.onset,
        face=face,
    )


def omega_max(params: DemParams):
    """Highest circular frequency [rad/s] of the block with every spring closed (at theta=0).

    Every subset of closed contacts has a smaller stiffness matrix (in the PSD order), so this
    bounds the frequency of any contact state.
    """
    one = jnp.ones_like(params.u_base)
    zero = jnp.zeros_like(params.u_base)
    # Jacobians of the point motions w.r.t. (x, y, theta), theta clockwise-positive.
    jn_base = jnp.stack([zero, one, -params.u_base], axis=-1)  # vertical motion
    js_base = jnp.stack([one, zero, params.v_base], axis=-1)  # horizontal motion
    k = jnp.einsum("i,ij,ik->jk", params.kn_base, jn_base, jn_base)
    k = k + jnp.einsum("i,ij,ik->jk", params.ks_base, js_base, js_base)
    if params.u_wall.shape[0]:
        onew = jnp.ones_like(params.u_wall)
        zerow = jnp.zeros_like(params.u_wall)
        jn_wall = jnp.stack([onew, zerow, params.v_wall], axis=-1)
        js_wall = jnp.stack([zerow, onew, -params.u_wall], axis=-1)
        k = k + jnp.einsum("i,ij,ik->jk", params.kn_wall, jn_wall, jn_wall)
        k = k + jnp.einsum("i,ij,ik->jk", params.ks_wall, js_wall, js_wall)
    minv_sqrt = 1.0 / jnp.sqrt(jnp.stack([params.m, params.m, params.I_c]))
    a = k * minv_sqrt[:, None] * minv_sqrt[None, :]
    return jnp.sqrt(jnp.max(jnp.linalg.eigvalsh(a)))


@jax.jit
def critical_dt(params: DemParams):
    """Stability limit [s] of central differences with centred dashpots: ``2 / omega_max``
    (damping does not lower it)."""
    return 2.0 / omega_max(params)


@jax.jit
def default_step(params: DemParams, accuracy):
    """The default step [s] before rounding: ``accuracy / (omega_max (1 + zeta))``,
    ``zeta = beta omega_max / 2``, at most ``DT_SAFETY * critical_dt(params)``.

    The step resolves the stiffest contact mode (``omega_max dt = accuracy`` at ``beta = 0``:
    central differences err by ``(omega dt)^2 / 24`` in its frequency) and, when that mode is
    overdamped, the relaxation time ``~1 / (2 zeta omega_max)`` of its dashpot, which the
    centred (trapezoidal) dashpot resolves only while ``2 zeta omega_max dt`` is small. The
    impact velocity drops out: the penalty contact is linear, so the penetration and the
    onset band scale together with it.
    """
    return _steps(params, accuracy)[1]


def _steps(params: DemParams, accuracy):
    """``(critical_dt, default_step)`` from one eigenvalue solve."""
    w = omega_max(params)
    zeta = 0.5 * params.beta * w
    return 2.0 / w, jnp.minimum(accuracy / (w * (1.0 + zeta)), DT_SAFETY * 2.0 / w)


_steps_program = persistent_jit(_steps)


def _steps_jit(params: DemParams, accuracy):
    """:func:`_steps` compiled once for every block and accuracy, and kept on disk with the
    persistent cache (:func:`rockjax.compilation.persistent_jit`)."""
    return _steps_program(params, np.float64(accuracy))


def stable_dt(
    block: Block,
    beta=0.0,
    *,
    mode: str = "two_sided",
    gap=0.0,
    joint: Joint = Joint(),
    accuracy: float | None = None,
) -> float:
    """The default DEM time step [s]: stable, and chosen for accuracy (before rounding to
    divide the record step).

    ``accuracy / (omega_max (1 + zeta))`` with ``zeta = beta omega_max / 2``, at most
    ``DT_SAFETY`` times the stability limit ``2 / omega_max`` (see :func:`default_step`,
    docs/theory.md "Time stepping"). It decreases with ``beta``, so the step for the largest
    ``beta`` of a sweep serves them all. Use it to fix the step outside a transform and pass it
    as ``simulate_dem(..., dt=...)`` inside ``jit``/``vmap``/``grad``.

    Args:
        block: The block.
        beta: Stiffness-proportional damping coefficient [s], Eq. (1).
        mode: ``"two_sided"`` (parapet) or ``"one_sided"`` (facade).
        gap: Facade gap [m] (does not change the step).
        joint: The contact joint (:class:`rockjax.Joint`; default the integrated face law).
        accuracy: ``omega_max dt (1 + zeta)`` [-]; default ``DT_ACCURACY[mode]`` (1.0 for
            parapets, 0.35 for facades; 0.5 for parapets with integer ``n_sub``: first-impact ``e``
            within 1e-3 of its converged value, facade rebound peaks within 2 %;
            docs/verification.md). Smaller is finer; values
            above ``2 DT_SAFETY / (1 + zeta)`` give the stability-based step.
    """
    params = dem_params(block, beta, mode=mode, gap=gap, joint=joint)
    accuracy = _check_accuracy(accuracy, mode, joint)
    return float(_steps_jit(params, accuracy)[1])


def _check_accuracy(accuracy, mode, joint):
    table = DT_ACCURACY if joint.face else DT_ACCURACY_SUB
    default = table.get(mode, table["two_sided"])
    if accuracy is None:
        return default
    if not (isinstance(accuracy, (int, float)) and np.isfinite(accuracy) and accuracy > 0):
        raise ValueError(
            f"accuracy (omega_max dt (1 + zeta), dimensionless) must be a positive float; got "
            f"accuracy={accuracy!r}. Leave accuracy=None for the default ({default}); smaller "
            "is finer."
        )
    return float(accuracy)


def _point_kinematics(state: DemState, u, v, c, s):
    """Offset from the centroid, position and velocity of the body point (u, v) [m, m/s]."""
    rx = u * c + v * s
    ry = -u * s + v * c
    return rx, ry, state.x + rx, state.y + ry, state.vx + state.w * ry, state.vy - state.w * rx


# The contact loops below run over Python scalars (n_sub is static and small), so one step is
# pure elementwise code with no reductions or stacking: XLA fuses it into few kernels, and
# under vmap every operation is a single elementwise pass over the batch.


def _contact_forces(params: DemParams, state: DemState, dt, c, s, wall=None):
    """Resultant contact force and clockwise moment on the block (dashpots at the lagged
    half-step velocity), the new shear springs, the dashpot matrix ``C`` in the generalised
    coordinates ``(x, y, theta)``: its entries ``(Cxx, Cyy, Cxt, Cyt, Ctt)`` (``Cxy = 0``), and
    the power of the return wall [W] (see :func:`_wall_line`; ``wall`` = ``(u_top, v_top)``)."""
    fx = fy = mom = 0.0
    cxx = cyy = cxt = cyt = ctt = 0.0
    fn_base, fs_base = [], []
    dt_onset = dt if params.onset == "sub_step" else None
    clipped = params.dashpot == "clipped"
    for i in range(len(state.fs_base)):
        u, v = params.u_base[i], params.v_base[i]
        rx, ry, _, y_pt, xd_pt, yd_pt = _point_kinematics(state, u, v, c, s)
        fn, fn_el, frac = normal_force(
            -y_pt, -yd_pt, params.kn_base[i], params.beta, params.dashpot, dt_onset
        )
        ft, fs, w_s = shear_force(
            state.fs_base[i], xd_pt, dt, params.ks_base[i], fn_el, params.tan_phi, params.beta, frac
        )
        # the shear dashpot, off where the contact slides: its weight depends on the state and
        # is read by the force and the dashpot matrix, so both are computed once
        ft, c_s = computed_once(ft, w_s * params.beta * params.ks_base[i])
        fx, fy, mom = fx + ft, fy + fn, mom + (ry * ft - rx * fn)
        fn_base.append(fn)
        fs_base.append(fs)
        # vertical point velocity = J_y . (vx, vy, w) with J_y = (0, 1, -rx); horizontal J_x = (1, 0, ry)
        c_n = frac * params.beta * params.kn_base[i]
        if clipped:  # a clipped dashpot acts only where the total force is compressive
            c_n = jnp.where(fn > 0, c_n, 0.0)
        cyy, cyt, ctt = cyy + c_n, cyt - c_n * rx, ctt + c_n * rx * rx
        cxx, cxt, ctt = cxx + c_s, cxt + c_s * ry, ctt + c_s * ry * ry
    fs_wall = []
    power = 0.0
    for j in range(len(state.fs_wall)):
        u, v = params.u_wall[j], params.v_wall[j]
        rx, ry, x_pt, y_pt, xd_pt, yd_pt = _point_kinematics(state, u, v, c, s)
        delta, delta_dot, slope, wall_v, rise = _wall_line(params, wall, x_pt, y_pt, xd_pt, yd_pt)
        fn, fn_el, frac = normal_force(
            delta, delta_dot, params.kn_wall[j], params.beta, params.dashpot, dt_onset
        )
        slip = yd_pt if wall is None else yd_pt - rise
        ft, fs, w_s = shear_force(
            state.fs_wall[j], slip, dt, params.ks_wall[j], fn_el, params.tan_phi, params.beta, frac
        )
        ft, c_s = computed_once(ft, w_s * params.beta * params.ks_wall[j])
        fx, fy, mom = fx + fn, fy + ft, mom + (ry * fn - rx * ft)
        if wall is not None:  # the inclined wall's normal (1, -slope): a vertical component
            fy, mom = fy - slope * fn, mom + rx * slope * fn
            power = power + fn * wall_v + ft * rise
        fs_wall.append(fs)
        c_n = frac * params.beta * params.kn_wall[j]
        if clipped:
            c_n = jnp.where(fn > 0, c_n, 0.0)
        cxx, cxt, ctt = cxx + c_n, cxt + c_n * ry, ctt + c_n * ry * ry
        cyy, cyt, ctt = cyy + c_s, cyt - c_s * rx, ctt + c_s * rx * rx
    damping = (cxx, cyy, cxt, cyt, ctt)
    return fx, fy, mom, tuple(fn_base), tuple(fs_base), tuple(fs_wall), damping, power


class _WallFrame(NamedTuple):
    """A moving return wall at one step, computed once (:func:`_wall_frame`)."""

    x0: Any  # the contact line x = x0 + slope y [m]
    slope: Any  # [-]
    x0_dot: Any  # [m/s]
    slope_dot: Any  # [1/s]
    x_pivot: Any  # the pivot the wall turns about [m]
    rate: Any  # theta_w' [rad/s]


def _wall_frame(params: DemParams, wall):
    """The return wall's contact line ``x = x0 + slope y``, its rates ``(x0', slope')``
    [m, -, m/s, 1/s], its pivot and rotation rate, from ``wall = (u_top, v_top)`` (a
    :class:`_WallFrame` is returned as it is; None: a fixed wall, returned as None).

    The line is the back face of the block rocked rigidly to ``theta_w = u_top / h``, moved
    back by ``gap``: turned about its toe ``(b/2, 0)`` for ``theta_w > 0`` (the heel goes to
    ``(b/2 - b cos theta_w, b sin theta_w)``), about its heel for ``theta_w < 0``
    (:func:`rockjax.walls.wall_line` with ``d = b`` or 0). A block riding on the wall with
    ``theta = theta_w`` touches it along its whole back face, as in the analytical model,
    whose gap is ``theta - theta_w`` (docs/pushover.md, "Moving return walls"). The material
    of the wall turns about the (gap-shifted) toe ``(b/2 - gap, 0)`` for ``theta_w > 0``,
    about the heel ``(-b/2 - gap, 0)`` otherwise.

    Computed as one XLA computation (:func:`rockjax._fusion.one_computation`): XLA:CPU
    would otherwise copy the series into every fusion of the step that reads them.
    """
    if wall is None or isinstance(wall, _WallFrame):
        return wall

    def frame(u_top, v_top, b, h, gap):
        theta_w, rate = u_top / h, v_top / h
        d = wall_pivot(theta_w, b, 0.0)  # the pivot's distance from the face
        line = wall_line(-0.5 * b - gap, d, theta_w, rate)
        x_pivot = wall_pivot(theta_w, 0.5 * b - gap, -0.5 * b - gap)
        return _WallFrame(*line, x_pivot, rate)

    u_top, v_top = (jnp.asarray(x, float) for x in wall)
    return one_computation(frame, u_top, v_top, params.b, params.h, params.gap)


def _wall_geometry(params: DemParams, wall):
    """``(x0, slope, x0', slope')`` of the return wall's contact line (:func:`_wall_frame`;
    ``wall = None``: fixed, ``x0 = -b/2 - gap``)."""
    if wall is None:
        return -0.5 * params.b - params.gap, 0.0, 0.0, 0.0
    return tuple(_wall_frame(params, wall)[:4])


def _wall_rise(params: DemParams, wall, x_pt):
    """Vertical velocity [m/s] of the wall's material at ``x = x_pt`` (it turns rigidly about
    its pivot, :func:`_wall_frame`; :func:`rockjax.walls.wall_rise`; 0 for a fixed wall)."""
    if wall is None:
        return 0.0
    frame = _wall_frame(params, wall)
    return wall_rise(frame.x_pivot, frame.rate, x_pt)


def _wall_line(params: DemParams, wall, x_pt, y_pt, xd_pt, yd_pt):
    """Penetration [m] and its rate [m/s] of the back-face point ``(x_pt, y_pt)`` into the
    return wall, the wall's slope [-], the line's horizontal velocity at the point's height
    and the wall's vertical velocity there [m/s].

    The wall's contact line ``x = x0(t) + slope(t) y`` is the back face of the block rocked to
    ``theta_w = u_top / h`` (:func:`_wall_geometry`; ``wall = None``: fixed).
    The penetration ``x0 + slope y_pt - x_pt`` is linear along a straight back face, so the
    face law stays exact; its rate is the exact time derivative, i.e. the normal velocity of
    the block point relative to the line (normal ``(1, -slope)``, not normalised). The slip
    along the wall is the point's vertical velocity less the wall's (:func:`_wall_rise`).
    """
    if wall is None:
        wall_x = -0.5 * params.b - params.gap
        return wall_x - x_pt, -xd_pt, 0.0, 0.0, 0.0
    x0, slope, x0_dot, slope_dot = _wall_geometry(params, wall)
    delta = x0 + slope * y_pt - x_pt
    wall_v = x0_dot + slope_dot * y_pt
    rise = _wall_rise(params, wall, x_pt)
    return delta, -xd_pt + wall_v + slope * yd_pt, slope, wall_v, rise


# ----------------------------------------------------------------------------- face law

_GAUSS_X = (-1.0 / math.sqrt(3.0), 1.0 / math.sqrt(3.0))
"""Two-point Gauss-Legendre nodes on [-1, 1] (weights 1): exact for cubics. Each piece of a
face between the breakpoints of the contact law gets this rule, so the closed part's
polynomials (degree <= 2 in the face coordinate) are integrated exactly."""

FACE_SHEAR_RELEASE = "uniform"
"""Integrated face law: what the resultant shear spring keeps when the closed part of a face
moves (the points that open release their shear, as each sub-contact's spring does):
``"uniform"`` assumes a uniform stress over the closed part and keeps the share of the closed
length that stays closed; ``"pressure"`` assumes the stress shaped like the previous step's
penetration (its Mohr-Coulomb cap, which vanishes at the contact line); ``"none"`` keeps the
spring whole. docs/verification.md ("Integrated face contact") compares them with 64
sub-contacts: ``"uniform"`` is the closest with damping (first-impact ``e`` within 5e-5)."""


def _linear_integral(a, b, d_a, d_b):
    """Integral over [a, b] of the linear function with end values d_a, d_b."""
    return 0.5 * (b - a) * (d_a + d_b)


def _face(params: DemParams, state: DemState, dt, c, s, wall: bool, hist, motion=None):
    """Integrated contact of one face on a continuous Winkler joint (normal and shear
    stiffness per unit length ``kn_line``, ``ks_line``).

    The face is ``{(t, -h/2)}`` (base, ``t`` in [-b/2, b/2]) or ``{(-b/2, t)}`` (back face
    against the wall, ``t`` in [-h/2, h/2]). For a rigid body the penetration, its rate, the
    slip rate and the lever arms are all linear in ``t``; the contact law of a point
    (:func:`rockjax.contact.normal_force`, with its onset window) is then piecewise polynomial
    in ``t``, with breakpoints where the penetration at the ends of the step window,
    ``delta -+ delta_dot dt/2``, changes sign. The face is cut at those breakpoints and each
    piece integrated by two-point Gauss-Legendre: exact on the closed part (degree <= 2), and on
    the onset band, where the elastic part is a ratio of linear functions, exact to
    ``O(dt^2)`` of a force that lasts a fraction of a step.

    Shear: one elastic-plastic spring per face, stiffness ``ks_line`` times the closed length,
    capped at ``tan(phi)`` times the face's elastic normal force and applied with the lever
    arm of the closed part's centroid; ``hist = (f_s,)`` is the spring force [N]. When the
    closed part moves, the spring keeps the share given by :data:`FACE_SHEAR_RELEASE`
    (docs/theory.md, "Integrated face contact").

    A moving wall (``motion = (u_top, v_top)``, see :func:`_wall_line`) keeps the penetration
    linear along the back face; its normal ``(1, -slope)`` adds the vertical component
    ``-fn slope``.

    Returns ``(Fx, Fy, moment, fn, hist_new, (cxx, cyy, cxt, cyt, ctt), wall_power)``.
    """
    half_b, half_h = 0.5 * params.b, 0.5 * params.h
    if wall:
        lo, hi = -half_h, half_h

        def kin(t):
            rx, ry, x_pt, y_pt, xd, yd = _point_kinematics(state, -half_b, t, c, s)
            delta, delta_dot, _, _, rise = _wall_line(params, motion, x_pt, y_pt, xd, yd)
            return rx, ry, delta, delta_dot, yd if motion is None else yd - rise
    else:
        lo, hi = -half_b, half_b

        def kin(t):
            rx, ry, _, y_pt, xd, yd = _point_kinematics(state, t, -half_h, c, s)
            return rx, ry, -y_pt, -yd, xd

    # everything is linear in t: the end values define it
    ends = [kin(lo), kin(hi)]
    if not params.single_history:
        # read by most of what follows: computed once (in one history the whole contact
        # computation is one already, see step)
        flat = computed_once(*(jnp.asarray(v, float) for e in ends for v in e))
        m = len(ends[0])
        ends = [tuple(flat[:m]), tuple(flat[m:])]

    def at(t):
        w = (t - lo) / (hi - lo)
        return tuple(a + w * (b_ - a) for a, b_ in zip(*ends))

    d_lo, d_hi = ends[0][2], ends[1][2]
    if params.onset == "sub_step":
        hw = 0.5 * dt
        r_lo, r_hi = ends[0][3], ends[1][3]
        z1 = crossing(lo, hi, d_lo - hw * r_lo, d_hi - hw * r_hi)
        z2 = crossing(lo, hi, d_lo + hw * r_lo, d_hi + hw * r_hi)
        cuts = [lo, jnp.minimum(z1, z2), jnp.maximum(z1, z2), hi]
        dt_onset = dt
    else:
        cuts = [lo, crossing(lo, hi, d_lo, d_hi), hi]
        dt_onset = None
    kn, ks, beta = params.kn_line, params.ks_line, params.beta
    clipped = params.dashpot == "clipped"
    if clipped:
        # the clipped law's kink: where the closed part's total force k (delta + beta delta_dot),
        # linear in t, changes sign; the pieces either side are then smooth
        q_lo, q_hi = d_lo + beta * ends[0][3], d_hi + beta * ends[1][3]
        cuts = insert_cut(cuts, crossing(lo, hi, q_lo, q_hi))
    # each cut is read by the positions and weights of the points either side of it
    cuts = [lo, *computed_once(*cuts[1:-1]), hi]
    pts = []
    for a, b_ in zip(cuts[:-1], cuts[1:]):
        mid, half = 0.5 * (a + b_), 0.5 * (b_ - a)
        pts += [(mid + half * xg, half) for xg in _GAUSS_X]

    def terms(t, w):
        # the integrands at points t with weights w (scalars or arrays), face_integrands with
        # the lever arms, and for a moving wall f rx
        rx, ry, delta, delta_dot, slip = at(t)
        f, f_el, frac = normal_force(delta, delta_dot, kn, beta, params.dashpot, dt_onset)
        # lever arms (moment = ry Fx - rx Fy) of the normal and the shear force
        arm_n, arm_s = (ry, -rx) if wall else (-rx, ry)
        wfn, wf = w * f, w * frac
        # a clipped dashpot acts only where the total force is compressive
        wn = jnp.where(f > 0, wf, 0.0) if clipped else wf
        out = face_integrands(wfn, w * f_el, wn, wf, slip, arm_n, arm_s)
        return out + ([wfn * rx] if motion is not None else [])

    if params.pointwise_sums:
        # in a large batch every point's terms are vectors over the batch, summed point by
        # point (as one reduction over (batch, points) arrays, XLA:CPU loops along rows of a
        # few points; POINTWISE_BATCH)
        sums = [sum(col) for col in zip(*(terms(t, w) for t, w in pts))]
    else:
        # the points as one array and the sums one reduction: the point law is evaluated
        # once per point for all sums (rockjax._fusion.sum_together)
        t = jnp.stack([jnp.asarray(q[0], float) for q in pts])
        w = jnp.stack([jnp.asarray(q[1], float) for q in pts])
        sums = sum_together(*terms(t, w))
    fn, fn_el, mom_n, n0, n1, n2, s0, s1, s2, v0, v1 = sums[:11]
    f_rx = sums[11] if motion is not None else 0.0
    # shear: one spring per face; the previous step's penetration is delta - dt delta_dot
    # (the lagged velocity is the one that took the block from there to here)
    (f_s,) = hist
    if FACE_SHEAR_RELEASE != "none":
        o_lo, o_hi = d_lo - dt * ends[0][3], d_hi - dt * ends[1][3]
        ca_old, cb_old = closed_interval(lo, hi, o_lo, o_hi)
        ca, cb = closed_interval(lo, hi, d_lo, d_hi)
        ka, kb = jnp.maximum(ca, ca_old), jnp.minimum(cb, cb_old)
        kb = jnp.maximum(kb, ka)
        if FACE_SHEAR_RELEASE == "pressure":

            def old_pen(x):
                return o_lo + (x - lo) / (hi - lo) * (o_hi - o_lo)

            whole = _linear_integral(ca_old, cb_old, old_pen(ca_old), old_pen(cb_old))
            kept = _linear_integral(ka, kb, old_pen(ka), old_pen(kb))
        else:
            whole, kept = cb_old - ca_old, kb - ka
        safe = jnp.where(whole > 0.0, whole, 1.0)
        f_s = f_s * jnp.where(whole > 0.0, jnp.clip(kept / safe, 0.0, 1.0), 0.0)
    # the shear dashpot acts only while the face sticks (rockjax.contact.coulomb)
    f_s, stick = coulomb(f_s - ks * v0 * dt, params.tan_phi * fn_el)
    arm_bar = jnp.where(s0 > 0.0, s1 / jnp.where(s0 > 0.0, s0, 1.0), 0.0)
    cn, cs = beta * kn, stick * beta * ks
    f_s, cs = computed_once(f_s, cs)  # read by the forces and the dashpot matrix
    ft = f_s - cs * v0
    mom = mom_n + f_s * arm_bar - cs * v1
    n = (cn * n0, cn * n1, cn * n2)
    t_ = (cs * s0, cs * s1, cs * s2)
    power = 0.0
    if wall:  # normal along x, shear along y
        fx, fy = fn, ft
        (cxx, cxt, ctt_x), (cyy, cyt, ctt_y) = n, t_
        if motion is not None:
            # the wall's normal (1, -slope); the line's velocity x0' + slope' y_pt,
            # y_pt = y + ry, and mom_n is the integral of f ry here
            _, slope, x0_dot, slope_dot = _wall_geometry(params, motion)
            fy, mom = fy - slope * fn, mom + slope * f_rx
            power = x0_dot * fn + slope_dot * (state.y * fn + mom_n)
            # the shear on the rising wall: its vertical velocity rate (x_pivot - x - rx),
            # and the shear traction's moment is the integral of f_t (-rx) here
            mom_s = f_s * arm_bar - cs * v1
            rate = _wall_frame(params, motion).rate
            power = power + _wall_rise(params, motion, state.x) * ft + rate * mom_s
    else:
        fx, fy = ft, fn
        (cxx, cxt, ctt_x), (cyy, cyt, ctt_y) = t_, n
    # the generalised dashpot matrix uses J_x = (1, 0, ry), J_y = (0, 1, -rx): the arms above
    # are ry for x-forces and -rx for y-forces, so C_xt = sum c ry and C_yt = sum c (-rx)
    return fx, fy, mom, fn, (f_s,), (cxx, cyy, cxt, cyt, ctt_x + ctt_y), power


def _face_forces(params: DemParams, state: DemState, dt, c, s, wall=None):
    """:func:`_contact_forces` for the integrated face law."""
    fx, fy, mom, fn, hb, damp, _ = _face(params, state, dt, c, s, False, state.fs_base)
    fs_wall = ()
    power = 0.0
    if len(state.fs_wall):
        wx, wy, wm, _, hw, dw, power = _face(params, state, dt, c, s, True, state.fs_wall, wall)
        fx, fy, mom = fx + wx, fy + wy, mom + wm
        damp = tuple(a + b_ for a, b_ in zip(damp, dw))
        fs_wall = hw
    return fx, fy, mom, (fn,), hb, fs_wall, damp, power


def step(params: DemParams, state: DemState, ag, ag_v, dt, *, wall=None, load=None):
    """One central-difference step with centred dashpots (un-jitted: the drivers scan it).

    Args:
        params: From :func:`dem_params`.
        state: The state at step n (velocities at n - 1/2).
        ag: Horizontal ground acceleration at step n [m/s^2].
        ag_v: Vertical ground acceleration at step n [m/s^2].
        dt: Time step [s].
        wall: ``(u_top, v_top)`` [m, m/s] of a moving return wall at step n (one-sided only;
            the wall's displacement and velocity at the block's height relative to the base),
            or None for a fixed wall.
        load: ``(Fx, Fy, M)`` [N, N, N m]: external force on the centroid and clockwise
            moment (the sign of ``theta``) at step n, e.g. a control spring (computed by the
            caller from ``state``), or None.

    Returns:
        ``(new_state, (ax, ay, aw, fn, d, wall_power))``: the state at step n + 1, the
        accelerations at step n [m/s^2, rad/s^2], the base normal forces [N], the top
        displacement at step n [m] and the power of the return wall on the block [W].

    The dashpot force uses the velocity at step n, ``v_n = (v_{n-1/2} + v_{n+1/2}) / 2``
    (the textbook central-difference method, second-order accurate): with ``F`` the force
    with the dashpots at the lagged velocity ``v_{n-1/2}`` and ``C`` the dashpot matrix,
    ``(M + dt/2 C) a_n = F``, a 3 x 3 solve (``C`` has no x-y coupling, so it is done by
    elimination of ``theta``). ``cos``/``sin`` of theta are carried and advanced by the exact
    rotation through ``dtheta = dt w``, with its cosine and sine from their Taylor series:
    ``|dtheta| < 1e-2`` in any stable step, so the truncation (``dtheta^6/720``) is below
    1e-15, and no transcendental function is evaluated in the loop.
    """
    c, s = state.c, state.s
    forces = _face_forces if params.face else _contact_forces
    wall = _wall_frame(params, wall)  # once a step
    if params.single_history:
        # scalar code: XLA:CPU would copy the contact law into each consumer of its results
        fx, fy, mom, fn, fs_base, fs_wall, damping, power = one_computation(
            lambda st, p, dt_, wl: forces(p, st, dt_, st.c, st.s, wl), state, params, dt, wall
        )
    else:
        fx, fy, mom, fn, fs_base, fs_wall, damping, power = forces(params, state, dt, c, s, wall)
    cxx, cyy, cxt, cyt, ctt = damping
    if load is not None:
        fx, fy, mom = fx + load[0], fy + load[1], mom + load[2]
    h = 0.5 * dt
    gx = fx - params.m * ag
    gy = fy - params.m * (G + ag_v)
    axx = params.m + h * cxx
    ayy = params.m + h * cyy
    axt, ayt = h * cxt, h * cyt
    att = params.I_c + h * ctt
    rxx, ryy = axt / axx, ayt / ayy
    aw = (mom - rxx * gx - ryy * gy) / (att - rxx * axt - ryy * ayt)
    ax = (gx - axt * aw) / axx
    ay = (gy - ayt * aw) / ayy
    vx = state.vx + dt * ax
    vy = state.vy + dt * ay
    w = state.w + dt * aw
    dth = dt * w
    d2 = dth * dth
    cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0 - d2 / 720.0))
    sd = dth * (1.0 - d2 * (1.0 / 6.0 - d2 / 120.0))
    d = state.x + 0.5 * params.h * s
    new = DemState(
        x=state.x + dt * vx,
        y=state.y + dt * vy,
        c=c * cd - s * sd,
        s=s * cd + c * sd,
        vx=vx,
        vy=vy,
        w=w,
        theta=state.theta + dth,
        theta_max=jnp.maximum(state.theta_max, jnp.abs(state.theta)),
        d_max=jnp.maximum(state.d_max, jnp.abs(d)),
        fs_base=fs_base,
        fs_wall=fs_wall,
    )
    return new, (ax, ay, aw, fn, d, power)


def _energy(params: DemParams, state: DemState, vx, vy, w, c, s, wall=None):
    """Kinetic + gravitational (from y = h/2) + contact spring energy [J] (``wall``: the
    moving wall's ``(u_top, v_top)`` [m, m/s], or None)."""
    e = 0.5 * params.m * (vx**2 + vy**2) + 0.5 * params.I_c * w**2
    e = e + params.m * G * (state.y - 0.5 * params.h)
    if params.face:
        return e + _face_energy(params, state, c, s, wall)
    for i in range(len(state.fs_base)):
        _, _, _, y_pt, _, _ = _point_kinematics(state, params.u_base[i], params.v_base[i], c, s)
        delta = jnp.maximum(-y_pt, 0.0)
        e = e + 0.5 * params.kn_base[i] * delta**2 + 0.5 * state.fs_base[i] ** 2 / params.ks_base[i]
    wall_x, slope, _, _ = _wall_geometry(params, wall)
    for j in range(len(state.fs_wall)):
        _, _, x_pt, y_pt, _, _ = _point_kinematics(state, params.u_wall[j], params.v_wall[j], c, s)
        delta = jnp.maximum(wall_x + slope * y_pt - x_pt, 0.0)
        e = e + 0.5 * params.kn_wall[j] * delta**2 + 0.5 * state.fs_wall[j] ** 2 / params.ks_wall[j]
    return e


def _face_energy(params: DemParams, state: DemState, c, s, wall=None):
    """Spring energy of the integrated faces [J]: ``kn_line delta^2 / 2`` integrated exactly
    over the closed interval, and ``f_s^2 / (2 ks_line length)`` of each face's shear spring."""
    e = 0.0
    faces = [(False, state.fs_base)] + ([(True, state.fs_wall)] if len(state.fs_wall) else [])
    for is_wall, (f_s,) in faces:
        if is_wall:
            lo, hi = -0.5 * params.h, 0.5 * params.h
            wall_x, slope, _, _ = _wall_geometry(params, wall)

            def pen(t):
                _, _, x_pt, y_pt, _, _ = _point_kinematics(state, -0.5 * params.b, t, c, s)
                return wall_x + slope * y_pt - x_pt
        else:
            lo, hi = -0.5 * params.b, 0.5 * params.b

            def pen(t):
                return -_point_kinematics(state, t, -0.5 * params.h, c, s)[3]

        ca, cb = closed_interval(lo, hi, pen(lo), pen(hi))
        mid, half = 0.5 * (ca + cb), 0.5 * (cb - ca)
        for xg in _GAUSS_X:
            e = e + 0.5 * params.kn_line * half * jnp.maximum(pen(mid + half * xg), 0.0) ** 2
        length = cb - ca
        safe = jnp.where(length > 0.0, length, 1.0)
        e = e + jnp.where(length > 0.0, 0.5 * f_s**2 / (params.ks_line * safe), 0.0)
    return e


@jax.jit
def initial_state(params: DemParams, theta0=0.0) -> DemState:
    """At rest: flat on its base under gravity (``theta0 = 0``), or tilted by ``theta0`` [rad]
    about its pivot corner, sunk so that the closed contacts carry the weight (vertical
    equilibrium; the moment is what releases it).

    With sub-contacts the pivot corner alone carries the weight while its sink is below the
    height of the next sub-contact; with many sub-contacts (small tributary areas) several
    carry it, and the sink solves ``sum_i k_i max(sink - d_i, 0) = m g``, ``d_i`` the height
    of sub-contact ``i`` above the pivot (a corner spring alone would be compressed far
    beyond equilibrium and launch the block)."""
    theta0 = jnp.asarray(theta0, float)
    zero = jnp.zeros(())
    n_base = params.u_base.shape[0]
    side = jnp.sign(theta0)
    up = side * 0.5 * params.b  # pivot corner, body coordinates (up, -h/2)
    vp = -0.5 * params.h
    # piecewise-linear vertical equilibrium, solved exactly bracket by bracket
    d = jnp.abs(jnp.sin(theta0)) * jnp.abs(up - params.u_base) * jnp.where(side == 0, 0.0, 1.0)
    order = jnp.argsort(d)
    d, k = d[order], params.kn_base[order]
    cand = (params.m * G + jnp.cumsum(k * d)) / jnp.cumsum(k)
    upper = jnp.concatenate([d[1:], jnp.full((1,), jnp.inf)])
    first = jnp.argmax(cand <= upper)
    sink = cand[first]
    if params.face:
        # the weight on a Winkler joint: a triangle of contact from the pivot corner, or the
        # whole face (a trapezoid) when the tilt is below sink / b
        w_line = params.m * G / params.kn_line
        tilt = jnp.abs(jnp.sin(theta0))
        # (the square root's derivative is infinite at zero tilt: keep it out of the graph)
        tri = jnp.sqrt(2.0 * w_line * jnp.where(tilt > 0.0, tilt, 1.0))
        tri = jnp.where(tilt > 0.0, tri, 0.0)
        trap = w_line / params.b + 0.5 * tilt * params.b
        sink = jnp.where(tri < tilt * params.b, tri, trap)
    c, s = jnp.cos(theta0), jnp.sin(theta0)
    x0 = jnp.where(side == 0, 0.0, up - (up * c + vp * s))
    y0 = -sink - (-up * s + vp * c)
    return DemState(
        x=x0,
        y=y0,
        c=c,
        s=s,
        vx=zero,
        vy=zero,
        w=zero,
        theta=theta0,
        theta_max=jnp.abs(theta0),
        d_max=zero,
        fs_base=(zero,) * (1 if params.face else n_base),
        fs_wall=(zero,)
        * (min(1, params.u_wall.shape[0]) if params.face else params.u_wall.shape[0]),
    )


@persistent_jit
def run_prepared(
    params: DemParams,
    state0: DemState,
    ag,
    ag_v,
    dt,
    dt_out: float,
    n_in: int,
    save: tuple,
    throw: bool,
    wall=None,
    n=None,
) -> Response:
    """The DEM run from a prepared state: what :func:`rockjax.simulate_dem` calls once it has
    checked its inputs (use it for set-ups it does not offer, e.g. a block dropped flat).

    An outer scan over the record samples, ``n_in`` steps of ``dt`` [s] each (the ground
    acceleration ``ag``, ``ag_v`` [m/s^2] linear in between), assembled into a
    :class:`Response` all inside one jit. Nothing is checked here: ``params`` from
    :func:`dem_params`, ``state0`` e.g. from :func:`initial_state`, ``dt = dt_out / n_in``.

    ``wall``: ``(u_top, v_top)`` [m, m/s], arrays shaped like ``ag``: the return wall's
    displacement and velocity at the block's height ``h`` relative to the base, at the record
    samples, linear in between (a one-sided ``params`` only; None: a fixed wall). With
    ``"energy"`` in ``save`` the work done by the wall on the block [J] since ``t = 0`` is
    returned as ``extras["work_wall"]`` (zeros for a fixed wall).

    ``n``: the true number of samples (an integer array: data, not a shape), when ``ag`` and
    the other series are padded beyond it (:func:`rockjax.compilation.pad_to`); None: all.
    From sample ``n`` on the state, the running maxima, ``overturned`` and ``status`` are
    frozen, and whole chunks of :data:`SCAN_CHUNK` padded samples are skipped, so the padding
    costs little time; the outputs hold the series up to the padded length (cut them to ``n``
    samples). Every record whose length pads to one length then shares one compiled program.
    """
    n_base, n_wall = len(state0.fs_base), len(state0.fs_wall)
    ag_next = jnp.concatenate([ag[1:], ag[-1:]])
    agv_next = jnp.concatenate([ag_v[1:], ag_v[-1:]])
    moving = wall is not None
    work = moving and "energy" in save
    xs = (ag, ag_next, ag_v, agv_next)
    if moving:
        u_w, v_w = (jnp.asarray(a, float) for a in wall)
        xs = xs + (u_w, jnp.concatenate([u_w[1:], u_w[-1:]]))
        xs = xs + (v_w, jnp.concatenate([v_w[1:], v_w[-1:]]))
    unstable = dt > critical_dt(params) * (1.0 + 1e-9)
    # traced inputs cannot be checked in Python: a lane with an impossible one is not run
    positive = [params.m, params.I_c, params.b, params.h, params.kn_line, params.tan_phi]
    bad_input = ~(
        jnp.all(jnp.isfinite(jnp.stack([*positive, params.beta, params.gap])))
        & jnp.all(jnp.stack(positive) > 0)
        & (params.beta >= 0)
        & (params.gap >= 0)
        & jnp.all(jnp.isfinite(ag))
        & jnp.all(jnp.isfinite(ag_v))
    )
    if moving:
        bad_input = bad_input | ~(jnp.all(jnp.isfinite(u_w)) & jnp.all(jnp.isfinite(v_w)))

    def outer(carry, xs):
        z, overturned, status = carry[:3]
        a0, a1, v0, v1 = xs[:4]
        w0 = (xs[4], xs[6]) if moving else None
        state = _unpack(z, n_base, n_wall)
        new, (ax, ay, aw, fn, d, power) = step(params, state, a0, v0, dt, wall=w0)
        # velocities at the sample time, centred from the half steps
        vx, vy, w = state.vx + 0.5 * dt * ax, state.vy + 0.5 * dt * ay, state.w + 0.5 * dt * aw
        out = {"theta": state.theta, "theta_dot": w, "d": d, "x": state.x, "y": state.y}
        if "energy" in save:
            out["energy"] = _energy(params, state, vx, vy, w, state.c, state.s, w0)
        if "forces" in save:
            out["normal_forces"] = jnp.stack(fn, axis=-1)
        if work:
            # the wall's work: the sum of power x dt over the steps (their forces act on the
            # centred velocities), half a step past the sample; the constant half step of the
            # first sample is taken off at the end
            out["work_wall"] = carry[3] + 0.5 * dt * power
            work_new = carry[3] + dt * power
        if n_in > 1:
            # the ground motion is linear between samples; the substep index travels in the
            # carry (not as scanned xs). The state travels as its fields, not packed: XLA:CPU
            # computes a packed vector as one fusion per element, each recomputing the contact
            # forces (~540 instead of ~195 arithmetic ops per step; docs/benchmarks.md).
            da, dv = (a1 - a0) / n_in, (v1 - v0) / n_in
            if moving:
                du, dw_ = (xs[5] - xs[4]) / n_in, (xs[7] - xs[6]) / n_in

            def inner(carry, _):
                st, j = carry[:2]
                wj = (xs[4] + j * du, xs[6] + j * dw_) if moving else None
                st, aux = step(params, st, a0 + j * da, v0 + j * dv, dt, wall=wj)
                if work:
                    return (st, j + 1.0, carry[2] + dt * aux[-1]), None
                return (st, j + 1.0), None

            init = (new, jnp.ones_like(a0)) + ((work_new,) if work else ())
            done, _ = jax.lax.scan(inner, init, length=n_in - 1)
            new = done[0]
            if work:
                work_new = done[2]
        z_new = _pack(new)
        theta, w_new = z_new[_SCALARS.index("theta")], z_new[_SCALARS.index("w")]
        # overturning: past eta and moving outward; the block is frozen from then on
        over = overturned | ((jnp.abs(theta) > params.eta) & (theta * w_new > 0))
        bad = ~jnp.all(jnp.isfinite(z_new))
        status = jnp.where(
            status != STATUS_OK,
            status,
            jnp.where(unstable, STATUS_UNSTABLE, jnp.where(bad, STATUS_NONFINITE, STATUS_OK)),
        )
        frozen = overturned | (status != STATUS_OK)
        z_new = jnp.where(frozen, z, z_new)
        if work:
            return (z_new, over, status, jnp.where(frozen, carry[3], work_new)), out
        return (z_new, over, status), out

    outer = jax.checkpoint(outer, prevent_cse=False)
    status0 = jnp.where(bad_input, STATUS_BAD_INPUT, STATUS_OK)
    carry0 = (_pack(state0), jnp.zeros((), bool), status0)
    if work:
        carry0 = carry0 + (jnp.zeros(()),)
    if n is None:
        (z, overturned, status, *_), out = jax.lax.scan(outer, carry0, xs)
    else:
        (z, overturned, status, *_), out = _scan_to(outer, carry0, xs, n)
    if throw:
        for code in (STATUS_BAD_INPUT, STATUS_UNSTABLE, STATUS_NONFINITE):
            out["theta"] = eqx.error_if(out["theta"], status == code, _failure_message(code))
    final = _unpack(z, n_base, n_wall)
    extras = {"x": out["x"], "y": out["y"], "d_max": final.d_max, "dt": dt}
    if "normal_forces" in out:
        extras["normal_forces"] = out["normal_forces"]
    if work:
        extras["work_wall"] = out["work_wall"] - out["work_wall"][0]
    elif n_wall and "energy" in save:  # a fixed wall does no work
        extras["work_wall"] = jnp.zeros_like(out["theta"])
    return Response(
        t=jnp.arange(ag.shape[0]) * dt_out,
        theta=out["theta"],
        theta_dot=out["theta_dot"],
        d=out["d"],
        overturned=overturned,
        status=status,
        theta_max=final.theta_max,
        eta=params.eta,
        b=params.b,
        energy=out.get("energy"),
        extras=extras,
    )


def _scan_to(body, carry0, xs, n):
    """``jax.lax.scan(body, carry0, xs)`` over the first ``n`` (traced) samples of ``xs``: the
    carry is frozen from sample ``n`` on (masked by the sample index), and the scan runs in
    chunks of :data:`SCAN_CHUNK` samples, a chunk that starts at or past ``n`` skipped by a
    ``lax.cond`` (its outputs zeros). A padded sample inside the last chunk costs one sample's
    work; a skipped chunk almost nothing."""
    n_pad = xs[0].shape[0]
    k = math.gcd(n_pad, SCAN_CHUNK)
    n = jnp.asarray(n)

    shapes = jax.eval_shape(body, carry0, jax.tree.map(lambda a: a[0], xs))[1]

    def zeros(shape=()):
        return jax.tree.map(lambda s: jnp.zeros(shape + s.shape, s.dtype), shapes)

    def sample(carry, x):
        i, x = x
        return jax.lax.cond(i < n, body, lambda c, _: (c, zeros()), carry, x)

    xs_c = jax.tree.map(lambda a: a.reshape((n_pad // k, k) + a.shape[1:]), (jnp.arange(n_pad), xs))

    def chunk(carry, xc):
        def run(c):
            return jax.lax.scan(sample, c, xc)

        def skip(c):
            return c, zeros((k,))

        return jax.lax.cond(xc[0][0] < n, run, skip, carry)

    carry, out = jax.lax.scan(chunk, carry0, xs_c)
    return carry, jax.tree.map(lambda a: a.reshape((n_pad,) + a.shape[2:]), out)


def simulate_dem(
    block: Block | Assembly,
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
    wall_motion=None,
    support_motion=None,
    storey: int | None = None,
) -> Response | eqx.Module:  # an AssemblyResponse for an Assembly
    """Simulate the DEM rigid block under a ground motion and/or a free release.

    Compiles once per bucket of record lengths (:mod:`rockjax.compilation`): called with
    concrete inputs, the record is padded to :func:`padded_length` ``(n)`` samples (32 768 for
    records up to that length) and its length passed as data, so a loop over records of
    different lengths (or free-rocking durations) at one record step compiles once; a new
    record step with a new number of substeps a sample compiles again. Inside
    ``jit``/``vmap``/``grad`` the caller's transform fixes the shapes.

    Args:
        block: The block (geometry and material), or an :class:`rockjax.Assembly` of several
            blocks: that runs :func:`rockjax.simulate_assembly` (per-block ``theta``, ``x``,
            ``y``; ``mode="one_sided"`` and ``gap`` put every block's back face on a return
            wall, fixed or moving with ``wall_motion``; ``save=("forces",)`` records each
            interface's normal and shear forces) and returns its
            :class:`rockjax.AssemblyResponse`.
        motion: Ground motion; ``None`` for free rocking (then ``duration`` is required).
        beta: Stiffness-proportional Rayleigh damping coefficient [s], Eq. (1), alpha = 0.
        mode: ``"two_sided"`` (parapet) or ``"one_sided"`` (facade with a return wall at -x).
        gap: Facade gap between the back face and the return wall [m] (one-sided only).
        theta0: Initial rotation [rad], released from rest on its pivot corner; ``|theta0| < eta``.
        duration: Length of the run [s]; default the record's. A longer duration appends zeros
            (free vibration after the record); a shorter one truncates it.
        dt: Time step [s]; default ``stable_dt(...)`` (chosen for accuracy, see ``accuracy``).
            The step used is the largest divisor of the output step not above ``dt``. A step
            above the stability limit is refused.
        accuracy: Accuracy of the default step, ``omega_max dt (1 + zeta)`` [-] (ignored when
            ``dt`` is given); default ``DT_ACCURACY[mode]`` (``DT_ACCURACY_SUB`` with integer
            ``n_sub``), which puts the first-impact ``e`` within 1e-3 of its converged value
            (docs/verification.md). Smaller is finer.
        joint: The contact joint, :class:`rockjax.Joint`: by default the contact law
            integrated in closed form over each face (the ``n_sub -> infinity`` limit of the
            sub-contacts; docs/theory.md, "Integrated face contact"), the closed dashpot and
            contact onsets located inside the step (responses smooth in ``beta``);
            ``rj.Joint(n_sub=2)`` is the paper's two corner contacts.
        phi_deg: Friction angle [deg]; default 50 (parapets) or 30 (facades), as in the paper.
        save_dt: Output interval for free rocking [s] (default 0.002); with a record, its ``dt``.
        save: Extra outputs: ``"energy"`` (total energy [J]), ``"forces"`` (base normal forces [N]).
        beta_max: Largest ``beta`` to size the default step for, when ``beta`` is traced.
        throw: Raise (also inside ``jit``) if the run fails; if False, report ``Response.status``.
        wall_motion: A return wall that moves relative to the base (``mode="one_sided"`` only;
            None: fixed). The wall is the block's back face rocked rigidly to
            ``theta_w = u_top / h`` (about the toe for ``theta_w > 0``, the heel otherwise):
            its contact line is ``x = -b/2 - gap + theta_w y - (b/2) theta_w^2`` to second
            order (``y`` above the base; docs/pushover.md, "Moving return walls"), so a facade
            riding on it at ``theta = theta_w`` lies flush, as in ``simulate_housner``.
            Either a pair ``(u_top, v_top)`` of arrays [m], [m/s] with one value per record
            sample (the wall's displacement and velocity at height ``h``
            relative to the base, ``u_top > 0`` toward the facade; traceable, so ``jit``/``vmap``
            over wall histories work), or what ``rockjax.building.wall_top_motion`` accepts (a
            ``ShearBuilding``, the wall's absolute acceleration as a ``GroundMotion``, or
            ``(height, GroundMotion)`` pairs). Linear between samples; past the record's end
            (a longer ``duration``) the wall holds its last position.
        support_motion: An :class:`rockjax.Assembly` only: the :class:`rockjax.ShearBuilding`
            the wall stands in (with ``storey``); see :func:`rockjax.simulate_assembly`.
        storey: The storey of ``support_motion`` the wall spans (its base on floor
            ``storey - 1``, its top restraint following floor ``storey``).

    Returns:
        A :class:`rockjax.Response` sampled at the record samples (or every ``save_dt``);
        ``extras`` holds ``x``, ``y`` (centroid [m]), ``d_max`` [m], ``dt`` [s] and the requested
        outputs; for a facade with ``"energy"`` saved also ``work_wall`` [J], the work done on the
        block by the return wall since ``t = 0`` (zero for a fixed wall), so that
        ``energy - work_wall`` is conserved without damping, slip or ground motion.

    Raises:
        ValueError: on invalid input, with the value, its unit and the fix.
    """
    check_kind(
        "block",
        block,
        (Block, Assembly),
        "Build one with rj.Block(b=0.25, h=3.0), or a wall of blocks with "
        "rj.Assembly.stack([...]).",
    )
    if isinstance(block, Assembly):
        return _simulate_assembly(
            block,
            motion,
            beta=beta,
            mode=mode,
            gap=gap,
            theta0=theta0,
            duration=duration,
            dt=dt,
            accuracy=accuracy,
            joint=joint,
            phi_deg=phi_deg,
            save_dt=save_dt,
            save=save,
            beta_max=beta_max,
            throw=throw,
            wall_motion=wall_motion,
            support_motion=support_motion,
            storey=storey,
        )
    if support_motion is not None or storey is not None:
        raise ValueError(
            "support_motion= and storey= place a wall of several blocks (an rj.Assembly) in a "
            "building; a single block on a floor runs on that floor's motion: "
            "rj.simulate_dem(block, bldg.floor_motions(gm)[i], ...), or wrap it as "
            "rj.Assembly.stack([block])."
        )
    if isinstance(save, str):
        raise ValueError(
            f"save must be a tuple of output names, e.g. save=({save!r},); got save={save!r}."
        )
    for key in save:
        check_choice("save entry", key, SAVE_OPTIONS)
    params = dem_params(
        block,
        beta,
        mode=mode,
        gap=gap,
        joint=joint,
        phi_deg=phi_deg,
    )
    _check_theta0(theta0, block, mode)
    if wall_motion is not None and mode != "one_sided":
        raise ValueError(
            f"wall_motion (a moving return wall) needs mode='one_sided' (a facade against its "
            f"return wall); got mode={mode!r}. Pass mode='one_sided', or drop wall_motion."
        )
    _check_motion_type(motion)
    n_record = None if motion is None else np.shape(motion.ag)[0]
    ag, ag_v, dt_out = prepare_motion(motion, duration, save_dt)
    wall = None
    if wall_motion is not None:  # a fixed wall takes the path without wall arrays
        wall = wall_arrays(wall_motion, motion, block.h, ag, dt_out, n_record)
    accuracy = _check_accuracy(accuracy, mode, joint)
    limit, dt_default = _concrete_steps(params, block, beta_max, joint, mode, dt, accuracy)
    if dt is None:
        dt_target = dt_default
    else:
        check_positive("dt", dt, "s", "Or leave dt=None (chosen for accuracy).", scalar=True)
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(
                f"dt must be a positive time step in s; got dt={dt}. Or leave dt=None."
            )
        if limit is not None and dt > limit * (1 + 1e-9):
            raise ValueError(
                f"dt={dt:.4g} s exceeds the explicit stability limit {limit:.4g} s of this block "
                f"at beta={_fmt(beta)} s. Use dt <= {limit:.4g} s or leave dt=None (default "
                f"{dt_default:.4g} s, chosen for accuracy)."
            )
        dt_target = dt
    n_in = max(1, math.ceil(dt_out / dt_target - 1e-9))
    step = dt_out / n_in
    state0 = initial_state(params, theta0)
    save = tuple(save)
    # step as an array: traced, so a new step (a new beta) does not recompile
    if is_traced(params, state0, ag, ag_v, wall, dt):
        # inside the caller's jit/vmap/grad: their transform fixes the shapes
        if batch_size(params, state0, ag, ag_v, wall, dt) >= POINTWISE_BATCH:
            params = dataclasses.replace(params, pointwise_sums=True)
        return run_prepared(
            params, state0, ag, ag_v, np.asarray(step), dt_out, n_in, save, throw, wall
        )
    # Compile once per bucket: the record is padded to its bucket (its last sample repeated,
    # which is what the last sample's substeps interpolate toward anyway) and its length
    # passed as data; the run freezes from there, and the outputs are cut on the host.
    n_out = ag.shape[0]
    n_pad = padded_length(n_out)
    notice_once(
        ("dem", n_pad, n_in, dt_out, mode, joint, save, wall is None),
        f"rockjax: compiling the DEM solver for records of <= {n_pad} samples, {n_in} steps a "
        "sample (once per session)...",
    )
    resp = run_prepared(
        dataclasses.replace(params, single_history=True),
        state0,
        pad_to(ag, n_pad),
        pad_to(ag_v, n_pad),
        np.asarray(step),
        dt_out,
        n_in,
        save,
        # An eager call checks in Python, after the run: a compiled program with error
        # callbacks (eqx.error_if) cannot go into the persistent compilation cache.
        False,
        None if wall is None else tuple(pad_to(a, n_pad) for a in wall),
        n=np.asarray(n_out, dtype=np.int32),
    )
    if throw:
        _raise_on_failure(int(resp.status))
    return _cut(resp, n_out)


def _failure_message(code: int) -> str:
    return (
        f"rockjax.simulate_dem: {STATUS_MESSAGES[code]}. "
        "Pass throw=False to get a per-run status instead."
    )


def _raise_on_failure(status: int) -> None:
    """The errors ``throw`` asks for, raised after an eager run with the messages
    ``eqx.error_if`` gives under a transform (:func:`run_prepared`)."""
    if status == STATUS_BAD_INPUT:
        raise ValueError(_failure_message(status))
    if status != STATUS_OK:
        raise RuntimeError(_failure_message(status))


def padded_length(n: int) -> int:
    """The length [samples] a concrete record of ``n`` samples is padded to by
    :func:`simulate_dem`: its bucket (:func:`rockjax.compilation.bucket_length`), rounded up
    to whole chunks of :data:`SCAN_CHUNK` samples."""
    return SCAN_CHUNK * math.ceil(bucket_length(n) / SCAN_CHUNK)


def _cut(resp: Response, n: int) -> Response:
    """The padded run's series cut to the true ``n`` samples, on the host (an eager slice of a
    device array would compile once per length)."""
    if resp.t.shape[0] == n:
        return resp

    def cut(x):
        return None if x is None else jax.device_put(np.asarray(x)[:n])

    extras = dict(resp.extras)
    for key in ("x", "y", "normal_forces", "work_wall"):
        if key in extras:
            extras[key] = cut(extras[key])
    return Response(
        t=cut(resp.t),
        theta=cut(resp.theta),
        theta_dot=cut(resp.theta_dot),
        d=cut(resp.d),
        overturned=resp.overturned,
        status=resp.status,
        theta_max=resp.theta_max,
        eta=resp.eta,
        b=resp.b,
        energy=cut(resp.energy),
        extras=extras,
    )


def _simulate_assembly(
    assembly, motion, *, mode, gap, wall_motion, phi_deg, support_motion, storey, **kw
):
    """``simulate_dem`` on an :class:`Assembly`: :func:`rockjax.simulate_assembly` (``mode``,
    ``gap`` and ``wall_motion``: its blocks' back faces on return walls)."""
    from .multiblock import simulate_assembly  # imports this module: imported at call time

    kw.update(mode=mode, gap=gap)
    if wall_motion is not None:
        kw["wall_motion"] = wall_motion
    if phi_deg is not None:
        kw["phi_deg"] = phi_deg
    if support_motion is not None:
        kw["support_motion"] = support_motion
    if storey is not None:  # simulate_assembly's default: storey 1
        kw["storey"] = storey
    return simulate_assembly(assembly, motion, **kw)


def _check_motion_type(motion) -> None:
    if motion is not None and not isinstance(motion, GroundMotion):
        raise ValueError(
            f"motion must be a rockjax.GroundMotion (or None for free rocking); got "
            f"{type(motion).__name__}. Wrap an acceleration array as "
            "rj.GroundMotion(ag=<m/s^2>, dt=<s>) or rj.GroundMotion.from_g(<g>, dt)."
        )


def _fmt(x):
    v = concrete(x)
    return "(traced)" if v is None else f"{float(v):.4g}"


def _check_theta0(theta0, block, mode):
    check_scalar("theta0", theta0, "rad", "e.g. theta0=0.5 * block.eta.")
    th = concrete(theta0)
    eta = concrete(block.eta)
    if th is None or eta is None:
        return
    if not np.isfinite(th) or abs(th) >= eta:
        raise ValueError(
            f"theta0={float(th):.4g} rad must satisfy |theta0| < eta = {float(eta):.4g} rad "
            "(beyond eta the block is already overturning). Try theta0 = 0.5 * block.eta."
        )
    if mode == "one_sided" and th < 0:
        raise ValueError(
            f"theta0={float(th):.4g} rad: a facade (mode='one_sided') can only rotate outward, "
            "theta0 >= 0."
        )


def _concrete_steps(params, block, beta_max, joint, mode, dt, accuracy):
    """``(stability limit, default step)`` [s] as floats, or ``(None, None)`` when they cannot
    be known outside the trace."""
    if beta_max is not None:
        try:  # rebuilt from the block: params may be tracers when only beta is traced
            with jax.ensure_compile_time_eval():
                p_max = dem_params(block, beta_max, mode=mode, joint=joint)
                return tuple(map(float, _steps_jit(p_max, accuracy)))
        except (jax.errors.ConcretizationTypeError, jax.errors.TracerArrayConversionError):
            raise ValueError(
                "beta_max cannot size the time step when the block itself is traced; pass "
                "dt=rj.stable_dt(block, beta_max) computed outside the transform."
            ) from None
    try:
        return tuple(map(float, _steps_jit(params, accuracy)))
    except (jax.errors.ConcretizationTypeError, jax.errors.TracerArrayConversionError):
        if dt is not None:
            return None, None  # checked inside the trace (status / error_if)
        raise ValueError(
            "simulate_dem was called with traced inputs (inside jit/vmap/grad), so the time step "
            "cannot be chosen automatically. Pass dt=rj.stable_dt(block, beta_max) computed "
            "outside the transform, or beta_max=<largest beta> [s]."
        ) from None


def prepare_motion(motion, duration, save_dt):
    """``(ag, ag_v, dt_out)``: a checked record as arrays [m/s^2], [m/s^2], [s], zero-padded or
    cut to ``duration`` [s]; free motion (``motion=None``) is zeros every ``save_dt`` [s]
    (default :data:`DEFAULT_SAVE_DT`). NumPy arrays for a concrete record, jnp when traced.
    Shared by :func:`simulate_dem` and :func:`rockjax.simulate_assembly`."""
    if motion is None:
        if duration is None:
            raise ValueError(
                "Free rocking (motion=None) needs duration=<seconds>, e.g. duration=5.0."
            )
        if save_dt is not None:
            check_positive(
                "save_dt", save_dt, "s", f"e.g. save_dt={DEFAULT_SAVE_DT} (the default)."
            )
        dt_out = DEFAULT_SAVE_DT if save_dt is None else float(save_dt)
        check_samples(duration, dt_out, dt_name="save_dt")
        motion = GroundMotion.zeros(duration, dt_out)
    _check_motion_type(motion)
    motion.check_finite()
    dt_out = motion.dt
    # NumPy for concrete records (no eager JAX dispatch); jnp when the record is traced (vmap)
    xp = np if concrete(motion.ag) is not None else jnp
    ag = xp.asarray(motion.ag, float)
    ag_v = xp.zeros_like(ag) if motion.ag_v is None else xp.asarray(motion.ag_v, float)
    if duration is not None:
        n = check_samples(duration, dt_out, dt_name="the record's dt")
        if n < 2:
            raise ValueError(f"duration={duration} s is shorter than two samples of {dt_out} s.")
        pad = max(0, n - ag.shape[0])
        ag = xp.pad(ag, (0, pad))[:n]
        ag_v = xp.pad(ag_v, (0, pad))[:n]
    return ag, ag_v, dt_out
