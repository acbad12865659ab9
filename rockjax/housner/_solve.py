"""The compiled Housner program (``solve``): the in-graph checks of traced inputs (a lane
with an impossible one is not run), the initial state, the loop over the record and the
``Response`` with its status."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp

from ..compilation import persistent_jit
from ..constants import G
from ..response import (
    STATUS_BAD_INPUT,
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_UNRESOLVED,
    STATUS_UNSTABLE,
    Response,
)
from ._field import sincos
from ._loop import run_record
from ._params import P_DT_LIMIT, law_frequency, law_potential, make_params
from ._record import Record
from ._state import Series, State
from ._wall import heel_time, wall_stop

FAULT_GEOMETRY, FAULT_E, FAULT_START, FAULT_RECORD = 1, 2, 3, 4


def fault_message(code: int, one_sided: bool) -> str:
    """What is wrong with a traced input, and the fix (``code``: the first failed check)."""
    side = " (and theta0 >= 0 one-sided)" if one_sided else ""
    return {
        FAULT_GEOMETRY: "the block's b and h [m] must be positive and finite, and its mass and "
        "inertia finite; check the b and h given to rj.Block.",
        FAULT_E: "e (restitution, dimensionless) must be in (0, 1]; pass a smaller e.",
        FAULT_START: f"theta0 must satisfy |theta0| < eta [rad]{side}, and theta0 and "
        "theta_dot0 be finite; give a smaller theta0.",
        FAULT_RECORD: "the record's ag [m/s^2] has non-finite samples (NaN/inf); clean the record.",
    }[code]


STATE_MESSAGES = {
    STATUS_NONFINITE: "the state became non-finite (NaN/inf).",
    STATUS_UNSTABLE: f"p*dt_step exceeds {P_DT_LIMIT}; pass a smaller dt [s].",
    STATUS_UNRESOLVED: "a solver step needed more impacts than max_impacts_per_step; raise "
    "max_impacts_per_step or pass a smaller dt [s].",
}


@persistent_jit
def solve(
    block,
    ag,
    ag_v,
    e,
    theta0,
    theta_dot0,
    dt_out,
    n_out,
    law=None,
    wall=None,
    *,
    n_sub,
    one_sided,
    max_impacts,
    loop_kind,
    checkpoints,
    throw,
):
    """The compiled Housner program: the record ``ag`` (``ag_v``) [m/s^2] padded to its
    bucket, ``n_out`` samples of it run (data), ``n_sub`` solver steps per sample interval.
    Returns ``(Response, fault)``, ``fault`` the first failed input check (0: none)."""
    dt_step = dt_out / n_sub
    (params, record, y0), bad, fault, p = prepare(
        block, ag, ag_v, e, theta0, theta_dot0, dt_out, law, wall, n_sub, one_sided, throw
    )
    eta = params.eta
    ys, final = run_record(
        y0,
        record,
        params,
        n_out,
        n_sub=n_sub,
        one_sided=one_sided,
        max_impacts=max_impacts,
        loop_kind=loop_kind,
        checkpoints=checkpoints,
    )
    too_coarse = (p if law is None else law_frequency(p, eta, law, xp=jnp)) * dt_step > P_DT_LIMIT
    resp = respond(
        block, ys, final, bad, too_coarse, dt_step, params, record, wall, n_out, throw=throw
    )
    return resp, fault


def prepare(block, ag, ag_v, e, theta0, theta_dot0, dt_out, law, wall, n_sub, one_sided, throw):
    """:func:`check_inputs`, then :func:`setup` on the checked inputs: ``((params, record,
    y0), bad, fault, p)``, ``p`` [rad/s] the block's frequency (its stand-in where ``bad``)."""
    checked, bad, fault = check_inputs(block, ag, ag_v, e, theta0, theta_dot0, one_sided, throw)
    eta, p, e, theta0, theta_dot0, ag, ag_v = checked
    setting = setup(p, eta, e, theta0, theta_dot0, ag, ag_v, dt_out, law, wall, n_sub, one_sided)
    return setting, bad, fault, p


def check_inputs(block, ag, ag_v, e, theta0, theta_dot0, one_sided: bool, throw: bool):
    """The in-graph checks of traced inputs. Traced inputs cannot be checked in Python: a lane
    with an impossible one is not run (benign stand-ins, NaN histories, ``STATUS_BAD_INPUT``),
    or with ``throw`` it raises, naming the input; the geometry is checked first so that
    ``b = 0`` is not blamed on ``theta0``.

    Returns:
        ``((eta, p, e, theta0, theta_dot0, ag, ag_v), bad, fault)``: the inputs with the
        stand-ins where ``bad``, and the first failed check (``FAULT_*``, 0: none).
    """
    eta, p = block.eta, block.p
    geometry_ok = (block.b > 0) & (block.h > 0) & (block.m > 0) & (p > 0)
    for x in (block.b, block.h, block.m, block.I_O, p):
        geometry_ok = geometry_ok & jnp.isfinite(x)
    e_ok = jnp.isfinite(e) & (e > 0) & (e <= 1)
    start_ok = jnp.isfinite(theta0) & jnp.isfinite(theta_dot0) & (jnp.abs(theta0) < eta)
    if one_sided:
        start_ok = start_ok & (theta0 >= 0) & ((theta0 > 0) | (theta_dot0 >= 0))
    record_ok = jnp.all(jnp.isfinite(ag))
    if ag_v is not None:
        record_ok = record_ok & jnp.all(jnp.isfinite(ag_v))
    oks = (geometry_ok, e_ok, start_ok, record_ok)
    bad = ~(geometry_ok & e_ok & start_ok & record_ok)
    # the first failed check (0: none), for the message of an eager call
    fault = jnp.int32(0)
    for code in range(len(oks), 0, -1):
        fault = jnp.where(oks[code - 1], fault, jnp.int32(code))
    if throw:
        for code, ok in enumerate(oks, start=1):
            if code == FAULT_START:  # a zero-width block is blamed on b, not on theta0
                ok = ok | ~geometry_ok
            e = eqx.error_if(e, ~ok, f"simulate_housner: {fault_message(code, one_sided)}")

    def benign(x, stand_in):
        return jnp.where(bad, stand_in, x)

    eta, p = benign(eta, 0.1), benign(p, 1.0)
    e, theta0, theta_dot0 = benign(e, 0.5), benign(theta0, 0.0), benign(theta_dot0, 0.0)
    ag = benign(ag, 0.0)
    ag_v = None if ag_v is None else benign(ag_v, 0.0)
    return (eta, p, e, theta0, theta_dot0, ag, ag_v), bad, fault


def setup(p, eta, e, theta0, theta_dot0, ag, ag_v, dt_out, law, wall, n_sub: int, one_sided):
    """The run's constants (``Params``), its ``Record`` (with a moving wall: the block's stop
    and its per-step table for ``n_sub`` solver steps per sample interval) and the initial
    ``State`` (pivot from the start's sign; at rest on a moving wall, on it)."""
    params = make_params(p, eta, e, law)
    if wall is None:
        record = Record(ag=ag, ag_v=ag_v, dt=dt_out)
    else:  # the block's stop: the wall, or its base where the wall has receded behind it
        stop_theta, stop_rate = wall_stop(*wall)
        record = Record(ag=ag, ag_v=ag_v, dt=dt_out, wall_theta=stop_theta, wall_rate=stop_rate)
        record = record.with_wall_steps(params, n_sub)
    moving = (theta0 != 0) | (theta_dot0 != 0)
    if one_sided:
        s0 = jnp.where(moving, 1.0, 0.0)
    else:
        s0 = jnp.where(theta0 != 0, jnp.sign(theta0), jnp.sign(theta_dot0))
    if wall is not None:  # at rest against its stop: on it, with its rate
        theta0 = jnp.where(moving, theta0, record.wall_theta[0])
        theta_dot0 = jnp.where(moving, theta_dot0, record.wall_rate[0])
    zero = jnp.zeros_like(theta0)
    y0 = State(
        theta=theta0,
        theta_dot=theta_dot0,
        s=s0,
        overturned=zero,
        n_impacts=zero,
        t_last_impact=jnp.full_like(theta0, -jnp.inf),
        theta_max=jnp.abs(theta0),
        n_unresolved=zero,
    )
    return params, record, y0


def respond(
    block, ys: Series, final: State, bad, too_coarse, dt_step, params, record, wall, n_out, *, throw
) -> Response:
    """The ``Response`` of a run from its samples ``ys`` and final state: the status (a bad
    input, a non-finite state, a step too coarse, an unresolved step; with ``throw`` an error
    instead), the displacement and energy, the extras (with a moving ``wall``, ``t_heel``)."""
    if throw:
        # Every output below is computed from the checked ys, so the checks cannot be
        # dropped as dead code whichever outputs the caller keeps.
        finite = jnp.all(jnp.isfinite(ys.theta)) & jnp.all(jnp.isfinite(ys.theta_dot))
        for failed, code in (
            (~finite, STATUS_NONFINITE),
            (too_coarse, STATUS_UNSTABLE),
            (final.n_unresolved > 0, STATUS_UNRESOLVED),
        ):
            msg = f"simulate_housner: {STATE_MESSAGES[code]}"
            ys, final = eqx.error_if((ys, final), failed, msg)
    theta, theta_dot = ys.theta, ys.theta_dot
    finite = jnp.all(jnp.isfinite(theta)) & jnp.all(jnp.isfinite(theta_dot))
    status = jnp.where(
        bad,
        STATUS_BAD_INPUT,
        jnp.where(
            finite,
            jnp.where(
                too_coarse,
                STATUS_UNSTABLE,
                jnp.where(final.n_unresolved > 0, STATUS_UNRESOLVED, STATUS_OK),
            ),
            STATUS_NONFINITE,
        ),
    )

    # The polynomial sine and cosine (rotations stay below 2 rad) on the whole padded series;
    # cos(eta - |theta|) - cos(eta) = cos(eta) (cos(theta) - 1) + sin(eta) |sin(theta)|.
    eta = params.eta
    sin_th, cos_th = sincos(theta, False)
    d = jnp.sign(theta) * 0.5 * block.b * (1.0 - cos_th) + block.h * sin_th
    if params.law is None:
        potential = jnp.cos(eta) * (cos_th - 1.0) + jnp.sin(eta) * jnp.abs(sin_th)
    else:
        potential = law_potential(jnp.abs(theta), eta, params.law)
    energy = 0.5 * block.I_O * theta_dot**2 + block.m * G * block.R * potential

    def not_run(x):
        return jnp.where(bad, jnp.nan, x)

    return Response(
        t=jnp.arange(theta.shape[0]) * record.dt,
        theta=not_run(theta),
        theta_dot=not_run(theta_dot),
        d=not_run(d),
        overturned=final.overturned > 0,
        status=status,
        theta_max=not_run(final.theta_max),
        eta=block.eta,
        b=block.b,
        energy=not_run(energy),
        extras={
            "n_impacts": ys.n_impacts.astype(jnp.int32),
            "t_last_impact": ys.t_last_impact,
            "pivot": ys.s,
            "n_unresolved": final.n_unresolved.astype(jnp.int32),
            "dt": dt_step,
        }
        | ({} if wall is None else {"t_heel": not_run(heel_time(ys, wall, record, params, n_out))}),
    )
