"""The solvers of the calibration: L-BFGS (optax, backtracking line search), the dense vmapped
grid, Illinois false position on the monotone signed gap, and the false-position finish of an
L-BFGS fit that stalled."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from .._checks import check_scalar
from .._lazy import lazy_module
from ..compilation import persistent_jit
from ._problems import CalibrationProblem, stats_batch

optax = lazy_module("optax")  # loaded on first use (rockjax/_lazy.py): a fit needs it


@functools.cache
def _optimizer():
    # L-BFGS with a backtracking (Armijo) line search: its trial points need the loss only,
    # so one iteration is one forward-mode derivative plus (usually) one plain run, and the
    # compiled program holds one copy of each (a zoom line search holds four derivative
    # copies: ~3x the compile time).
    return optax.lbfgs(
        memory_size=5,
        linesearch=optax.scale_by_backtracking_linesearch(
            max_backtracking_steps=12, decrease_factor=0.5
        ),
    )


@persistent_jit
def _init(u):
    # strong types, as _step returns them (a weakly typed count would trace _step again)
    return jax.tree.map(lambda x: jnp.asarray(x, x.dtype), _optimizer().init(u))


@persistent_jit
def _step(loss, params_of, u, state, problem):
    # One compiled program per iteration (the derivative, the line search and the update),
    # which the persistent cache keeps; the parameters are computed here too, so that the
    # driver does no eager arithmetic (each new eager operation compiles a small program).
    value, grad = jax.value_and_grad(loss)(u, problem)

    def fn(x):
        return loss(x, problem)

    updates, state = _optimizer().update(grad, state, u, value=value, grad=grad, value_fn=fn)
    n_ls = optax.tree_utils.tree_get(state, "num_linesearch_steps")
    failed = optax.tree_utils.tree_get(state, "decrease_error") > 0
    u_new = optax.apply_updates(u, updates)
    params = jnp.stack([jnp.asarray(p, float) for p in params_of(u, problem)])
    params_new = jnp.stack([jnp.asarray(p, float) for p in params_of(u_new, problem)])
    return value, u_new, state, n_ls, failed, params, params_new


def minimize(loss, problem, u0, params_of, rtol: float, max_iter: int, on_step=None):
    """L-BFGS on ``loss(u, problem)`` from ``u0``.

    Stops when no parameter (``params_of(u, problem)``, a tuple of scalars; traced, so give a
    module-level function: a new one compiles again) moves by more than ``rtol`` relative in
    an iteration, or when the line search twice in a row (the second time from a reset
    curvature memory) finds no decrease: a stationary point to within the loss's numerical
    noise. ``on_step(params, loss)``, if given, is called after every iteration (a progress
    bar).

    Returns ``(u, params of u, history of (params, loss), n_simulations, n_iterations,
    converged)``, params as tuples of floats; one simulation is one loss evaluation (with or
    without its derivative).

    Raises:
        ValueError: the loss is not finite (a simulation failed).
    """
    u = jax.device_put(np.asarray(u0, float))
    state = _init(u)
    hist, n_sims, converged, n_iter, restarted = [], 0, False, 0, False
    for n_iter in range(1, max_iter + 1):
        value, u_new, state_new, n_ls, failed, p_u, p_new = _step(
            loss, params_of, u, state, problem
        )
        value, prev = float(value), tuple(float(x) for x in np.asarray(p_u))
        n_sims += 1
        if not np.isfinite(value):
            raise ValueError(
                f"the calibration loss is not finite at {prev} (a simulation failed); "
                "check the block, or narrow beta_max."
            )
        n_sims += int(n_ls)
        if on_step is not None:
            on_step(prev, value)
        if bool(failed):
            hist.append((prev, value))
            if restarted:  # twice in a row: stationary to within the loss's noise
                converged = True
                break
            state, restarted = _init(u), True  # drop the curvature memory, retry
            continue
        restarted = False
        u, state = u_new, state_new
        now = tuple(float(x) for x in np.asarray(p_new))
        hist.append((now, value))
        done = all(abs(a - b) <= rtol * max(abs(a), 1e-12) for a, b in zip(now, prev))
        prev = now  # the parameters of u
        if done:
            converged = True
            break
    return u, prev, hist, n_sims, n_iter, converged


def interp_root(scan, gap_s) -> float:
    """Linear interpolation of the first sign change of the gap along the scan [s]."""
    for i in range(scan.size - 1):
        a, b = gap_s[i], gap_s[i + 1]
        if np.isfinite(a) and np.isfinite(b) and a >= 0.0 >= b:
            return (
                float(scan[i] + (scan[i + 1] - scan[i]) * a / (a - b)) if a != b else float(scan[i])
            )
    return float(scan[np.nanargmin(np.abs(gap_s))])


def grid(problem: CalibrationProblem, bmax: float, n_grid: int, chunk: int = 64):
    """Dense grid of ``n_grid`` values of ``beta`` in ``[0, bmax]`` [s] (vmapped in chunks),
    refined by a parabola through the best three points.

    Returns ``(beta, n_simulations, grid, losses)``.
    """
    betas = np.linspace(0.0, bmax, n_grid)
    losses = []
    for i in range(0, n_grid, chunk):
        part = betas[i : i + chunk]
        pad = chunk - part.size
        ls = stats_batch(problem, np.pad(part, (0, pad), mode="edge"))[0]
        losses.append(np.asarray(ls)[: part.size])
    gl = np.concatenate(losses)
    i = int(np.nanargmin(gl))
    beta = betas[i]
    if 0 < i < n_grid - 1:  # parabola through the best three points
        y0, y1, y2 = gl[i - 1], gl[i], gl[i + 1]
        den = y0 - 2 * y1 + y2
        if den > 0:
            beta = betas[i] + 0.5 * (y0 - y2) / den * (betas[1] - betas[0])
    return float(beta), n_grid, betas, gl


def illinois(problem: CalibrationProblem, scan, gap_s, rtol: float, max_iter: int, on_step=None):
    """Illinois false position on the monotone signed gap, bracketed by ``scan[0]`` and
    ``scan[-1]`` [s] with gaps ``gap_s[0] >= 0 >= gap_s[-1]``.

    Returns ``(beta, n_simulations, betas tried, their losses, converged, n_iterations)``.
    """
    a, b = float(scan[0]), float(scan[-1])
    fa, fb = float(gap_s[0]), float(gap_s[-1])
    hb, hl = [], []
    n, side, converged = 0, 0, False
    c = a
    for n in range(1, max_iter + 1):
        c = b - fb * (b - a) / (fb - fa) if fb != fa else 0.5 * (a + b)
        lc, gc, _, _ = (float(np.asarray(x)[0]) for x in stats_batch(problem, np.asarray([c])))
        hb.append(c)
        hl.append(lc)
        if on_step is not None:
            on_step((c,), lc)
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


def false_position_finish(
    problem: CalibrationProblem, scan, gap_s, beta, g_now, rtol, max_iter, on_step=None
):
    """Finish an L-BFGS fit at ``beta`` (signed gap ``g_now``) by :func:`illinois` from the
    tightest bracket that the scan (``scan``, ``gap_s``) and ``beta`` give.

    Where the DEM's contacts chatter (squat blocks at low beta) the derivative can mislead the
    line search into stopping on a flat step of the loss; the gap is monotone and bracketed.
    Returns what :func:`illinois` returns.
    """
    lo = [(float(b), float(g)) for b, g in zip(scan, gap_s) if g >= 0] + [(beta, g_now)]
    hi = [(float(b), float(g)) for b, g in zip(scan, gap_s) if g < 0] + [(beta, g_now)]
    a = max((p for p in lo if p[1] >= 0), key=lambda p: p[0])
    b = min((p for p in hi if p[1] < 0), key=lambda p: p[0])
    return illinois(
        problem, np.array([a[0], b[0]]), np.array([a[1], b[1]]), rtol, max_iter, on_step
    )


def check_count(name: str, value, least: int, default: int) -> None:
    """``value`` an int >= ``least``, checked before any run."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < least:
        raise ValueError(
            f"{name} must be an int >= {least}; got {name}={value!r}. The default is {default}."
        )


def check_stopping(rtol, max_iter, rtol_default: float, max_iter_default: int) -> None:
    """``rtol`` in (0, 1) and ``max_iter >= 1``, checked before any run."""
    check_scalar("rtol", rtol, "[-]", f"The default is rtol={rtol_default:g}.")
    if not (np.isfinite(float(rtol)) and 0.0 < float(rtol) < 1.0):
        raise ValueError(
            f"rtol (relative step tolerance) must lie in (0, 1); got rtol={rtol!r}. The "
            f"default is rtol={rtol_default:g}."
        )
    check_count("max_iter", max_iter, 1, max_iter_default)
