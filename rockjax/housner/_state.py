"""The Housner solver's state: the continuous and discrete state carried from pass to pass
(``State``), the part saved at every sample (``Series``) and a crossing handed from the pass
that finds it to the pass that resolves it (``Hit``)."""

from __future__ import annotations

from typing import Any

import equinox as eqx
from jaxtyping import Array


class State(eqx.Module):
    """The solver state: float64 scalars, carried by the loop and saved at the samples."""

    theta: Array  # rotation [rad]
    theta_dot: Array  # angular velocity [rad/s]
    s: Array  # pivot: +1, -1, or 0 at rest
    overturned: Array  # 1.0 once overturned (then frozen)
    n_impacts: Array  # impacts so far
    t_last_impact: Array  # time of the latest impact [s] (-inf before the first)
    theta_max: Array  # running max |theta| [rad], on each step's dense output
    n_unresolved: Array  # steps that needed more than max_impacts_per_step impacts


class Series(eqx.Module):
    """The part of the state saved at every sample (the rest is needed only at the end). Inside
    the loop its fields are the loop's buffers, not arrays: hence no annotations to check."""

    theta: Any
    theta_dot: Any
    s: Any
    n_impacts: Any
    t_last_impact: Any


def series(y: State) -> Series:
    return Series(y.theta, y.theta_dot, y.s, y.n_impacts, y.t_last_impact)


class Hit(eqx.Module):
    """A crossing found by a pass and resolved by the next one (see ``one_pass``)."""

    pending: Array  # bool: the next pass resolves an impact
    tau: Array  # the crossing time from the step's cubic fit [s]
    t_hi: Array  # the end of the bracket it lies in [s]
    # With a three-branch law: the level of u = s theta crossed [rad], 0 for the wall (an
    # impact) or a kink of the law (u1, u2 > 0: the state is put on it, nothing else changes).
    level: Array | None = None
