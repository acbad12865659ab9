"""``beta`` and ``b`` fitted to a measured history: :func:`fit_history`."""

from __future__ import annotations

import time

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .. import metrics
from ..block import Block
from ..dem import simulate_dem
from ..modes import Mode, as_mode
from ..response import Response
from . import _solvers as solvers
from ._derivatives import forward_mode
from ._problems import (
    history_loss,
    history_params,
    history_problem,
)
from ._result import (
    MIN_ENERGY_RATIO,
    HistoryFit,
    history_missed,
    verdict,
)
from ._solvers import check_stopping

_h_loss = forward_mode(history_loss)


def _history_params(u, problem):
    return history_params(problem, u)


def fit_history(
    block: Block,
    measured: Response,
    *,
    beta0: float | None = None,
    mode: Mode | str = "two_sided",
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
        mode: :class:`rockjax.Parapet` / ``"two_sided"`` or :class:`rockjax.Facade` /
            ``"one_sided"`` (the Facade's gap [m] is the DEM's).
        n_bounces: Bounces compared.

    Returns:
        A :class:`HistoryFit`.
    """
    t_start = time.perf_counter()
    check_stopping(rtol, max_iter, 1e-5, 50)
    mode = as_mode(mode)
    problem = history_problem(block, measured, beta0, mode, n_bounces)
    block, theta0 = problem.block, float(problem.theta0)
    t = np.asarray(measured.t, float)
    save_dt = problem.save_dt
    u, (beta, b), hist_raw, n_sims, n_iter, converged = solvers.minimize(
        _h_loss, problem, jnp.zeros(2), _history_params, rtol, max_iter
    )
    hist = {
        "beta": [p[0] for p, _ in hist_raw],
        "b": [p[1] for p, _ in hist_raw],
        "loss": [v for _, v in hist_raw],
    }
    fitted = eqx.tree_at(lambda k: k.b, block, b)
    dem = simulate_dem(
        fitted, beta=beta, mode=mode, theta0=theta0, duration=float(t[-1]), save_dt=save_dt
    )
    loss = float(history_loss(u, problem))
    n_compared = int(np.sum(metrics.bounce_weights(problem.measured, MIN_ENERGY_RATIO)[0]))
    missed = history_missed(dem, measured, n_compared, float(problem.t_scale), mode)
    converged, reason = verdict(converged, missed, loss=loss, beta=beta, b=b)
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
