"""The Housner solver's loop over the record: one ``equinox.internal.while_loop`` of passes
(``run_record``).

Design. The whole record is one loop of passes (an ``equinox.internal.while_loop`` of the kind
the adjoint can differentiate: ``"checkpointed"`` for ``grad``, ``"lax"`` under
``diffrax.ForwardMode`` for ``jvp``), over fixed solver steps: the record samples, each record
step split into ``n_sub`` equal steps. The record is a ``Record`` (samples on a uniform grid,
linear in between); each step uses the exact linear forcing between its two ends. A step is
explored and, for each crossing found, resolved by the next pass; at most
``max_impacts_per_step + 1`` explorations a step. An exploring pass: (1) if at rest, the uplift
time from the linear forcing; (2) a Tsit5 step (diffrax's tableau, unrolled) to the step end;
(3) if ``s theta`` crossed zero (it changed sign, or it dipped below zero and came back: a
graze, seen as a turning point of the step's cubic Hermite fit below zero), the first crossing
time ``tau`` from that fit (bisection, then Newton), handed to the next pass. An impact pass:
a Tsit5 step to ``tau``, one Newton correction ``tau' = tau - theta/theta_dot`` on the true
trajectory with the state advanced linearly to ``tau'``, the impact map and the rest rule; the
next pass explores on from ``tau'``. Each pass holds one Tsit5 step, so the loop body holds one
copy of it. A step that needs more explorations is reported (``STATUS_UNRESOLVED``), never
silently rested. Per-record branches are selects, so batches of records, blocks and
restitution coefficients vectorise (each record of a batch at its own step), and
``grad``/``jvp`` go through the root-finding (the last Newton steps carry the
implicit-function derivative of the impact times). The Tsit5 step sits in a ``lax.cond`` on
whether any record of the batch needs it; the solver's ``cond``s differentiate as selects of
both branches (``cond`` of ``_lax.py``), which halves the time to trace ``grad``. The discrete
state (pivot, flags, impact count, last impact time, running max ``|theta|``) rides along in
the loop state; the loop saves the state at every sample into buffers written once each.
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.numpy as jnp
from jaxtyping import Array

from ._lax import floordiv, mod, where
from ._params import Params
from ._pass import one_pass
from ._record import Record, step_time
from ._state import Hit, Series, State, series
from ._wall import on_the_wall


class _Carry(eqx.Module):
    """The loop state: one pass per iteration, the solver step in progress, the saved samples."""

    y: State
    ta: Array  # the time the state holds at [s]
    k: Array  # the step in progress (int32), from step_time(k) to step_time(k + 1)
    passes: Array  # exploring passes made in this step (int32)
    hit: Hit  # a crossing for the next pass to resolve
    out: Series  # the state at the samples: loop buffers, each sample written once


def end_step(y: State, ta, t1, params: Params) -> State:
    """Close a step at ``t1``. A step that ran out of passes (``ta < t1``) stops the block:
    reported, never silent (``n_unresolved`` makes the status ``STATUS_UNRESOLVED``, an error
    if ``throw``). A block past ``eta`` moving outward is flagged overturned; its state is then
    frozen (``one_pass`` moves nothing once ``overturned``)."""
    unresolved = ta < t1
    y = State(
        theta=where(unresolved, 0.0, y.theta),
        theta_dot=where(unresolved, 0.0, y.theta_dot),
        s=where(unresolved, 0.0, y.s),
        overturned=y.overturned,
        n_impacts=y.n_impacts,
        t_last_impact=y.t_last_impact,
        theta_max=y.theta_max,
        n_unresolved=y.n_unresolved + unresolved,
    )
    goes_over = (y.s != 0) & (jnp.abs(y.theta) > params.theta_u) & (y.theta * y.theta_dot > 0)
    return eqx.tree_at(lambda z: z.overturned, y, where(goes_over, 1.0, y.overturned))


def run_record(
    y0: State,
    record: Record,
    params: Params,
    n_out,
    *,
    n_sub,
    one_sided,
    max_impacts,
    loop_kind,
    checkpoints,
):
    """The whole record as one loop of passes (see the module docstring, "Design").

    Each iteration is one ``one_pass`` of the step in progress; a pass that reaches the step end
    closes the step (``end_step``) and, at a sample, saves the state. The loop stops after
    ``(n_out - 1) n_sub`` steps: ``n_out`` is data, so records of any length up to the
    padded length of ``record`` share one compilation.
    """
    n_pad = record.ag.shape[0]
    dt_out = record.dt
    dt_step = dt_out / n_sub
    n_steps = (n_out - 1) * n_sub

    def cond(c):
        return c.k < n_steps

    def body(c):
        active = c.k < n_steps  # False only for a finished record of a vmap batch
        t1 = step_time(c.k + 1, n_sub, dt_out, dt_step)
        t0 = step_time(c.k, n_sub, dt_out, dt_step)
        y, ta, hit = one_pass(c.y, c.ta, c.hit, c.k, t0, t1, record, params, one_sided)
        # A step may explore max_impacts + 1 times, each exploration that finds a crossing
        # followed by its impact pass; then it ends, resolved (ta = t1) or not.
        passes = c.passes + (~c.hit.pending).astype(jnp.int32)
        ends = ~hit.pending & ((ta >= t1) | (passes > max_impacts))
        y = jax.tree.map(lambda a, b: where(ends, a, b), end_step(y, ta, t1, params), y)
        k = c.k + ends.astype(jnp.int32)
        save = active & ends & (mod(k, n_sub) == 0)
        i = jnp.minimum(floordiv(k, n_sub), n_pad - 1)
        new = series(y)
        # field by field: inside the loop the buffers are not ordinary pytree leaves
        out = Series(
            *(
                eqxi.buffer_at_set(getattr(c.out, f.name), i, getattr(new, f.name), pred=save)
                for f in dataclasses.fields(Series)
            )
        )
        return _Carry(
            y=y,
            ta=where(ends, t1, ta),
            k=k,
            passes=where(ends, 0, passes),
            hit=hit,
            out=out,
        )

    out0 = jax.tree.map(lambda v: jnp.zeros(n_pad, v.dtype).at[0].set(v), series(y0))
    zero = jnp.zeros((), jnp.int32)
    t0 = jnp.zeros_like(y0.theta)
    hit0 = Hit(
        pending=jnp.zeros((), bool),
        tau=t0,
        t_hi=t0,
        level=None if params.law is None else jnp.zeros_like(t0),
    )
    carry0 = _Carry(y=y0, ta=t0, k=zero, passes=zero, hit=hit0, out=out0)
    ag_v0 = None if record.ag_v is None else record.ag_v[0]
    wall0 = None if record.wall_theta is None else (record.wall_theta[0], record.wall_rate[0])
    carry0 = entangle(carry0, (params, record.ag[0], ag_v0, record.dt, wall0))
    carry = eqxi.while_loop(
        cond,
        body,
        carry0,
        max_steps=(n_pad - 1) * n_sub * 2 * (max_impacts + 1),
        buffers=lambda c: c.out,
        kind=loop_kind,
        checkpoints=checkpoints,
    )
    carry = entangle(carry)
    if record.wall_theta is None:
        return carry.out, carry.y
    return on_the_wall(carry.out, carry.y, record, n_out)


def entangle(tree, others=()):
    """``tree`` with a zero added to each float leaf that depends on every float leaf of
    ``tree`` and ``others``: the values are unchanged, and so are the derivatives.

    Why: under ``jvp``/``grad`` the checkpointed loop first finds which carried values depend
    on the inputs (a fixed point over traces of the body) and which receive cotangents (another
    one). Entangled before and after the loop, every carried value does so from the start and
    each search ends after one trace of the body instead of three: it halves the time to
    trace ``grad`` of a run.
    """

    def is_float(x):
        return jnp.issubdtype(jnp.result_type(x), jnp.floating)

    # Arrays (the saved series) take part through their first element: O(1), not O(length).
    total = sum(
        x if jnp.ndim(x) == 0 else x[0] for x in jax.tree.leaves((tree, others)) if is_float(x)
    )
    zero = where(jnp.isfinite(total), 0.0 * total, 0.0)  # 0 * inf would be NaN

    def add(x):
        if not is_float(x):
            return x
        return x + zero if jnp.ndim(x) == 0 else x.at[0].add(zero)

    return jax.tree.map(add, tree)
