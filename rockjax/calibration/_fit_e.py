"""The paper's direction of the calibration: :func:`fit_e` (Housner's ``e`` of a DEM run)
and :func:`e_effective` (the DEM's restitution over a batch of ``beta``)."""

from __future__ import annotations

import math
import time

import jax
import jax.numpy as jnp
import numpy as np

from .. import metrics
from .._checks import check_nonnegative
from ..block import Block
from ..compilation import persistent_jit
from ..contact import Joint
from ..housner import simulate_housner
from ..modes import Mode, as_mode
from ..response import STATUS_OK
from . import _solvers as solvers
from ._derivatives import forward_mode
from ._problems import (
    SAVE_DT,
    CalibrationProblem,
    EProblem,
    bounce_log_e,
    build_problem,
    concrete_block,
    default_beta_max,
    dem_peaks,
    dem_run,
    housner_loss,
    last_compared_time,
)
from ._result import (
    Calibration,
    bounce_e_exp,
    e_missed,
    restitution,
    verdict,
)
from ._solvers import check_stopping


def e_effective(
    block: Block,
    beta,
    *,
    mode: Mode | str = "two_sided",
    theta0=None,
    n_bounces: int | None = None,
    joint: Joint | None = None,
    gap: float | None = None,
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
    mode = as_mode(mode, gap)
    if beta_max is None:
        beta_max = default_beta_max(concrete_block(block), mode)
    problem, _ = build_problem(
        block,
        e=1.0,
        target="e",
        mode=mode,
        theta0=theta0,
        n_bounces=n_bounces,
        beta_max=max(beta_max, float(np.max(betas)) / 1.25 + 1e-15),
        joint=joint,
    )
    log_e, e3, ok = _e_batch(problem, betas)
    return {
        "beta": betas,
        "e": np.exp(np.asarray(log_e)),
        "e_exp": np.asarray(e3),
        "ok": np.asarray(ok),
    }


@persistent_jit
def _e_batch(problem: CalibrationProblem, betas):
    def one(beta):
        pk, status = dem_peaks(problem, beta)
        log_e = jnp.mean(jax.vmap(metrics.log_e_fit)(pk))
        e3 = jnp.where(pk.valid[0, 1:4], jnp.exp(bounce_log_e(problem, pk))[0], jnp.nan)
        return log_e, e3, jnp.all(status == STATUS_OK)

    return jax.vmap(one)(betas)


_e_loss = forward_mode(housner_loss)


def _e_params(v, problem: EProblem):
    return (jax.nn.sigmoid(v),)


def _dem_peaks_jit(problem: CalibrationProblem, beta):
    return dem_peaks(problem, beta)


def fit_e(
    block: Block,
    beta: float,
    *,
    mode: Mode | str = "two_sided",
    theta0=None,
    n_bounces: int | None = None,
    joint: Joint | None = None,
    gap: float | None = None,
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
    check_nonnegative(
        "beta",
        beta,
        "s",
        "beta is the DEM's stiffness-proportional damping, e.g. 2e-3.",
        scalar=True,
    )
    check_stopping(rtol, max_iter, 1e-6, 30)
    mode = as_mode(mode, gap)
    problem, _ = build_problem(
        block,
        e=1.0,
        target="e",
        mode=mode,
        theta0=theta0,
        n_bounces=n_bounces,
        beta_max=max(float(beta), 1e-9),
        joint=joint,
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
    eproblem = EProblem(
        block=problem.block,
        theta0=problem.theta0,
        dem=dem_pk,
        mode=mode.without_gap(),  # Housner's facade stands flush on its walls
        n_bounces=problem.n_bounces,
        duration=problem.duration,
        hysteresis=problem.hysteresis,
    )
    e0 = min(max(math.exp(log_e0), 1e-3), 1 - 1e-6)
    v = jnp.asarray(math.log(e0 / (1 - e0)))
    v, (e_fit,), hist, n_sims, n_iter, converged = solvers.minimize(
        _e_loss, eproblem, v, _e_params, rtol, max_iter
    )
    hist_e = [e0] + [p[0] for p, _ in hist]
    hist_l = [val for _, val in hist]
    th0 = float(problem.theta0[0])
    dem = dem_run(problem, float(beta), th0)
    housner = simulate_housner(
        problem.block,
        e=e_fit,
        mode=mode.without_gap(),
        theta0=th0,
        duration=problem.duration,
        dt=SAVE_DT,
    )
    t_last = last_compared_time(housner, problem)
    w = (np.asarray(dem.t) <= t_last).astype(float)
    e_eff = restitution(dem, problem.n_bounces, mode)
    loss = float(housner_loss(v, eproblem))
    missed = e_missed(e_fit, e_eff)
    converged, reason = verdict(converged, missed, e=e_fit, loss=loss)
    return Calibration(
        beta=float(beta),
        e=e_fit,
        e_effective=e_eff,
        e_exp=bounce_e_exp(dem, mode),
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
        target_met=not missed,
        target_missed="; ".join(missed),
    )
