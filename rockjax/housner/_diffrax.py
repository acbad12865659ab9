"""The Housner model through ``diffrax.diffeqsolve``: any diffrax solver with an adaptive
step-size controller, events located by an optimistix root finder (``solve_events``).

One ``equinox.internal.while_loop`` over the record, as the default loop (``_loop.py``), but
each iteration is one ``diffrax.diffeqsolve`` from the time the state holds at to the next
record sample, on which the forcing is the exact linear one (``Record.line``), so the solver
never steps over a kink of the record. The solve ends at the sample or at the first of three
events (``diffrax.Event``, located on the solver's dense output by the root finder):

* impact: ``s theta`` falls through zero; the impact map and the rest rule (``_impact.py``)
  are applied and the next iteration starts from the impact;
* overturning: ``s theta`` rises through the overturning rotation ``theta_u`` (``eta`` for
  the rigid block); the state is frozen there;
* peak: ``s theta_dot`` falls through zero, a turning point of ``|theta|`` counted in
  ``theta_max``. The next solve, which starts on the turning point, has this event disarmed
  until the next impact or sample (it would find the same root again).

Where several events trigger in one step the first of overturning, peak and impact (in that
order) ends the solve: a flight's turning point comes before the impact that ends it, so a
flight shorter than a step still has its peak counted (the next solve finds the impact).

A block at rest lifts where the forcing first exceeds the uplift threshold on the interval
(``find_uplift``, the default loop's rule). The vector field (``theta_ddot``), the impact map,
the uplift and the rest rule are the default loop's own, imported: the two paths differ only
in how a flight is integrated and how its events are located.

What it does not do: a moving return wall (``wall_motion``) is solved by the default loop
only; a crossing and return of ``s theta`` inside one accepted step of the solver (a graze)
is not seen by the event's sign test, where the default loop finds it from the step's cubic
fit (it is rare at the default tolerances, whose steps are a small fraction of a flight).
"""

from __future__ import annotations

import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.numpy as jnp
from jaxtyping import Array

from .._lazy import lazy_module
from ._field import theta_ddot
from ._impact import find_uplift, impact_map, rest_rule
from ._lax import where
from ._params import Params
from ._record import Record
from ._solve import prepare, respond
from ._state import Series, State, series

diffrax = lazy_module("diffrax")
optx = lazy_module("optimistix")

RTOL = 1e-8
"""Default relative tolerance [-] of the diffrax path's step-size controller
(``diffrax.PIDController(rtol=RTOL, atol=ATOL)``)."""

ATOL = 1e-10
"""Default absolute tolerance [rad, rad/s] of the diffrax path's step-size controller."""

ROOT_TOL = 1e-12
"""Relative and absolute tolerance [-, s] of the events' root finder (``optimistix.Newton``)
on the event time."""

MAX_SOLVER_STEPS = 4096
"""Steps one ``diffeqsolve`` (one record interval, or part of it) may take; a solve that needs
more is reported as unresolved (``STATUS_UNRESOLVED``)."""

# The events in diffrax's order of precedence when several trigger in one step: an overturning
# before the turning point past it, a turning point before the impact that ends its flight.
_OVERTURN, _PEAK, _IMPACT = 0, 1, 2


def default_controller():
    """The diffrax path's default step-size controller: ``PIDController(rtol=RTOL,
    atol=ATOL)``."""
    return diffrax.PIDController(rtol=RTOL, atol=ATOL)


class _Carry(eqx.Module):
    """The loop state: the state, the time it holds at, the record interval in progress."""

    y: State
    ta: Array  # [s]
    k: Array  # the interval in progress (int32), from k dt to (k + 1) dt
    armed: Array  # bool: the peak event is armed
    events: Array  # events resolved in this interval (int32)
    out: Series  # the state at the samples: loop buffers


def _field(t, y, args):
    theta, theta_dot = y
    s, line, params = args
    return theta_dot, theta_ddot(t, theta, s, params, line)


def _flight(ta, t1, theta, theta_dot, s, armed, line, params: Params, solver, controller, adjoint):
    """One ``diffeqsolve`` of a flight on pivot ``s`` from ``ta`` to at most ``t1`` [s], ended
    by the first event. Returns ``(t, theta, theta_dot, events, ok)``: where it ended, the
    state there, the ``(overturn, peak, impact)`` mask and whether the solve succeeded."""

    def impact(t, y, args, **kwargs):
        return s * y[0]

    def overturn(t, y, args, **kwargs):
        return s * y[0] - params.theta_u

    def peak(t, y, args, **kwargs):
        return where(armed, s * y[1], -1.0)

    event = diffrax.Event(
        (overturn, peak, impact),
        root_finder=optx.Newton(rtol=ROOT_TOL, atol=ROOT_TOL),
        direction=(True, False, False),
    )
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(_field),
        solver,
        ta,
        t1,
        None,
        (theta, theta_dot),
        args=(s, line, params),
        saveat=diffrax.SaveAt(t1=True),
        stepsize_controller=controller,
        event=event,
        max_steps=MAX_SOLVER_STEPS,
        adjoint=adjoint,
        throw=False,
    )
    mask = jnp.stack([jnp.asarray(m) for m in sol.event_mask])
    theta_b, theta_dot_b = (x[-1] for x in sol.ys)
    return sol.ts[-1], theta_b, theta_dot_b, mask, diffrax.is_okay(sol.result)


def _body(c: _Carry, record: Record, params: Params, n_steps, options) -> _Carry:
    """One iteration: at rest, the uplift on the interval; rocking, one flight to the next
    sample or event and what the event does."""
    one_sided, max_events, solver, controller, adjoint = options
    y = c.y
    dt = record.dt
    t0, t1 = c.k.astype(float) * dt, (c.k + 1).astype(float) * dt
    line = record.line(t0, t1)
    lifts, t_up, s_up = find_uplift(c.ta, t1, line, params, one_sided)
    lift_now = (y.s == 0) & lifts & (y.overturned == 0)
    s = where(lift_now, s_up, y.s)
    ta = where(lift_now, t_up, c.ta)
    rocking = (s != 0) & (y.overturned == 0) & (ta < t1)
    none = jnp.zeros(3, bool)
    t_b, theta_b, theta_dot_b, mask, ok = jax.lax.cond(
        eqxi.unvmap_any(rocking),
        lambda: _flight(
            ta, t1, y.theta, y.theta_dot, s, c.armed, line, params, solver, controller, adjoint
        ),
        lambda: (t1, y.theta, y.theta_dot, none, jnp.ones((), bool)),
    )
    t_b = where(rocking, t_b, t1)
    theta_b = where(rocking, theta_b, y.theta)
    theta_dot_b = where(rocking, theta_dot_b, y.theta_dot)
    mask = mask & rocking
    impact, over, peak = mask[_IMPACT], mask[_OVERTURN], mask[_PEAK]
    failed = rocking & ~ok
    events = c.events + (impact | peak).astype(jnp.int32)
    # a failed solve or too many events in one interval: reported, the block stopped (as
    # the default loop does with a step that runs out of passes)
    stop = failed | (events > max_events)
    impact = impact & ~stop

    theta_dot_plus, s_plus = impact_map(theta_dot_b, s, params.e, one_sided)
    rests, hop = jax.lax.cond(
        eqxi.unvmap_any(impact),
        lambda: rest_rule(t_b, jnp.abs(theta_dot_plus), s_plus, line, record, params, one_sided),
        lambda: (jnp.zeros((), bool), jnp.zeros_like(t_b)),
    )
    rests = impact & rests
    reached = stop | ~(impact | over | peak)
    y_new = State(
        theta=where(stop | impact, 0.0, theta_b),
        theta_dot=where(stop | rests, 0.0, where(impact, theta_dot_plus, theta_dot_b)),
        s=where(stop | rests, 0.0, where(impact, s_plus, s)),
        overturned=where(over & ~stop, 1.0, y.overturned),
        n_impacts=y.n_impacts + impact,
        t_last_impact=where(impact, t_b, y.t_last_impact),
        theta_max=jnp.maximum(
            y.theta_max, where(rocking, jnp.maximum(jnp.abs(theta_b), where(rests, hop, 0.0)), 0.0)
        ),
        n_unresolved=y.n_unresolved + stop,
    )
    active = c.k < n_steps  # False only for a finished record of a vmap batch
    k = c.k + reached.astype(jnp.int32)
    out = Series(
        *(
            eqxi.buffer_at_set(
                getattr(c.out, name),
                jnp.minimum(k, record.ag.shape[0] - 1),
                getattr(series(y_new), name),
                pred=active & reached,
            )
            for name in ("theta", "theta_dot", "s", "n_impacts", "t_last_impact")
        )
    )
    return _Carry(
        y=y_new,
        ta=where(reached, t1, t_b),
        k=k,
        armed=where(peak & ~reached, False, True),
        events=where(reached, 0, events),
        out=out,
    )


def event_loop(y0: State, record: Record, params: Params, n_out, options, loop_kind, checkpoints):
    """The whole record as one loop of ``diffeqsolve`` calls (module docstring). Returns the
    state at the samples and at the end."""
    n_pad = record.ag.shape[0]
    n_steps = n_out - 1
    max_events = options[1]
    out0 = jax.tree.map(lambda v: jnp.zeros(n_pad, v.dtype).at[0].set(v), series(y0))
    zero = jnp.zeros((), jnp.int32)
    carry0 = _Carry(
        y=y0,
        ta=jnp.zeros_like(y0.theta),
        k=zero,
        armed=jnp.ones((), bool),
        events=zero,
        out=out0,
    )
    carry = eqxi.while_loop(
        lambda c: c.k < n_steps,
        lambda c: _body(c, record, params, n_steps, options),
        carry0,
        max_steps=(n_pad - 1) * (max_events + 2),
        buffers=lambda c: c.out,
        kind=loop_kind,
        checkpoints=checkpoints,
    )
    return carry.out, carry.y


@eqx.filter_jit
def solve_events(
    block,
    ag,
    ag_v,
    e,
    theta0,
    theta_dot0,
    dt_out,
    n_out,
    law=None,
    *,
    one_sided,
    max_impacts,
    solver,
    controller,
    loop_kind,
    checkpoints,
    throw,
):
    """The compiled program of the diffrax path (``simulate_housner(..., solver=...)``), with
    the default path's input checks and ``Response`` (``_solve.py``). Returns ``(Response,
    fault)``; ``extras["dt"]`` is NaN (the step is adaptive)."""
    (params, record, y0), bad, fault, _ = prepare(
        block, ag, ag_v, e, theta0, theta_dot0, dt_out, law, None, 1, one_sided, throw
    )
    if loop_kind == "lax":  # forward mode: jvp through every loop
        adjoint = diffrax.ForwardMode()
    else:
        adjoint = diffrax.RecursiveCheckpointAdjoint()
    # an impact and a peak per flight, and the uplift after a rest
    max_events = 2 * max_impacts + 1
    options = (one_sided, max_events, solver, controller, adjoint)
    ys, final = event_loop(y0, record, params, n_out, options, loop_kind, checkpoints)
    no = jnp.zeros((), bool)
    resp = respond(block, ys, final, bad, no, jnp.nan, params, record, None, n_out, throw=throw)
    return resp, fault
