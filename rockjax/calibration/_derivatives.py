"""The derivative path of the calibration losses: forward mode (one tangent per parameter, no
reverse pass through the long ``lax.scan``), wrapped as a ``custom_vjp`` so that optax's
reverse-mode ``value_and_grad`` calls it."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp

from ..compilation import stable_name
from ._problems import CalibrationProblem, stats


def beta_of_u(problem: CalibrationProblem, u):
    """``beta = beta_cap tanh(|u| / (S beta_cap))`` [s]: the scaled, bounded unknown of
    :func:`rockjax.fit_beta` (``S = problem.scale``), so the loss is ``~ (u - u*)^2``."""
    return problem.beta_cap * jnp.tanh(jnp.abs(u) / (problem.scale * problem.beta_cap))


@eqx.filter_custom_vjp
def loss_u(u, problem: CalibrationProblem):
    """The loss of :func:`rockjax.calibration.stats` at ``beta_of_u(u)``, with a forward-mode
    derivative checked against the monotone trend (see the comment of its forward rule)."""
    return stats(problem, beta_of_u(problem, u))[0]


@loss_u.def_fwd
def _loss_u_fwd(perturbed, u, problem):
    # Forward mode: one tangent, no reverse pass through the long scan. The derivative is
    # that of the signed gap (the loss is its square, or for "bounces" built from it), checked
    # against the monotone trend: where contacts chatter (squat blocks) the local derivative
    # of a DEM history is exact but says nothing about the trend (it flips sign or is off by
    # orders of magnitude from one beta to the next), so a gap slope of the wrong sign, or
    # more than 10x off the secant slope of the endpoint scan, is replaced by that secant.
    def f(v):
        loss, gap, _, _ = stats(problem, beta_of_u(problem, v))
        return loss, gap

    (loss, gap), (dloss, dgap) = jax.jvp(f, (u,), (jnp.ones_like(u),))
    # the trend in u: u = S beta so d(gap)/du ~ -dbeta/du * S (tanh bound, reflection at 0)
    w = jnp.abs(u) / (problem.scale * problem.beta_cap)
    trend = -jnp.sign(u) / jnp.cosh(w) ** 2
    ratio = dgap / jnp.where(trend == 0, 1.0, trend)
    sane = (ratio > 0.1) & (ratio < 10.0)
    dgap_used = jnp.where(sane, dgap, trend)
    if problem.kind == "e":
        dval = 2.0 * gap * dgap_used
    else:  # mean square of the bounce gaps: keep its own derivative when the gap's is sane
        dval = jnp.where(sane, dloss, 2.0 * gap * trend)
    return loss, dval


@loss_u.def_bwd
def _loss_u_bwd(dval, g, perturbed, u, problem):
    return g * dval


# a static argument of the L-BFGS step: named, so that its program can be kept on disk
stable_name(loss_u, "rockjax.calibration._derivatives.loss_u")


def forward_mode(loss):
    """``loss(u, problem)`` whose reverse-mode gradient in ``u`` is computed in forward mode:
    one tangent per parameter (``jax.jacfwd``, primal and tangents in one pass), cheaper than
    a reverse pass through the long scan for the one or two parameters fitted here."""

    def value_and_jac(u, problem):
        def both(x):
            val = loss(x, problem)
            return val, val

        jac, val = jax.jacfwd(both, has_aux=True)(u)
        return val, jac

    @eqx.filter_custom_vjp
    def wrapped(u, problem):
        return loss(u, problem)

    @wrapped.def_fwd
    def _fwd(perturbed, u, problem):
        return value_and_jac(u, problem)

    @wrapped.def_bwd
    def _bwd(jac, g, perturbed, u, problem):
        return g * jac

    return stable_name(wrapped, f"forward_mode({loss.__module__}.{loss.__qualname__})")
