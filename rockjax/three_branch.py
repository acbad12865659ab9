"""The three-branch (trilinear) capacity law of a rocking wall and its fit to a pushover curve.

The law (Doherty et al. 2002; used as a moment-rotation law for one-sided rocking by AlShawa
et al. 2012 and, calibrated on DEM pushovers, by the paper, Fig. 9) gives the static load
multiplier ``lambda = a/g`` that holds the wall at a nondimensional top displacement
``x = d/b``:

* ``0 <= x < Delta_1``: the initial stiff branch, ``lambda = lambda_p x / Delta_1``;
* ``Delta_1 <= x < Delta_2``: the plateau, ``lambda = lambda_p``;
* ``x >= Delta_2``: the rigid-body line ``lambda = lambda_0 (1 - x / Delta_u)``, zero at
  ``x = Delta_u`` and negative (overturning) beyond;

with the plateau on the rigid-body line, ``lambda_p = lambda_0 (1 - Delta_2 / Delta_u)``. The
rigid block is ``Delta_1 = Delta_2 = 0``, ``Delta_u = 1``, ``lambda_0 = b / h``:
``lambda = (b/h)(1 - d/b)``. Derivation, sources and how the rocking solver uses the law:
docs/three_branch.md.
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._checks import check_scalar, concrete
from ._types import ScalarLike
from .block import Block

__all__ = ["ThreeBranchFit", "ThreeBranchLaw", "fit_three_branch"]

HUBER_K = 1.345
"""Huber threshold of the robust fit, in robust standard deviations of the residuals (the
usual 95 %-efficiency constant)."""

_N_GRID = 48  # breakpoint candidates per axis and zoom level of the fit's grid search
_N_ZOOM = 6  # zoom levels: the breakpoints end within ~x_max (4/_N_GRID)^(_N_ZOOM-1) / _N_GRID
_N_IRLS = 3  # robust reweighting rounds


MAX_DELTA_U = 2.0
"""Largest ``Delta_u`` accepted [-]: the rigid block's ``Delta_u = 1`` is the largest a rocking
wall reaches (a semi-rigid joint's crushed pivot lowers it), so 2 leaves room for fitted laws;
above it the Deltas are taken for percent typed for fractions of ``b`` (``Delta_u=100``)."""


class ThreeBranchLaw(eqx.Module):
    r"""Three-branch capacity law ``lambda(d/b)`` of a rocking wall (Doherty et al. 2002).

    $\lambda(x) = \lambda_p x/\Delta_1$ for $x < \Delta_1$, $\lambda_p$ for
    $\Delta_1 \le x < \Delta_2$, $\lambda_0 (1 - x/\Delta_u)$ for $x \ge \Delta_2$, with
    $\lambda_p = \lambda_0 (1 - \Delta_2/\Delta_u)$ and $x = d/b$.

    Args:
        lambda_0: Load multiplier [-] (``a/g``) of the rigid-body line at ``d = 0``; ``b/h``
            for a rectangular block.
        Delta_1: End of the initial stiff branch [-], a fraction of ``b``.
        Delta_2: End of the plateau [-], a fraction of ``b``; ``Delta_1 <= Delta_2``.
        Delta_u: Zero-capacity (instability) displacement [-], a fraction of ``b``;
            ``Delta_2 < Delta_u``. ``1`` for a rigid block.

    Raises:
        ValueError: for concrete values out of order or not finite, naming the fix.
    """

    lambda_0: ScalarLike
    Delta_1: ScalarLike
    Delta_2: ScalarLike
    Delta_u: ScalarLike

    def __check_init__(self):
        for name in ("lambda_0", "Delta_1", "Delta_2", "Delta_u"):
            check_scalar(name, getattr(self, name), "[-]", "e.g. ThreeBranchLaw.rigid(block).")
        v = [concrete(getattr(self, n)) for n in ("lambda_0", "Delta_1", "Delta_2", "Delta_u")]
        if any(x is None for x in v):
            return  # traced: the solver documents what it does with inconsistent values
        lam0, d1, d2, du = (float(x) for x in v)
        if not all(np.isfinite([lam0, d1, d2, du])):
            raise ValueError(
                f"ThreeBranchLaw needs finite values; got lambda_0={lam0}, Delta_1={d1}, "
                f"Delta_2={d2}, Delta_u={du} (all dimensionless, Deltas as fractions of b)."
            )
        if lam0 <= 0:
            raise ValueError(
                f"lambda_0 (load multiplier a/g at d = 0, dimensionless) must be positive; got "
                f"lambda_0={lam0}. For a rectangular block it is b/h."
            )
        if du > MAX_DELTA_U:
            raise ValueError(
                f"Delta_u={du:g} is above {MAX_DELTA_U:g}: the Deltas are fractions of b "
                f"(d/b, dimensionless; a rigid block has Delta_u = 1), not percent. Did you "
                f"give percent? Divide the Deltas by 100 (e.g. Delta_1={d1 / 100:g}, "
                f"Delta_2={d2 / 100:g}, Delta_u={du / 100:g})."
            )
        if not 0 <= d1 <= d2 < du:
            raise ValueError(
                "the three-branch law needs 0 <= Delta_1 <= Delta_2 < Delta_u (fractions of b); "
                f"got Delta_1={d1}, Delta_2={d2}, Delta_u={du}. A rigid block is Delta_1 = "
                "Delta_2 = 0, Delta_u = 1."
            )

    @classmethod
    def rigid(cls, block: Block) -> ThreeBranchLaw:
        """The rigid block's law: ``lambda_0 = b/h``, ``Delta_1 = Delta_2 = 0``,
        ``Delta_u = 1``; the rocking solver then gives the plain Housner results."""
        b = jnp.asarray(block.b, dtype=float)
        h = jnp.asarray(block.h, dtype=float)
        return cls(lambda_0=b / h, Delta_1=0.0, Delta_2=0.0, Delta_u=1.0)

    @property
    def lambda_p(self) -> Array:
        """Plateau load multiplier [-]: ``lambda_0 (1 - Delta_2 / Delta_u)``."""
        return jnp.asarray(self.lambda_0, dtype=float) * (1.0 - self.Delta_2 / self.Delta_u)

    @property
    def lambda_uplift(self) -> Array:
        """Load multiplier [-] just above ``d = 0``: the static threshold for motion from rest
        (``lambda_p`` when ``Delta_1 = 0``; 0 when there is a stiff branch, which moves at any
        load)."""
        return jnp.where(jnp.asarray(self.Delta_1) > 0, 0.0, self.lambda_p)

    def load_multiplier(self, d_over_b: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        """Static load multiplier ``lambda = a/g`` [-] at ``d/b`` (evaluated at ``|d/b|``).

        Args:
            d_over_b: Top displacement over thickness [-].

        Returns:
            ``lambda`` [-], same shape; negative beyond ``Delta_u`` (overturning).
        """
        x = jnp.abs(jnp.asarray(d_over_b, dtype=float))
        lam0 = jnp.asarray(self.lambda_0, dtype=float)
        d1, d2, du = (
            jnp.asarray(v, dtype=float) for v in (self.Delta_1, self.Delta_2, self.Delta_u)
        )
        lam_p = self.lambda_p
        first = lam_p * x / jnp.where(d1 > 0, d1, 1.0)
        rigid_line = lam0 * (1.0 - x / du)
        return jnp.where(x < d1, first, jnp.where(x < d2, lam_p, rigid_line))


class ThreeBranchFit(eqx.Module):
    """Result of :func:`rockjax.fit_three_branch`.

    Args:
        law: The fitted :class:`rockjax.ThreeBranchLaw`.
        rmse: Root-mean-square error of the fit over the pushover points [-] (load multiplier).
        max_error: Largest absolute error over the points [-].
    """

    law: ThreeBranchLaw
    rmse: ScalarLike
    max_error: ScalarLike


def fit_three_branch(capacity, *, lambda_0: float | None = None) -> ThreeBranchFit:
    """Fit the three-branch law to a pushover curve (robust least squares).

    Given the breakpoints ``Delta_1 <= Delta_2`` the law is linear in its two line parameters
    (``lambda_0`` and ``-lambda_0/Delta_u``), solved exactly; the breakpoints are searched on
    a grid over the data range, zoomed around the best pair ``_N_ZOOM`` times, so the fit does
    not depend on a starting guess. Outlying points (a DEM curve's impact spikes) are
    down-weighted by iteratively reweighted least squares with Huber weights
    (``HUBER_K`` robust standard deviations, scale from the median absolute deviation).

    Args:
        capacity: Any object with arrays ``d_over_b`` (top displacement over thickness [-]) and
            ``load_multiplier`` (``a/g`` [-]) of the same length, e.g. a DEM pushover's
            ``Capacity``.
        lambda_0: Fix the rigid-line intercept [-] (e.g. ``b/h``, as the paper calibrates only
            the three Deltas); default: fitted too.

    Returns:
        A :class:`rockjax.ThreeBranchFit` (the law, the RMS and largest errors).

    Raises:
        ValueError: if the arrays are missing, of different lengths, too short, not finite, or
            the curve never descends (no rigid-body branch to fit).

    References:
        Doherty, K., Griffith, M. C., Lam, N., Wilson, J. (2002), EESD 31:833-850.
    """
    x, y = _capacity_arrays(capacity)
    if lambda_0 is not None:
        check_scalar("lambda_0", lambda_0, "[-]", "e.g. lambda_0=b/h, or None to fit it.")
        if not (np.isfinite(float(lambda_0)) and float(lambda_0) > 0):
            raise ValueError(
                f"lambda_0 (load multiplier a/g at d = 0, dimensionless) must be positive; got "
                f"lambda_0={lambda_0}. Use b/h, or None to fit it."
            )
    weights = np.ones_like(x)
    best = None
    for _ in range(_N_IRLS + 1):
        best = _grid_fit(x, y, weights, lambda_0)
        r = y - _model(x, *best)
        scale = 1.4826 * np.median(np.abs(r - np.median(r)))
        if not scale > 1e-12 * max(1.0, float(np.max(np.abs(y)))):
            break  # (near) exact fit: nothing to reweight
        a = np.abs(r) / (HUBER_K * scale)
        weights = np.where(a <= 1.0, 1.0, 1.0 / np.maximum(a, 1.0))
    lam0, slope, d1, d2 = best
    du = -lam0 / slope
    r = y - _model(x, *best)
    law = ThreeBranchLaw(
        lambda_0=float(lam0), Delta_1=float(d1), Delta_2=float(d2), Delta_u=float(du)
    )
    return ThreeBranchFit(
        law=law,
        rmse=float(np.sqrt(np.mean(r * r))),
        max_error=float(np.max(np.abs(r))),
    )


def _capacity_arrays(capacity) -> tuple[np.ndarray, np.ndarray]:
    """``(d_over_b, load_multiplier)`` as sorted float arrays, checked."""
    try:
        x = np.asarray(capacity.d_over_b, dtype=float)
        y = np.asarray(capacity.load_multiplier, dtype=float)
    except AttributeError as err:
        raise ValueError(
            "capacity must have arrays d_over_b (top displacement / b, dimensionless) and "
            f"load_multiplier (a/g, dimensionless), e.g. a pushover's Capacity; got a "
            f"{type(capacity).__name__} ({err})."
        ) from None
    if x.ndim != 1 or x.shape != y.shape:
        raise ValueError(
            "capacity.d_over_b and capacity.load_multiplier must be 1-D arrays of the same "
            f"length; got shapes {x.shape} and {y.shape}."
        )
    if x.size < 6:
        raise ValueError(
            f"a three-branch fit needs at least 6 pushover points; got {x.size}. Run the "
            "pushover with more load steps."
        )
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ValueError(
            "capacity.d_over_b and capacity.load_multiplier must be finite (dimensionless); "
            "drop the NaN/inf points first."
        )
    if np.max(np.abs(x)) > MAX_DELTA_U:
        raise ValueError(
            f"capacity.d_over_b reaches {float(np.max(np.abs(x))):.4g}, above {MAX_DELTA_U:g}: "
            "it is the top displacement over b (dimensionless; a rigid block's capacity is zero "
            "at 1), not percent. Divide it by 100 if it is in percent, or drop the points past "
            f"d/b = {MAX_DELTA_U:g}."
        )
    order = np.argsort(np.abs(x), kind="stable")
    return np.abs(x)[order], y[order]


def _model(x, lam0, slope, d1, d2):
    """The law with the rigid line ``lam0 + slope x`` and breakpoints ``d1 <= d2``."""
    lam_p = lam0 + slope * d2
    phi = np.where(d1 > 0, np.minimum(x / np.where(d1 > 0, d1, 1.0), 1.0), 1.0)
    return np.where(x >= d2, lam0 + slope * x, lam_p * phi)


def _grid_fit(x, y, w, lambda_0):
    """The weighted least-squares ``(lam0, slope, d1, d2)`` over a zoomed breakpoint grid: first
    ``d2`` over the data range with ``d1`` a fraction of it, then both zoomed around the best
    pair (each level narrows the window to 4 grid steps)."""
    x_max = float(x[-1])
    d2 = np.linspace(0.0, x_max, _N_GRID)[:, None]
    d1 = np.linspace(0.0, 1.0, _N_GRID)[None, :] * d2
    step1 = step2 = x_max / (_N_GRID - 1)
    best_cost, best = np.inf, None
    for _ in range(_N_ZOOM):
        cost, lam0, slope = _solve_lines(x, y, w, d1, d2, lambda_0)
        i, j = np.unravel_index(np.argmin(cost), cost.shape)
        if cost[i, j] <= best_cost:
            best_cost = cost[i, j]
            best = (lam0[i, j], slope[i, j], float(d1[i, j]), float(d2[i, 0]))
        c1, c2 = best[2], best[3]
        d2 = np.linspace(max(0.0, c2 - 2 * step2), min(x_max, c2 + 2 * step2), _N_GRID)[:, None]
        d1 = np.linspace(max(0.0, c1 - 2 * step1), c1 + 2 * step1, _N_GRID)[None, :]
        d1 = np.minimum(d1, d2)  # the stiff branch ends no later than the plateau
        step1, step2 = 4 * step1 / (_N_GRID - 1), 4 * step2 / (_N_GRID - 1)
    if best is None or not np.isfinite(best_cost):
        raise ValueError(
            "the pushover curve does not descend: no rigid-body branch (load multiplier "
            "falling to zero) to fit. Push the wall further, towards d/b ~ 1."
        )
    return best


def _solve_lines(x, y, w, d1, d2, lambda_0):
    """For every breakpoint pair (arrays ``d1`` (n2, n1), ``d2`` (n2, 1)): the weighted LSQ
    line ``(lam0, slope)`` and its cost. Infeasible pairs (rising line, ``d2 >= Delta_u``,
    ``lam0 <= 0``) cost inf."""
    xx = x[None, None, :]
    d1e, d2e = d1[..., None], d2[..., None]
    phi = np.where(d1e > 0, np.minimum(xx / np.where(d1e > 0, d1e, 1.0), 1.0), 1.0)
    after = xx >= d2e
    f_a = np.where(after, 1.0, phi)  # d model / d lam0
    f_b = np.where(after, xx, d2e * phi)  # d model / d slope
    ww = w[None, None, :]
    if lambda_0 is None:
        saa = np.sum(ww * f_a * f_a, -1)
        sab = np.sum(ww * f_a * f_b, -1)
        sbb = np.sum(ww * f_b * f_b, -1)
        say = np.sum(ww * f_a * y, -1)
        sby = np.sum(ww * f_b * y, -1)
        det = saa * sbb - sab * sab
        ok = np.abs(det) > 1e-14 * np.maximum(saa * sbb, 1e-300)
        det = np.where(ok, det, 1.0)
        lam0 = (sbb * say - sab * sby) / det
        slope = (saa * sby - sab * say) / det
    else:
        lam0 = np.full(d1.shape, float(lambda_0))
        sbb = np.sum(ww * f_b * f_b, -1)
        ok = sbb > 0
        slope = np.sum(ww * f_b * (y - lam0[..., None] * f_a), -1) / np.where(ok, sbb, 1.0)
    r = y - (lam0[..., None] * f_a + slope[..., None] * f_b)
    cost = np.sum(ww * r * r, -1)
    du = -lam0 / np.where(slope < 0, slope, -1.0)
    feasible = ok & (slope < 0) & (lam0 > 0) & (d2 < du)
    return np.where(feasible, cost, np.inf), lam0, slope
