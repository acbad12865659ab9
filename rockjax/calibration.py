"""Calibrate the DEM damping ``beta`` to a coefficient of restitution, by gradient descent.

The paper matched DEM and Housner free-rocking histories by trial; here the match is a
differentiable loss minimised with L-BFGS (``optax.lbfgs``, zoom line search):

1. **Reference**: Housner's free rocking with the target ``e`` (or, for facades, the measured
   bounce ratios of ``e_ISR``), released from rest at ``theta0`` (one or several amplitudes).
2. **Loss** (:func:`rockjax.metrics.peak_loss`): the mean square gap of the bounce
   log-energies ``log U_k - log U_0`` between the DEM and Housner, bounce by bounce, over the
   first ``n_bounces`` impacts that keep at least 2 % of the release energy (weights 1, else 0).
   It is insensitive to phase, and equals ``(log e_DEM - log e)^2`` for a DEM with a constant
   restitution. The paper's pointwise weighted-mean history error
   (:func:`rockjax.metrics.history_error`) is reported beside it.
3. **Smoothness**: the DEM locates contact onsets inside the step (``onset="sub_step"``,
   :mod:`rockjax.contact`), so the loss is continuous in ``beta``; with onsets on the step grid
   it jumps ~1e-4 at ~1e-5 ``beta_DeJong`` intervals and the local derivative misses the trend.
4. **Scaling and bounds**: two DEM runs at ``beta = 0`` and ``beta_max`` (vmapped) give the
   reachable range (a target outside it raises) and the slope used to scale the variable
   ``u = S beta`` so that the loss is ``~ (u - u*)^2``; ``beta = beta_cap tanh(|u| / (S beta_cap))``
   keeps it in ``[0, beta_cap]`` (``beta_cap = 1.25 beta_max``, the step is sized for it).
5. **Derivatives** in forward mode (``jax.jvp`` through the ``lax.scan``; one tangent per
   parameter), wrapped as a ``custom_vjp`` for optax.

Baselines (``method=``): ``"grid"`` (dense vmapped grid, parabola through the best three
points) and ``"root"`` (Illinois false position on the signed log-energy gap, monotone in
``beta``).

**What a result promises.** Before any optimisation, a target whose Housner reference has no
bounce keeping :data:`MIN_ENERGY_RATIO` of its release energy (the loss would be identically
zero), ``n_bounces < 1``, a DEM that keeps no such bounce at an end of the search (the
reachable range is undefined) and an unreachable target raise ``ValueError`` with the fix.
After it, every method (``lbfgs``, its false-position finish, ``grid``, ``root``; and
:func:`fit_e`) reports ``converged=True`` only if the target is met within a stated tolerance
(:data:`E_TOL` on the DEM's own ``e``, :data:`BOUNCE_BANDS` for facades), measured on the DEM's
saved history by a NumPy peak finder independent of the loss, with every number finite;
otherwise ``converged=False`` and ``reason`` says what was missed. The mode's default target
(:func:`default_target`) is ``"bounces"`` for facades.
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optax

from . import metrics
from ._checks import check_choice
from .block import Block
from .dem import simulate_dem, stable_dt
from .housner import simulate_housner
from .relations import beta_dejong, beta_hcrit, e_isr, free_rocking_period
from .response import STATUS_OK, Response, e_exp

MODES = ("two_sided", "one_sided")
METHODS = ("lbfgs", "grid", "root")
BOUNCE_FRACTIONS = (0.68, 0.80, 1.00)
"""Facade targets (``target="bounces"``): ``e_exp`` (Eq. 6) of bounces 1-3 as fractions of
``|e_ISR|``, the middles of the measured 64-72 %, 74-86 % and ~100 % (the paper, Sect. 2.2,
from Sorrentino et al.'s tests)."""

BOUNCE_BANDS = ((0.64, 0.72), (0.74, 0.86), (0.925, 1.075))
"""Tolerance of ``target="bounces"``: ``e_exp`` of bounces 1-3 over ``|e_ISR|`` must lie in these
bands for ``converged=True``: the measured 64-72 % and 74-86 % (the paper, Sect. 2.2) and, for
the third bounce (measured "similar to ``e_ISR``", no band given), the wider of the two
measured half-widths, +-7.5 %, around 100 %."""

E_TOL = 2e-3
"""Tolerance of ``target="e"`` (and of :func:`fit_e`): ``converged=True`` needs the DEM's own
restitution, measured from peaks found in NumPy on the saved history (an independent path from
the loss), within ``E_TOL`` of the target [-]."""

MIN_ENERGY_RATIO = 0.02
"""A bounce informs the fit only if it keeps at least this fraction of the release energy."""
GAP_TOL = 1e-4
"""``fit_beta`` (``target="e"``): an L-BFGS result whose signed gap ``|log e_DEM - log e|``
exceeds this is finished by false position on the bracketed gap."""
SAVE_DT = 0.002
"""Output step of the calibration runs [s] (the peaks are refined between samples)."""


@dataclasses.dataclass(frozen=True)
class Calibration:
    """Result of :func:`fit_beta` (or :func:`fit_e`, where ``e`` is the fitted value).

    Attributes:
        beta: Fitted (or given) ``beta`` [s].
        e: Target (``fit_beta``) or fitted (``fit_e``) Housner restitution [-]; None for
            ``target="bounces"``.
        e_effective: The DEM's own restitution at ``beta``: ``sqrt`` of its mean energy ratio
            per impact over the compared bounces (least squares on ``log U_k``), from peaks
            found in NumPy on the saved history [-]; NaN if no bounce keeps
            :data:`MIN_ENERGY_RATIO` of the release energy.
        e_exp: Eq. (6) of the DEM's bounces 1-3 [-] (first release amplitude; NumPy peaks as
            for ``e_effective``; NaN for a bounce that did not happen).
        loss: Final loss [-]: ``fit_beta`` with ``target="e"``: the squared signed gap
            ``(log e_DEM - log e)^2`` (least squares over the compared bounces); ``"bounces"``:
            the mean square log gap of ``e_exp,1-3``; ``fit_e``: the peak loss.
        peak_loss: The bounce-by-bounce mismatch :func:`rockjax.metrics.peak_loss` [-] (what a
            single ``beta`` cannot remove: the DEM's amplitude dependence of ``e``).
        history_error: The paper's weighted-mean history error of the DEM against Housner,
            up to the last compared bounce [-] (None for ``target="bounces"``).
        history: Per iteration: ``"beta"`` [s] and ``"loss"`` [-] (NumPy arrays).
        n_simulations: DEM (or Housner, for ``fit_e``) runs spent, per release amplitude.
        n_iterations: Optimiser iterations.
        converged: True only if the target is met within its stated tolerance and every
            number is finite: ``target="e"`` and :func:`fit_e`: ``|e_effective - e| <=``
            :data:`E_TOL`; ``target="bounces"``: each ``e_exp`` in its band of
            :data:`BOUNCE_BANDS`; and the method's stopping rule was met before ``max_iter``.
        reason: Empty when ``converged``; else why not, in words.
        e_range: Reachable ``(e at beta_max, e at beta = 0)`` [-] (``fit_beta`` with
            ``target="e"``; None otherwise). Both ends finite (else ``fit_beta`` raises).
        beta_max: Upper end of the searched range [s].
        method: ``"lbfgs"``, ``"grid"`` or ``"root"``.
        root_finish: ``method="lbfgs"`` only: True when L-BFGS stopped with
            ``|gap| > GAP_TOL`` and false position finished the fit (see :data:`GAP_TOL`).
        seconds: Wall time of the fit [s] (including compilation on a first call).
        dem: DEM response at the result (first release amplitude).
        housner: Housner reference (first release amplitude), or None.
    """

    beta: float
    e: float | None
    e_effective: float
    e_exp: np.ndarray
    loss: float
    peak_loss: float
    history_error: float | None
    history: dict
    n_simulations: int
    n_iterations: int
    converged: bool
    e_range: tuple | None
    beta_max: float
    method: str
    seconds: float
    dem: Response
    housner: Response | None
    root_finish: bool = False
    reason: str = ""

    @property
    def e_target(self):
        """Alias of ``e``."""
        return self.e


# --------------------------------------------------------------------------- the problem


class _Problem(eqx.Module):
    """Everything a loss evaluation needs; arrays traced, the rest static (one compile per
    geometry/duration)."""

    block: Block
    theta0: jax.Array  # (n_release,)
    ref: metrics.Peaks  # Housner reference peaks, leading axis n_release (or dummies)
    targets: jax.Array  # bounce targets (target="bounces") or e (target="e")
    gap: jax.Array
    scale: jax.Array  # S: d(log e)/d(beta) magnitude [1/s], for u = S beta
    beta_cap: jax.Array
    mode: str = eqx.field(static=True)
    kind: str = eqx.field(static=True)  # "e" or "bounces"
    n_bounces: int = eqx.field(static=True)
    duration: float = eqx.field(static=True)
    dt: float = eqx.field(static=True)
    dashpot: str = eqx.field(static=True)
    onset: str = eqx.field(static=True)
    hysteresis: float = eqx.field(static=True)


def _dem(problem: _Problem, beta, theta0, save_energy=False) -> Response:
    return simulate_dem(
        problem.block,
        beta=beta,
        mode=problem.mode,
        gap=problem.gap,
        theta0=theta0,
        duration=problem.duration,
        dt=problem.dt,
        dashpot=problem.dashpot,
        onset=problem.onset,
        save_dt=SAVE_DT,
        throw=False,
    )


def _dem_peaks(problem: _Problem, beta):
    def one(theta0):
        r = _dem(problem, beta, theta0)
        pk = metrics.peaks(
            r.t, r.theta, problem.block.eta, problem.n_bounces, problem.mode, problem.hysteresis
        )
        return pk, r.status

    return jax.vmap(one)(problem.theta0)


def _bounce_log_e(problem: _Problem, pk: metrics.Peaks):
    n = jnp.arange(1, 4)[None, :]
    e_n = e_exp(pk.amplitude[:, 1:4], pk.amplitude[:, :1], problem.block.eta, n)
    return jnp.log(e_n)


def _stats(problem: _Problem, beta):
    """``(loss, signed gap, the DEM's own log e, peak loss)`` at ``beta``; NaN if a run failed.

    ``target="e"``: the gap is :func:`rockjax.metrics.log_e_gap` (the least-squares
    ``log e_DEM - log e`` over the compared bounces, averaged over the releases) and the loss is
    its square, zero exactly where the DEM's restitution equals the target. The full
    bounce-by-bounce mismatch :func:`rockjax.metrics.peak_loss` is returned beside it: what is
    left of it at the optimum is the DEM's amplitude dependence of ``e``, which no single
    ``beta`` removes. ``target="bounces"``: the loss is the mean square of the three
    ``log e_exp,n - log target_n`` and the gap their mean.
    """
    pk, status = _dem_peaks(problem, beta)
    if problem.kind == "e":
        gap = jnp.mean(jax.vmap(metrics.log_e_gap)(pk, problem.ref))
        shape = jnp.mean(jax.vmap(metrics.peak_loss)(pk, problem.ref))
        loss = gap * gap
    else:
        d = _bounce_log_e(problem, pk) - jnp.log(problem.targets)[None, :]
        loss = jnp.mean(d * d)
        gap = jnp.mean(d)
        shape = loss
    own = jnp.mean(jax.vmap(metrics.log_e_fit)(pk))  # the DEM's own log e, target-free
    bad = jnp.any(status != STATUS_OK)
    return tuple(jnp.where(bad, jnp.nan, x) for x in (loss, gap, own, shape))


@eqx.filter_jit
def _stats_batch(problem: _Problem, betas):
    return jax.vmap(lambda b: _stats(problem, b))(betas)


def _beta_of_u(problem: _Problem, u):
    return problem.beta_cap * jnp.tanh(jnp.abs(u) / (problem.scale * problem.beta_cap))


@eqx.filter_custom_vjp
def _loss_u(u, problem: _Problem):
    return _stats(problem, _beta_of_u(problem, u))[0]


@_loss_u.def_fwd
def _loss_u_fwd(perturbed, u, problem):
    # Forward mode: one tangent, no reverse pass through the long scan. The derivative is
    # that of the signed gap (the loss is its square, or for "bounces" built from it), checked
    # against the monotone trend: where contacts chatter (squat blocks) the local derivative
    # of a DEM history is exact but says nothing about the trend (it flips sign or is off by
    # orders of magnitude from one beta to the next), so a gap slope of the wrong sign, or
    # more than 10x off the secant slope of the endpoint scan, is replaced by that secant.
    def f(v):
        loss, gap, _, _ = _stats(problem, _beta_of_u(problem, v))
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


@_loss_u.def_bwd
def _loss_u_bwd(dval, g, perturbed, u, problem):
    return g * dval


def _forward_mode(loss):
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

    return wrapped


# L-BFGS with a backtracking (Armijo) line search: its trial points need the loss only, so
# one iteration is one forward-mode derivative plus (usually) one plain run, and the compiled
# program holds one copy of each (a zoom line search holds four derivative copies: ~3x the
# compile time).
_OPT = optax.lbfgs(
    memory_size=5,
    linesearch=optax.scale_by_backtracking_linesearch(
        max_backtracking_steps=12, decrease_factor=0.5
    ),
)


@eqx.filter_jit
def _value_and_grad(loss, u, problem):
    return jax.value_and_grad(loss)(u, problem)


@eqx.filter_jit
def _update(loss, u, state, value, grad, problem):
    def fn(x):
        return loss(x, problem)

    updates, state = _OPT.update(grad, state, u, value=value, grad=grad, value_fn=fn)
    n_ls = optax.tree_utils.tree_get(state, "num_linesearch_steps")
    failed = optax.tree_utils.tree_get(state, "decrease_error") > 0
    return optax.apply_updates(u, updates), state, n_ls, failed


def _minimize(loss, problem, u0, params_of, rtol: float, max_iter: int):
    """L-BFGS on ``loss(u, problem)`` from ``u0``; stops when no parameter (``params_of(u)``,
    a tuple of floats) moves by more than ``rtol`` relative in an iteration, or when the line
    search twice in a row (the second time from a reset curvature memory) finds no decrease:
    a stationary point to within the loss's numerical noise.

    Returns ``(u, history of (params, loss), n_simulations, n_iterations, converged)``; one
    simulation is one loss evaluation (with or without its derivative).
    """
    u = jnp.asarray(u0, float)
    state = _OPT.init(u)
    hist, n_sims, converged, n_iter, restarted = [], 0, False, 0, False
    prev = params_of(u)
    for n_iter in range(1, max_iter + 1):
        value, grad = _value_and_grad(loss, u, problem)
        n_sims += 1
        if not np.isfinite(float(value)):
            raise ValueError(
                f"the calibration loss is not finite at {prev} (a simulation failed); "
                "check the block, or narrow beta_max."
            )
        u_new, state, n_ls, failed = _update(loss, u, state, value, grad, problem)
        n_sims += int(n_ls)
        if bool(failed):
            hist.append((prev, float(value)))
            if restarted:  # twice in a row: stationary to within the loss's noise
                converged = True
                break
            state, restarted = _OPT.init(u), True  # drop the curvature memory, retry
            continue
        restarted = False
        u = u_new
        now = params_of(u)
        hist.append((now, float(value)))
        if all(abs(a - b) <= rtol * max(abs(a), 1e-12) for a, b in zip(now, prev)):
            converged = True
            break
        prev = now
    return u, hist, n_sims, n_iter, converged


# --------------------------------------------------------------------------- set-up


def _release(block: Block, theta0):
    eta = float(block.eta)
    th = np.atleast_1d(np.asarray(0.5 * eta if theta0 is None else theta0, float))
    if th.ndim != 1 or th.size == 0 or not np.all(np.isfinite(th)):
        raise ValueError(
            f"theta0 must be a release rotation [rad] or a 1-D list of them; got {theta0}."
        )
    if np.any(np.abs(th) >= eta) or np.any(np.abs(th) < 0.05 * eta):
        raise ValueError(
            f"theta0={th} rad: each release must satisfy 0.05 eta <= |theta0| < eta "
            f"(eta = {eta:.4g} rad); e.g. theta0=0.5*block.eta."
        )
    return np.abs(th)


def _concrete_block(block: Block) -> Block:
    try:
        return jax.tree.map(lambda x: float(np.asarray(x)), block)
    except Exception:
        raise ValueError(
            "fit_beta/fit_e need a concrete Block (Python floats), not traced values."
        ) from None


def _duration(block: Block, theta0: np.ndarray, n_bounces: int) -> float:
    """Long enough for impact n_bounces + 1 at the largest release (rounded up to 0.5 s so
    similar blocks share a compilation)."""
    t_full = float(free_rocking_period(block.p, block.eta, float(np.max(theta0))))
    return math.ceil(2.0 * (n_bounces + 2) * 0.5 * t_full) / 2.0


FACADE_BETA_MAX_HCRIT = 8.0
"""Default ``beta_max`` of a facade (``mode="one_sided"``) in units of ``beta_Hcrit`` (the
paper's lower bound from ``omega_Hcrit``): this DEM's facade bounces vanish by 2-8
``beta_Hcrit`` and its best fits lie at 0.5-6 ``beta_Hcrit`` (calibrate/REPORT.md), far below
``beta_DeJong``."""


def _default_beta_max(block: Block, mode: str) -> float:
    """``2 beta_DeJong`` for parapets; ``FACADE_BETA_MAX_HCRIT beta_Hcrit`` for facades [s]."""
    if mode == "one_sided":
        return FACADE_BETA_MAX_HCRIT * float(beta_hcrit(block))
    return 2.0 * float(beta_dejong(block))


def _hysteresis(mode):
    return metrics.HYSTERESIS if mode == "two_sided" else 0.1 * metrics.HYSTERESIS


def _housner_peaks(block, e, theta0, mode, n_bounces, duration):
    pks, resps = [], []
    for th in theta0:
        r = simulate_housner(block, e=e, mode=mode, theta0=th, duration=duration, dt=SAVE_DT)
        pks.append(metrics.peaks(r.t, r.theta, block.eta, n_bounces, mode, _hysteresis(mode)))
        resps.append(r)
    return jax.tree.map(lambda *x: jnp.stack(x), *pks), resps


def _make_problem(
    block, *, e, target, mode, theta0, n_bounces, beta_max, dashpot, gap, onset
) -> tuple[_Problem, list]:
    check_choice("mode", mode, MODES)
    one_sided = mode == "one_sided"
    defaulted = target is None
    if defaulted:
        target = default_target(mode)
    check_choice("target", target, ("e", "bounces"))
    block = _concrete_block(block)
    th = _release(block, theta0)
    if n_bounces is None:
        n_bounces = 3 if (one_sided or target == "bounces") else 8
    elif isinstance(n_bounces, bool) or not (
        isinstance(n_bounces, (int, np.integer)) and n_bounces >= 1
    ):
        raise ValueError(
            f"n_bounces (impacts compared) must be an int >= 1; got {n_bounces!r}. Leave it "
            "None for the default (8 two-sided, 3 one-sided)."
        )
    if target == "bounces":
        if not one_sided:
            raise ValueError(
                "target='bounces' is the facade calibration (measured e_exp of bounces 1-3 as "
                "fractions of e_ISR); use mode='one_sided', or target='e' for a parapet."
            )
        if e is not None:
            if defaulted:
                raise ValueError(
                    "mode='one_sided' calibrates to the facade bounce targets by default "
                    "(target='bounces', which takes no e); drop e, or pass target='e' to match "
                    "Housner's one-sided rocking with this e instead."
                )
            raise ValueError("target='bounces' takes no e (its targets are fractions of e_ISR).")
        n_bounces = max(int(n_bounces), 3)
    elif e is None:
        raise ValueError(
            "fit_beta needs the target restitution e (e.g. e=rj.e_housner(block), Eq. 2), or "
            "target='bounces' for a facade."
        )
    if beta_max is None:
        beta_max = _default_beta_max(block, mode)
    if not (np.isfinite(beta_max) and beta_max > 0):
        raise ValueError(f"beta_max must be a positive damping coefficient in s; got {beta_max}.")
    beta_cap = 1.25 * float(beta_max)
    duration = _duration(block, th, n_bounces)
    dt = stable_dt(block, beta_cap, mode=mode)
    resps = []
    if target == "e":
        e_val = float(np.asarray(e))
        hi = 1.0
        if not (0.0 < abs(e_val) <= hi):
            raise ValueError(f"e (restitution, dimensionless) must be in (0, 1]; got e={e_val}.")
        # Housner's bounce k keeps e^(2k) of the release energy (impact map x flight energy
        # conservation): refuse an uninformative e before running anything, then check the runs
        if e_val**2 < MIN_ENERGY_RATIO:
            _check_informative(None, e_val, th, mode, n_bounces)
        ref, resps = _housner_peaks(block, e_val, th, mode, n_bounces, duration)
        _check_informative(ref, e_val, th, mode, n_bounces)
        targets = jnp.asarray([abs(e_val)])
    else:
        ref = metrics.Peaks(
            t=jnp.zeros((th.size, n_bounces + 1)),
            amplitude=jnp.zeros((th.size, n_bounces + 1)),
            log_energy=jnp.zeros((th.size, n_bounces + 1)),
            valid=jnp.zeros((th.size, n_bounces + 1), bool),
            n_impacts=jnp.zeros(th.size, jnp.int32),
        )
        targets = jnp.asarray(BOUNCE_FRACTIONS) * abs(float(e_isr(block)))
    problem = _Problem(
        block=block,
        theta0=jnp.asarray(th),
        ref=ref,
        targets=targets,
        dt=float(dt),
        gap=jnp.asarray(float(gap)),
        scale=jnp.asarray(1.0),
        beta_cap=jnp.asarray(beta_cap),
        mode=mode,
        kind=target,
        n_bounces=int(n_bounces),
        duration=duration,
        dashpot=dashpot,
        onset=onset,
        hysteresis=_hysteresis(mode),
    )
    return problem, resps


def default_target(mode: str) -> str:
    """The calibration target of a mode: ``"e"`` two-sided, ``"bounces"`` one-sided.

    A facade's one-sided Housner rocking with ``e = |e_ISR|`` keeps about 20 % of its energy per
    impact, so at most two bounces inform an ``e`` fit, and the measured facade bounces are not
    Housner's (their ``e_exp`` rises from ~68 % to ~100 % of ``|e_ISR|``, :data:`BOUNCE_FRACTIONS`):
    the bounce targets are what a facade is calibrated to.
    """
    check_choice("mode", mode, MODES)
    return "bounces" if mode == "one_sided" else "e"


def _check_informative(ref: metrics.Peaks | None, e, th, mode, n_bounces):
    """Refuse a target ``e`` whose Housner reference has no bounce that keeps
    :data:`MIN_ENERGY_RATIO` of its release energy: the loss would be identically zero."""
    if ref is not None:
        lu = np.asarray(ref.log_energy)
        use = np.asarray(ref.valid) & (lu - lu[:, :1] >= math.log(MIN_ENERGY_RATIO))
        if np.all(use[:, 1:].sum(axis=1) > 0):
            return
    fix = (
        "use target='bounces' (the facade default)"
        if mode == "one_sided"
        else "raise e, or calibrate to a measured e"
    )
    raise ValueError(
        f"target e={e:.4g} gives no informative bounce: Housner's free rocking with it from "
        f"theta0={np.round(th, 5).tolist()} rad keeps less than {100 * MIN_ENERGY_RATIO:g} % "
        f"of the release energy at each of its first {n_bounces} impacts (bounce k keeps e^(2k), "
        f"so e >= {math.sqrt(MIN_ENERGY_RATIO):.3f} is needed), and the calibration loss would "
        f"be identically zero. {fix[0].upper() + fix[1:]}."
    )


def _range_message(problem, g0, g1, beta_max, e_range):
    if problem.kind == "e":
        e = float(problem.targets[0])
        lo, hi = e_range
        fix = (
            "; the 'clipped' dashpot saturates: use dashpot='closed' for lower e"
            if problem.dashpot == "clipped"
            else ", or widen beta_max for lower e"
        )
        if problem.mode == "one_sided":
            fix += "; or use target='bounces' (the facade default)"
        return (
            f"target e={e:.4g} is not reachable by this DEM block: over beta in "
            f"[0, {beta_max:.4g}] s its restitution spans e = {lo:.4f} (beta_max) to {hi:.4f} "
            f"(beta = 0; dashpot={problem.dashpot!r}). Pick e in that range{fix}."
        )
    return (
        f"the facade bounce targets {np.round(np.asarray(problem.targets), 4).tolist()} are not "
        f"bracketed over beta in [0, {beta_max:.4g}] s (mean log-gap {g0:+.3g} at beta = 0, "
        f"{g1:+.3g} at beta_max); widen beta_max."
    )


def _check_range(problem, scan, own_s, beta_max):
    """The reachable ``(e(beta_max), e(0))`` of a ``target="e"`` fit (None for bounces), or a
    ValueError where the DEM keeps no informative bounce at an end (the range is undefined)."""
    e_lo, e_hi = math.exp(float(own_s[-1])), math.exp(float(own_s[0]))
    one_sided = problem.mode == "one_sided"
    lost = (
        f"keeps no bounce with {100 * MIN_ENERGY_RATIO:g} % of its release energy within "
        f"{problem.n_bounces} impacts"
    )
    if not np.isfinite(e_hi):
        raise ValueError(
            f"this DEM block {lost} even at beta = 0 (or a run failed): nothing to calibrate. "
            "Check the block (E, rho), the release theta0 and n_bounces"
            + (", or the gap." if one_sided else ".")
        )
    if problem.kind != "e":
        return None
    if not np.isfinite(e_lo):
        ok = [float(b) for b, o in zip(scan, own_s) if np.isfinite(o)]
        where = (
            f" (the scan saw bounces up to beta = {max(ok):.4g} s; the step is sized for "
            "beta_max, so aim a little lower)"
            if len(ok) > 1
            else ""
        )
        raise ValueError(
            f"the reachable range of e is undefined at beta_max={beta_max:.4g} s: the DEM block "
            f"{lost} there (its restitution is below {math.sqrt(MIN_ENERGY_RATIO):.3f}). Lower "
            f"beta_max{where}"
            + (", or use target='bounces' (the facade default)." if one_sided else ".")
        )
    return (e_lo, e_hi)


def _check_reachable(problem, g0, g1, beta_max, e_range):
    if not (np.isfinite(g0) and np.isfinite(g1)):
        raise ValueError(
            "a DEM calibration run failed (non-finite or unstable); check the block and beta_max."
        )
    if not (g0 >= 0.0 >= g1):
        raise ValueError(_range_message(problem, g0, g1, beta_max, e_range))


# --------------------------------------------------------------------------- public API


def fit_beta(
    block: Block,
    e=None,
    *,
    target: str | None = None,
    mode: str = "two_sided",
    theta0=None,
    n_bounces: int | None = None,
    beta0: float | None = None,
    beta_max: float | None = None,
    method: str = "lbfgs",
    n_seed: int = 9,
    n_grid: int = 256,
    rtol: float = 1e-4,
    max_iter: int = 40,
    dashpot: str = "closed",
    gap: float = 0.0,
    onset: str = "sub_step",
) -> Calibration:
    """Fit the DEM's ``beta`` [s] so that its free rocking matches Housner's with restitution ``e``.

    Args:
        block: The block (concrete floats).
        e: Target restitution [-] (two-sided ``e``; one-sided ``|e|``), e.g. ``rj.e_housner``
            (Eq. 2) or a measured value (``target="e"`` only).
        target: ``"e"`` (match Housner with ``e``) or ``"bounces"`` (facades: match ``e_exp``
            of bounces 1-3 to :data:`BOUNCE_FRACTIONS` of ``|e_ISR|``, Eq. 5-6); default
            (None) the mode's, :func:`default_target`: ``"e"`` two-sided, ``"bounces"``
            one-sided.
        mode: ``"two_sided"`` (parapet) or ``"one_sided"`` (facade).
        theta0: Release rotation(s) [rad] (default ``0.5 eta``); several are averaged.
        n_bounces: Impacts compared (default 8 two-sided, 3 one-sided).
        beta0: Starting ``beta`` [s]; default: seeded by a vmapped scan of ``n_seed`` values.
        beta_max: Upper end of the search [s] (default ``2 beta_DeJong``; facades
            ``8 beta_Hcrit``, see :data:`FACADE_BETA_MAX_HCRIT`).
        method: ``"lbfgs"`` (gradient, default), ``"grid"`` (``n_grid`` points) or ``"root"``.
        rtol: Stop when an iteration moves ``beta`` by less than ``rtol`` relative.
        max_iter: Iteration cap (L-BFGS or root find).
        dashpot, gap, onset: DEM options (see :func:`rockjax.simulate_dem`).

    Returns:
        A :class:`Calibration` (``.beta``, ``.e_effective``, ``.loss``, ``.history``,
        ``.n_simulations``, ...). ``.converged`` is True only when the target is met within
        its tolerance (:data:`E_TOL`, :data:`BOUNCE_BANDS`), measured on the DEM's history
        independently of the loss; otherwise ``.reason`` says what was missed.

    Raises:
        ValueError: bad input (e.g. ``n_bounces < 1``), a target with no informative bounce
            (Housner's bounces keep less than :data:`MIN_ENERGY_RATIO` of the release energy:
            the loss would be identically zero), a DEM block that keeps no such bounce at
            ``beta = 0`` or (``target="e"``) at ``beta_max`` (the reachable range is undefined),
            or a target outside the reachable range. The message gives the range and the fix.
            All are raised before the optimisation.
    """
    check_choice("method", method, METHODS)
    t_start = time.perf_counter()
    problem, h_resps = _make_problem(
        block,
        e=e,
        target=target,
        mode=mode,
        theta0=theta0,
        n_bounces=n_bounces,
        beta_max=beta_max,
        dashpot=dashpot,
        gap=gap,
        onset=onset,
    )
    bmax = float(problem.beta_cap) / 1.25
    # reachability, slope scale, and (no beta0) a seed: one vmapped batch of DEM runs
    if method == "lbfgs" and beta0 is None:
        scan = np.linspace(0.0, bmax, max(2, n_seed))
    else:
        scan = np.array([0.0, bmax])
    loss_s, gap_s, own_s, _ = map(np.asarray, _stats_batch(problem, jnp.asarray(scan)))
    n_sims = scan.size
    e_range = _check_range(problem, scan, own_s, bmax)
    _check_reachable(problem, float(gap_s[0]), float(gap_s[-1]), bmax, e_range)
    slope = max((gap_s[0] - gap_s[-1]) / bmax, 1e-12)
    problem = eqx.tree_at(lambda p: p.scale, problem, jnp.asarray(slope))
    hist_b, hist_l = list(scan), list(loss_s)

    converged = True
    n_iter = 0
    root_finish = False
    if method == "grid":
        beta, n_add, grid, gl = _grid(problem, bmax, n_grid)
        n_sims += n_add
        hist_b, hist_l = list(grid), list(gl)
    elif method == "root":
        beta, n_add, hb, hl, converged, n_iter = _illinois(problem, scan, gap_s, rtol, max_iter)
        n_sims += n_add
        hist_b += hb
        hist_l += hl
    else:
        if beta0 is None:
            beta0 = _interp_root(scan, gap_s)
        elif not (np.isfinite(beta0) and 0.0 <= beta0 <= float(problem.beta_cap)):
            raise ValueError(
                f"beta0 must lie in [0, {float(problem.beta_cap):.4g}] s; got {beta0}."
            )
        # the inverse of beta(u) = beta_cap tanh(|u| / (S beta_cap))
        cap = float(problem.beta_cap)
        u0 = slope * cap * math.atanh(min(max(float(beta0), 1e-4 * bmax) / cap, 0.999))
        u, hist, n_add, n_iter, converged = _minimize(
            _loss_u, problem, u0, lambda v: (float(_beta_of_u(problem, v)),), rtol, max_iter
        )
        n_sims += n_add
        hist_b += [p[0] for p, _ in hist]
        hist_l += [v for _, v in hist]
        beta = float(_beta_of_u(problem, u))
        if problem.kind == "e":
            # Where the DEM's contacts chatter (squat blocks at low beta) the derivative can
            # mislead the line search into stopping on a flat step of the loss. The gap is
            # monotone and bracketed, so finish by false position from the bracket that the
            # scan and the last iterate give (usually no run: the fit is already there).
            _, g_now, _, _ = (
                float(np.asarray(x)[0]) for x in _stats_batch(problem, jnp.asarray([beta]))
            )
            n_sims += 1
            root_finish = abs(g_now) > GAP_TOL
            if root_finish:
                lo = [(float(b), float(g)) for b, g in zip(scan, gap_s) if g >= 0] + [(beta, g_now)]
                hi = [(float(b), float(g)) for b, g in zip(scan, gap_s) if g < 0] + [(beta, g_now)]
                a = max((p for p in lo if p[1] >= 0), key=lambda p: p[0])
                b = min((p for p in hi if p[1] < 0), key=lambda p: p[0])
                beta, n_add, hb, hl, converged, n_more = _illinois(
                    problem, np.array([a[0], b[0]]), np.array([a[1], b[1]]), rtol, max_iter
                )
                n_sims += n_add
                n_iter += n_more
                hist_b += hb
                hist_l += hl
    return _finish(
        problem,
        beta,
        h_resps,
        hist_b,
        hist_l,
        n_sims,
        n_iter,
        converged,
        bmax,
        method,
        t_start,
        e_range,
        root_finish,
    )


def _interp_root(scan, gap_s):
    """Linear interpolation of the first sign change of the gap along the scan [s]."""
    for i in range(scan.size - 1):
        a, b = gap_s[i], gap_s[i + 1]
        if np.isfinite(a) and np.isfinite(b) and a >= 0.0 >= b:
            return (
                float(scan[i] + (scan[i + 1] - scan[i]) * a / (a - b)) if a != b else float(scan[i])
            )
    return float(scan[np.nanargmin(np.abs(gap_s))])


def _grid(problem, bmax, n_grid, chunk=64):
    grid = np.linspace(0.0, bmax, n_grid)
    losses = []
    for i in range(0, n_grid, chunk):
        part = grid[i : i + chunk]
        pad = chunk - part.size
        ls = _stats_batch(problem, jnp.asarray(np.pad(part, (0, pad), mode="edge")))[0]
        losses.append(np.asarray(ls)[: part.size])
    gl = np.concatenate(losses)
    i = int(np.nanargmin(gl))
    beta = grid[i]
    if 0 < i < n_grid - 1:  # parabola through the best three points
        y0, y1, y2 = gl[i - 1], gl[i], gl[i + 1]
        den = y0 - 2 * y1 + y2
        if den > 0:
            beta = grid[i] + 0.5 * (y0 - y2) / den * (grid[1] - grid[0])
    return float(beta), n_grid, grid, gl


def _illinois(problem, scan, gap_s, rtol, max_iter):
    """Illinois false position on the monotone signed gap, bracketed by the scan."""
    a, b = float(scan[0]), float(scan[-1])
    fa, fb = float(gap_s[0]), float(gap_s[-1])
    hb, hl = [], []
    n, side, converged = 0, 0, False
    c = a
    for n in range(1, max_iter + 1):
        c = b - fb * (b - a) / (fb - fa) if fb != fa else 0.5 * (a + b)
        lc, gc, _, _ = (float(np.asarray(x)[0]) for x in _stats_batch(problem, jnp.asarray([c])))
        hb.append(c)
        hl.append(lc)
        if gc == 0.0 or abs(b - a) <= rtol * max(c, 1e-12):
            converged = True
            break
        if (gc > 0) == (fa > 0):
            a, fa = c, gc
            if side == -1:
                fb *= 0.5
            side = -1
        else:
            b, fb = c, gc
            if side == 1:
                fa *= 0.5
            side = 1
        if abs(hb[-1] - (hb[-2] if len(hb) > 1 else np.inf)) <= rtol * max(c, 1e-12):
            converged = True
            break
    return c, n, hb, hl, converged, n


def _finish(
    problem,
    beta,
    h_resps,
    hist_b,
    hist_l,
    n_sims,
    n_iter,
    converged,
    bmax,
    method,
    t_start,
    e_range,
    root_finish=False,
):
    th0 = float(problem.theta0[0])
    dem = simulate_dem(
        problem.block,
        beta=beta,
        mode=problem.mode,
        gap=float(problem.gap),
        theta0=th0,
        duration=problem.duration,
        dt=float(problem.dt),
        dashpot=problem.dashpot,
        onset=problem.onset,
        save_dt=SAVE_DT,
    )
    stats = _stats_batch(problem, jnp.asarray([beta]))
    loss, peak = float(np.asarray(stats[0])[0]), float(np.asarray(stats[3])[0])
    e_eff = _e_effective_np(dem, problem.n_bounces, problem.mode)
    e3 = _e_exp_np(dem, problem.mode)
    h_err = None
    e_val = None
    housner = h_resps[0] if h_resps else None
    if problem.kind == "e":
        e_val = float(problem.targets[0])
        t_last = _last_compared_time(housner, problem)
        w = (np.asarray(dem.t) <= t_last).astype(float)
        h_err = float(metrics.history_error(dem.theta, housner.theta, w))
        missed = _e_missed(e_val, e_eff)
        if missed and abs(float(np.asarray(stats[1])[0])) <= GAP_TOL:
            missed[-1] += (
                ", although the loss is met on the bounces that inform Housner's reference: "
                "the DEM's restitution changes from bounce to bounce (e_exp 1-3 = "
                f"{np.round(e3, 4).tolist()}), so no single beta gives both"
            )
    else:
        missed = _bounces_missed(e3, float(e_isr(problem.block)))
    converged, reason = _verdict(converged, missed, beta=beta, loss=loss)
    return Calibration(
        beta=float(beta),
        e=e_val,
        e_effective=e_eff,
        e_exp=e3,
        loss=loss,
        peak_loss=peak,
        history_error=h_err,
        history={"beta": np.asarray(hist_b), "loss": np.asarray(hist_l)},
        n_simulations=int(n_sims),
        n_iterations=int(n_iter),
        converged=bool(converged),
        e_range=e_range,
        beta_max=bmax,
        method=method,
        seconds=time.perf_counter() - t_start,
        root_finish=bool(root_finish),
        dem=dem,
        housner=housner,
        reason=reason,
    )


def _e_missed(e_target: float, e_eff: float) -> list[str]:
    """Why a restitution target is not met (empty: met within :data:`E_TOL`)."""
    if not np.isfinite(e_eff):
        return [
            f"the DEM keeps no bounce with {100 * MIN_ENERGY_RATIO:g} % of its release energy "
            "at the result (e_effective is NaN)"
        ]
    if abs(e_eff - e_target) > E_TOL:
        return [
            f"the DEM's own e_effective = {e_eff:.5f} misses the target e = {e_target:.5f} by "
            f"{abs(e_eff - e_target):.2g} > E_TOL = {E_TOL:g}"
        ]
    return []


def _bounces_missed(e3: np.ndarray, e_isr_value: float) -> list[str]:
    """Why the facade bounce targets are not met (empty: each ``e_exp`` in its band)."""
    out = []
    for n, (val, (lo, hi)) in enumerate(zip(e3, BOUNCE_BANDS), start=1):
        r = val / abs(e_isr_value)
        if not np.isfinite(r):
            out.append(f"bounce {n} did not happen")
        elif not lo <= r <= hi:
            out.append(
                f"bounce {n}: e_exp = {100 * r:.1f} % of |e_ISR|, outside the band "
                f"{100 * lo:g}-{100 * hi:g} %"
            )
    return out


def _verdict(stopped: bool, missed: list[str], **numbers) -> tuple[bool, str]:
    """``(converged, reason)``: the stopping rule met, every number finite, the target met."""
    why = [f"{k} is not finite" for k, v in numbers.items() if not np.isfinite(v)]
    why += missed
    if not stopped:
        why.append("the stopping rule was not met within max_iter")
    return not why, "; ".join(why)


def _last_compared_time(resp: Response, problem: _Problem) -> float:
    pk = metrics.peaks(
        resp.t, resp.theta, resp.eta, problem.n_bounces, problem.mode, problem.hysteresis
    )
    keep = np.asarray(pk.valid) & (
        np.asarray(pk.log_energy) - float(pk.log_energy[0]) >= math.log(MIN_ENERGY_RATIO)
    )
    return float(np.asarray(pk.t)[keep].max())


def _bounces_np(resp: Response, mode: str) -> np.ndarray:
    """Bounce amplitudes ``|theta_k|``, ``k >= 1`` [rad], found in NumPy on the saved history,
    without impact detection (an independent path from the loss's
    :func:`rockjax.metrics.peaks`): the local maxima of ``y = |theta|`` (one-sided
    ``max(theta, 0)``: the rebounds), where two neighbours whose valley stays above half the
    smaller one are one flight (penalty-contact wobble on it; the larger is kept), each
    refined by a parabola through three samples and kept only if it exceeds
    ``metrics.RELATIVE_BOUNCE`` of the previous kept one (the release first) and twice the
    impact threshold (micro-vibration in contact is no bounce)."""
    th = np.asarray(resp.theta, float)
    y = np.abs(th) if mode == "two_sided" else np.maximum(th, 0.0)
    idx = np.flatnonzero((y[1:-1] > y[:-2]) & (y[1:-1] >= y[2:])) + 1
    merged: list[int] = []
    for i in idx:
        if merged and y[merged[-1] : i + 1].min() > 0.5 * min(y[merged[-1]], y[i]):
            if y[i] > y[merged[-1]]:
                merged[-1] = i
        else:
            merged.append(i)
    prev = abs(float(th[0]))
    floor = 2.0 * _hysteresis(mode) * float(resp.eta)
    out = []
    for i in merged:
        y0, y1, y2 = y[i - 1], y[i], y[i + 1]
        den = y0 - 2.0 * y1 + y2
        s = min(max(0.5 * (y0 - y2) / den, -1.0), 1.0) if den < 0 else 0.0
        a = y1 - 0.25 * (y0 - y2) * s
        if a > max(floor, metrics.RELATIVE_BOUNCE * prev):
            out.append(a)
            prev = a
    return np.asarray(out, float)


def _e_effective_np(resp: Response, n_bounces: int, mode: str) -> float:
    """The DEM's restitution from its own peaks, found in NumPy (:func:`_bounces_np`): least
    squares of ``log U_k - log U_0`` on ``2k`` over the first ``n_bounces`` bounces that keep
    :data:`MIN_ENERGY_RATIO` of the release energy; NaN if none does."""
    eta = float(resp.eta)
    amp = _bounces_np(resp, mode)[:n_bounces]
    u0 = math.cos(eta - abs(float(np.asarray(resp.theta)[0]))) - math.cos(eta)
    k = np.arange(1, amp.size + 1)
    u = np.cos(eta - amp) - math.cos(eta)
    keep = u / u0 >= MIN_ENERGY_RATIO
    if not np.any(keep):
        return float("nan")
    y = np.log(u[keep] / u0)
    x = 2.0 * k[keep]
    return float(np.exp(np.sum(x * y) / np.sum(x * x)))


def _e_exp_np(resp: Response, mode: str) -> np.ndarray:
    """Eq. (6) of bounces 1-3 from :func:`_bounces_np` (NaN for a bounce that did not happen)."""
    amp = _bounces_np(resp, mode)[:3]
    th0 = abs(float(np.asarray(resp.theta)[0]))
    out = np.full(3, np.nan)
    out[: amp.size] = np.asarray(e_exp(amp, th0, float(resp.eta), np.arange(1, amp.size + 1)))
    return out


def e_effective(
    block: Block,
    beta,
    *,
    mode: str = "two_sided",
    theta0=None,
    n_bounces: int | None = None,
    dashpot: str = "closed",
    gap: float = 0.0,
    onset: str = "sub_step",
    beta_max: float | None = None,
) -> dict:
    """The DEM's restitution at each ``beta`` [s] (an array: one vmapped batch), from free rocking.

    The time step is sized as in :func:`fit_beta` with the same ``beta_max`` (default
    ``2 beta_DeJong``, raised to cover every ``beta`` given), so the two agree run for run.

    Returns a dict of NumPy arrays over ``beta``: ``"e"`` (least-squares restitution from the
    bounce energies, the statistic :func:`fit_beta` matches; NaN with no bounce), ``"e_exp"``
    (Eq. 6 of bounces 1-3, shape ``(n_beta, 3)``, first release amplitude; NaN for a bounce that
    did not happen), ``"ok"`` (run status).
    """
    betas = np.atleast_1d(np.asarray(beta, float))
    if beta_max is None:
        beta_max = _default_beta_max(_concrete_block(block), mode)
    problem, _ = _make_problem(
        block,
        e=1.0,
        target="e",
        mode=mode,
        theta0=theta0,
        n_bounces=n_bounces,
        beta_max=max(beta_max, float(np.max(betas)) / 1.25 + 1e-15),
        dashpot=dashpot,
        gap=gap,
        onset=onset,
    )
    log_e, e3, ok = _e_batch(problem, jnp.asarray(betas))
    return {
        "beta": betas,
        "e": np.exp(np.asarray(log_e)),
        "e_exp": np.asarray(e3),
        "ok": np.asarray(ok),
    }


@eqx.filter_jit
def _e_batch(problem: _Problem, betas):
    def one(beta):
        pk, status = _dem_peaks(problem, beta)
        log_e = jnp.mean(jax.vmap(metrics.log_e_fit)(pk))
        e3 = jnp.where(pk.valid[0, 1:4], jnp.exp(_bounce_log_e(problem, pk))[0], jnp.nan)
        return log_e, e3, jnp.all(status == STATUS_OK)

    return jax.vmap(one)(betas)


class _EProblem(eqx.Module):
    """fit_e: the DEM peaks (fixed) and what the Housner runs need."""

    block: Block
    theta0: jax.Array
    dem: metrics.Peaks
    mode: str = eqx.field(static=True)
    n_bounces: int = eqx.field(static=True)
    duration: float = eqx.field(static=True)
    hysteresis: float = eqx.field(static=True)


def _housner_loss(v, problem: _EProblem):
    import diffrax

    e = jax.nn.sigmoid(v)

    def one(theta0, ref):
        r = simulate_housner(
            problem.block,
            e=e,
            mode=problem.mode,
            theta0=theta0,
            duration=problem.duration,
            dt=SAVE_DT,
            adjoint=diffrax.ForwardMode(),
        )
        pk = metrics.peaks(
            r.t, r.theta, problem.block.eta, problem.n_bounces, problem.mode, problem.hysteresis
        )
        return metrics.peak_loss(pk, ref)

    return jnp.mean(jax.vmap(one)(problem.theta0, problem.dem))


_e_loss = _forward_mode(_housner_loss)


@eqx.filter_jit
def _dem_peaks_jit(problem: _Problem, beta):
    return _dem_peaks(problem, beta)


def fit_e(
    block: Block,
    beta: float,
    *,
    mode: str = "two_sided",
    theta0=None,
    n_bounces: int | None = None,
    dashpot: str = "closed",
    gap: float = 0.0,
    onset: str = "sub_step",
    rtol: float = 1e-6,
    max_iter: int = 30,
) -> Calibration:
    """The paper's direction: the Housner ``e`` whose free rocking best matches the DEM's at ``beta``.

    Minimises the same bounce log-energy loss (:func:`rockjax.metrics.peak_loss`, DEM as the
    reference) over ``e = sigmoid(v)`` with L-BFGS, the derivative taken in forward mode through
    the Housner solve (``diffrax.ForwardMode``). Starts from the DEM's own least-squares
    restitution (for free rocking Housner's bounce energies are exactly ``e^(2k) U_0``, so that
    start is already close; the iterations confirm it on the simulated responses).

    Returns:
        A :class:`Calibration` whose ``e`` is the fitted Housner restitution; ``converged``
        only if it is within :data:`E_TOL` of the DEM's own ``e_effective`` (NumPy peaks) and
        finite (else ``reason`` says why: e.g. a DEM whose restitution changes from bounce to
        bounce more than one Housner ``e`` can follow).

    Raises:
        ValueError: bad input (e.g. ``n_bounces < 1``), a failed DEM run, or a DEM that keeps
            no bounce with :data:`MIN_ENERGY_RATIO` of its release energy (nothing to match).
    """
    t_start = time.perf_counter()
    if not (np.isfinite(beta) and beta >= 0):
        raise ValueError(f"beta must be a damping coefficient >= 0 in s; got beta={beta}.")
    problem, _ = _make_problem(
        block,
        e=1.0,
        target="e",
        mode=mode,
        theta0=theta0,
        n_bounces=n_bounces,
        beta_max=max(float(beta), 1e-9),
        dashpot=dashpot,
        gap=gap,
        onset=onset,
    )
    dem_pk, status = _dem_peaks_jit(problem, jnp.asarray(float(beta)))
    if not bool(np.all(np.asarray(status) == STATUS_OK)):
        raise ValueError(f"the DEM run at beta={beta} s failed; check beta and the block.")
    log_e0 = float(np.nanmean(np.asarray(jax.vmap(metrics.log_e_fit)(dem_pk))))
    if not np.isfinite(log_e0):
        raise ValueError(
            f"the DEM block at beta={beta} s does not bounce after its release (no impact "
            "keeps 2 % of the release energy): no Housner e matches it; lower beta."
        )
    eproblem = _EProblem(
        block=problem.block,
        theta0=problem.theta0,
        dem=dem_pk,
        mode=mode,
        n_bounces=problem.n_bounces,
        duration=problem.duration,
        hysteresis=problem.hysteresis,
    )
    e0 = min(max(math.exp(log_e0), 1e-3), 1 - 1e-6)
    v = jnp.asarray(math.log(e0 / (1 - e0)))
    v, hist, n_sims, n_iter, converged = _minimize(
        _e_loss, eproblem, v, lambda x: (float(jax.nn.sigmoid(x)),), rtol, max_iter
    )
    hist_e = [e0] + [p[0] for p, _ in hist]
    hist_l = [val for _, val in hist]
    e_fit = float(jax.nn.sigmoid(v))
    th0 = float(problem.theta0[0])
    dem = _dem(problem, float(beta), th0)
    housner = simulate_housner(
        problem.block, e=e_fit, mode=mode, theta0=th0, duration=problem.duration, dt=SAVE_DT
    )
    t_last = _last_compared_time(housner, problem)
    w = (np.asarray(dem.t) <= t_last).astype(float)
    e_eff = _e_effective_np(dem, problem.n_bounces, mode)
    loss = float(_housner_loss(v, eproblem))
    converged, reason = _verdict(converged, _e_missed(e_fit, e_eff), e=e_fit, loss=loss)
    return Calibration(
        beta=float(beta),
        e=e_fit,
        e_effective=e_eff,
        e_exp=_e_exp_np(dem, mode),
        loss=loss,
        peak_loss=loss,
        history_error=float(metrics.history_error(dem.theta, housner.theta, w)),
        history={"e": np.asarray(hist_e[1:]), "loss": np.asarray(hist_l)},
        n_simulations=n_sims,
        n_iterations=n_iter,
        converged=converged,
        e_range=None,
        beta_max=float(beta),
        method="lbfgs",
        seconds=time.perf_counter() - t_start,
        dem=dem,
        housner=housner,
        reason=reason,
    )


__all__: list[Any] = [
    "BOUNCE_BANDS",
    "BOUNCE_FRACTIONS",
    "Calibration",
    "E_TOL",
    "default_target",
    "HistoryFit",
    "e_effective",
    "fit_beta",
    "fit_e",
    "fit_history",
]


# --------------------------------------------------------------------------- two parameters


class _HProblem(eqx.Module):
    """fit_history: the measured peaks and the DEM set-up (b and beta are the unknowns)."""

    block: Block
    theta0: jax.Array
    measured: metrics.Peaks
    beta_ref: jax.Array
    t_scale: jax.Array
    mode: str = eqx.field(static=True)
    n_bounces: int = eqx.field(static=True)
    duration: float = eqx.field(static=True)
    save_dt: float = eqx.field(static=True)
    dt: float = eqx.field(static=True)
    hysteresis: float = eqx.field(static=True)


def _history_params(problem: _HProblem, u):
    return problem.beta_ref * jnp.exp(u[0]), problem.block.b * jnp.exp(u[1])


def _history_loss(u, problem: _HProblem):
    beta, b = _history_params(problem, u)
    blk = eqx.tree_at(lambda k: k.b, problem.block, b)
    r = simulate_dem(
        blk,
        beta=beta,
        mode=problem.mode,
        theta0=problem.theta0,
        duration=problem.duration,
        dt=problem.dt,
        save_dt=problem.save_dt,
        throw=False,
    )
    pk = metrics.peaks(r.t, r.theta, blk.eta, problem.n_bounces, problem.mode, problem.hysteresis)
    ref = problem.measured
    loss = metrics.amplitude_loss(pk, ref, MIN_ENERGY_RATIO) + metrics.timing_loss(
        pk, ref, problem.t_scale, MIN_ENERGY_RATIO
    )
    return jnp.where(r.status == STATUS_OK, loss, jnp.nan)


_h_loss = _forward_mode(_history_loss)


@dataclasses.dataclass(frozen=True)
class HistoryFit:
    """Result of :func:`fit_history`: ``beta`` [s] and the effective width ``b`` [m] of the DEM
    block that best reproduce a measured free-rocking history.

    Attributes:
        beta: Fitted damping [s].
        b: Fitted rocking width [m] (e.g. a pivot moved inward by damaged corners).
        block: The nominal block with ``b`` replaced.
        loss: Final loss [-]. history: ``"beta"``, ``"b"``, ``"loss"`` per iteration.
        n_simulations, n_iterations, seconds: as in :class:`Calibration`.
        converged: True only if the stopping rule was met and the loss and both parameters
            are finite. A measured history has no exact target: the residual is ``loss``.
        reason: Empty when ``converged``; else why not.
        dem: DEM response at the fit.
    """

    beta: float
    b: float
    block: Block
    loss: float
    history: dict
    n_simulations: int
    n_iterations: int
    converged: bool
    seconds: float
    dem: Response
    reason: str = ""


def _history_problem(block, measured, beta0, mode, n_bounces) -> _HProblem:
    """Checks and set-up of :func:`fit_history` (also used to map its loss on a grid)."""
    check_choice("mode", mode, MODES)
    if isinstance(n_bounces, bool) or not (
        isinstance(n_bounces, (int, np.integer)) and n_bounces >= 1
    ):
        raise ValueError(f"n_bounces (impacts compared) must be an int >= 1; got {n_bounces!r}.")
    block = _concrete_block(block)
    t = np.asarray(measured.t, float)
    th = np.asarray(measured.theta, float)
    if t.ndim != 1 or t.size < 3 or not np.all(np.isfinite(th)):
        raise ValueError("measured must be a Response with finite, uniformly sampled theta(t).")
    save_dt = float(t[1] - t[0])
    if not np.allclose(np.diff(t), save_dt, rtol=1e-6, atol=1e-12):
        raise ValueError("measured.t must be uniform; resample the record first.")
    theta0 = float(th[0])
    eta = float(block.eta)
    _release(block, theta0)
    hyst = _hysteresis(mode)
    ref = metrics.peaks(t, th, eta, n_bounces, mode, hyst)
    if int(ref.n_impacts) < 2:
        raise ValueError("the measured history has fewer than two impacts; record longer.")
    w, _ = metrics._bounce_weights(ref, MIN_ENERGY_RATIO)
    if not float(jnp.sum(w)) > 0:
        raise ValueError(
            f"the measured history keeps no bounce with {100 * MIN_ENERGY_RATIO:g} % of its "
            "release energy: the loss would be identically zero; release from a larger theta0."
        )
    beta0 = 0.3 * float(beta_dejong(block)) if beta0 is None else float(beta0)
    if not beta0 > 0:
        raise ValueError(f"beta0 must be > 0 s (the fit works on log beta); got {beta0}.")
    wide = eqx.tree_at(lambda k: k.b, block, 1.5 * block.b)
    dt = 0.8 * min(stable_dt(block, 20 * beta0, mode=mode), stable_dt(wide, 20 * beta0, mode=mode))
    problem = _HProblem(
        block=block,
        theta0=jnp.asarray(theta0),
        measured=ref,
        beta_ref=jnp.asarray(beta0),
        t_scale=jnp.asarray(float(ref.t[1]) if bool(ref.valid[1]) else t[-1]),
        mode=mode,
        n_bounces=n_bounces,
        duration=float(t[-1]),
        save_dt=save_dt,
        dt=float(dt),
        hysteresis=hyst,
    )
    return problem


def fit_history(
    block: Block,
    measured: Response,
    *,
    beta0: float | None = None,
    mode: str = "two_sided",
    n_bounces: int = 8,
    rtol: float = 1e-5,
    max_iter: int = 50,
) -> HistoryFit:
    """Fit two DEM parameters at once, ``beta`` and the rocking width ``b``, to a measured
    free-rocking history (released from rest at ``measured.theta[0]``).

    The loss compares the bounce peaks bounce by bounce: the gap of ``log |theta_k|`` (the energy
    lost per impact, set mostly by ``beta``) plus the gap of the peak times over the first
    impact time (the rocking period, set by ``b`` through ``eta`` and ``p``), weights as in
    :func:`rockjax.metrics.peak_loss`. Unknowns are scaled as ``beta = beta0 exp(u0)`` and
    ``b = b_nominal exp(u1)``; L-BFGS with forward-mode derivatives (two tangents). A dense
    grid over two parameters costs ``n^2`` runs; this takes tens.

    Args:
        block: The nominal block (its ``b`` is the start; ``h``, ``rho``, ``E`` are kept).
        measured: The measured response (uniform samples; e.g. a test record as a Response).
        beta0: Starting ``beta`` [s] (default ``0.3 beta_DeJong``).
        mode: ``"two_sided"`` or ``"one_sided"``.
        n_bounces: Bounces compared.

    Returns:
        A :class:`HistoryFit`.
    """
    t_start = time.perf_counter()
    problem = _history_problem(block, measured, beta0, mode, n_bounces)
    block, theta0 = problem.block, float(problem.theta0)
    t = np.asarray(measured.t, float)
    save_dt = problem.save_dt
    u, hist_raw, n_sims, n_iter, converged = _minimize(
        _h_loss,
        problem,
        jnp.zeros(2),
        lambda x: tuple(float(y) for y in _history_params(problem, x)),
        rtol,
        max_iter,
    )
    hist = {
        "beta": [p[0] for p, _ in hist_raw],
        "b": [p[1] for p, _ in hist_raw],
        "loss": [v for _, v in hist_raw],
    }
    beta, b = (float(x) for x in _history_params(problem, u))
    fitted = eqx.tree_at(lambda k: k.b, block, b)
    dem = simulate_dem(
        fitted, beta=beta, mode=mode, theta0=theta0, duration=float(t[-1]), save_dt=save_dt
    )
    loss = float(_history_loss(u, problem))
    converged, reason = _verdict(converged, [], loss=loss, beta=beta, b=b)
    return HistoryFit(
        beta=beta,
        b=b,
        block=fitted,
        loss=loss,
        history={k: np.asarray(v) for k, v in hist.items()},
        n_simulations=n_sims,
        n_iterations=n_iter,
        converged=converged,
        seconds=time.perf_counter() - t_start,
        dem=dem,
        reason=reason,
    )
