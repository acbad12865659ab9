"""Figures of rocking responses; the only rockjax module that imports matplotlib.

matplotlib is imported inside each function, so ``import rockjax`` never pays for it. When no
display is available (a headless Linux machine, CI) and no backend was chosen, the Agg backend
is selected before ``pyplot`` is first imported, so figures can always be saved.

Every function draws on ``ax`` when one is given (so figures can be composed), otherwise on a
new figure, and returns the ``Axes``; the figure is ``ax.figure``. Save it with
``ax.figure.savefig(path)`` and close it with :func:`close`.
"""

from __future__ import annotations

import os
import sys
import warnings
from collections.abc import Mapping, Sequence

import numpy as np

from .constants import G
from .motion import GroundMotion
from .relations import amplitude_after_impacts
from .response import Response

_FIGSIZE = (7.0, 4.0)


def _pyplot():
    """Import ``matplotlib.pyplot``, choosing Agg first when there is no display to draw on."""
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
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=figsize, layout="constrained")
    return ax


def close(fig_or_ax) -> None:
    """Close a figure made by this module (pass the figure or one of its axes).

    Args:
        fig_or_ax: A matplotlib ``Figure`` or ``Axes``.
    """
    fig = getattr(fig_or_ax, "figure", fig_or_ax)
    _pyplot().close(fig)


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
