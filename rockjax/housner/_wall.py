"""Moving return walls in the Housner model (docs/three_branch.md, "Moving return walls"):
the wall's rotation at the run's samples (``wall_series``, ``pad_wall``), the block's stop
(``wall_stop``), a resting block put on its wall after the loop (``on_the_wall``) and the time
the rigid block would rock on its heel (``heel_time``, ``HEEL_TOL``)."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._checks import concrete
from ..block import Block
from ..motion import GroundMotion
from ..supports import wall_history
from ._lax import clip, safe, where
from ._params import REST_HOP, Params
from ._record import Record
from ._state import Series, State

HEEL_TOL = 1e-3
"""Heel motions of at most this fraction of ``eta`` [-] do not end the one-sided model's
validity (``extras["t_heel"]`` of ``simulate_housner``): a wall behind the base by at most
``HEEL_TOL eta`` (the heel's room, which bounds its rotation), and a wall passing the base
under a resting block at a rate ``w`` whose hop ``w^2 / (2 p^2 sin eta)`` is at most
``HEEL_TOL eta``. The cross-checks count a facade as lifted off its stop from the same
``1e-3 eta`` (tests/test_wall_models.py)."""


def wall_stop(theta_w, rate):
    """The one-sided block's stop at the samples [rad, rad/s] (docs/three_branch.md, "Moving
    return walls"): the wall where it stands in front of the base (or leaves it forward), else
    the base itself at rest, i.e. ``max(theta_w, 0)`` with the wall's rate where the wall is
    the stop and 0 elsewhere. A wall that has receded behind the base leaves the block standing
    on its base, where it lifts at the fixed wall's threshold, instead of following the wall
    down on its toe. The solver's cubic between samples fits the stop's samples: where the
    wall passes the base inside a sample interval it bends over that interval."""
    ahead = (theta_w > 0) | ((theta_w == 0) & (rate > 0))
    return where(ahead, theta_w, 0.0), where(ahead, rate, 0.0)


def on_the_wall(ys: Series, y: State, record: Record, n_out):
    """The saved samples with a block at rest on its moving wall put on it (see
    :func:`one_pass`): at a sample where the block rests (``s = 0``; an overturned block keeps its
    pivot) its rotation and rate are the wall's; the final state's ``theta_max`` includes
    them (at the samples: with ``n_sub > 1`` not the wall's rotation between two samples). The
    final state's rotation and rate are left as the loop ends them (nothing reads them)."""
    resting = ys.s == 0
    theta = where(resting, record.wall_theta, ys.theta)
    theta_dot = where(resting, record.wall_rate, ys.theta_dot)
    counted = resting & (jnp.arange(theta.shape[0]) < n_out)
    top = jnp.max(jnp.where(counted, jnp.abs(record.wall_theta), 0.0))
    ys = eqx.tree_at(lambda z: (z.theta, z.theta_dot), ys, (theta, theta_dot))
    return ys, eqx.tree_at(lambda z: z.theta_max, y, jnp.maximum(y.theta_max, top))


def heel_time(ys: Series, wall, record: Record, params: Params, n_out):
    """The first sample [s] at which the rigid block, its wall behind its base by more than
    ``HEEL_TOL eta``, would rock on its heel, which the one-sided model does not (its toe is
    its only pivot): ``inf`` if never. Three ways, read from the saved samples:

    * it lands on its base (the last impact of the interval ending at the sample, with the
      wall behind the base at that time): the block would go on onto its heel;
    * it stands on its base with the ground acceleration beyond the inward uplift threshold
      (``a_g > lambda_up g_eff``);
    * it rests on its stop at two consecutive samples between which the wall passes the
      base, with a rate whose hop ``rate^2 / (2 p^2 sin eta)`` exceeds ``HEEL_TOL eta``: the
      landing on its base of a block that rode on the wall (receding) or the wall's blow on a
      block standing on its base (advancing) would throw the block; the model lets it land on
      its base, or ride on the wall, without a rebound.

    ``wall``: the wall's rotation and rate at the samples [rad, rad/s] (not the stop)."""
    theta_w, rate = (jax.lax.stop_gradient(w) for w in wall)
    ys = jax.tree.map(jax.lax.stop_gradient, ys)
    n = theta_w.shape[0]
    i = jnp.arange(n)
    gap = HEEL_TOL * jax.lax.stop_gradient(params.eta)
    w2_hop = (HEEL_TOL / REST_HOP) * jax.lax.stop_gradient(params.w2_tiny)  # hop HEEL_TOL eta
    walls = Record(ag=record.ag, ag_v=None, dt=record.dt, wall_theta=theta_w, wall_rate=rate)
    previous = jnp.concatenate([ys.n_impacts[:1], ys.n_impacts[:-1]])
    t_impact = jnp.maximum(ys.t_last_impact, 0.0)  # (-inf before the first impact)
    landing = (ys.n_impacts > previous) & (walls.wall(t_impact)[0] < -gap)
    resting = ys.s == 0
    a_g, g_eff = record.sample(i)
    lam_up = jax.lax.stop_gradient(params.lam_up)
    inward = resting & (theta_w < -gap) & (a_g > lam_up * g_eff)
    both = resting & jnp.concatenate([resting[:1], resting[:-1]])
    theta_a, rate_a = (jnp.concatenate([w[:1], w[:-1]]) for w in (theta_w, rate))
    # from in front of the base (the block rode on the wall) to behind it, or back
    passes = ((theta_a > 0.0) & (theta_w <= 0.0)) | ((theta_a < 0.0) & (theta_w >= 0.0))
    # the wall's rate where it passes the base (both linear between the samples)
    frac = clip(theta_a / safe(theta_a - theta_w), 0.0, 1.0)
    rate_0 = rate_a + frac * (rate - rate_a)
    thrown = both & passes & (rate_0 * rate_0 > w2_hop)
    heel = (landing | inward | thrown) & (i < n_out)
    return jnp.min(jnp.where(heel, i * record.dt, jnp.inf))


def wall_series(wall_motion, motion: GroundMotion, block: Block, n_out: int):
    """``(theta_w, theta_w')`` [rad, rad/s] at the run's ``n_out`` samples from ``wall_motion``
    (see ``simulate_housner``); beyond the record the wall stays where it ended."""
    u, v = wall_history(wall_motion, motion, block.h, motion.n)
    # NumPy when concrete: eager jnp ops on a new length would each compile once.
    vals = [concrete(x) for x in (u, v, block.h)]
    xp = jnp if any(x is None for x in vals) else np
    if xp is np:
        u, v, h = vals
    else:
        h = jnp.asarray(block.h, dtype=float)
    u, v = xp.asarray(u, dtype=float) / h, xp.asarray(v, dtype=float) / h
    n = u.shape[0]
    if n >= n_out:
        return u[:n_out], v[:n_out]
    return xp.pad(u, (0, n_out - n), mode="edge"), xp.pad(v, (0, n_out - n))


def pad_wall(wall, n_pad: int, dt: float):
    """The wall's samples padded to ``n_pad`` (concrete only; traced runs are not padded) as a
    wall moving on at its last velocity: its cubic stays consistent (no acceleration spike)
    where the rest rule looks past the end."""
    theta, rate = wall
    n = theta.shape[0]
    if n_pad == n:
        return jnp.asarray(theta), jnp.asarray(rate)
    theta, rate = np.asarray(theta, dtype=float), np.asarray(rate, dtype=float)
    extra = np.arange(1, n_pad - n + 1) * dt
    theta = np.concatenate([theta, theta[-1] + rate[-1] * extra])
    rate = np.concatenate([rate, np.full(n_pad - n, rate[-1])])
    return jax.device_put(theta), jax.device_put(rate)
