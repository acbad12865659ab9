r"""Lognormal collapse fragility from an IDA Dataset, with a bootstrap confidence interval.

The fragility is the probability of collapse (overturning) given an intensity measure (IM),

.. math:: P(\mathrm{collapse} \mid IM) = \Phi\!\left(\frac{\ln(IM/\theta)}{\sigma}\right),

with median ``theta`` (in the units of the IM) and logarithmic standard deviation ``sigma``
(``beta_log``). Two estimators:

* ``first_collapse=False`` (default), maximum likelihood on every run. IDA curves of rocking
  blocks are not monotonic (a record that overturns the block at one scale may leave it standing
  at a larger one), so instead of assuming that a record collapses at every IM above its first
  collapse, every valid run is one Bernoulli observation ``(IM, collapse)``, and ``theta`` and
  ``sigma`` maximise the probit likelihood (Newton's method, which converges from any start
  because the probit log-likelihood is concave in ``(-ln theta / sigma, 1 / sigma)``). The
  estimate exists only when collapses and survivals overlap in IM; with no collapse, no
  survival, or every collapse above every survival (complete separation, ``sigma -> 0``) a
  ``ValueError`` says so.
* ``first_collapse=True``, the classic IDA estimator: each record's lowest collapse IM (among its
  valid runs, as :func:`rockjax.collapse_intervals`), fitted by the method of moments in log
  space: ``ln theta`` is the mean and ``sigma`` the sample standard deviation (``ddof=1``) of
  the logarithms. Records that never collapse in the scale range are left out, which biases
  ``theta`` low; ``n_no_collapse`` counts them (widen the scale range until it is 0).

The confidence intervals come from a bootstrap over records (the records are the independent
samples; the runs of one record are not): ``n_boot`` resamples of the records with replacement,
refitted with the same estimator; the interval is the central ``ci`` percentile range of the
refits. Resamples whose fit does not exist (e.g. no collapse drawn) are left out and counted in
``n_boot_failed``. The generator is ``numpy.random.default_rng(seed)``, so a seed gives the same
interval every time.

Runs with a nonzero ``status`` (failed runs) and runs with a non-positive or non-finite IM (the
lognormal gives them ``P = 0``) are left out of both estimators.

Intensity measures (:func:`intensity_grid`): ``"pga"``, ``"pgv"`` and the IDA's own IM
(``"sa(T)"``, :func:`rockjax.ida`'s ``im=``) are computed from the Dataset (every one is the
record's IM times the scale factor); any other name is a variable or coordinate of the Dataset
(e.g. ``"pga_scaled"``, ``"scale"``). The median is in the IM's units, and for an acceleration
also in g (:attr:`Fragility.median_g`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from jaxtyping import ArrayLike, Float

from ._checks import check_scalar
from ._lazy import lazy_module
from .constants import G
from .response import STATUS_OK
from .spectra import is_im_name, parse_im

xr = lazy_module("xarray")  # loaded on first use (rockjax/_lazy.py)

_erfc = np.frompyfunc(math.erfc, 1, 1)
_SQRT2 = math.sqrt(2.0)
_Z_CLIP = 37.0  # |z| beyond which Phi(-|z|) underflows float64; clipping keeps logs finite
_NEWTON_TOL = 1e-10
_NEWTON_MAX_ITER = 100


@dataclasses.dataclass(frozen=True)
class Fragility:
    r"""A fitted lognormal collapse fragility, :math:`\Phi(\ln(IM/\theta)/\sigma)`.

    Returned by :func:`fragility`; immutable.

    ``median_g`` and ``median_ci_g`` give the median in g where the IM is an acceleration.

    Attributes:
        median: Median ``theta`` of the fragility, in the units of the IM (``im_units``; PGA and
            Sa: [m/s^2], PGV: [m/s]).
        beta_log: Logarithmic standard deviation ``sigma`` [-].
        median_ci: ``(lo, hi)`` bootstrap confidence interval of ``median``; NaN if
            ``n_boot == 0``.
        beta_log_ci: ``(lo, hi)`` bootstrap confidence interval of ``beta_log``.
        ci: Confidence level of the intervals, e.g. 0.9.
        n_records: Records that entered the fit (``first_collapse``: those that collapsed).
        n_runs: Valid runs (``status == 0``, positive finite IM) in the Dataset.
        n_no_collapse: Records whose valid runs never collapsed.
        n_boot_failed: Bootstrap resamples left out because their fit does not exist.
        method: ``"mle"`` or ``"first_collapse"``.
        im: The IM: ``"pga"``, ``"pgv"``, ``"sa(T)"``, or the name of a Dataset variable.
        im_units: Units of the IM (``"m/s^2"``, ``"m/s"``, ``"g"``; "" if it has none).
        boot_median: The bootstrap medians (failed resamples left out), read-only.
        boot_beta_log: The matching bootstrap ``beta_log`` values, read-only.
        im_range: ``(lo, hi)`` lowest and highest IM of the valid runs, in the IM's units: the
            range the fit rests on (what :func:`rockjax.openquake.fragility_model` writes as
            ``minIML`` / ``maxIML``); NaN for a Fragility built by hand.
    """

    median: float
    beta_log: float
    median_ci: tuple[float, float]
    beta_log_ci: tuple[float, float]
    ci: float
    n_records: int
    n_runs: int
    n_no_collapse: int
    n_boot_failed: int
    method: str
    im: str
    im_units: str
    boot_median: np.ndarray = dataclasses.field(repr=False, compare=False)
    boot_beta_log: np.ndarray = dataclasses.field(repr=False, compare=False)
    im_range: tuple[float, float] = dataclasses.field(default=(math.nan, math.nan), compare=False)

    @property
    def median_g(self) -> float | None:
        """Median in g [-] where the IM is an acceleration (m/s^2 or g), else None."""
        factor = _to_g(self.im_units)
        return None if factor is None else self.median * factor

    @property
    def median_ci_g(self) -> tuple[float, float] | None:
        """``median_ci`` in g [-] where the IM is an acceleration, else None."""
        factor = _to_g(self.im_units)
        if factor is None:
            return None
        return (self.median_ci[0] * factor, self.median_ci[1] * factor)

    def __repr__(self) -> str:
        def interval(lo, hi, unit):
            return f" [{lo:.3g}, {hi:.3g}]{unit}" if math.isfinite(lo) else ""

        unit = f" {self.im_units}" if self.im_units not in ("", "1") else ""
        if self.median_g is not None and self.im_units != "g":
            lo, hi = self.median_ci_g
            median = (
                f"median {self.median_g:.4g} g{interval(lo, hi, ' g')} = {self.median:.4g}{unit}"
            )
        else:
            median = f"median {self.median:.4g}{unit}{interval(*self.median_ci, unit)}"
        level = f" ({100 * self.ci:.0f}% CI)" if math.isfinite(self.median_ci[0]) else ""
        return (
            f"Fragility({self.im}: {median}, beta_log {self.beta_log:.3g}"
            f"{interval(*self.beta_log_ci, '')}{level}, {self.method}, "
            f"{self.n_records} records, {self.n_runs} runs)"
        )

    def summary(self) -> dict:
        """The fit as a JSON-ready dict (what ``rockjax ida`` writes to its fragility file).

        Keys: ``im``, ``im_units``, ``method``, ``median`` and ``median_ci`` (IM units),
        ``median_g`` and ``median_ci_g`` (g; None where the IM is no acceleration),
        ``beta_log``, ``beta_log_ci``, ``ci``, ``n_records``, ``n_runs``, ``n_no_collapse``,
        ``n_boot`` (resamples drawn) and ``n_boot_failed``. Intervals are ``[lo, hi]``, NaN
        without bootstrap (``rockjax.jsonio`` writes NaN as null).
        """
        return {
            "im": self.im,
            "im_units": self.im_units,
            "method": self.method,
            "median": self.median,
            "median_ci": list(self.median_ci),
            "median_g": self.median_g,
            "median_ci_g": None if self.median_ci_g is None else list(self.median_ci_g),
            "beta_log": self.beta_log,
            "beta_log_ci": list(self.beta_log_ci),
            "ci": self.ci,
            "n_records": self.n_records,
            "n_runs": self.n_runs,
            "n_no_collapse": self.n_no_collapse,
            "n_boot": int(np.size(self.boot_median)) + self.n_boot_failed,
            "n_boot_failed": self.n_boot_failed,
        }

    def prob(self, im: Float[ArrayLike, "*shape"]) -> Float[np.ndarray, "*shape"]:
        r"""Probability of collapse :math:`\Phi(\ln(IM/\theta)/\sigma)` at the given IM values.

        Args:
            im: Intensity measure, in the units of the fit (``im_units``); ``<= 0`` gives 0.

        Returns:
            Probabilities in ``[0, 1]``, with the shape of ``im``.
        """
        return _lognormal_cdf(np.asarray(im, dtype=float), self.median, self.beta_log)

    def prob_band(
        self, im: Float[ArrayLike, " n"]
    ) -> tuple[Float[np.ndarray, " n"], Float[np.ndarray, " n"]]:
        """Pointwise bootstrap confidence band of :meth:`prob` (level ``ci``).

        Args:
            im: Intensity measure values, 1-D, in the units of the fit.

        Returns:
            ``(lo, hi)`` probabilities, each of the shape of ``im``; NaN without bootstrap.
        """
        x = np.asarray(im, dtype=float)
        if self.boot_median.size == 0:
            nan = np.full(x.shape, np.nan)
            return nan, nan.copy()
        curves = _lognormal_cdf(x[None, :], self.boot_median[:, None], self.boot_beta_log[:, None])
        q = 50.0 * (1.0 - self.ci), 50.0 * (1.0 + self.ci)
        lo, hi = np.percentile(curves, q, axis=0)
        return np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)


def fragility(
    ds: xr.Dataset,
    im: str | None = None,
    *,
    n_boot: int = 1000,
    seed: int = 0,
    ci: float = 0.9,
    first_collapse: bool = False,
) -> Fragility:
    r"""Fit a lognormal collapse fragility :math:`\Phi(\ln(IM/\theta)/\sigma)` to IDA results.

    See the module docstring for the two estimators and the bootstrap.

    Args:
        ds: A Dataset with dims ``("record", "scale")`` and variables ``collapse``, ``status``
            and ``im``, as :func:`rockjax.ida` returns.
        im: The intensity measure: ``"pga"`` [m/s^2], ``"pgv"`` [m/s], the IDA's ``"sa(T)"``
            [m/s^2], or a variable or coordinate of ``ds`` broadcastable to
            ``(record, scale)`` (e.g. ``"scale"``); see :func:`intensity_grid`. Default: the
            IDA's IM (``ds.attrs["im"]``, ``"pga"`` unless ``rj.ida`` was given ``im=``), or
            ``"pga_scaled"`` for a Dataset without one.
        n_boot: Bootstrap resamples of the records; 0 skips the bootstrap (NaN intervals).
            Each resample is one refit: about 2 s per 1000 resamples for 1600 runs (MLE).
        seed: Seed of ``numpy.random.default_rng`` for the bootstrap.
        ci: Confidence level of the intervals, in ``(0, 1)``.
        first_collapse: Fit each record's lowest collapse IM by the method of moments in log
            space, instead of maximum likelihood on every run.

    Returns:
        A :class:`Fragility`.

    Raises:
        ValueError: if ``ds`` lacks a variable, an argument is out of range, or the fit does
            not exist (no collapse, no survival, fewer than two collapsing records for
            ``first_collapse``, or collapses and survivals that do not overlap in IM).
    """
    if not isinstance(ds, xr.Dataset):
        raise ValueError(
            f"ds must be the xarray.Dataset that rj.ida returns (dims record and scale); got "
            f"{type(ds).__name__}. Run ds = rj.ida(block, records, scales, ...) first, or "
            "xr.open_dataset(path) for a saved one."
        )
    for var in ("collapse", "status"):
        if var not in ds.variables:
            raise ValueError(
                f"ds has no {var!r} variable; pass the Dataset that rj.ida returns "
                f"(it has {sorted(map(str, ds.variables))})."
            )
    im = default_im(ds) if im is None else im
    im_grid = intensity_grid(ds, im)
    if isinstance(n_boot, bool) or not (isinstance(n_boot, int | np.integer) and n_boot >= 0):
        raise ValueError(f"n_boot must be an int >= 0; got n_boot={n_boot!r}. Use 1000.")
    check_scalar("ci", ci, "[-]", "Use ci=0.9 for a 90 % interval.")
    if not 0.0 < float(ci) < 1.0:
        raise ValueError(f"ci must be a confidence level in (0, 1); got ci={ci}. Use 0.9.")
    dims = ("record", "scale")
    collapse = np.asarray(ds["collapse"].transpose(*dims), dtype=bool)
    status = np.asarray(ds["status"].transpose(*dims))
    x_im = np.asarray(im_grid.transpose(*dims), dtype=float)
    with np.errstate(invalid="ignore"):
        valid = (status == STATUS_OK) & np.isfinite(x_im) & (x_im > 0)
    log_im = np.log(np.where(valid, x_im, 1.0))
    n_rec = collapse.shape[0]
    n_runs = int(valid.sum())
    n_no_collapse = int(np.sum(~np.any(collapse & valid, axis=1)))
    n_collapse = int(np.sum(collapse & valid))
    im_name, im_units = str(im_grid.name), str(im_grid.attrs.get("units", ""))

    def show(value: float) -> str:
        return f"{im_name} = {_im_text(value, im_units)}"

    if n_collapse == 0 or n_collapse == n_runs:
        what = "no valid run collapsed" if n_collapse == 0 else "every valid run collapsed"
        fix = "larger" if n_collapse == 0 else "smaller"
        if n_runs:
            reached = x_im[valid].max() if n_collapse == 0 else x_im[valid].min()
            where = "up to" if n_collapse == 0 else "down to"
            what += f" {where} {show(float(reached))}"
        raise ValueError(
            f"the fragility is undefined: {what} ({n_runs} valid runs of {n_rec} records). "
            f"Widen the scale range of rj.ida to {fix} scale factors so that the runs include "
            f"both collapses and survivals."
        )

    # per run: record index, log IM, outcome; each estimator takes per-record weights
    rec_of_run = np.broadcast_to(np.arange(n_rec)[:, None], collapse.shape)[valid]
    x, y = log_im[valid], collapse[valid].astype(float)
    if first_collapse:
        first = np.where(collapse & valid, log_im, np.inf).min(axis=1)

        def fit(w_rec, start=None):
            return _fit_first_collapse(first, w_rec)

    else:

        def fit(w_rec, start=None):
            return _fit_mle(x, y, w_rec[rec_of_run], start, show)

    mu, sigma, reason = fit(np.ones(n_rec))
    if reason:
        raise ValueError(f"the fragility is undefined: {reason}")

    rng = np.random.default_rng(seed)
    boot = np.full((n_boot, 2), np.nan)
    for k in range(n_boot):
        w_rec = np.bincount(rng.integers(0, n_rec, size=n_rec), minlength=n_rec).astype(float)
        mu_k, sigma_k, reason_k = fit(w_rec, (mu, sigma))
        if not reason_k:
            boot[k] = mu_k, sigma_k
    ok = np.all(np.isfinite(boot), axis=1)
    boot = boot[ok]
    if boot.shape[0]:
        q = 50.0 * (1.0 - ci), 50.0 * (1.0 + ci)
        mu_ci = np.percentile(boot[:, 0], q)
        sigma_ci = np.percentile(boot[:, 1], q)
    else:
        mu_ci = sigma_ci = np.full(2, np.nan)
    boot_median = np.exp(boot[:, 0])
    boot_beta_log = boot[:, 1].copy()
    boot_median.flags.writeable = False
    boot_beta_log.flags.writeable = False
    return Fragility(
        median=float(np.exp(mu)),
        beta_log=float(sigma),
        median_ci=(float(np.exp(mu_ci[0])), float(np.exp(mu_ci[1]))),
        beta_log_ci=(float(sigma_ci[0]), float(sigma_ci[1])),
        ci=float(ci),
        n_records=int(n_rec - n_no_collapse) if first_collapse else n_rec,
        n_runs=n_runs,
        n_no_collapse=n_no_collapse,
        n_boot_failed=int(n_boot - boot.shape[0]),
        method="first_collapse" if first_collapse else "mle",
        im=im_name,
        im_units=im_units,
        boot_median=boot_median,
        boot_beta_log=boot_beta_log,
        im_range=(float(x_im[valid].min()), float(x_im[valid].max())),
    )


def default_im(ds: xr.Dataset) -> str:
    """The IM a fragility or IDA figure uses by default: the IDA's (``ds.attrs["im"]``), or
    ``"pga_scaled"`` for a Dataset without one."""
    name = ds.attrs.get("im")
    return str(name) if name is not None and "im" in ds.variables else "pga_scaled"


def intensity_grid(ds: xr.Dataset, im: str) -> xr.DataArray:
    """The intensity measure of every run of an IDA Dataset, on ``(record, scale)``.

    ``"pga"`` is ``pga_scaled`` [m/s^2]; ``"pgv"`` is the coordinate ``pgv`` times ``scale``
    [m/s]; an ``"sa(T)"`` is the Dataset's ``im`` variable when the IDA ran with that IM
    (``ds.attrs["im"]``). Any other name is a variable or coordinate of ``ds``, broadcast to
    ``(record, scale)``.

    Args:
        ds: A Dataset from :func:`rockjax.ida`.
        im: ``"pga"``, ``"pgv"``, ``"sa(T)"`` or a variable name.

    Returns:
        A DataArray named ``im`` (canonical, e.g. ``"sa(0.5)"``) with a ``units`` attribute.

    Raises:
        ValueError: if ``ds`` cannot give that IM (an ``sa(T)`` other than the IDA's, or a
            missing variable), with the IMs it can give.
    """
    if not isinstance(im, str):
        raise ValueError(f"im must be a string such as 'pga' or 'sa(0.5)'; got im={im!r}.")
    if "collapse" not in ds.variables:
        raise ValueError(
            "ds has no 'collapse' variable; pass the Dataset that rj.ida returns "
            f"(it has {sorted(map(str, ds.variables))})."
        )
    shape = ds["collapse"]
    ida_im = ds.attrs.get("im") if "im" in ds.variables else None
    if is_im_name(im):
        spec = parse_im(im)
        if spec.name == ida_im:
            out = ds["im"]
        elif spec.kind == "pga" and "pga_scaled" in ds.variables:
            out = ds["pga_scaled"]
        elif spec.kind == "pgv" and "pgv" in ds.variables and "scale" in ds.variables:
            out = ds["pgv"] * ds["scale"]
        else:
            have = ["pga"] if "pga_scaled" in ds.variables else []
            have += ["pgv"] if "pgv" in ds.variables else []
            have += [ida_im] if ida_im and ida_im not in have else []
            raise ValueError(
                f"this Dataset cannot give im={spec.name!r}: it holds {have or 'no IM'} "
                f"(the IDA ran with im={ida_im!r}). Run rj.ida(..., im={spec.name!r}) for it."
            )
        out = out.broadcast_like(shape).rename(spec.name)
        out.attrs = {"units": spec.units, "long_name": spec.long_name}
        return out
    if im not in ds.variables:
        raise ValueError(
            f"ds has no {im!r} variable; pass the Dataset that rj.ida returns "
            f"(it has {sorted(map(str, ds.variables))}), or an IM: 'pga', 'pgv' or the IDA's "
            f"{ida_im!r}."
        )
    out = ds[im].broadcast_like(shape).rename(im)
    out.attrs = dict(ds[im].attrs)
    return out


# ----------------------------------------------------------------------------- helpers


def _to_g(units: str) -> float | None:
    """Factor from ``units`` to g, or None when they are not an acceleration."""
    return {"m/s^2": 1.0 / G, "g": 1.0}.get(units)


def _im_text(value: float, units: str) -> str:
    """An IM value with its unit, in g first where it is an acceleration: ``0.327 g (3.21
    m/s^2)``, ``0.41 m/s``, ``1.5`` (a scale factor)."""
    factor = _to_g(units)
    if factor is not None and units != "g":
        return f"{value * factor:.4g} g ({value:.4g} {units})"
    return f"{value:.4g}" + (f" {units}" if units not in ("", "1") else "")


def _norm_tail(z: np.ndarray) -> np.ndarray:
    """``Phi(-|z|)``, the smaller tail, accurate to the last bits (no ``1 - Phi`` rounding)."""
    return np.asarray(0.5 * np.asarray(_erfc(np.abs(z) / _SQRT2), dtype=float), dtype=float)


def _lognormal_cdf(im: np.ndarray, median, beta_log) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.log(np.maximum(im, 0.0) / median) / beta_log
    z = np.asarray(z, dtype=float)
    finite = np.isfinite(z)
    tail = _norm_tail(np.where(finite, z, 0.0))
    p = np.where(z > 0, 1.0 - tail, tail)
    return np.asarray(np.where(finite, p, (z > 0).astype(float)), dtype=float)


def _probit_terms(eta: np.ndarray, y: np.ndarray, w: np.ndarray):
    """Log-likelihood of ``P(y=1) = Phi(eta)`` and its first two derivatives in ``eta``."""
    eta = np.clip(eta, -_Z_CLIP, _Z_CLIP)
    tail = _norm_tail(eta)  # Phi(-|eta|)
    big = 1.0 - tail
    phi_pos = np.where(eta >= 0, big, tail)  # Phi(eta)
    phi_neg = np.where(eta >= 0, tail, big)  # Phi(-eta)
    pdf = np.exp(-0.5 * eta * eta) / math.sqrt(2.0 * math.pi)
    # z = +eta for a collapse, -eta for a survival: l = log Phi(z), l' = lam, l'' = -lam (z + lam)
    s = 2.0 * y - 1.0
    cdf = np.where(y > 0, phi_pos, phi_neg)
    lam = pdf / cdf
    ll = float(np.sum(w * np.log(cdf)))
    d1 = w * s * lam
    d2 = -w * lam * (s * eta + lam)
    return ll, d1, d2


def _fit_mle(x: np.ndarray, y: np.ndarray, w: np.ndarray, start=None, show=None):
    """Weighted probit MLE of ``y ~ Phi((x - mu)/sigma)``: ``(mu, sigma, "")`` or a reason.

    ``start`` is an optional ``(mu, sigma)`` first guess (the full-data fit, for the bootstrap);
    ``show`` words an IM value (``x`` is its log) for the reason, with its name and unit.
    """
    show = (lambda v: f"IM {v:.4g}") if show is None else show
    use = w > 0
    x, y, w = x[use], y[use], w[use]
    hit, miss = x[y > 0], x[y == 0]
    if hit.size == 0 or miss.size == 0:
        return np.nan, np.nan, "the runs have no collapse or no survival."
    if hit.min() >= miss.max():
        return (
            np.nan,
            np.nan,
            f"every collapse (from {show(math.exp(hit.min()))}) lies above every survival "
            f"(up to {show(math.exp(miss.max()))}), so sigma -> 0. Add records, or scale "
            "factors between those IMs, so that collapses and survivals overlap.",
        )
    if hit.max() <= miss.min():
        return (
            np.nan,
            np.nan,
            "every collapse lies below every survival: collapse does not increase with the IM. "
            "Check the IM variable and the collapse flags.",
        )
    x0 = float(np.average(x, weights=w))
    xc = x - x0  # centred: a well-conditioned Newton system
    sd = math.sqrt(float(np.average(xc * xc, weights=w)))
    if start is None:
        params = np.array([0.0, 1.0 / sd])  # (a, b): eta = a + b * xc
    else:
        params = np.array([(x0 - start[0]) / start[1], 1.0 / start[1]])
    ll, d1, d2 = _probit_terms(params[0] + params[1] * xc, y, w)
    for _ in range(_NEWTON_MAX_ITER):
        grad = np.array([d1.sum(), (d1 * xc).sum()])
        hess = np.array([[d2.sum(), (d2 * xc).sum()], [(d2 * xc).sum(), (d2 * xc * xc).sum()]])
        step = -np.linalg.solve(hess, grad)
        t = 1.0
        while True:  # step halving: the full Newton step may overshoot far from the optimum
            trial = params + t * step
            ll_t, d1_t, d2_t = _probit_terms(trial[0] + trial[1] * xc, y, w)
            if ll_t >= ll - 1e-12 * abs(ll) or t < 1e-8:
                break
            t *= 0.5
        params, ll, d1, d2 = trial, ll_t, d1_t, d2_t
        if np.max(np.abs(t * step)) < _NEWTON_TOL * (1.0 + np.max(np.abs(params))):
            break
    else:
        return np.nan, np.nan, "the maximum-likelihood fit did not converge."
    a, b = params
    if not b > 0:
        return np.nan, np.nan, "the fitted probability of collapse decreases with the IM."
    return x0 - a / b, 1.0 / b, ""


def _fit_first_collapse(first: np.ndarray, w: np.ndarray):
    """Method of moments in log space on the records' lowest collapse log-IMs (``inf``: none)."""
    use = (w > 0) & np.isfinite(first)
    n = float(w[use].sum())
    if n < 2 or np.count_nonzero(use) < 1:
        return (
            np.nan,
            np.nan,
            f"first_collapse needs at least two records that collapse; got {int(n)}. Widen "
            f"the scale range of rj.ida to larger scale factors, or add records.",
        )
    v, wv = first[use], w[use]
    mu = float(np.sum(wv * v) / n)
    sigma = math.sqrt(float(np.sum(wv * (v - mu) ** 2) / (n - 1.0)))
    return mu, sigma, ""
