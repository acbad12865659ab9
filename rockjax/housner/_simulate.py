"""``simulate_housner``: the public entry point, its boundary checks of concrete inputs,
the step-size rule and the length buckets of eager calls.

Step-size rule: the solver step is the output step divided by
``n_sub = ceil(p dt_out / P_DT_TARGET)``, i.e. ``p dt_step <= 0.1``: Tsit5's error per step is
then about ``(p dt_step)^6 ~ 1e-6`` of the motion. Typical records (``dt <= 0.02`` s) and
parapets (``p ~ 2-4`` rad/s) give ``n_sub = 1``. When the geometry is traced (``vmap`` over
``b``, ``h``), ``p`` is unknown at trace time: pass ``dt`` to bound the step, else
``n_sub = 1`` and ``p dt_step > P_DT_LIMIT`` is reported as ``STATUS_UNSTABLE``.

Compile once: the record's length and step are data (``n_out``, ``Record.dt``), so an eager
call pads the record to a bucket (:func:`rockjax.compilation.bucket_length`, repeating its
last sample, which is what the forcing beyond the end holds anyway) and records of any length
and step in the bucket share one compiled program; the loop stops at the true length.
"""

from __future__ import annotations

import math
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike, Float

from .._checks import (
    GAP_HINT,
    HOUSNER_GAP_UNUSED,
    check_gap,
    check_kind,
    check_positive,
    check_samples,
    check_scalar,
    concrete,
)
from .._lazy import lazy_module
from ..block import Block
from ..compilation import bucket_length, cut_to, is_traced, notice, pad_to
from ..modes import MODE_NAMES, Mode, as_mode
from ..motion import GroundMotion
from ..response import STATUS_BAD_INPUT, STATUS_OK, Response
from ..three_branch import ThreeBranchFit, ThreeBranchLaw
from ._diffrax import default_controller, solve_events
from ._params import P_DT_LIMIT, P_DT_TARGET, law_frequency
from ._solve import STATE_MESSAGES, fault_message, solve
from ._wall import pad_wall, wall_series

# loaded on first use (rockjax/_lazy.py): the solver reads diffrax's adjoint classes, and the
# import (with optimistix and lineax) took a quarter of `import rockjax`
diffrax = lazy_module("diffrax")


MODES = MODE_NAMES


DEFAULT_DT = 0.005
"""Output step for free rocking [s]."""


DEFAULT_MAX_IMPACTS = 64
"""Default ``max_impacts_per_step``: impacts one solver step may resolve before the run is
reported as unresolved (``STATUS_UNRESOLVED``)."""


def simulate_housner(
    block: Block,
    motion: GroundMotion | None = None,
    *,
    e: Float[ArrayLike, ""] | None = None,
    mode: Mode | str = "two_sided",
    theta0: Float[ArrayLike, ""] = 0.0,
    theta_dot0: Float[ArrayLike, ""] = 0.0,
    duration: float | None = None,
    dt: float | None = None,
    max_impacts_per_step: int = DEFAULT_MAX_IMPACTS,
    adjoint: diffrax.AbstractAdjoint | None = None,
    throw: bool = True,
    law: ThreeBranchLaw | ThreeBranchFit | None = None,
    wall_motion: Any = None,
    solver: diffrax.AbstractSolver | None = None,
    stepsize_controller: diffrax.AbstractStepSizeController | None = None,
) -> Response:
    r"""Simulate Housner rocking with impacts (two-sided parapet or one-sided facade).

    $I_O \ddot\theta = -m g R \sin(\eta - \theta) - m a_g R \cos(\eta - \theta)$ for
    $\theta > 0$ (mirrored for $\theta < 0$), $\dot\theta \to e \dot\theta$ at each impact.

    Compiles once per bucket of record lengths (:mod:`rockjax.compilation`): called with
    concrete inputs, the record is padded to ``rockjax.compilation.bucket_length(n)`` samples
    and its length passed as data, so a loop over records of different lengths and steps
    compiles once. Inside ``jit``/``vmap``/``grad`` the caller's transform fixes the shapes.

    Args:
        block: The block; only ``b`` and ``h`` (and ``m``, for the energy) matter.
        motion: Ground motion, a :class:`rockjax.GroundMotion`; ``None`` for free rocking
            (then ``duration`` is required).
        e: Coefficient of restitution [-]: two-sided ``0 < e <= 1`` (default ``e_H``, Eq. (2));
            one-sided ``0 < |e| <= 1``, its magnitude is used (default ``|e_1sr|``, Eq. (5)).
        mode: :class:`rockjax.Parapet` (``"two_sided"``) or :class:`rockjax.Facade`
            (``"one_sided"``, ``theta >= 0``; flush on its return walls: a gap is refused).
        theta0: Initial rotation [rad], ``|theta0| < eta`` (``>= 0`` one-sided).
        theta_dot0: Initial angular velocity [rad/s]. A start faster than
            ``(2 pi + |theta0|) / (|e| dt_step)`` (``dt_step`` the solver's step), which
            carries the block past overturning within that step, is run at that speed: it
            overturns all the same (docs/conventions.md, "Input checks").
        duration: Length of the run [s]; required for free rocking, else default the record's.
            A longer duration appends zeros (free vibration after the record); a shorter one
            truncates it.
        dt: Free rocking: the output step [s] (default 0.005), split into
            ``ceil(p dt / P_DT_TARGET)`` solver steps. With a motion: a bound on the solver step
            [s] (default ``P_DT_TARGET / p``), each record step split into ``ceil(motion.dt /
            dt)`` equal solver steps; the output stays at the record samples.
        max_impacts_per_step: Impacts one solver step may resolve (static; default 64). A step
            that needs more is counted in ``extras["n_unresolved"]``, the block is stopped
            there, and the run is an error (``throw``) or has ``STATUS_UNRESOLVED``; raise it
            or pass a smaller ``dt``. Chatter that provably dies out below the uplift
            threshold is put to rest by the rest rule and does not count.
        adjoint: ``None`` or ``diffrax.RecursiveCheckpointAdjoint()`` (reverse mode, ``grad``;
            its ``checkpoints`` is honoured), or ``diffrax.ForwardMode()`` for
            ``jvp``/``jacfwd``. With ``solver``, it picks the loop over the record the same
            way, and each ``diffeqsolve`` gets ``RecursiveCheckpointAdjoint()`` or
            ``ForwardMode()`` to match.
        throw: Raise (also inside ``jit``) on an invalid traced input, a non-finite state or an
            unresolved step; if False report it in ``Response.status`` (for batches: a lane
            with an invalid input, e.g. ``e > 1`` or ``|theta0| >= eta``, gets
            ``STATUS_BAD_INPUT`` and NaN histories, and the other lanes run as alone).
        law: A :class:`rockjax.ThreeBranchLaw` (or the :class:`rockjax.ThreeBranchFit` of
            :func:`rockjax.fit_three_branch`) for the restoring moment (docs/three_branch.md):
            $I_O \ddot\theta = -m g R \cos(\eta - u) [\Lambda(u) + a_g/g]$ on the pivot's side
            ($u = s\theta$), $\Lambda$ the law's load multiplier at the rigid-equivalent
            displacement $x = 1 - \tan(\eta - u)/\tan\eta$; the block overturns past the
            law's zero-capacity rotation and lifts from rest at its ``lambda_uplift``. ``None``
            (default): the rigid block, the same as ``ThreeBranchLaw.rigid(block)``.
        wall_motion: One-sided only: the return wall moves relative to the base (a facade in a
            building; docs/three_branch.md, "Moving return walls"). A ``(u_top, v_top)`` pair of
            arrays [m], [m/s] at the record samples (the wall's displacement and velocity at
            the block's height ``h``, relative to the base, positive toward the facade), or
            anything ``rockjax.wall_top_motion`` takes (a ``ShearBuilding``, a
            ``GroundMotion`` of the wall's absolute acceleration, or ``(height, GroundMotion)``
            pairs). The wall rotates by ``theta_w = u_top / h``; the block's stop is the wall,
            or its base where the wall has receded behind it (``theta >= max(theta_w, 0)``);
            impacts restitute the velocity relative to the stop; at rest the block rides on
            it. The block rocks on its toe only: see ``extras["t_heel"]``. Needs ``motion``.
        solver: ``None`` (default): the fixed-step loop (Tsit5 steps of ``p dt_step <= 0.1``,
            crossings from each step's cubic fit). A diffrax solver, e.g. ``diffrax.Tsit5()``
            or ``diffrax.Dopri8()``: each record interval is integrated by
            ``diffrax.diffeqsolve`` with an adaptive ``stepsize_controller``, impacts,
            overturning and peaks located as ``diffrax.Event``s by an optimistix Newton root
            finder; the vector field, impact map, uplift and rest rule are the default loop's.
            Slower (docs/benchmarks.md, "Housner through diffrax"); for checking the default
            at a chosen tolerance, or a higher order. ``max_impacts_per_step`` then bounds the
            impacts per record interval; ``extras["dt"]`` is NaN. Not with ``wall_motion``.
        stepsize_controller: With ``solver``: an adaptive diffrax controller, default
            ``diffrax.PIDController(rtol=1e-8, atol=1e-10)`` (tolerances on ``theta`` [rad]
            and ``theta_dot`` [rad/s]).

    Returns:
        A :class:`rockjax.Response` at the record samples (or every ``dt``). ``energy`` is
        $\tfrac12 I_O\dot\theta^2 + m g R(\cos(\eta-|\theta|) - \cos\eta)$ [J] (with a ``law``,
        its potential: the work of its restoring moment). ``extras``:
        ``"n_impacts"`` (impacts up to each sample), ``"t_last_impact"`` [s] (time of the
        latest impact up to each sample, exact from the root-find; ``-inf`` before the first),
        ``"pivot"`` (``s``: +1, -1, 0 at rest), ``"n_unresolved"`` (steps with more impacts
        than ``max_impacts_per_step``; nonzero only with ``throw=False``), ``"dt"`` (solver
        step [s]); with ``wall_motion`` also ``"t_heel"`` [s]: the first sample at which the
        rigid block, its wall receded behind its base, would rock on its heel (it lands on its
        base, the ground throws it inward while it stands, or the wall passes the base under
        it fast enough to throw it), ``inf`` if never. The history is the rigid block's up to
        that time only (docs/three_branch.md, "Moving return walls").

    Raises:
        ValueError: on invalid input, with the value, its unit and the fix.

    References:
        Housner, G. W. (1963), BSSA 53(2):403-417. The paper, Eqs. (2) and (5).
    """
    mode, law = _check_arguments(
        block,
        motion,
        e,
        mode,
        theta0,
        theta_dot0,
        duration,
        dt,
        max_impacts_per_step,
        law,
        wall_motion,
    )
    loop_kind, checkpoints = _loop_kind(adjoint)
    controller = _check_solver(solver, stepsize_controller, motion, dt, wall_motion)
    dt_out, n_out, ag, ag_v, dt_max = _record_arrays(motion, duration, dt)
    n_sub = _substeps(block, law, dt_out, dt_max)

    wall = None
    if wall_motion is not None:
        if n_out > motion.n:
            raise ValueError(
                f"with wall_motion the run cannot outlast the record ({motion.n} samples, "
                f"{(motion.n - 1) * motion.dt:g} s): the wall's motion after it is unknown; got "
                f"duration={duration} s. Pad the record and the wall motion yourself."
            )
        wall = wall_series(wall_motion, motion, block, n_out)

    one_sided = mode.one_sided
    default_e = e is None
    if default_e:
        e = mode.default_e(block.eta)
    check_restitution(e, mode, default=default_e)
    # Compile once per bucket: with nothing traced the record is padded (its last sample
    # repeated, which the solver's evaluation beyond the end already holds) and its length
    # passed as data. Under the caller's jit/vmap/grad their transform fixes the shapes.
    traced = is_traced(block, ag, ag_v, e, theta0, theta_dot0, law, wall)
    n_pad = n_out if traced else bucket_length(n_out)
    # an eager call converts in NumPy: each eager jnp conversion is a dispatch (~0.03 ms)
    xp = jnp if traced else np

    def floats(tree):
        return jax.tree.map(lambda x: xp.asarray(x, dtype=float), tree)

    block = floats(block)
    e = xp.asarray(e, dtype=float)
    theta_dot0 = _first_step_velocity(theta_dot0, theta0, e, dt_out / n_sub)
    inputs = (
        block,
        pad_to(ag, n_pad),
        None if ag_v is None else pad_to(ag_v, n_pad),
        mode.e_magnitude(e),
        xp.asarray(theta0, dtype=float),
        xp.asarray(theta_dot0, dtype=float),
        xp.asarray(dt_out, dtype=float),
        xp.asarray(n_out, dtype=np.int32),
        None if law is None else floats(law),
    )
    options = dict(
        one_sided=one_sided,
        max_impacts=max_impacts_per_step,
        loop_kind=loop_kind,
        checkpoints=checkpoints,
        throw=throw and traced,
    )
    # An eager call checks in Python, after the run: a compiled program with error callbacks
    # (eqx.error_if) cannot go into the persistent compilation cache.
    if solver is None:
        wall = None if wall is None else pad_wall(wall, n_pad, dt_out)
        if not traced and solve.will_compile(*inputs, wall, n_sub=n_sub, **options):
            notice(compile_notice(mode, n_pad, law, wall, ag_v))
        resp, fault = solve(*inputs, wall, n_sub=n_sub, **options)
    else:  # the diffrax path (_diffrax.py)
        resp, fault = solve_events(*inputs, solver=solver, controller=controller, **options)
    if throw and not traced:
        _raise_on_failure(int(resp.status), int(fault), one_sided)
    return resp if n_pad == n_out else _cut(resp, n_out)


def compile_notice(mode, n_pad, law, wall, ag_v) -> str:
    """The one line that says which Housner program a call compiles, and what reuses it."""
    what = [mode.name.replace("_", "-")]
    what += [] if law is None else ["three-branch law"]
    what += [] if wall is None else ["moving return wall"]
    what += [] if ag_v is None else ["vertical motion"]
    return (
        f"rockjax: compiling the Housner solver ({', '.join(what)}) for records of <= "
        f"{n_pad} samples (once per session: every block, e, scale and record of this kind "
        "reuses it)..."
    )


def _check_arguments(
    block, motion, e, mode, theta0, theta_dot0, duration, dt, max_impacts_per_step, law, wall_motion
):
    """The boundary checks of :func:`simulate_housner`'s concrete arguments (``ValueError``
    naming the argument, its unit and the fix). Returns ``(mode, law)``: the mode object
    (:func:`rockjax.as_mode`), a ``ThreeBranchFit`` replaced by its law."""
    check_kind(
        "block",
        block,
        (Block,),
        "simulate_housner rocks one rigid block, e.g. rj.Block(b=0.25, h=3.0); run a wall of "
        "blocks (an rj.Assembly) with rj.simulate_dem or rj.simulate_assembly.",
    )
    mode = as_mode(mode)
    check_gap(mode.gap, used=False, unused=HOUSNER_GAP_UNUSED, hint=GAP_HINT)
    one_sided = mode.one_sided
    if motion is not None and not isinstance(motion, GroundMotion):
        raise ValueError(
            f"motion must be a rockjax GroundMotion (or None for free rocking); got a "
            f"{type(motion).__name__}. Wrap the accelerations with their step: "
            "rj.GroundMotion(ag=ag, dt=0.01) in m/s^2, or rj.GroundMotion.from_g(ag_g, dt=0.01) "
            "in g."
        )
    if isinstance(max_impacts_per_step, bool) or not (
        isinstance(max_impacts_per_step, int) and max_impacts_per_step >= 1
    ):
        raise ValueError(
            f"max_impacts_per_step must be an int >= 1; got {max_impacts_per_step!r}. Use the default, 64."
        )
    if e is not None:
        check_scalar("e", e, "[-]", "e.g. e=0.9, or e=None for the paper's default.")
    check_scalar("theta0", theta0, "rad", "e.g. theta0=0.01.")
    check_scalar("theta_dot0", theta_dot0, "rad/s", "e.g. theta_dot0=0.0.")
    if dt is not None:
        check_positive("dt", dt, "s", "Or leave dt=None.", scalar=True)
    if duration is not None:
        check_positive("duration", duration, "s", "e.g. duration=10.0.", scalar=True)
    _check_theta0(theta0, theta_dot0, block, one_sided)
    if isinstance(law, ThreeBranchFit):  # rj.fit_three_branch(...) passed as it is
        law = law.law
    if law is not None and not isinstance(law, ThreeBranchLaw):
        raise ValueError(
            f"law must be a rockjax ThreeBranchLaw (or None for the rigid block); got a "
            f"{type(law).__name__}. Build one with rj.ThreeBranchLaw(lambda_0=b/h, Delta_1=..., "
            "Delta_2=..., Delta_u=...) (Deltas as fractions of b) or rj.fit_three_branch(...)."
        )
    if wall_motion is not None:
        if not one_sided:
            raise ValueError(
                f"wall_motion needs mode='one_sided' (a facade against its return walls); got "
                f"mode={mode.name!r}. Drop wall_motion for a parapet."
            )
        if motion is None:
            raise ValueError(
                "wall_motion needs the ground motion it is relative to: pass motion=GroundMotion "
                "(free rocking against a moving wall is not supported)."
            )
    return mode, law


def _record_arrays(motion, duration, dt):
    """The run's output step [s], its length in samples, the record's horizontal and vertical
    accelerations [m/s^2] at its samples (NumPy when concrete; zeros for free rocking) and the
    bound on the solver step [s] (None: the step-size rule's)."""
    if motion is None:
        if duration is None:
            raise ValueError(
                "free rocking (motion=None) needs duration, in s: e.g. duration=10.0; "
                "or pass a GroundMotion."
            )
        dt_out = DEFAULT_DT if dt is None else float(dt)
        n_out = check_samples(duration, dt_out)
        ag = np.zeros(n_out)
        ag_v = None
        dt_max = None
    else:
        dt_out = motion.dt
        n_out = motion.n if duration is None else check_samples(duration, dt_out)
        for label, arr in (("ag", motion.ag), ("ag_v", motion.ag_v)):
            a = None if arr is None else concrete(arr)
            if a is not None and not np.all(np.isfinite(a)):
                bad = np.flatnonzero(~np.isfinite(a))
                raise ValueError(
                    f"{label} of record {motion.name!r} has {bad.size} non-finite samples "
                    f"(first at index {bad[0]}, t={bad[0] * dt_out:.4f} s) [m/s^2]. Clean or "
                    "trim the record first."
                )
        ag = _fit(motion.ag, n_out)
        ag_v = None if motion.ag_v is None else _fit(motion.ag_v, n_out)
        dt_max = dt
    if n_out < 2:
        raise ValueError(f"the run must span at least one step; got duration={duration} s.")
    return dt_out, n_out, ag, ag_v, dt_max


def _substeps(block, law, dt_out: float, dt_max) -> int:
    """The step-size rule (module docstring): solver steps per output step, ``ceil(dt_out /
    dt_max)`` with ``dt_max = P_DT_TARGET / p`` by default; a concrete step too coarse for
    the block (``p dt_step > P_DT_LIMIT``) is refused."""
    p = concrete(block.p)
    if p is not None and law is not None:
        p = law_frequency(p, concrete(block.eta), law)
    if dt_max is None:
        dt_max = dt_out if p is None else P_DT_TARGET / float(np.max(p))
    n_sub = max(1, math.ceil(dt_out / dt_max - 1e-9))
    if p is not None and np.max(p) * dt_out / n_sub > P_DT_LIMIT:
        raise ValueError(
            f"the solver step {dt_out / n_sub:.4g} s is too coarse for this block "
            f"(p = {float(np.max(p)):.4g} rad/s, p*dt = {float(np.max(p)) * dt_out / n_sub:.3g} > "
            f"{P_DT_LIMIT}); pass dt <= {P_DT_TARGET / float(np.max(p)):.4g} s or leave dt=None."
        )
    return n_sub


def _cut(resp: Response, n_out: int) -> Response:
    """A run on a padded record cut to its ``n_out`` samples.

    Padded only when nothing is traced: the outputs are concrete, and cut on the host (an eager
    slice of a device array would compile once per length).
    """

    series = (resp.t, resp.theta, resp.theta_dot, resp.d, resp.energy)
    extras = {k: resp.extras[k] for k in ("n_impacts", "t_last_impact", "pivot")}
    series, extras = cut_to((series, extras), n_out)
    return eqx.tree_at(
        lambda r: (r.t, r.theta, r.theta_dot, r.d, r.energy, r.extras),
        resp,
        (*series, {**resp.extras, **extras}),
    )


def _check_solver(solver, controller, motion, dt, wall_motion):
    """The diffrax path's arguments: ``solver`` None or a ``diffrax.AbstractSolver``, and its
    step-size controller an adaptive one (default :func:`default_controller`). Returns the
    controller (None without a solver)."""
    if solver is None:
        if controller is not None:
            raise ValueError(
                "stepsize_controller is used with a diffrax solver only; pass solver=, e.g. "
                "solver=diffrax.Tsit5(), or drop stepsize_controller (the default loop's step "
                "follows dt)."
            )
        return None
    if not isinstance(solver, diffrax.AbstractSolver):
        raise ValueError(
            f"solver must be None (the default loop) or a diffrax solver such as "
            f"diffrax.Tsit5() or diffrax.Dopri8(); got a {type(solver).__name__}."
        )
    if controller is None:
        controller = default_controller()
    if not isinstance(controller, diffrax.AbstractAdaptiveStepSizeController):
        raise ValueError(
            f"stepsize_controller must be an adaptive diffrax controller, e.g. "
            f"diffrax.PIDController(rtol=1e-8, atol=1e-10) (tolerances in rad, rad/s); got a "
            f"{type(controller).__name__}. For fixed steps use solver=None and dt."
        )
    if wall_motion is not None:
        raise ValueError(
            "wall_motion is solved by the default loop only; pass solver=None with wall_motion."
        )
    if motion is not None and dt is not None:
        raise ValueError(
            f"with a diffrax solver the step is the controller's: dt [s] is the output step of "
            f"free rocking only; got dt={dt} with a record. Drop dt, or tighten "
            "stepsize_controller's rtol and atol."
        )
    return controller


def _raise_on_failure(status: int, fault: int, one_sided: bool) -> None:
    """The errors ``throw`` asks for, raised after an eager run (as ``eqx.error_if`` would)."""
    if status == STATUS_BAD_INPUT:
        raise ValueError(f"simulate_housner: {fault_message(fault, one_sided)}")
    if status != STATUS_OK:
        raise RuntimeError(
            f"simulate_housner: {STATE_MESSAGES[status]} Pass throw=False to get "
            "Response.status instead."
        )


def _loop_kind(adjoint) -> tuple[str, int | None]:
    """The ``equinox.internal.while_loop`` kind (and checkpoints) the adjoint differentiates."""
    if adjoint is None:
        return "checkpointed", None
    if isinstance(adjoint, diffrax.RecursiveCheckpointAdjoint):
        return "checkpointed", adjoint.checkpoints
    if isinstance(adjoint, diffrax.ForwardMode):
        return "lax", None  # jvp cannot go through the checkpointed loop's custom_vjp
    raise ValueError(
        f"adjoint must be None or diffrax.RecursiveCheckpointAdjoint() (reverse mode, grad), or "
        f"diffrax.ForwardMode() (jvp); got {type(adjoint).__name__}."
    )


def _fit(a, n: int):
    """``a`` truncated or zero-padded to ``n`` samples (in NumPy when concrete: no compile per
    length)."""
    v = concrete(a)
    if v is None:
        a = jnp.asarray(a, dtype=float)
        return a[:n] if a.shape[0] >= n else jnp.pad(a, (0, n - a.shape[0]))
    return v[:n] if v.shape[0] >= n else np.pad(v, (0, n - v.shape[0]))


def check_restitution(e, mode: Mode, default: bool) -> None:
    """Refuse a concrete restitution ``e`` [-] outside (0, 1] (one-sided: its magnitude), naming
    the paper's default (Eq. 2, Eq. 5) when ``default`` (it leaves that range for squat blocks).
    A traced ``e`` is checked in-graph by the solver."""
    v = concrete(e)
    if v is None:
        return
    mag = mode.e_magnitude(v)
    if np.all(np.isfinite(v)) and np.all(mag > 0) and np.all(mag <= 1):
        return
    one_sided = mode.one_sided
    if default:
        eq = "Eq. (5) e_1sr" if one_sided else "Eq. (2) e_H"
        raise ValueError(
            f"the default restitution {eq} = {float(np.min(v)):.4g} is not usable for this block "
            "(e_H <= 0 for eta >= 54.7 deg; e_1sr = 0 at eta = 35.3 deg); pass e explicitly, "
            "0 < e <= 1."
        )
    which = "0 < |e| <= 1 (its magnitude is used)" if one_sided else "0 < e <= 1"
    raise ValueError(
        f"e (coefficient of restitution, dimensionless) must satisfy {which}; got e={e}. "
        "Leave e=None for the paper's default (Eq. 2 two-sided, Eq. 5 one-sided)."
    )


def _first_step_velocity(theta_dot0, theta0, e, dt_step: float):
    """``theta_dot0`` [rad/s] limited to ``(2 pi + |theta0|) / (|e| dt_step)``: a start that
    carries the block through ``2 pi`` rad (past any overturning rotation, ``theta_u <= 2 eta
    < pi``, even after an impact that keeps ``|e|`` of its speed) within the first solver step
    ``dt_step`` [s]: gravity and a record of up to 10 g take at most ``11 (p dt_step)^2 / 2``
    rad of that swing, 1.4 rad at the coarsest step allowed (``p dt_step = 0.5``). A faster
    start overturns in that step all the same, while the solver's rotation polynomials would
    overflow to NaN on it (1e6 rad/s)."""
    vals = [concrete(x) for x in (theta_dot0, theta0, e)]
    if all(v is not None for v in vals):  # NumPy: an eager jnp op would compile
        w, th, e_c = vals
        cap = (2.0 * np.pi + np.abs(th)) / (np.abs(e_c) * dt_step)
        return np.clip(w, -cap, cap)
    cap = (2.0 * jnp.pi + jnp.abs(theta0)) / (jnp.abs(e) * dt_step)
    return jnp.clip(jnp.asarray(theta_dot0, dtype=float), -cap, cap)


def _check_theta0(theta0, theta_dot0, block: Block, one_sided: bool) -> None:
    th, thd, eta = concrete(theta0), concrete(theta_dot0), concrete(block.eta)
    if thd is not None and not np.all(np.isfinite(thd)):
        raise ValueError(f"theta_dot0 must be finite, in rad/s; got theta_dot0={theta_dot0}.")
    if th is None:
        return
    if not np.all(np.isfinite(th)):
        raise ValueError(f"theta0 must be finite, in rad; got theta0={theta0}.")
    if eta is not None and np.any(np.abs(th) >= eta):
        raise ValueError(
            f"theta0 must satisfy |theta0| < eta = {float(np.max(eta)):.6g} rad (a block released "
            f"at or beyond eta overturns); got theta0={theta0} rad. Give a smaller rotation."
        )
    if one_sided and np.any(th < 0):
        raise ValueError(
            f"a one-sided facade rotates only to theta >= 0 (away from its return walls); got "
            f"theta0={theta0} rad. Use theta0 >= 0 or mode='two_sided'."
        )
    if one_sided and thd is not None and np.any((th == 0) & (thd < 0)):
        raise ValueError(
            f"a one-sided facade at theta0 = 0 cannot move into its return walls; got "
            f"theta_dot0={theta_dot0} rad/s. Use theta_dot0 >= 0."
        )
