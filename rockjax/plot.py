"""Figures of rocking responses; the only rockjax module that imports matplotlib.

matplotlib is imported inside each function, so ``import rockjax`` never pays for it. When no
display is available (a headless Linux machine, CI) and no backend was chosen, the Agg backend
is selected before ``pyplot`` is first imported, so figures can always be saved.

Every function draws on ``ax`` when one is given (so figures can be composed), otherwise on a
new figure, and returns the ``Axes``; the figure is ``ax.figure``. Save it with
``ax.figure.savefig(path)`` and close it with :func:`close`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from .constants import G
from .fragility import default_im, intensity_grid
from .motion import GroundMotion
from .relations import amplitude_after_impacts
from .response import Response

__all__ = [
    "calibration",
    "close",
    "e_beta",
    "fragility",
    "ground_motion",
    "ida",
    "pairs",
    "peaks_decay",
    "pushover",
    "pyplot",
    "spectrum",
    "time_history",
]

_FIGSIZE = (7.0, 4.0)


def __dir__() -> list[str]:
    """What ``dir(rj.plot)`` and tab completion list: the figures, not the module's imports."""
    return sorted(__all__)


def pyplot():
    """Import ``matplotlib.pyplot``, choosing Agg first when there is no display to draw on."""
    import os
    import sys

    import matplotlib

    headless = sys.platform.startswith("linux") and not (
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    )
    # Only before pyplot exists and only when the user chose no backend: never switch the
    # backend of a running notebook or GUI session.
    if headless and "matplotlib.pyplot" not in sys.modules and not os.environ.get("MPLBACKEND"):
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _new_axes(ax, figsize=_FIGSIZE):
    if ax is not None:
        return ax
    plt = pyplot()
    fig, ax = plt.subplots(figsize=figsize, layout="constrained")
    return ax


def close(fig_or_ax) -> None:
    """Close a figure made by this module (pass the figure or one of its axes).

    Args:
        fig_or_ax: A matplotlib ``Figure`` or ``Axes``.
    """
    fig = getattr(fig_or_ax, "figure", fig_or_ax)
    pyplot().close(fig)


def time_history(
    responses: Mapping[str, Response],
    ax=None,
    normalise: bool = True,
    *,
    title: str | None = None,
):
    """Rotation against time for one or more labelled responses, overlaid.

    Args:
        responses: ``{label: Response}``; each is drawn as one line, labelled in the legend.
        ax: A matplotlib ``Axes`` to draw on; default a new figure.
        normalise: Plot ``theta/eta`` [-] (dashed lines mark overturning, ``|theta| = eta``)
            instead of ``theta`` [rad].
        title: Axes title; default none.

    Returns:
        The matplotlib ``Axes``.

    Raises:
        ValueError: If ``responses`` is empty.
    """
    if not responses:
        raise ValueError("time_history needs at least one response: pass {label: Response}.")
    ax = _new_axes(ax)
    two_sided = False
    for label, resp in responses.items():
        t = np.asarray(resp.t)
        theta = np.asarray(resp.theta)
        y = theta / float(resp.eta) if normalise else theta
        suffix = " (overturned)" if bool(resp.overturned) else ""
        ax.plot(t, y, lw=1.2, label=f"{label}{suffix}")
        # a facade's DEM corner may dip a few percent of eta below 0 inside its gap
        two_sided = two_sided or bool(np.any(theta < -0.05 * float(resp.eta)))
    if normalise:
        ax.axhline(1.0, color="0.4", ls="--", lw=0.8, label=r"overturning, $|\theta| = \eta$")
        if two_sided:
            ax.axhline(-1.0, color="0.4", ls="--", lw=0.8)
    ax.axhline(0.0, color="0.7", lw=0.6)
    ax.set_xlabel("time t [s]")
    ax.set_ylabel(r"rotation $\theta/\eta$ [-]" if normalise else r"rotation $\theta$ [rad]")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    if title:
        ax.set_title(title)
    return ax


def peaks_decay(
    responses: Mapping[str, Response],
    ax=None,
    *,
    n_bounces: int | None = None,
    e_reference: Mapping[str, float] | None = None,
    title: str | None = None,
):
    """Peak rotation ``|theta_n|/eta`` after each bounce ``n`` (``n = 0`` is the release).

    With ``e_reference`` the linearised free-rocking decay for a constant coefficient of
    restitution (``rockjax.relations.amplitude_after_impacts``, the forward form of Eq. (6)) is
    drawn for comparison, from the release of the first response.

    Args:
        responses: ``{label: Response}`` of free-rocking runs released from rest.
        ax: A matplotlib ``Axes`` to draw on; default a new figure.
        n_bounces: Largest bounce number drawn; default every peak found.
        e_reference: ``{label: e}`` [-] reference coefficients of restitution, e.g.
            ``{"e_H, Eq. (2)": float(rockjax.e_housner(block))}``.
        title: Axes title; default none.

    Returns:
        The matplotlib ``Axes``.

    Raises:
        ValueError: If ``responses`` is empty.
    """
    if not responses:
        raise ValueError("peaks_decay needs at least one response: pass {label: Response}.")
    ax = _new_axes(ax)
    n_max = 0
    first = None
    for label, resp in responses.items():
        eta = float(resp.eta)
        _, amp = resp.peaks()
        amp = np.concatenate([[abs(float(resp.theta[0]))], amp])
        if n_bounces is not None:
            amp = amp[: n_bounces + 1]
        n = np.arange(amp.size)
        ax.plot(n, amp / eta, "o-", ms=4, lw=1.0, label=label)
        n_max = max(n_max, int(n[-1]))
        if first is None:
            first = (abs(float(resp.theta[0])), eta)
    if e_reference and first is not None and first[0] > 0:
        theta0, eta = first
        n = np.arange(n_max + 1)
        for label, e in e_reference.items():
            ref = np.asarray(amplitude_after_impacts(theta0, eta, float(e), n))
            ax.plot(n, ref / eta, "k:", lw=1.2, label=f"{label} (linearised)")
    ax.set_xlabel("bounce n [-] (0 = release)")
    ax.set_ylabel(r"peak rotation $|\theta_n|/\eta$ [-]")
    ax.set_ylim(bottom=0.0)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    if title:
        ax.set_title(title)
    return ax


def e_beta(
    betas: Sequence[float] | np.ndarray,
    e_values,
    ax=None,
    *,
    e_h: float | None = None,
    beta_dejong: float | None = None,
    label: str = "DEM",
    title: str | None = None,
):
    """Coefficient of restitution against the stiffness-proportional damping ``beta``.

    The relation the paper fits as Eq. (3), ``e = e_H - x beta``. Each series is drawn with
    markers; a 2-D series (one column per bounce, as from ``Response.e_exp``) is drawn as its
    mean over bounces with a bar spanning the bounces' minimum to maximum.

    Args:
        betas: Stiffness-proportional Rayleigh coefficients [s], Eq. (1), shape ``(n_beta,)``.
        e_values: Coefficients of restitution [-]: an array of shape ``(n_beta,)`` or
            ``(n_beta, n_bounces)``, or ``{label: array}`` for several series.
        ax: A matplotlib ``Axes`` to draw on; default a new figure.
        e_h: Housner's ``e_H`` [-], Eq. (2), drawn as a horizontal line; default none.
        beta_dejong: DeJong's ``beta`` [s] (``rockjax.beta_dejong``), drawn as a vertical line.
        label: Legend label when ``e_values`` is a single array.
        title: Axes title; default none.

    Returns:
        The matplotlib ``Axes``.

    Raises:
        ValueError: If a series does not have one row per ``beta``.
    """
    betas = np.asarray(betas, dtype=float)
    series = dict(e_values) if isinstance(e_values, Mapping) else {label: e_values}
    ax = _new_axes(ax)
    for name, values in series.items():
        e = np.asarray(values, dtype=float)
        if e.ndim not in (1, 2) or e.shape[0] != betas.shape[0]:
            raise ValueError(
                f"e_values[{name!r}] must have shape (n_beta,) or (n_beta, n_bounces) with "
                f"n_beta={betas.shape[0]}; got shape {e.shape}."
            )
        if e.ndim == 1:
            ax.plot(betas, e, "o-", ms=5, lw=1.2, label=name)
            continue
        import warnings

        with warnings.catch_warnings():
            # a bounce that never happened is NaN; an all-NaN row stays NaN without a warning
            warnings.simplefilter("ignore", RuntimeWarning)
            mean, lo, hi = np.nanmean(e, axis=1), np.nanmin(e, axis=1), np.nanmax(e, axis=1)
        ax.errorbar(
            betas,
            mean,
            yerr=np.vstack([mean - lo, hi - mean]),
            fmt="o-",
            ms=5,
            lw=1.2,
            capsize=3,
            label=f"{name}, mean of bounces 1-{e.shape[1]} (bars: min-max)",
        )
    if e_h is not None:
        ax.axhline(e_h, color="C3", ls="--", lw=1.0, label=rf"$e_H$ = {e_h:.3f}, Eq. (2)")
    if beta_dejong is not None:
        ax.axvline(
            beta_dejong,
            color="0.4",
            ls=":",
            lw=1.0,
            label=rf"$\beta_{{DeJong}}$ = {beta_dejong:.3g} s",
        )
    ax.set_xlabel(r"stiffness-proportional damping $\beta$ [s]")
    ax.set_ylabel(r"coefficient of restitution $e_{exp}$ [-], Eq. (6)")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    if title:
        ax.set_title(title)
    return ax


def ground_motion(motion: GroundMotion, ax=None, *, in_g: bool = True, title: str | None = None):
    """The horizontal ground acceleration of a record against time.

    Args:
        motion: The record.
        ax: A matplotlib ``Axes`` to draw on; default a new figure.
        in_g: Plot ``a_g/g`` [-] instead of ``a_g`` [m/s^2].
        title: Axes title; default none.

    Returns:
        The matplotlib ``Axes``.
    """
    ax = _new_axes(ax, figsize=(7.0, 2.5))
    ag = np.asarray(motion.ag, dtype=float)
    ax.plot(np.asarray(motion.t), ag / G if in_g else ag, color="0.2", lw=1.0, label=motion.name)
    ax.axhline(0.0, color="0.7", lw=0.6)
    ax.set_xlabel("time t [s]")
    ax.set_ylabel(r"ground acc. $a_g/g$ [-]" if in_g else r"ground acc. $a_g$ [m/s$^2$]")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    if title:
        ax.set_title(title)
    return ax


def calibration(fit, axes=None, *, title: str | None = None):
    """A calibration (:func:`rockjax.fit_beta` or :func:`rockjax.fit_e`) in two panels.

    Left: the free-rocking histories ``theta/eta`` against time of the DEM at the result and of
    its Housner reference (the DEM alone for ``target="bounces"``, which has no reference run).
    Right: the loss of every evaluation in ``fit.history`` against the fitted parameter
    (``beta`` [s], or ``e`` [-] for ``fit_e``), on a log scale, coloured by evaluation order,
    with the result marked.

    Args:
        fit: A :class:`rockjax.Calibration`.
        axes: Two matplotlib ``Axes`` ``(histories, loss)`` to draw on; default a new figure.
        title: Title of the history panel; default one naming the fitted values.

    Returns:
        The two ``Axes`` ``(histories, loss)``; the figure is ``axes[0].figure``.

    Raises:
        ValueError: If ``axes`` is not a pair of Axes.
    """
    if axes is None:
        plt = pyplot()
        _, axes = plt.subplots(1, 2, figsize=(11.0, 4.0), width_ratios=[3, 2], layout="constrained")
    axes = tuple(np.ravel(np.asarray(axes, dtype=object)))
    if len(axes) != 2:
        raise ValueError(f"axes must be two Axes (histories, loss); got {len(axes)}.")
    ax_t, ax_l = axes
    fitted_e = "e" in fit.history  # fit_e: the Housner e was fitted, beta given
    runs = {f"DEM, beta = {fit.beta:.4g} s": fit.dem}
    if fit.housner is not None:
        runs[f"Housner, e = {fit.e:.4f}"] = fit.housner
    if title is None:
        title = (
            f"fitted e = {fit.e:.4f} at beta = {fit.beta:.4g} s"
            if fitted_e
            else f"fitted beta = {fit.beta:.4g} s, DEM e_effective = {fit.e_effective:.4f}"
        )
    time_history(runs, ax=ax_t, title=title)

    key = "e" if fitted_e else "beta"
    x = np.asarray(fit.history[key], dtype=float)
    y = np.asarray(fit.history["loss"], dtype=float)
    n = min(x.size, y.size)
    x, y = x[:n], y[:n]
    ok = np.isfinite(x) & np.isfinite(y) & (y > 0)
    if np.any(ok):
        points = ax_l.scatter(
            x[ok], y[ok], c=np.arange(n)[ok], cmap="viridis", s=18, zorder=2, label="evaluations"
        )
        ax_l.figure.colorbar(points, ax=ax_l, label="evaluation order [-]")
        ax_l.set_yscale("log")
    best = fit.e if fitted_e else fit.beta
    unit = "" if fitted_e else " s"
    ax_l.axvline(best, color="C3", ls="--", lw=1.0, label=f"result {key} = {best:.4g}{unit}")
    ax_l.set_xlabel(
        "Housner restitution e [-]" if fitted_e else r"stiffness-proportional damping $\beta$ [s]"
    )
    ax_l.set_ylabel("loss [-] (bounce log-energy gap$^2$)")
    ax_l.set_title(f"{fit.method}: {fit.n_iterations} iterations, {fit.n_simulations} runs")
    ax_l.grid(True, alpha=0.3)
    ax_l.legend(loc="best", fontsize="small")
    return ax_t, ax_l


# ----------------------------------------------------------------------------- IDA and fragility

_IM_LABELS = {
    "pga_scaled": "PGA",
    "pga": "PGA",
    "pgv": "PGV",
    "im_g": "IM",
    "scale": "scale factor",
}
_EDP_LABELS = {
    "max_d_over_b": r"peak top displacement $|d|/b$",
    "max_theta_over_eta": r"$\theta_{max}/\eta$",
}


def _im_label(name: str) -> str:
    if name.startswith("sa(") and name.endswith(")"):
        return f"$S_a$({name[3:-1]} s)"
    return _IM_LABELS.get(name, name)


def _im_axis(name: str, units_attr: str, units: str) -> tuple[float, str, str]:
    """Divisor, axis label and unit text of an IM: accelerations are shown in ``units``."""
    if units not in ("g", "m/s^2"):
        raise ValueError(f"units must be 'g' or 'm/s^2'; got units={units!r}.")
    label = _im_label(name)
    if units_attr in ("m/s^2", "g"):
        to_si = G if units_attr == "g" else 1.0  # the IM in m/s^2 is value * to_si
        if units == "g":
            return G / to_si, f"{label} [g]", "g"
        return 1.0 / to_si, f"{label} [m/s$^2$]", "m/s$^2$"
    unit = units_attr if units_attr not in ("", "1") else "-"
    return 1.0, f"{label} [{unit}]", "" if unit == "-" else unit


def _check_vars(ds, names) -> None:
    for var in names:
        if var not in ds.variables:
            raise ValueError(
                f"ds has no {var!r} variable; pass the Dataset that rockjax.ida returns "
                f"(it has {sorted(map(str, ds.variables))})."
            )


def ida(ds, ax=None, *, edp: str = "max_d_over_b", im: str | None = None, units: str = "g"):
    """IDA curves: one line per record, the demand on x and the intensity on y (paper Fig. 10).

    Only valid runs (``status == 0``) are drawn; collapsed runs are marked with a cross (their
    demand is where the run stopped, just past overturning).

    Args:
        ds: A Dataset from :func:`rockjax.ida`.
        ax: A matplotlib ``Axes`` to draw on; default a new figure.
        edp: Demand variable of ``ds``, e.g. ``"max_d_over_b"`` or ``"max_theta_over_eta"``.
        im: Intensity measure: ``"pga"``, ``"pgv"``, the IDA's ``"sa(T)"``, or a variable or
            coordinate of ``ds`` such as ``"scale"`` (:func:`rockjax.fragility.intensity_grid`);
            default the IDA's IM (``"pga_scaled"`` for a Dataset without one).
        units: ``"g"`` or ``"m/s^2"``: the unit of an acceleration IM on the axis.

    Returns:
        The matplotlib ``Axes``.

    Raises:
        ValueError: If ``ds`` lacks a variable or ``units`` is unknown.
    """
    _check_vars(ds, ("collapse", "status", edp))
    grid = intensity_grid(ds, default_im(ds) if im is None else im)
    div, ylabel, _ = _im_axis(str(grid.name), str(grid.attrs.get("units", "")), units)
    ax = _new_axes(ax)
    dims = ("record", "scale")
    x_all = np.asarray(ds[edp].transpose(*dims), dtype=float)
    y_all = np.asarray(grid.transpose(*dims), dtype=float) / div
    col_all = np.asarray(ds["collapse"].transpose(*dims), dtype=bool)
    ok_all = np.asarray(ds["status"].transpose(*dims)) == 0
    names = [str(r) for r in np.asarray(ds["record"])]
    show_legend = len(names) <= 10
    marked = False
    for i, name in enumerate(names):
        ok = ok_all[i]
        order = np.argsort(y_all[i][ok])
        x, y, c = x_all[i][ok][order], y_all[i][ok][order], col_all[i][ok][order]
        (line,) = ax.plot(x, y, "o-", ms=3, lw=1.0, label=name if show_legend else None)
        if c.any():
            ax.plot(
                x[c],
                y[c],
                "x",
                color=line.get_color(),
                ms=7,
                mew=1.5,
            )
            marked = True
    if marked:  # one neutral legend entry for the crosses of every record
        ax.plot([], [], "x", color="0.2", ms=7, mew=1.5, label="collapse")
    edp_label = _EDP_LABELS.get(edp, edp)
    edp_units = str(ds[edp].attrs.get("units", ""))
    ax.set_xlabel(f"{edp_label} [{edp_units if edp_units not in ('', '1') else '-'}]")
    ax.set_ylabel(ylabel)
    ax.set_xlim(left=0.0)
    ax.set_ylim(bottom=0.0)
    ax.grid(True, alpha=0.3)
    if show_legend or marked:
        ax.legend(loc="best", fontsize="small")
    return ax


def fragility(frag, ax=None, *, ds=None, units: str = "g"):
    """A fitted collapse fragility: the lognormal CDF, its bootstrap band, and the data.

    Args:
        frag: A :class:`rockjax.fragility.Fragility` from :func:`rockjax.fragility`.
        ax: A matplotlib ``Axes`` to draw on; default a new figure.
        ds: The IDA Dataset the fit came from; when given, the fraction of valid runs that
            collapsed at each scale factor is drawn at the geometric mean IM of that scale.
        units: ``"g"`` or ``"m/s^2"``: the unit of an acceleration IM on the axis.

    Returns:
        The matplotlib ``Axes``.

    Raises:
        ValueError: If ``ds`` lacks a variable or ``units`` is unknown.
    """
    div, xlabel, unit = _im_axis(frag.im, frag.im_units, units)
    ax = _new_axes(ax)
    emp = None
    if ds is not None:
        _check_vars(ds, ("collapse", "status"))
        dims = ("record", "scale")
        x_im = np.asarray(intensity_grid(ds, frag.im).transpose(*dims), float)
        ok = (np.asarray(ds["status"].transpose(*dims)) == 0) & (x_im > 0)
        col = np.asarray(ds["collapse"].transpose(*dims), dtype=bool) & ok
        n_ok = ok.sum(axis=0)
        keep = n_ok > 0
        log_im = np.where(ok, np.log(np.where(ok, x_im, 1.0)), 0.0)
        gm = np.exp(log_im.sum(axis=0)[keep] / n_ok[keep])
        emp = gm, col.sum(axis=0)[keep] / n_ok[keep]
    hi_im = 3.0 * frag.median
    if emp is not None and emp[0].size:
        hi_im = max(hi_im, float(emp[0].max()))
    im = np.linspace(0.0, hi_im, 301)[1:]
    lo, hi = frag.prob_band(im)
    if np.all(np.isfinite(lo)):
        ax.fill_between(
            im / div,
            lo,
            hi,
            color="C0",
            alpha=0.25,
            lw=0,
            label=f"{100 * frag.ci:.0f}% bootstrap band",
        )
    label = (
        rf"lognormal ({frag.method}): $\theta$ = {frag.median / div:.3g}"
        rf"{' ' + unit if unit else ''}, $\sigma$ = {frag.beta_log:.3g}"
    )
    ax.plot(im / div, frag.prob(im), color="C0", lw=1.8, label=label)
    if emp is not None:
        ax.plot(emp[0] / div, emp[1], "ks", ms=4, label="collapsed fraction per scale")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("probability of collapse [-]")
    ax.set_xlim(left=0.0)
    ax.set_ylim(-0.02, 1.02)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    return ax


def pairs(ds_facade, ds_parapet, ax=None, *, edp: str = "max_d_over_b"):
    """Facade against parapet demand for the same record and scale, with the 1:1 line (Fig. 11).

    The two Datasets are matched on ``record`` and ``scale`` (their intersection); a pair is
    drawn when both runs are valid, with a distinct marker when either block collapsed.

    Args:
        ds_facade: IDA Dataset of the facade (``mode="one_sided"``).
        ds_parapet: IDA Dataset of the parapet (``mode="two_sided"``).
        ax: A matplotlib ``Axes`` to draw on; default a new figure.
        edp: Demand variable to compare, e.g. ``"max_d_over_b"``.

    Returns:
        The matplotlib ``Axes``.

    Raises:
        ValueError: If a Dataset lacks a variable or the two share no (record, scale) pair.
    """
    import xarray as xr

    for ds in (ds_facade, ds_parapet):
        _check_vars(ds, ("collapse", "status", edp))
    f, p = xr.align(ds_facade, ds_parapet, join="inner")
    if f.sizes.get("record", 0) == 0 or f.sizes.get("scale", 0) == 0:
        raise ValueError(
            "ds_facade and ds_parapet share no (record, scale) pair; run rockjax.ida on the same "
            "records and scale factors for both blocks."
        )
    dims = ("record", "scale")
    ok = (np.asarray(f["status"].transpose(*dims)) == 0) & (
        np.asarray(p["status"].transpose(*dims)) == 0
    )
    x = np.asarray(f[edp].transpose(*dims), float)[ok]
    y = np.asarray(p[edp].transpose(*dims), float)[ok]
    cf = np.asarray(f["collapse"].transpose(*dims), bool)[ok]
    cp = np.asarray(p["collapse"].transpose(*dims), bool)[ok]
    ax = _new_axes(ax, figsize=(5.0, 5.0))
    groups = [
        (~cf & ~cp, "o", "C0", "both standing"),
        (cf & ~cp, "^", "C1", "facade collapsed"),
        (~cf & cp, "v", "C2", "parapet collapsed"),
        (cf & cp, "x", "C3", "both collapsed"),
    ]
    for mask, marker, color, label in groups:
        if mask.any():
            ax.plot(x[mask], y[mask], marker, color=color, ms=4, ls="none", label=label)
    top = float(np.nanmax(np.concatenate([x, y, [1e-3]])))
    ax.plot([0.0, 1.05 * top], [0.0, 1.05 * top], "k--", lw=1.0, label="1:1")
    edp_label = _EDP_LABELS.get(edp, edp)
    edp_units = str(f[edp].attrs.get("units", ""))
    unit = edp_units if edp_units not in ("", "1") else "-"
    ax.set_xlabel(f"facade {edp_label} [{unit}]")
    ax.set_ylabel(f"parapet {edp_label} [{unit}]")
    ax.set_xlim(0.0, 1.05 * top)
    ax.set_ylim(0.0, 1.05 * top)
    ax.set_aspect("equal")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    return ax


# ----------------------------------------------------------------------------- capacity, spectra

_PUSHOVER_AXES = {
    "d_over_b": (r"top displacement $d/b$ [-]", "d_over_b"),
    "theta": (r"rotation $\theta$ [rad]", "theta"),
}


def pushover(capacity, fit=None, ax=None, *, x: str = "d_over_b", title: str | None = None):
    """A pushover curve: the load multiplier ``lambda = F/(m g)`` against the top displacement
    ``d/b`` (or the rotation), with the three-branch law overlaid when given.

    For one block the rigid block's curve (:meth:`rockjax.Capacity.rigid_load_multiplier`) is
    drawn dotted, for comparison; for an assembly its rigid collapse multiplier
    ``lambda_rigid`` (:func:`rockjax.limit_analysis`) is a horizontal line.

    Args:
        capacity: A :class:`rockjax.Capacity` from :func:`rockjax.pushover`.
        fit: A :class:`rockjax.ThreeBranchFit` (:func:`rockjax.fit_three_branch`) or a
            :class:`rockjax.ThreeBranchLaw`, drawn against ``d/b``; default none.
        ax: A matplotlib ``Axes`` to draw on; default a new figure.
        x: The abscissa: ``"d_over_b"`` (top displacement over ``b`` [-]) or ``"theta"``
            (rotation [rad]; the law, a function of ``d/b``, is drawn at the curve's
            rotations).
        title: Axes title; default none.

    Returns:
        The matplotlib ``Axes``.

    Raises:
        ValueError: for an unknown ``x``, or a ``fit`` that is no three-branch law.
    """
    if x not in _PUSHOVER_AXES:
        raise ValueError(f"x must be one of {list(_PUSHOVER_AXES)}; got x={x!r}.")
    law = getattr(fit, "law", fit)
    if law is not None and not hasattr(law, "load_multiplier"):
        raise ValueError(
            "fit must be a rockjax.ThreeBranchFit (rj.fit_three_branch(capacity)) or a "
            f"rockjax.ThreeBranchLaw; got a {type(fit).__name__}."
        )
    ax = _new_axes(ax)
    xlabel, attr = _PUSHOVER_AXES[x]
    d_over_b = np.asarray(capacity.d_over_b, dtype=float)
    abscissa = np.asarray(getattr(capacity, attr), dtype=float)
    lam = np.asarray(capacity.load_multiplier, dtype=float)
    ax.plot(abscissa, lam, color="C0", lw=1.4, label="DEM pushover")
    lam_rigid = float(np.asarray(capacity.lambda_rigid))
    if capacity.theta_blocks is None:
        theta = np.asarray(capacity.theta, dtype=float)
        rigid = np.asarray(capacity.rigid_load_multiplier(theta), dtype=float)
        ax.plot(abscissa, rigid, "k:", lw=1.0, label=rf"rigid block, $\lambda_0$ = {lam_rigid:.3g}")
    elif np.isfinite(lam_rigid):
        ax.axhline(
            lam_rigid,
            color="k",
            ls=":",
            lw=1.0,
            label=rf"rigid collapse, $\lambda$ = {lam_rigid:.3g}",
        )
    if law is not None:
        grid = np.linspace(0.0, max(float(np.max(np.abs(d_over_b))), 1e-9), 301)
        at = np.interp(grid, np.abs(d_over_b), abscissa) if x == "theta" else grid
        label = (
            rf"three-branch: $\lambda_0$ = {float(law.lambda_0):.3g}, "
            rf"$\Delta_1$ = {float(law.Delta_1):.3g}, $\Delta_2$ = "
            rf"{float(law.Delta_2):.3g}, $\Delta_u$ = {float(law.Delta_u):.3g}"
        )
        ax.plot(at, np.asarray(law.load_multiplier(grid)), color="C3", ls="--", lw=1.4, label=label)
    ax.axhline(0.0, color="0.7", lw=0.6)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(r"load multiplier $\lambda = a/g$ [-]")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    if title:
        ax.set_title(title)
    return ax


def spectrum(spec, ax=None, *, labels: Sequence[str] | None = None, title: str | None = None):
    """A response spectrum: the pseudo-spectral acceleration ``Sa/g`` against the period.

    Args:
        spec: A :class:`rockjax.spectra.Spectrum` (:func:`rockjax.response_spectrum`; or
            :func:`rockjax.floor_spectra`'s, one line per floor).
        ax: A matplotlib ``Axes`` to draw on; default a new figure.
        labels: One legend label per motion of a 2-D spectrum; default ``"floor 1"``, ...
        title: Axes title; default none.

    Returns:
        The matplotlib ``Axes``.

    Raises:
        ValueError: If ``labels`` does not give one label per motion.
    """
    periods = np.asarray(spec.periods, dtype=float)
    sa = np.atleast_2d(np.asarray(spec.sa, dtype=float)) / G
    if labels is None:
        labels = [None] if sa.shape[0] == 1 else [f"floor {k + 1}" for k in range(sa.shape[0])]
    if len(labels) != sa.shape[0]:
        raise ValueError(
            f"labels must give one label per motion: {sa.shape[0]}; got {len(labels)}."
        )
    ax = _new_axes(ax)
    zeta = 100.0 * float(np.asarray(spec.damping))
    for row, label in zip(sa, labels, strict=True):
        ax.plot(periods, row, lw=1.4, label=label)
    ax.set_xlabel("period T [s]")
    ax.set_ylabel(rf"pseudo-spectral acc. $S_a/g$ [-], {zeta:g} % damping")
    ax.set_xlim(left=0.0)
    ax.set_ylim(bottom=0.0)
    ax.grid(True, alpha=0.3)
    if any(label is not None for label in labels):
        ax.legend(loc="best", fontsize="small")
    if title:
        ax.set_title(title)
    return ax
