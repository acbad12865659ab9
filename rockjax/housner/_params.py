"""The numbers of a Housner run: the rules' parameters (the step-size rule's ``P_DT_TARGET``
and ``P_DT_LIMIT``, the rest rule's ``REST_*``) and a run's constants (``Params``, built by
``make_params``), with a three-branch law's restoring terms (``LawTerms``), its step-size
frequency (``law_frequency``) and its potential energy (``law_potential``)."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array

from .._checks import concrete
from ..constants import G
from ._lax import clip, where

P_DT_TARGET = 0.1
"""Largest ``p dt_step`` [-] the automatic step subdivision allows (see the module docstring)."""


P_DT_LIMIT = 0.5
"""``p dt_step`` [-] beyond which the step is refused: a ``ValueError`` for a concrete block, and
for a traced one (``n_sub`` then cannot follow ``p``) ``STATUS_UNSTABLE`` (an error if
``throw``)."""


REST_A_MARGIN = 0.5
"""Rest rule: the restoring acceleration ``A_s`` on either pivot must stay at least this
fraction of its value at the impact over twice the chatter's Zeno time (docs/theory.md)."""


REST_HOP = 1e-6
"""Rest rule, second clause: an impact whose rebound would lift the block by less than this
fraction of ``eta`` under gravity alone (``w^2 / (2 p^2 sin eta) <= REST_HOP eta``) puts it to
rest whatever the forcing ahead; it then lifts at the exact threshold crossing. This ends
chatter that the first clause cannot (the forcing nears the threshold before the sequence
ends), which for ``e`` near 1 would otherwise take hundreds of impacts per step. A block at
rest likewise does not start a flight that would rise less than this (a forcing just above the
threshold that falls back within the step; see ``uplift``)."""


REST_HORIZON = 8
"""Rest rule: twice the chatter's Zeno time must fit in this many record intervals (the rule
checks the forcing at every sample inside; a longer chatter is resolved impact by impact)."""


class Params(eqx.Module):
    """Per-run constants of the step (built once, traced or not)."""

    p2_over_g: Array  # p^2 / g [1/m]
    sin_eta: Array
    cos_eta: Array
    tan_eta: Array
    eta: Array  # [rad]
    e: Array  # restitution magnitude [-]
    theta_u: Array  # rotation [rad] past which the block overturns (eta for the rigid block)
    lam_up: Array  # static uplift threshold |a_g| / g_eff [-] at rest (tan eta, rigid block)
    lam_lift: Array  # |a_g| / g_eff [-] that lifts a block at rest (lam_up, or see make_params)
    w2_tiny: Array  # rebound speed^2 [rad^2/s^2] below which the rest rule's 2nd clause rests
    law: LawTerms | None  # the three-branch law's restoring terms; None: the rigid block


class LawTerms(eqx.Module):
    """A :class:`rockjax.ThreeBranchLaw` as the solver uses it (docs/three_branch.md): on the
    pivot's side, ``u = s theta``, the static capacity is ``Lambda(u) = alpha_k + beta_k
    tan(eta - u)`` on branch ``k`` (``u < u1``, ``u < u2``, else), so the restoring moment
    ``m g R cos(eta - u) Lambda`` is ``m g R (alpha_k cos(eta - u) + beta_k sin(eta - u))``."""

    u1: Array  # rotation at d/b = Delta_1 [rad]
    u2: Array  # rotation at d/b = Delta_2 [rad]
    alpha: Array  # (3,) [-]
    beta: Array  # (3,) [-]

    def coefficients(self, u):
        """``(alpha, beta)`` of the branch holding rotation ``u`` [rad]."""
        first, plateau = u < self.u1, u < self.u2
        alpha = where(first, self.alpha[0], where(plateau, self.alpha[1], self.alpha[2]))
        beta = where(first, self.beta[0], where(plateau, self.beta[1], self.beta[2]))
        return alpha, beta


def make_params(p, eta, e, law) -> Params:
    """The run's constants; with a three-branch ``law``, its restoring terms (``LawTerms``)."""
    sin_eta, cos_eta, tan_eta = jnp.sin(eta), jnp.cos(eta), jnp.tan(eta)
    p2_over_g = p**2 / G
    w2_tiny = 2.0 * REST_HOP * eta * p2_over_g * G * sin_eta
    if law is None:
        return Params(
            p2_over_g=p2_over_g,
            sin_eta=sin_eta,
            cos_eta=cos_eta,
            tan_eta=tan_eta,
            eta=eta,
            e=e,
            theta_u=eta,
            lam_up=tan_eta,
            lam_lift=tan_eta,
            w2_tiny=w2_tiny,
            law=None,
        )
    lam0, d1, d2, du = (
        jnp.asarray(v, dtype=float) for v in (law.lambda_0, law.Delta_1, law.Delta_2, law.Delta_u)
    )
    lam_p = lam0 * (1.0 - d2 / du)

    def rotation(x):  # u at the rigid-equivalent displacement x: tan(eta - u) = tan(eta)(1 - x)
        return eta - jnp.arctan(tan_eta * (1.0 - x))

    # Branch k: Lambda = alpha_k + beta_k tan(eta - u), from lambda(x) with x = 1 - tan(eta-u)/tan(eta).
    has_first = d1 > 0
    a1 = where(has_first, lam_p / where(has_first, d1, 1.0), lam_p)
    b1 = where(has_first, -a1 / tan_eta, 0.0)
    a3 = lam0 * (1.0 - 1.0 / du)
    b3 = lam0 / (du * tan_eta)
    terms = LawTerms(
        u1=rotation(d1),
        u2=rotation(d2),
        alpha=jnp.stack([a1, lam_p, a3]),
        beta=jnp.stack([b1, jnp.zeros_like(b1), b3]),
    )
    lam_up = where(has_first, 0.0, lam_p)
    k = p2_over_g * cos_eta
    # Second rest clause: a hop of REST_HOP eta, from the threshold's restoring acceleration
    # (k g lam_up) or, on a stiff first branch (lam_up = 0), from its frequency (k g lam_p / u1).
    w2_hop = 2.0 * REST_HOP * eta * k * G * lam_up
    w2_spring = (REST_HOP * eta) ** 2 * k * G * lam_p / where(has_first, terms.u1, 1.0)
    # Lift-off from rest on a stiff first branch (threshold 0): only a forcing whose static
    # deflection of the branch, u1 a_g / (g lam_p), exceeds REST_HOP eta, the motion the rest
    # rule's second clause gives up. Any smaller forcing would lift a block put to rest at once
    # into a flight below that size, to be put to rest again: a chatter at round-off amplitude,
    # hundreds of impacts a step (docs/theory.md, "Housner rest and chatter rule").
    lam_micro = REST_HOP * eta * lam_p / where(has_first, terms.u1, 1.0)
    return Params(
        p2_over_g=p2_over_g,
        sin_eta=sin_eta,
        cos_eta=cos_eta,
        tan_eta=tan_eta,
        eta=eta,
        e=e,
        theta_u=rotation(du),
        lam_up=lam_up,
        lam_lift=where(has_first, lam_micro, lam_up),
        w2_tiny=where(has_first, w2_spring, w2_hop),
        law=terms,
    )


def law_frequency(p, eta, law, xp=np):
    """The larger of ``p`` and the angular frequency of the law's stiff first branch [rad/s],
    ``p sqrt(cos(eta) lambda_p / u1)`` (``u1`` its end rotation): the step-size rule's rate.
    NumPy for concrete values (``None`` if the law is traced), ``xp=jnp`` inside the solve."""
    vals = [law.lambda_0, law.Delta_1, law.Delta_2, law.Delta_u]
    if xp is np:
        vals = [concrete(v) for v in vals]
        if eta is None or any(v is None for v in vals):
            return None
    lam0, d1, d2, du = vals
    lam_p = lam0 * (1.0 - d2 / du)
    u1 = eta - xp.arctan(xp.tan(eta) * (1.0 - d1))
    stiff = xp.sqrt(xp.maximum(xp.cos(eta) * lam_p / xp.where(d1 > 0, u1, 1.0), 0.0))
    return xp.maximum(p, xp.where(d1 > 0, p * stiff, p))


def law_potential(u, eta, terms: LawTerms):
    """``V(u) / (m g R)`` [-]: the work of the law's restoring moment from 0 to ``u >= 0``.

    On branch ``k`` the moment over ``m g R`` is ``alpha_k cos(eta - u) + beta_k sin(eta - u)``,
    whose integral is ``F_k(u) = -alpha_k sin(eta - u) + beta_k cos(eta - u)``.
    """
    bounds = ((0.0, terms.u1), (terms.u1, terms.u2), (terms.u2, jnp.inf))
    total = jnp.zeros_like(u)
    for k, (lo, hi) in enumerate(bounds):
        lo = jnp.maximum(lo, 0.0)
        hi = jnp.maximum(hi, lo)
        uu = clip(u, lo, hi)

        def f(v, k=k):
            return -terms.alpha[k] * jnp.sin(eta - v) + terms.beta[k] * jnp.cos(eta - v)

        total = total + f(uu) - f(lo)
    return total
