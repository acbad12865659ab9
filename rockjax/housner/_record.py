"""The forcing as the Housner solver reads it: the record on its uniform grid, linear between
samples (``Record``, with a moving wall's cubic and its per-step uplift table), the exact
linear forcing on one step (``Line``), a moving wall on one step (``WallStep``), forcing
already evaluated (``Given``) and the solver's step ends (``step_time``)."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array

from ..constants import G
from ._field import SMALL_ANGLE, theta_ddot
from ._hermite import hermite
from ._lax import clip, floordiv, mod
from ._params import Params


class Line(eqx.Module):
    """Linear forcing inside one step: ``a_g(t) = a0 + (t - t0) da`` and the same for ``a_gv``."""

    t0: Array
    a0: Array
    da: Array
    v0: Array
    dv: Array

    def at(self, t):
        """``(a_g, g_eff)`` at time ``t`` [m/s^2]."""
        dt = t - self.t0
        return self.a0 + dt * self.da, G + self.v0 + dt * self.dv


class WallStep(eqx.Module):
    """A moving wall on one solver step ``[t0, t0 + h]``: the cubic Hermite fit of its
    rotation and rate at the step's ends (:meth:`Record.segment`), which is the wall's cubic
    on the sample interval holding the step (:meth:`Record.wall`), without its gathers."""

    t0: Array  # [s]
    h: Array  # [s]
    terms: tuple  # (theta at t0, rate at t0 * h, theta at t0 + h, rate there * h)

    def at(self, t):
        """``(theta_w, theta_w', theta_w'')`` at time ``t`` in the step [rad, rad/s, rad/s^2]."""
        theta, rate, accel = hermite((t - self.t0) / self.h, self.terms)
        return theta, rate / self.h, accel / (self.h * self.h)


class Given(eqx.Module):
    """Forcing already evaluated where it is needed: ``at`` ignores the time."""

    a_g: Array  # [m/s^2]
    g_eff: Array | float  # [m/s^2]

    def at(self, t):
        """``(a_g, g_eff)`` [m/s^2]."""
        return self.a_g, self.g_eff


class Record(eqx.Module):
    """The whole record on its uniform grid ``t_i = i dt``, linear between samples.

    ``ag_v`` may be None. Evaluation indexes the grid directly (no search): the step ends and
    the rest rule's look-ahead times need the forcing at arbitrary times.
    """

    ag: Array  # [m/s^2], one value per sample (padded by repeating the last one)
    ag_v: Array | None
    dt: Array  # sample spacing [s]: data, so records of any step share one compilation
    # A moving return wall (one-sided; docs/three_branch.md, "Moving return walls"): the
    # block's stop (wall_stop: the wall's rotation theta_w = u_top / h, or the base where the
    # wall has receded behind it) [rad] and its rate [rad/s] at the samples, or None.
    wall_theta: Array | None = None
    wall_rate: Array | None = None
    # With a moving wall, computed once per run (``with_wall_steps``): for every solver step,
    # the uplift excess (``wall_excess``) of a block resting on the wall at the step's start
    # and at its end, on the step (the wall's acceleration may jump at a sample), shape
    # (2, (n - 1) n_sub). A pass reads its uplift check from its step's column instead of
    # evaluating the wall's cubic; the rest rule's look-ahead reads the first row.
    wall_steps: Array | None = None

    def wall(self, t):
        """``(theta_w, theta_w', theta_w'')`` at time ``t`` [rad, rad/s, rad/s^2]: the cubic
        Hermite fit of the samples' rotation and rate on the interval holding ``t`` (at a
        sample: the one it starts), exact for a wall whose acceleration is linear between
        samples. (A solver step reads its own interval: :class:`WallStep`.)"""
        n = self.wall_theta.shape[0]
        x = clip(t / self.dt, 0.0, n - 1.0)
        i = jax.lax.stop_gradient(clip(jnp.floor(x), 0.0, n - 2.0))
        r = x - i
        i = i.astype(jnp.int32)
        p0, p1 = self.wall_theta[i], self.wall_theta[i + 1]
        m0, m1 = self.wall_rate[i] * self.dt, self.wall_rate[i + 1] * self.dt
        theta, rate, accel = hermite(r, (p0, m0, p1, m1))
        return theta, rate / self.dt, accel / (self.dt * self.dt)

    def with_wall_steps(self, params: Params, n_sub: int) -> Record:
        """This record with ``wall_steps`` filled in (a moving wall only), for ``n_sub``
        solver steps per sample interval: the wall's cubic (:meth:`wall`) and the forcing at
        every step end at once, from slices (no gathers)."""
        dt = self.dt
        terms = (  # p0, m0, p1, m1 of every interval, as in wall()
            self.wall_theta[:-1],
            self.wall_rate[:-1] * dt,
            self.wall_theta[1:],
            self.wall_rate[1:] * dt,
        )
        # (theta_w, rate, accel) at the fractions 0, 1/n_sub, ..., 1 of every interval
        at = [hermite(q / n_sub, terms) for q in range(n_sub + 1)]

        def steps(columns):  # one value per interval and step in it: step by step
            return jnp.stack(columns, axis=1).reshape(-1)

        def ends(columns, samples):  # at the step ends (at the samples: the samples' own)
            if n_sub == 1:
                return samples
            return jnp.concatenate([steps(columns), samples[-1:]])

        def forcing(a):  # the record's linear interpolation
            return ends([a[:-1] + (q / n_sub) * (a[1:] - a[:-1]) for q in range(n_sub)], a)

        theta_w = ends([c[0] for c in at[:-1]], self.wall_theta)
        # the wall's acceleration where each step starts and ends, inside its interval
        accel_start = steps([c[2] for c in at[:-1]]) / (dt * dt)
        accel_end = steps([c[2] for c in at[1:]]) / (dt * dt)
        g_eff = G if self.ag_v is None else G + forcing(self.ag_v)
        given = Given(a_g=forcing(self.ag), g_eff=g_eff)
        # (a wall's rotation is mostly a small angle: the sine's and cosine's shorter series)
        free = jax.lax.cond(
            jnp.max(jnp.abs(theta_w)) <= SMALL_ANGLE,
            lambda: theta_ddot(None, theta_w, jnp.ones_like(theta_w), params, given, True),
            lambda: theta_ddot(None, theta_w, jnp.ones_like(theta_w), params, given),
        )
        k = params.p2_over_g * params.cos_eta
        table = jnp.stack([(free[:-1] - accel_start) / k, (free[1:] - accel_end) / k])
        return eqx.tree_at(lambda r: r.wall_steps, self, table, is_leaf=lambda x: x is None)

    @property
    def n_sub(self) -> int:
        """Solver steps per sample interval of ``wall_steps`` (static: from the shapes)."""
        return self.wall_steps.shape[1] // max(self.wall_theta.shape[0] - 1, 1)

    def segment(self, k):
        """The moving wall on solver step ``k`` (:class:`WallStep`), from the two samples of
        the interval holding it (two slices, no search)."""
        n, n_sub = self.wall_theta.shape[0], self.n_sub
        i = jnp.minimum(floordiv(k, n_sub), n - 2)
        theta2 = jax.lax.dynamic_slice_in_dim(self.wall_theta, i, 2)
        rate2 = jax.lax.dynamic_slice_in_dim(self.wall_rate, i, 2) * self.dt
        terms = (theta2[0], rate2[0], theta2[1], rate2[1])
        r0 = mod(k, n_sub).astype(float) / n_sub
        dt_step = self.dt / n_sub
        ends = [hermite(r, terms) for r in (r0, r0 + 1.0 / n_sub)]
        t0 = step_time(k, n_sub, self.dt, dt_step)
        return WallStep(
            t0,
            dt_step,
            (ends[0][0], ends[0][1] / n_sub, ends[1][0], ends[1][1] / n_sub),
        )

    def excess_at_samples(self, i):
        """``wall_excess`` [m/s^2] on the interval that starts at samples ``i`` (integers,
        clipped to the record), from ``wall_steps``."""
        n = self.wall_theta.shape[0]  # (the last sample: the last interval's start)
        return self.wall_steps[0, clip(i, 0, n - 2) * self.n_sub]

    def _eval(self, ys, t):
        n = ys.shape[0]
        x = clip(t / self.dt, 0.0, n - 1.0)
        i = jax.lax.stop_gradient(clip(jnp.floor(x), 0.0, n - 2.0))
        frac = x - i
        i = i.astype(jnp.int32)
        return ys[i] + frac * (ys[i + 1] - ys[i])

    def sample(self, i):
        """``(a_g, g_eff)`` at sample ``i`` (an integer array, clipped to the record) [m/s^2]."""
        i = clip(i, 0, self.ag.shape[0] - 1)
        return self.ag[i], G + (0.0 if self.ag_v is None else self.ag_v[i])

    def at(self, t):
        """``(a_g, g_eff)`` at time ``t`` [m/s^2] (held at the last sample beyond the end)."""
        v = 0.0 if self.ag_v is None else self._eval(self.ag_v, t)
        return self._eval(self.ag, t), G + v

    def line(self, t0, t1):
        """The exact linear forcing on ``[t0, t1]`` (inside one sample interval), from the two
        end values only."""
        a0, a1 = self._eval(self.ag, t0), self._eval(self.ag, t1)
        if self.ag_v is None:
            v0 = dv = jnp.zeros_like(a0)
        else:
            v0 = self._eval(self.ag_v, t0)
            dv = (self._eval(self.ag_v, t1) - v0) / (t1 - t0)
        return Line(t0=t0, a0=a0, da=(a1 - a0) / (t1 - t0), v0=v0, dv=dv)


def step_time(k, n_sub: int, dt_out, dt_step):
    """End ``k`` of the solver steps [s]: the samples ``i dt_out`` exactly, and ``n_sub - 1``
    equal steps between two samples."""
    return floordiv(k, n_sub).astype(float) * dt_out + dt_step * mod(k, n_sub).astype(float)
