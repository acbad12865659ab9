"""The DEM's driver: the scan over the record samples (one output sample each) and, inside
it, over the steps between two samples, with the status and collapse bookkeeping; and the
choices of program layout that XLA:CPU needs (one computation per history, chunks of padded
samples skipped).

Scan layout: the outer scan's body is wrapped in ``jax.checkpoint``, so reverse mode stores
one small carry per sample and recomputes the steps; the inner scan over the ``n_in`` steps
carries the state's fields themselves (one copy of the step in the program). With rockjax's
``xla_cpu_small_while_loop_byte_threshold`` setting (:func:`rockjax.compilation.configure_cpu`) XLA:CPU
compiles the loop as a single kernel without per-iteration dispatch.

Compile once per bucket of record lengths (:mod:`rockjax.compilation`): :func:`run` takes the
true number of samples ``n`` as data when the series are padded beyond it; it then skips the
chunks of :data:`SCAN_CHUNK` samples past ``n`` and freezes the state from there. The number of
steps a sample ``n_in`` may be data too (a ``fori_loop`` with a traced trip count instead of the
inner scan: as fast, measured in benchmarks/bench_compile.py ``--dem-loop``), so a loop over
``beta`` or geometries compiles once.

Open steps: a facade of one block takes each sample whose start is out of reach of its return
wall in open steps of ``dt_out / n_open`` (the step rule without the wall's springs), without
the wall's face; a sample that starts in reach, or whose open steps reach a state in reach, is
taken from its start in steps of ``dt`` (:func:`run`, ``n_open``; docs/theory.md, "Time
stepping"). Under ``vmap`` a batch takes, each sample, the open steps if any of its runs does
and the steps of ``dt`` if any does. A run that has collapsed or failed takes one step a
sample. Both need the steps a sample as data (their loops' trip counts).
"""

from __future__ import annotations

import dataclasses
import math

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import ArrayLike, Int

from ..compilation import bucket_length, persistent_jit
from ..response import (
    STATUS_BAD_INPUT,
    STATUS_MESSAGES,
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_UNSTABLE,
    Response,
)
from ._faces import wall_reach
from ._params import (
    SOLVE_UNROLLED_MAX_BLOCKS,
    STATE_FIELDS,
    DemParams,
    DemState,
    as_arrays,
    as_tuples,
    omega_max,
    stacked,
)
from ._response import AssemblyResponse, block_response
from ._stacked import collapsed_stacked, energy_stacked, step_stacked
from ._step import advance, collapsed, energy, step

REACH_SAMPLES = 1.5
"""A facade's sample is taken in steps of ``dt`` from its start where the wall's penetration
plus this many sample intervals times its rate's magnitude is positive at either end of the
back face (:func:`rockjax.dem.run`, ``n_open``): a prediction, which also keeps in steps of
``dt`` the samples just after the block leaves its wall. The open steps check every state
they make (:data:`REACH_STEPS`). Less conservative choices (0.5 samples of the closing rate,
and the rest of a sample in steps of ``dt`` from the last open state instead of the whole
sample) ran a facade IDA 10 % faster, and more than doubled the 95th percentile of its peak errors
against a 4x finer step (docs/verification.md, "Open steps")."""

REACH_STEPS = 2.0
"""An open step's state is in reach of the return wall where its penetration plus this many
open steps times its rate is positive (the wall's force needs ``> -|rate| dt_open / 2``, and
the next state moves by ``rate dt_open``); the sample is then taken again from its start in
steps of ``dt``."""

SCAN_CHUNK = 256
"""Samples per chunk of the outer scan when a record is padded to its bucket (:func:`run`
with ``n``): a chunk wholly past the true length is skipped, so a record padded from 2 000 to
32 768 samples runs 120 empty chunks instead of 30 768 samples."""


def padded_length(n: int) -> int:
    """The length [samples] a concrete record of ``n`` samples is padded to by
    :func:`rockjax.simulate_dem`: its bucket (:func:`rockjax.compilation.bucket_length`),
    rounded up to whole chunks of :data:`SCAN_CHUNK` samples."""
    return SCAN_CHUNK * math.ceil(bucket_length(n) / SCAN_CHUNK)


def failure_message(code: int) -> str:
    """The message of a failed run's status ``code`` (what ``throw`` raises)."""
    return (
        f"rockjax.simulate_dem: {STATUS_MESSAGES[code]}. "
        "Pass throw=False to get a per-run status instead."
    )


@persistent_jit
def run(
    p: DemParams,
    st0: DemState,
    ag,
    ag_v,
    dt,
    dt_out,
    n_in: int | Int[ArrayLike, ""],
    save: tuple = (),
    throw: bool = False,
    top=None,
    wall=None,
    n=None,
    one_history: bool = False,
    layout: str | None = None,
    n_open=None,
) -> AssemblyResponse:
    """The DEM run from a prepared state: what :func:`rockjax.simulate_dem` calls once it has
    checked its inputs (use it for set-ups it does not offer, e.g. a block dropped flat).

    An outer scan over the record samples, ``n_in`` steps of ``dt`` [s] each (the base
    accelerations ``ag``, ``ag_v`` [m/s^2] linear in between), assembled into an
    :class:`AssemblyResponse` (per-block series, also for one block) all inside one jit.
    Nothing is checked here: ``p`` from :func:`rockjax.dem.dem_params`, ``st0`` e.g. from
    :func:`rockjax.dem.initial_state`, ``dt = dt_out / n_in``.

    Args:
        n_in: Steps per record sample: a Python ``int`` (static: the steps run as a scan of
            that length, differentiable in reverse mode; a new value compiles a new program)
            or an integer array (data: the steps run as a loop whose trip count is traced, so
            every ``n_in``, i.e. every ``beta`` and geometry, shares one program; forward mode
            only). The two give the same history to round-off (0 to 7e-21 of its peak,
            benchmarks/bench_compile.py ``--dem-loop``). The eager
            :func:`rockjax.simulate_dem` passes it as data.
        save: Extra outputs, ``"energy"`` and/or ``"forces"``.
        throw: Fail loudly (``eqx.error_if``) on a failed status; else report it.
        top: ``None``, or the top restraint's displacement [m] and velocity [m/s] relative to
            the base at the samples, linear between them as ``ag``.
        wall: ``None`` (fixed return walls, or none), or a moving wall's ``(u_top, v_top)``
            [m, m/s] likewise.
        n: The true number of samples (an integer array: data, not a shape), when ``ag`` and
            the other series are padded beyond it (:func:`rockjax.compilation.pad_to`); None:
            all. From sample ``n`` on the state, the running maxima, ``overturned`` and
            ``status`` are frozen, and whole chunks of :data:`SCAN_CHUNK` padded samples are
            skipped; the outputs hold the series up to the padded length (cut them to ``n``
            samples). Every record whose length pads to one length shares one program.
        one_history: One history outside any transform: the step's shared values are kept
            as one XLA computation each (:func:`rockjax.dem.step`).
        layout: How a stack's step is laid out: ``"unrolled"`` (every block and joint
            written out, :func:`rockjax.dem.step`), ``"stacked"`` (array operations over the
            blocks: a program whose size does not grow with the stack's height), or None:
            stacks of :data:`rockjax.dem.STACKED_MIN_BLOCKS` blocks or more stacked
            (:data:`rockjax.dem.STACKED_MIN_BLOCKS_ONE` with ``one_history``), the others
            unrolled; with ``one_history`` a stack of up to
            :data:`rockjax.dem.SOLVE_UNROLLED_MAX_BLOCKS` blocks then writes its solve out
            block by block (a cheaper step; its reverse-mode program compiles several times
            slower, so a caller inside a transform names the layout, as
            :func:`rockjax.simulate_dem` does). A row of blocks side by side is always
            unrolled. The layouts give the same history to round-off.
        n_open: A facade of one block (``p.one_sided``): the steps a sample while its return
            wall is out of reach (an integer array <= ``n_in``, with ``n_in`` data), or None:
            every sample in ``n_in`` steps. A sample whose start is within
            :data:`REACH_SAMPLES` samples of the wall at its rate runs ``n_in`` steps;
            the others run open steps of ``dt_out / n_open`` while every state stays out of
            reach (:data:`REACH_STEPS`), and where one does not, ``n_in`` steps from the
            sample's start. The wall's force is zero in every open step (its
            springs do not set that step, and its face is not computed), and the switch
            between steps keeps central differences second order (:func:`rockjax.dem.step`,
            ``dt_next``). With ``n_in`` data, a run that has collapsed or failed takes one
            step a sample.
    """
    vec = stacked(p, layout, one_history)
    # the default rule in one history (the eager call) writes a stack's solve out: under a
    # transform the caller names the layout (the reverse-mode program of a 10-block stack
    # with the solve written out compiled in 123 s, with the scan in 22 s)
    written_out = vec and one_history and layout is None and p.n <= SOLVE_UNROLLED_MAX_BLOCKS
    st0 = as_arrays(st0) if vec else as_tuples(st0)

    def nxt(a):
        return jnp.concatenate([a[1:], a[-1:]])

    ag_next, agv_next = nxt(ag), nxt(ag_v)
    if top is None:
        zeros = jnp.zeros_like(ag)
        top_xs = (zeros, zeros, zeros, zeros)
    else:
        top_xs = (top[0], nxt(top[0]), top[1], nxt(top[1]))
    static = isinstance(n_in, int)
    # a facade of one block steps by dt_out / n_open while its return wall is out of reach
    sub = p.one_sided and p.n == 1 and n_open is not None and not static
    off = dataclasses.replace(p, one_sided=False) if sub else None  # the wall out of reach
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
        zero = jnp.zeros_like(a0)
        if moving:
            p0, p1, q0, q1 = xs[8:]
        # a run that has collapsed or failed is frozen (below): its sample takes one step,
        # for the accelerations it reports, where the trip count is data
        halt = overturned | (status != STATUS_OK)
        dt_prev = carry[-1] if sub else dt  # the step that led to st

        def wall_at(j, n):
            """A moving wall's ``(u_top, v_top)`` at step ``j`` of ``n`` (None: fixed)."""
            return (p0 + j * (p1 - p0) / n, q0 + j * (q1 - q0) / n) if moving else None

        def substep(s_, j, n, h, h_next=None, p_=p):
            """The ``j``-th of ``n`` steps of ``h`` in the sample (``h_next``: the next step
            where it differs, :func:`rockjax.dem.step`): the new state, the values the sample
            records of it (as scalars, not a stacked vector: XLA:CPU would build a vector
            element by element, each element's fusion recomputing the step) and a moving
            wall's power."""
            tm = None if top is None else (u0 + j * (u1 - u0) / n, w0 + j * (w1 - w0) / n)
            wm = wall_at(j, n)
            ag_j, agv_j = a0 + j * (a1 - a0) / n, v0 + j * (v1 - v0) / n
            if vec:
                s_, acc, power, rec = step_stacked(
                    p, s_, ag_j, agv_j, h, top_motion=tm, wall=wm, written_out=written_out
                )
                # whole arrays (the unrolled layout's scalars, in the same order)
                flat = [acc]
            else:
                s_, acc, power, rec = step(
                    p_, s_, ag_j, agv_j, h, top_motion=tm, wall=wm, one_history=one_history,
                    dt_next=h_next,
                )  # fmt: skip
                flat = [v for row in acc for v in row]
            if work:
                flat.append(power)
            if forces and p_ is p:  # (an open step's values are not recorded)
                if vec:
                    flat += [rec["normal"], rec["shear"]]
                else:
                    flat += [*rec["normal"], *rec["shear"]]
                flat += [rec["restraint"]] if p.restrained else []
                if p.one_sided:
                    flat += [rec["wall"]] if vec else rec["wall"]
            return s_, flat, power

        if sub:
            # a sample whose start is out of reach of the return wall in open steps (the
            # step without the wall's face: the wall's force is zero there), unless a state
            # they reach is in reach; then, as a sample that starts in reach, in steps of dt
            # from its start (module docstring, "Open steps"). Two loops with traced trip
            # counts: one run skips what it does not take; under vmap a run waits, masked,
            # for the others
            dt_o = dt_out / n_open
            w_in = carry[3] if work else zero
            # the first step, at the sample time (what the sample records), and its state
            # after a step of dt instead (its accelerations do not depend on the next step)
            new_o, first, power = substep(st, zero, n_in, dt_prev, dt_o)
            moved = advance(*(getattr(st, f)[0] for f in STATE_FIELDS), *first[:3], dt_prev, dt)
            new_c = dataclasses.replace(new_o, **{f: (moved[f],) for f in STATE_FIELDS})
            released = jax.tree.map(jnp.zeros_like, st.fs_wall)

            def reach(s_, k):
                return wall_reach(p, s_, REACH_STEPS * dt_o, wall_at(k, n_open))

            closed = wall_reach(p, st, REACH_SAMPLES * dt_out, wall_at(zero, n_open))
            closed = closed | reach(new_o, zero + 1.0)

            def open_step(c):
                k, _, s_ = c
                # (the wall's shear springs stay released, as a full step leaves them)
                s_, _, _ = substep(dataclasses.replace(s_, fs_wall=()), k, n_open, dt_o, p_=off)
                s_ = dataclasses.replace(s_, fs_wall=released)
                return k + 1.0, reach(s_, k + 1.0), s_

            _, closed, new = jax.lax.while_loop(
                lambda c: ~halt & ~c[1] & (c[0] < n_open), open_step, (zero + 1.0, closed, new_o)
            )

            def closed_step(c):
                k, s_, w_ = c
                s_, _, power = substep(s_, k, n_in, dt)
                return k + 1.0, s_, w_ + dt * power

            _, new_c, w_c = jax.lax.while_loop(
                lambda c: ~halt & closed & (c[0] < n_in),
                closed_step,
                (zero + 1.0, new_c, w_in + dt * power),
            )
            new = jax.tree.map(lambda c_, o: jnp.where(closed, c_, o), new_c, new)
            dt_last = jnp.where(closed, dt, dt_o)
            # (open steps do no work: the wall is out of reach)
            w_out = jnp.where(closed, w_c, w_in + dt_o * power)
            done = (new, None, None) + ((w_out,) if work else ())
        elif p.n == 1:
            # a block's step is small: the sample's first step is a copy of its own, whose
            # accelerations are read directly, and the scan runs the other n_in - 1
            new, first, power = substep(st, zero, n_in, dt)
            init = (new, zero + 1.0) + ((carry[3] + dt * power,) if work else ())

            def inner(c, _):
                s_, j = c[:2]
                s_, _, power = substep(s_, j, n_in, dt)
                return (s_, j + 1.0) + ((c[2] + dt * power,) if work else ()), None

            if static:
                if n_in > 1:
                    init, _ = jax.lax.scan(inner, init, length=n_in - 1)
            else:  # a traced trip count: one program for every n_in
                trips = jnp.where(halt, 1, n_in)
                init = jax.lax.fori_loop(1, trips, lambda _, c: inner(c, None)[0], init)
            new = init[0]
            done = (new, None, None) + init[2:]
        else:
            # one scan over the n_in steps (one copy of the step in the program); the
            # accelerations of the first step, at the sample time, travel in the carry (with
            # a moving wall, its power at the sample time and its work summed over the steps)
            def inner(c, _):
                s_, j, first = c[:3]
                s_, flat, power = substep(s_, j, n_in, dt)
                first = tuple(jnp.where(j == 0.0, v, f) for v, f in zip(flat, first))
                if work:
                    return (s_, j + 1.0, first, c[3] + dt * power), None
                return (s_, j + 1.0, first), None

            if vec:
                first0 = jax.eval_shape(lambda s_: substep(s_, zero, n_in, dt)[1], st)
                first0 = tuple(jnp.zeros(a.shape, a.dtype) for a in first0)
            else:
                n_forces = (2 * p.n + p.restrained + (p.n if p.one_sided else 0)) if forces else 0
                first0 = tuple(zero for _ in range(n_acc + n_forces))
            init = (st, zero, first0) + ((carry[3],) if work else ())
            if static:
                done, _ = jax.lax.scan(inner, init, length=n_in)
            else:
                trips = jnp.where(halt, 1, n_in)
                done = jax.lax.fori_loop(0, trips, lambda _, c: inner(c, None)[0], init)
            new, first = done[0], done[2]
        wall_now = (p0, q0) if moving else None
        if vec:
            vel = jnp.stack([st.vx, st.vy, st.w], axis=-1) + 0.5 * dt_prev * first[0]
            out = {
                "theta": st.theta,
                "theta_dot": vel[:, 2],
                "x": st.x - p.x0,
                "y": st.y,
                "d": st.x - p.x0 + 0.5 * p.h * st.s,
            }
            if "energy" in save:
                out["energy"] = energy_stacked(p, st, vel, wall_now)
            if work:
                out["work_wall"] = carry[3] + 0.5 * dt_prev * first[1]
            if forces:
                rec = first[1 + work :]
                out["normal_forces"], out["shear_forces"] = rec[0], rec[1]
                if p.restrained:
                    out["restraint_force"] = rec[2]
                if p.one_sided:
                    out["wall_forces"] = rec[2 + p.restrained]
            over = overturned | collapsed_stacked(p, new)
        else:
            vel = [
                (
                    st.vx[k] + 0.5 * dt_prev * first[3 * k],
                    st.vy[k] + 0.5 * dt_prev * first[3 * k + 1],
                    st.w[k] + 0.5 * dt_prev * first[3 * k + 2],
                )
                for k in range(p.n)
            ]
            out = {
                "theta": jnp.stack(st.theta, axis=-1),
                "theta_dot": jnp.stack([v[2] for v in vel], axis=-1),
                "x": jnp.stack(st.x, axis=-1) - p.x0,
                "y": jnp.stack(st.y, axis=-1),
                "d": jnp.stack(
                    [st.x[k] - p.x0[k] + 0.5 * p.h[k] * st.s[k] for k in range(p.n)], axis=-1
                ),
            }
            if "energy" in save:
                out["energy"] = energy(p, st, vel, wall_now, one_history)
            if work:
                # as rockjax.simulate_dem: the steps' power x dt summed, half a step past the
                # sample (the constant half step of the first sample is taken off at the end)
                out["work_wall"] = carry[3] + 0.5 * dt_prev * first[3 * p.n]
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
            over = overturned | collapsed(p, new)
        leaves = jax.tree_util.tree_leaves(new)
        bad = ~jnp.all(jnp.stack([jnp.all(jnp.isfinite(v)) for v in leaves]))
        status = jnp.where(
            status != STATUS_OK,
            status,
            jnp.where(unstable, STATUS_UNSTABLE, jnp.where(bad, STATUS_NONFINITE, STATUS_OK)),
        )
        keep = overturned | (status != STATUS_OK)
        new = jax.tree_util.tree_map(lambda a, b: jnp.where(keep, a, b), st, new)
        rest = (jnp.where(keep, carry[3], done[3]),) if work else ()
        if sub:
            rest += (jnp.where(keep, dt_prev, dt_last),)
        return (new, over, status, *rest), out

    outer = jax.checkpoint(outer, prevent_cse=False)
    status0 = jnp.where(bad_input, STATUS_BAD_INPUT, STATUS_OK)
    carry0 = (st0, jnp.zeros((), bool), status0) + ((jnp.zeros(()),) if work else ())
    if sub:
        carry0 += (jnp.asarray(dt, float),)
    xs = (ag, ag_next, ag_v, agv_next, *top_xs, *wall_xs)
    if n is None:
        (st, overturned, status, *_), out = jax.lax.scan(outer, carry0, xs)
    else:
        (st, overturned, status, *_), out = scan_to(outer, carry0, xs, n)
    work_wall = None
    if work:
        work_wall = out["work_wall"] - out["work_wall"][0]
    elif p.one_sided and "energy" in save:  # a fixed wall does no work
        work_wall = jnp.zeros_like(out["energy"])
    if throw:
        for code in (STATUS_BAD_INPUT, STATUS_UNSTABLE, STATUS_NONFINITE):
            msg = failure_message(code)
            out["theta"] = eqx.error_if(out["theta"], status == code, msg)
    return AssemblyResponse(
        t=jnp.arange(ag.shape[0]) * dt_out,
        theta=out["theta"],
        theta_dot=out["theta_dot"],
        x=out["x"],
        y=out["y"],
        d=out["d"],
        d_max=st.d_max if vec else jnp.stack(st.d_max),
        overturned=overturned,
        status=status,
        theta_max=st.theta_max if vec else jnp.stack(st.theta_max),
        eta=p.eta,
        energy=out.get("energy"),
        dt=jnp.asarray(dt, float),
        work_wall=work_wall,
        normal_forces=out.get("normal_forces"),
        shear_forces=out.get("shear_forces"),
        restraint_force=out.get("restraint_force"),
        wall_forces=out.get("wall_forces"),
        dt_open=jnp.asarray(dt_out / n_open, float) if sub else None,
    )


@persistent_jit
def run_block(
    p: DemParams,
    st0: DemState,
    ag,
    ag_v,
    dt,
    dt_out,
    n_in: int | Int[ArrayLike, ""],
    save: tuple = (),
    throw: bool = False,
    top=None,
    wall=None,
    n=None,
    one_history: bool = False,
    n_open=None,
) -> Response:
    """:func:`run` of a single block (an assembly of one), returned as its
    :class:`rockjax.Response` from the same program."""
    r = run(
        p, st0, ag, ag_v, dt, dt_out, n_in, save, throw, top, wall, n, one_history, None, n_open
    )
    return block_response(r, p.b[0])


def scan_to(body, carry0, xs, n):
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
