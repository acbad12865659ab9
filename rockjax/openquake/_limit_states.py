r"""Several limit states from one IDA: peak displacement thresholds and collapse.

Fitted one by one, two lognormal curves with different dispersions cross somewhere, and the
engine's damage-state fractions (differences of the curves) turn negative there. By default the
limit states are therefore fitted together with one dispersion (ordinal probit, maximum
likelihood): every valid run reached a damage state ``s`` (the number of limit states it
exceeded), and

.. math:: P(s \ge k \mid IM) = \Phi\!\left(\frac{\ln IM - \ln\theta_k}{\sigma}\right),
   \qquad \theta_1 < \theta_2 < \dots,

so the curves are parallel in log IM and never cross. With one limit state this is
:func:`rockjax.fragility`'s estimator.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np

from .._lazy import lazy_module
from ..fragility import Fragility, fragility, intensity_grid
from ..response import STATUS_OK

xr = lazy_module("xarray")  # loaded on first use (rockjax/_lazy.py)


def limit_state_name(d_over_b: float) -> str:
    """The default name of the limit state ``d/b >= d_over_b``: ``0.3`` -> ``"d_over_b_0p3"``
    (the engine's identifiers have no dots)."""
    return "d_over_b_" + f"{float(d_over_b):g}".replace(".", "p").replace("-", "m")


def limit_state_fragilities(
    ds: xr.Dataset,
    d_over_b: Sequence[float] | Mapping[str, float] = (0.3,),
    *,
    im: str | None = None,
    collapse: bool = True,
    common_beta: bool = True,
    **fit: object,
) -> dict[str, Fragility]:
    """Fragilities of several limit states from one IDA, in increasing severity.

    A run reaches the limit state ``d/b >= x`` when its peak top displacement over the block's
    thickness, ``max_d_over_b``, is at least ``x``, or when it collapsed (a collapse exceeds
    every displacement); the last limit state is collapse itself. Each is fitted by
    :func:`rockjax.fragility` on the same runs, so the curves rest on the same records.

    Args:
        ds: A Dataset from :func:`rockjax.ida` (``max_d_over_b``, ``collapse``, ``status``).
        d_over_b: Thresholds of ``max_d_over_b`` [-], e.g. ``(0.3,)``, or a dict from limit-state
            name to threshold; default names from :func:`limit_state_name`.
        im: The IM, as :func:`rockjax.fragility`.
        collapse: Add the ``"collapse"`` limit state last.
        common_beta: Fit the limit states together with one dispersion (the module
            docstring): curves that never cross, as the engine needs. False fits each on its
            own with :func:`rockjax.fragility` (its bootstrap intervals included); such curves
            may cross, which :func:`rockjax.openquake.fragility_model` refuses.
        **fit: Further arguments of :func:`rockjax.fragility` (``n_boot``, ``seed``, ...);
            with ``common_beta`` the bootstrap is not run (the intervals are NaN).

    Returns:
        Limit-state name -> :class:`rockjax.Fragility`, mildest first (the thresholds sorted):
        the ``fragilities`` value of one class for
        :func:`rockjax.openquake.fragility_model`.

    Raises:
        ValueError: on a threshold that is not positive and finite, a Dataset without
            ``max_d_over_b``, or a limit state whose fragility is undefined (as
            :func:`rockjax.fragility`).
    """
    named = (
        dict(d_over_b)
        if isinstance(d_over_b, Mapping)
        else {limit_state_name(x): x for x in d_over_b}
    )
    for name, x in named.items():
        if isinstance(x, bool) or not (np.isscalar(x) and np.isfinite(x) and float(x) > 0):
            raise ValueError(
                f"the d/b threshold of limit state {name!r} must be a positive number [-] "
                f"(peak top displacement over the thickness b); got {x!r}. Use e.g. 0.3."
            )
    if named and "max_d_over_b" not in ds.variables:
        raise ValueError(
            "ds has no 'max_d_over_b' variable; pass the Dataset that rj.ida returns "
            f"(it has {sorted(map(str, ds.variables))})."
        )
    if common_beta:
        fit = {**fit, "n_boot": 0}
    reached, out = {}, {}
    for name, x in sorted(named.items(), key=lambda item: float(item[1])):
        reached[name] = ds["collapse"] | (ds["max_d_over_b"] >= float(x))
    if collapse:
        reached["collapse"] = ds["collapse"]
    if not reached:
        raise ValueError("no limit state asked for: give d_over_b thresholds or collapse=True.")
    for name, hit in reached.items():
        out[name] = fragility(ds.assign(collapse=hit), im, **fit)
    if not common_beta or len(out) == 1:
        return out
    first = next(iter(out.values()))
    dims = ("record", "scale")
    x_im = np.asarray(intensity_grid(ds, first.im).transpose(*dims), dtype=float)
    with np.errstate(invalid="ignore"):
        valid = (np.asarray(ds["status"].transpose(*dims)) == STATUS_OK) & (x_im > 0)
    valid &= np.isfinite(x_im)
    state = sum(np.asarray(h.transpose(*dims), dtype=int) for h in reached.values())
    start = [math.log(f.median) for f in out.values()]
    start_sigma = float(np.mean([f.beta_log for f in out.values()]))
    mu, sigma = ordinal_probit(np.log(x_im[valid]), state[valid], start, start_sigma)
    return {
        name: dataclasses.replace(f, median=math.exp(m), beta_log=sigma, method="ordinal_mle")
        for (name, f), m in zip(out.items(), mu, strict=True)
    }


def ordinal_probit(x, state, mu0, sigma0) -> tuple[np.ndarray, float]:
    """Maximum-likelihood ``(mu_k, sigma)`` of ``P(state >= k) = Phi((x - mu_k) / sigma)``.

    Args:
        x: ``ln IM`` of every run.
        state: Damage state of every run, ``0`` (no limit state) to ``K``.
        mu0: First guess of the ``K`` values ``mu_k = ln theta_k``, increasing.
        sigma0: First guess of ``sigma``.

    Returns:
        ``(mu, sigma)``, ``mu`` increasing.
    """
    from scipy import optimize, special

    x, state = np.asarray(x, float), np.asarray(state, int)
    k = len(mu0)
    mu0 = np.maximum.accumulate(np.asarray(mu0, float))
    # unconstrained: mu_1, log of the increments, log sigma (ordered thresholds by design)
    p0 = np.concatenate([[mu0[0]], np.log(np.maximum(np.diff(mu0), 1e-3)), [math.log(sigma0)]])

    def unpack(p):
        return np.cumsum(np.concatenate([[p[0]], np.exp(p[1:k])])), math.exp(p[k])

    def nll(p):
        mu, sigma = unpack(p)
        z = (x[:, None] - mu[None, :]) / sigma  # (run, k): P(state >= k+1) = Phi(z)
        z = np.concatenate([np.full((x.size, 1), np.inf), z, np.full((x.size, 1), -np.inf)], 1)
        a = np.take_along_axis(z, state[:, None], 1)[:, 0]  # P(s >= state)
        b = np.take_along_axis(z, state[:, None] + 1, 1)[:, 0]  # P(s >= state + 1)
        # P = Phi(a) - Phi(b) = Phi(-b) - Phi(-a), the smaller tails for accuracy
        upper = b > 0
        lo_a = np.where(upper, special.log_ndtr(-b), special.log_ndtr(a))
        lo_b = np.where(upper, special.log_ndtr(-a), special.log_ndtr(b))
        with np.errstate(divide="ignore"):
            logp = lo_a + np.log1p(-np.exp(np.minimum(lo_b - lo_a, 0.0)))
        return -float(np.sum(np.maximum(logp, -1e300)))

    best = optimize.minimize(nll, p0, method="Nelder-Mead", options=_NM_OPTIONS)
    best = optimize.minimize(nll, best.x, method="BFGS", options={"gtol": 1e-8})
    return unpack(best.x)


_NM_OPTIONS = {"xatol": 1e-10, "fatol": 1e-12, "maxiter": 20000, "maxfev": 20000}
