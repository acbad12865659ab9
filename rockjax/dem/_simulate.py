"""The public entry points of the DEM: :func:`simulate_dem` (a block, or an assembly of
blocks), :func:`stable_dt`, and their checks of the user's inputs."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from .._checks import check_choice, check_positive, check_samples, check_scalar, concrete
from .._types import ScalarLike
from ..assembly import Assembly
from ..block import Block
from ..compilation import is_batched, is_traced, notice, pad_to
from ..contact import Joint
from ..modes import Mode
from ..motion import GroundMotion
from ..response import STATUS_BAD_INPUT, STATUS_OK, Response
from ..supports import resolve_supports
from ._params import (
    as_assembly,
    check_accuracy,
    check_params,
    mode_of,
    stacked_layout,
)
from ._response import AssemblyResponse, cut, cut_block
from ._run import failure_message, padded_length, run, run_block
from ._state import check_theta0, set_up

SAVE_OPTIONS = ("energy", "forces")

DEFAULT_SAVE_DT = 0.002
"""Output interval [s] for free rocking (no record)."""


def simulate_dem(
    block: Block | Assembly,
    motion: GroundMotion | None = None,
    *,
    beta=0.0,
    mode: Mode | str = "two_sided",
    gap=None,
    theta0=0.0,
    duration: float | None = None,
    dt: ScalarLike | None = None,
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
) -> Response | AssemblyResponse:
    """Simulate the DEM of a rigid block, or of an assembly of blocks, under a ground motion
    and/or a free release.

    One model for both: a block is the assembly of one (its base joint, and with
    ``mode="one_sided"`` its back face on the return wall), so ``simulate_dem(block, ...)``
    and ``simulate_dem(rj.Assembly.stack([block]), ...)`` give the same history to the bit.

    Compiles once per bucket of record lengths (:mod:`rockjax.compilation`): called with
    concrete inputs, the record is padded to :func:`padded_length` ``(n)`` samples (32 768 for
    records up to that length) and its length passed as data, and the number of steps a
    sample is data too, so a loop over records of different lengths (or free-rocking
    durations) and steps, over ``beta``, ``gap`` or block geometries compiles once. Inside
    ``jit``/``vmap``/``grad`` the caller's transform fixes the shapes. Many facades of one
    block run fastest one after another on CPU (``rj.ida``, or ``jax.lax.map`` under ``jit``):
    each takes its own open steps, where a ``vmap`` batch takes, each sample, those of all its
    runs (32 far-field runs: 0.42 s in a loop, 1.53 s as a ``vmap`` batch;
    ``benchmarks/bench_facade_batch.py``). Many parapets run fastest through
    :func:`rockjax.vmap_chunks` (chunks of a ``vmap`` batch in threads, one per core).

    In a building (an assembly with ``support_motion=bldg``), the wall of storey ``storey``
    stands on floor ``storey - 1`` (0 the ground) and its top restraint is held by floor
    ``storey``: the run is in the frame of the base floor (the ground acceleration is the base
    floor's absolute acceleration) and the restraint moves by the storey's drift,
    docs/assemblies.md "Supports in a building".

    Args:
        block: The block (geometry and material), or an :class:`rockjax.Assembly` of several
            blocks (per-block ``theta``, ``x``, ``y`` in an :class:`AssemblyResponse`;
            ``mode="one_sided"`` puts every block's back face on a return wall).
        motion: Ground motion; ``None`` for free rocking (then ``duration`` is required).
        beta: Stiffness-proportional Rayleigh damping coefficient [s], Eq. (1), alpha = 0.
        mode: :class:`rockjax.Parapet` (``"two_sided"``) or :class:`rockjax.Facade`
            (``"one_sided"``: a return wall at -x, its ``gap`` behind the back face).
        gap: With ``mode="one_sided"``: the facade's gap between the back face and the
            return wall [m]; default None (0, or the Facade's own; :func:`rockjax.as_mode`).
        theta0: Initial rotation [rad], released from rest on its pivot corner; ``|theta0| <
            eta`` (of the whole stack about block 0's corner); a restrained two-block wall is
            released in its hinge mechanism; ``theta0 >= 0`` one-sided.
        duration: Length of the run [s]; default the record's. A longer duration appends zeros
            (free vibration after the record); a shorter one truncates it.
        dt: Time step [s]; default :func:`stable_dt` (chosen for accuracy, see ``accuracy``).
            The step used is the largest divisor of the output step not above ``dt``. A step
            above the stability limit is refused. Inside a transform, a concrete ``dt`` fixes
            the steps a sample in the program; a traced one makes them data (one program for
            every step; forward mode and ``vmap`` only, a reverse-mode derivative cannot run
            a loop of traced length), its stability checked in the run. A facade of one block
            steps by ``dt`` only where its return wall is in reach, and elsewhere by the longer
            open step ``extras["dt_open"]`` (set by its base alone; docs/theory.md, "Time
            stepping"), scaled with ``dt``; with a concrete ``dt`` inside a transform it steps
            by ``dt`` throughout.
        accuracy: Accuracy of the default step, ``omega_max dt (1 + zeta)`` [-] (ignored when
            ``dt`` is given); default the mode's ``dt_accuracy`` (``dt_accuracy_sub`` with
            integer ``n_sub``; :data:`DT_ACCURACY`), which puts the first-impact ``e`` within 1e-3 of its converged value
            (docs/verification.md). Smaller is finer.
        joint: The contact joint of every interface, :class:`rockjax.Joint`: by default the
            contact law integrated in closed form over each face (the ``n_sub -> infinity``
            limit of the sub-contacts; docs/theory.md, "Integrated face contact"), the closed
            dashpot and contact onsets located inside the step (responses smooth in
            ``beta``); ``rj.Joint(n_sub=2)`` is the paper's two corner contacts.
        phi_deg: Friction angle [deg]; default 50 (parapets) or 30 (facades), as in the paper.
        save_dt: Output interval for free rocking [s] (default 0.002); with a record, its ``dt``.
        save: Extra outputs: ``"energy"`` (total energy [J]), ``"forces"`` (the joints'
            normal and shear forces [N]; an assembly's top restraint's and return walls' too).
        beta_max: Largest ``beta`` to size the default step for, when ``beta`` is traced.
        throw: Raise (also inside ``jit``) if the run fails; if False, report ``status``.
        wall_motion: A return wall that moves relative to the base (``mode="one_sided"`` only;
            None: fixed). The wall is the back face (a stack's: the line of its back faces)
            rocked rigidly to ``theta_w = u_top / H`` about block 0's toe (its heel for
            ``theta_w < 0``), ``H`` the height: its contact line is ``x = -b/2 - gap +
            theta_w y - (b/2) theta_w^2`` to second order (``y`` above the base;
            docs/pushover.md, "Moving return walls"), so a facade riding on it at ``theta =
            theta_w`` lies flush, as in ``simulate_housner``. Anything
            :func:`rockjax.supports.resolve_supports` accepts: a pair ``(u_top, v_top)`` of
            arrays [m], [m/s] with one value per record sample (traceable), a
            ``ShearBuilding``, the wall's absolute acceleration as a ``GroundMotion``, or
            ``(height, GroundMotion)`` pairs. Linear between samples; past the record's end
            (a longer ``duration``) the wall holds its last position.
        support_motion: An assembly only: the :class:`rockjax.ShearBuilding` whose floors
            carry the wall (with ``storey``), or a pair ``(u, v)`` of arrays: the top
            restraint's displacement [m] and velocity [m/s] relative to the base.
        storey: The storey of ``support_motion`` the wall spans (1-based; its base on floor
            ``storey - 1``, its top restraint following floor ``storey``); default 1.

    Returns:
        For a block, a :class:`rockjax.Response` sampled at the record samples (or every
        ``save_dt``); ``extras`` holds ``x``, ``y`` (centroid [m]), ``d_max`` [m], ``dt`` [s],
        a facade's ``dt_open`` [s] and the requested outputs; for a facade with ``"energy"``
        saved also ``work_wall`` [J], the work done on the block by the return wall since
        ``t = 0`` (zero for a fixed wall), so that ``energy - work_wall`` is conserved without
        damping, slip or ground motion. For an assembly, an :class:`AssemblyResponse`.

    Raises:
        ValueError: on invalid input, with the value, its unit and the fix.
    """
    assembly = as_assembly(block)
    single = isinstance(block, Block)
    if single and (support_motion is not None or storey is not None):
        raise ValueError(
            "support_motion= and storey= place a wall of several blocks (an rj.Assembly) in a "
            "building; a single block on a floor runs on that floor's motion: "
            "rj.simulate_dem(block, bldg.floor_motions(gm)[i], ...), or wrap it as "
            "rj.Assembly.stack([block])."
        )
    save = check_save(save)
    mode = mode_of(block, mode, gap)  # (the gap checked with the message for the kind of body)
    phi_deg = check_params(beta, mode, joint, phi_deg)
    check_theta0(theta0, assembly, mode)
    if wall_motion is not None and not mode.one_sided:
        raise ValueError(
            f"wall_motion (a moving return wall) needs mode='one_sided' (a facade against its "
            f"return wall); got mode={mode.name!r}. Pass mode='one_sided', or drop wall_motion."
        )
    ag, ag_v, dt_out = prepare_motion(motion, duration, save_dt)
    supports = resolve_supports(
        assembly, motion, ag, dt_out, wall_motion=wall_motion,
        support_motion=support_motion, storey=storey,
    )  # fmt: skip
    ag, top, wall = supports.ag, supports.top, supports.wall
    accuracy = check_accuracy(accuracy, mode, joint)
    # the parameters, the steps and the initial state: one program
    p, steps, st0 = set_up(assembly, beta, mode, joint, phi_deg, accuracy, theta0)
    n_in = steps_per_sample(p, block, steps, beta, beta_max, mode, joint, dt, dt_out, accuracy)
    traced = is_traced(p, st0, ag, ag_v, top, wall, n_in)
    # open steps need the steps a sample as data (not a static n_in in a transform: reverse mode)
    n_in, n_open = (n_in, None) if traced and isinstance(n_in, int) else open_steps(p, steps, n_in)
    step = (np if isinstance(n_in, int) else jnp).asarray(dt_out / n_in)
    dt_out = np.asarray(dt_out)
    program = run_block if single else run
    if traced:
        # inside the caller's jit/vmap/grad: their transform fixes the shapes
        one = not is_batched(p, st0, ag, ag_v, top, wall, step)
        args = (save, throw, top, wall)
        kw = dict(one_history=one, n_open=n_open)
        if not single:
            # a stack takes the batch's layout rule in any transform: the reverse-mode program
            # of an unrolled 8-block stack compiled in 69 s, of the stacked one in 22 s
            # (docs/benchmarks.md, "Tall walls: one history and batches")
            kw["layout"] = "stacked" if stacked_layout(p.n, p.row) else "unrolled"
        return program(p, st0, ag, ag_v, step, dt_out, n_in, *args, **kw)
    resp = run_padded(
        program, p, st0, ag, ag_v, step, dt_out, (n_in, n_open), save, top, wall, mode.name
    )
    if throw:
        raise_on_failure(int(resp.status))
    out = (cut_block if single else cut)(resp, ag.shape[0])
    LAST_RESPONSE[:] = [out]
    return out


LAST_RESPONSE: list = []
"""The eager :func:`simulate_dem`'s last Response, referenced until the next eager call
returns its own. A loop that dropped each Response before the next call freed the top of the
process's heap, glibc's allocator gave those pages back to the system, and the next run
faulted them in again: 525 page faults and 0.6 ms of a 20 s history's 3.8 ms, against 4-118
faults with the last Response kept (docs/benchmarks.md, "One history: values read by many")."""


def simulate_assembly(assembly: Assembly, motion: GroundMotion | None = None, **kw):
    """:func:`simulate_dem` of an :class:`rockjax.Assembly` (the same model and keywords),
    returning its :class:`AssemblyResponse`; kept for the name."""
    if not isinstance(assembly, Assembly):
        raise ValueError(
            f"assembly must be a rockjax.Assembly; got a {type(assembly).__name__}. Run a "
            "single block with rj.simulate_dem(block, ...), or wrap it: "
            "rj.Assembly.stack([block])."
        )
    return simulate_dem(assembly, motion, **kw)


def open_steps(p, steps, n_in):
    """``(n_in, n_open)``: the steps a sample, and those of a one-block facade while its
    return wall is out of reach (:func:`rockjax.dem.run`): ``n_in`` over the open ratio of
    ``steps`` (:func:`rockjax.dem.default_step`'s rule at ``Facade.dt_accuracy_open``),
    rounded up; ``n_open = None`` for every other body. Ints for an int ``n_in`` and concrete
    ``steps``, else arrays."""
    if not (p.one_sided and p.n == 1):
        return n_in, None
    ratio = concrete(steps[2])
    if isinstance(n_in, int) and ratio is not None:
        return n_in, min(n_in, max(1, math.ceil(n_in / float(ratio) - 1e-9)))
    n_open = jnp.ceil(n_in / steps[2] - 1e-9).astype(jnp.int32)
    return n_in, jnp.clip(n_open, 1, n_in)


def run_padded(program, p, st0, ag, ag_v, step, dt_out, n_steps, save, top, wall, mode):
    """An eager run of ``program`` (:func:`rockjax.dem.run` or its single block's), padded to
    its bucket (its last sample repeated, which is what the last sample's steps interpolate
    toward anyway) with its length passed as data; the run freezes from there (cut its outputs
    to the record's length on the host). It does not raise: the caller checks its status, as
    a compiled program with error callbacks (``eqx.error_if``) cannot go into the persistent
    compilation cache. ``n_steps``: ``(n_in, n_open)`` (:func:`open_steps`)."""
    n_out = ag.shape[0]
    n_pad = padded_length(n_out)

    def padded(pair):
        return None if pair is None else tuple(pad_to(a, n_pad) for a in pair)

    args = (p, st0, pad_to(ag, n_pad), pad_to(ag_v, n_pad), step, dt_out)
    # n_in as data: every number of steps a sample (beta, the geometry) runs one program
    n_in, n_open = n_steps
    args += (np.asarray(n_in, dtype=np.int32), save, False, padded(top), padded(wall))
    kw = dict(n=np.asarray(n_out, dtype=np.int32), one_history=True)
    if n_open is not None:
        kw["n_open"] = np.asarray(n_open, dtype=np.int32)
    if program.will_compile(*args, **kw):  # not when in memory or kept on disk
        notice(compile_notice(p, mode, n_pad, save, top, wall))
    return program(*args, **kw)


def compile_notice(p, mode, n_pad, save, top, wall) -> str:
    """The one line that says which DEM program a call compiles, and what reuses it."""
    body = "a block" if p.n == 1 else f"an assembly of {p.n} blocks"
    joint = "integrated joint" if p.n_sub == "exact" else f"{p.n_sub} sub-contacts a face"
    extras = [f"saving {', '.join(save)}"] if save else []
    extras += [] if top is None else ["moving top restraint"]
    extras += [] if wall is None else ["moving return wall"]
    what = ", ".join([body, mode.replace("_", "-"), joint, *extras])
    return (
        f"rockjax: compiling the DEM solver ({what}) for records of <= {n_pad} samples "
        "(once per session: every beta, gap, time step and record of this kind reuses it)..."
    )


def raise_on_failure(status: int) -> None:
    """The errors ``throw`` asks for, raised after an eager run with the messages
    ``eqx.error_if`` gives under a transform."""
    if status == STATUS_BAD_INPUT:
        raise ValueError(failure_message(status))
    if status != STATUS_OK:
        raise RuntimeError(failure_message(status))


def check_save(save) -> tuple:
    if isinstance(save, str):
        raise ValueError(
            f"save must be a tuple of output names, e.g. save=({save!r},); got save={save!r}."
        )
    for key in save:
        check_choice("save entry", key, SAVE_OPTIONS)
    return tuple(save)


def steps_per_sample(p, body, steps, beta, beta_max, mode, joint, dt, dt_out, accuracy):
    """The number of steps per record sample: the default step (or ``dt``, checked against
    the stability limit) rounded down to divide the sample step ``dt_out`` [s]. An ``int``;
    an int32 array when ``dt`` is traced. ``steps``: ``p``'s ``(critical_dt, default_step)``
    [s], as :func:`rockjax.dem.default_step` gives them."""
    if dt is not None and concrete(dt) is None:
        # a traced step (e.g. one program for every beta of a batch): the number of steps is
        # data, the inner loop's trip count (forward mode only: reverse mode cannot run a loop
        # whose length is traced); the stability limit is checked in the run (its status)
        check_scalar("dt", dt, "s", "Or leave dt=None (chosen for accuracy).")
        return jnp.maximum(1, jnp.ceil(dt_out / dt - 1e-9)).astype(jnp.int32)
    limit, dt_default = concrete_steps(p, body, steps, beta_max, joint, mode, dt, accuracy)
    if dt is None:
        return max(1, math.ceil(dt_out / dt_default - 1e-9))
    check_positive("dt", dt, "s", "Or leave dt=None (chosen for accuracy).", scalar=True)
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive time step in s; got dt={dt}. Or leave dt=None.")
    if limit is not None and dt > limit * (1 + 1e-9):
        kind = "block" if isinstance(body, Block) else "assembly"
        raise ValueError(
            f"dt={dt:.4g} s exceeds the explicit stability limit {limit:.4g} s of this {kind} "
            f"at beta={fmt(beta)} s. Use dt <= {limit:.4g} s or leave dt=None (default "
            f"{dt_default:.4g} s, chosen for accuracy)."
        )
    return max(1, math.ceil(dt_out / float(dt) - 1e-9))


def fmt(x) -> str:
    v = concrete(x)
    return "(traced)" if v is None else f"{float(v):.4g}"


def concrete_steps(p, body, steps, beta_max, joint, mode, dt, accuracy):
    """``(stability limit, default step)`` [s] as floats, or ``(None, None)`` when they cannot
    be known outside the trace."""
    if beta_max is not None:
        try:  # rebuilt from the body: p may hold tracers when only beta is traced
            with jax.ensure_compile_time_eval():
                check_params(beta_max, mode, joint, 45.0)
                _, steps_max, _ = set_up(body, beta_max, mode, joint, 45.0, accuracy, 0.0)
                return float(steps_max[0]), float(steps_max[1])
        except (jax.errors.ConcretizationTypeError, jax.errors.TracerArrayConversionError):
            raise ValueError(
                "beta_max cannot size the time step when the block itself is traced; pass "
                "dt=rj.stable_dt(block, beta_max) computed outside the transform."
            ) from None
    try:
        return float(steps[0]), float(steps[1])
    except (jax.errors.ConcretizationTypeError, jax.errors.TracerArrayConversionError):
        if dt is not None:
            return None, None  # checked inside the trace (status / error_if)
        raise ValueError(
            "simulate_dem was called with traced inputs (inside jit/vmap/grad), so the time step "
            "cannot be chosen automatically. Pass dt=rj.stable_dt(block, beta_max) computed "
            "outside the transform, or beta_max=<largest beta> [s]."
        ) from None


def stable_dt(
    block: Block | Assembly,
    beta=0.0,
    *,
    mode: Mode | str = "two_sided",
    gap=None,
    joint: Joint = Joint(),
    accuracy: float | None = None,
) -> float:
    """The default DEM time step [s]: stable, and chosen for accuracy (before rounding to
    divide the record step); a facade's where its return wall is in reach (elsewhere a facade
    of one block takes longer open steps, :func:`simulate_dem`).

    ``accuracy / (omega_max (1 + zeta))`` with ``zeta = beta omega_max / 2``, at most
    ``DT_SAFETY`` times the stability limit ``2 / omega_max``, ``omega_max`` the highest
    frequency of the block (or the whole assembly) on all its springs closed (see
    :func:`rockjax.dem.default_step`, docs/theory.md "Time stepping"). It decreases with
    ``beta``, so the step for the largest ``beta`` of a sweep serves them all. Use it to fix
    the step outside a transform and pass it as ``simulate_dem(..., dt=...)`` inside
    ``jit``/``vmap``/``grad``.

    Args:
        block: The block, or an :class:`rockjax.Assembly`.
        beta: Stiffness-proportional damping coefficient [s], Eq. (1).
        mode: :class:`rockjax.Parapet` (``"two_sided"``) or :class:`rockjax.Facade`
            (``"one_sided"``).
        gap: With ``mode="one_sided"``: the facade's gap [m] (does not change the step).
        joint: The contact joint (:class:`rockjax.Joint`; default the integrated face law).
        accuracy: ``omega_max dt (1 + zeta)`` [-]; default the mode's ``dt_accuracy`` (1.0 for
            parapets, 0.35 for facades; 0.5 for parapets with integer ``n_sub``: first-impact
            ``e`` within 1e-3 of its converged value, facade rebound peaks within 2 %;
            docs/verification.md). Smaller is finer; values above ``2 DT_SAFETY / (1 + zeta)``
            give the stability-based step.
    """
    mode = mode_of(block, mode, gap)
    phi_deg = check_params(beta, mode, joint, None)
    # simulate_dem's set-up program (its initial state unused): no program of its own
    accuracy = check_accuracy(accuracy, mode, joint)
    _, steps, _ = set_up(block, beta, mode, joint, phi_deg, accuracy, 0.0)
    return float(steps[1])


def stable_dt_assembly(
    assembly: Assembly,
    beta=0.0,
    *,
    joint: Joint = Joint(),
    accuracy: float | None = None,
    mode: Mode | str = "two_sided",
) -> float:
    """:func:`stable_dt` of an :class:`rockjax.Assembly`; kept for the name."""
    return stable_dt(assembly, beta, mode=mode, joint=joint, accuracy=accuracy)


def check_motion_type(motion) -> None:
    if motion is not None and not isinstance(motion, GroundMotion):
        raise ValueError(
            f"motion must be a rockjax.GroundMotion (or None for free rocking); got "
            f"{type(motion).__name__}. Wrap an acceleration array as "
            "rj.GroundMotion(ag=<m/s^2>, dt=<s>) or rj.GroundMotion.from_g(<g>, dt)."
        )


def prepare_motion(motion, duration, save_dt):
    """``(ag, ag_v, dt_out)``: a checked record as arrays [m/s^2], [m/s^2], [s], zero-padded or
    cut to ``duration`` [s]; free motion (``motion=None``) is zeros every ``save_dt`` [s]
    (default :data:`DEFAULT_SAVE_DT`). NumPy arrays for a concrete record, jnp when traced."""
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
    check_motion_type(motion)
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
