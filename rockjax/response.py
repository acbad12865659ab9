"""The time-history result of a simulation, and its post-processing (peaks, Eq. 6)."""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

from .modes import MODE_NAMES, Facade, Mode, Parapet, as_mode

HYSTERESIS = 2e-3
"""Impact detection threshold as a fraction of ``eta`` [-]: two-sided, an impact is counted when
``theta`` reaches the other side beyond ``HYSTERESIS * eta``; one-sided, when ``theta`` falls
below ``HYSTERESIS * eta`` after having been above twice that (:func:`rockjax.metrics.peaks`).
Sub-threshold rocking (e.g. the penalty contact's micro-vibration, ~1e-6 rad) is not counted."""

RELATIVE_BOUNCE = 0.02
"""One-sided: a rebound is a bounce only if it rises above this fraction of the previous peak."""

MODES = MODE_NAMES

STATUS_OK = 0
STATUS_NONFINITE = 1
STATUS_UNSTABLE = 2
STATUS_UNRESOLVED = 3
STATUS_BAD_INPUT = 4
STATUS_MESSAGES = {
    STATUS_OK: "ok",
    STATUS_NONFINITE: "the state became non-finite (NaN/inf): reduce dt or check the inputs",
    STATUS_UNSTABLE: "dt exceeds the explicit stability limit: leave dt=None or use rj.stable_dt",
    STATUS_UNRESOLVED: (
        "Housner: a solver step needed more impacts than max_impacts_per_step (the block was "
        "stopped there): raise max_impacts_per_step or pass a smaller dt"
    ),
    STATUS_BAD_INPUT: (
        "an input traced through jit/vmap is out of range (block dimensions, E or rho not "
        "finite and positive; a non-finite ground acceleration; DEM: beta or gap negative or "
        "not finite; Housner: e outside (0, 1] or |theta0| >= eta): the run was not made; "
        "check that lane's inputs"
    ),
}


class Response(eqx.Module):
    """A simulated rocking history, sampled at ``t``.

    Attributes:
        t: Sample times [s].
        theta: Rotation [rad] (positive about the +x bottom corner).
        theta_dot: Angular velocity [rad/s].
        d: Horizontal displacement of the top centre relative to the base [m].
        overturned: True if ``|theta|`` passed ``eta`` while moving outward (with a three-branch
            ``law``: the law's zero-capacity rotation); the state is frozen from then on.
        status: 0 if the run is valid, else a code in ``rockjax.response.STATUS_MESSAGES``.
        theta_max: Largest ``|theta|`` reached over the run, including between samples [rad]:
            DEM, the running maximum over every substep; Housner, the maximum of each solver
            step's Tsit5 dense output, which finds a turning point inside a step, or a flight
            shorter than one, at the solver's accuracy (docs/verification.md, "Housner",
            "Peaks between samples").
        eta: Slenderness angle of the block [rad], to normalise ``theta``.
        b: Block thickness [m], to normalise ``d``.
        energy: Total mechanical energy [J] (DEM: kinetic + potential + contact springs;
            Housner: kinetic + potential), or None when not requested.
        extras: Model-specific series, e.g. contact forces (DEM) or impact counts (Housner).
    """

    t: Float[Array, " time"]
    theta: Float[Array, " time"]
    theta_dot: Float[Array, " time"]
    d: Float[Array, " time"]
    overturned: Bool[Array, ""]
    status: Int[Array, ""]
    theta_max: Float[Array, ""]
    eta: Float[Array, ""]
    b: Float[Array, ""]
    energy: Float[Array, " time"] | None = None
    extras: dict = eqx.field(default_factory=dict)

    def __repr__(self) -> str:
        """One line: model, block, duration, peak ``|theta|/eta``, overturned, status."""
        return _summary(self)

    def to_dataframe(self):
        """The history as a ``pandas.DataFrame``, one row per sample (one run only).

        The index is ``"t [s]"``; the columns carry their units in their names:
        ``"theta [rad]"``, ``"theta_dot [rad/s]"``, ``"d [m]"``, ``"theta/eta [-]"``,
        ``"d/b [-]"``, ``"energy [J]"`` (when saved), and the model's per-sample extras whose
        units are known: DEM ``"x [m]"``, ``"y [m]"`` (centroid); Housner ``"n_impacts [-]"``
        (impacts so far), ``"t_last_impact [s]"``, ``"pivot [-]"`` (+1 or -1). Contact forces
        and other per-contact series stay in ``extras``. ``df.attrs`` holds the run's scalars:
        ``model``, ``overturned``, ``status``, ``status_message``, ``theta_max [rad]``,
        ``eta [rad]`` and ``b [m]`` (and ``t_heel [s]`` for Housner with a moving wall: the
        time its history stops being the rigid block's). Write it with ``df.to_csv(path)``.

        Returns:
            The ``pandas.DataFrame`` (pandas comes with xarray, a rockjax dependency).

        Raises:
            ValueError: for a batch of runs (from ``vmap``; index one run first,
                e.g. ``jax.tree.map(lambda x: x[i], resp)``) or inside ``jit``.
        """
        import pandas as pd

        t = one_run_times(self)
        columns = {
            "theta [rad]": self.theta,
            "theta_dot [rad/s]": self.theta_dot,
            "d [m]": self.d,
            "theta/eta [-]": self.theta_over_eta,
            "d/b [-]": self.d_over_b,
        }
        if self.energy is not None:
            columns["energy [J]"] = self.energy
        for key, unit in _EXTRA_UNITS.items():
            value = self.extras.get(key)
            if value is not None and np.shape(value) == t.shape:
                columns[f"{key} [{unit}]"] = value
        df = pd.DataFrame(
            {name: np.asarray(v, dtype=float) for name, v in columns.items()},
            index=pd.Index(t, name="t [s]"),
        )
        status = int(np.asarray(self.status))
        df.attrs.update(
            model=_model(self),
            overturned=bool(np.asarray(self.overturned)),
            status=status,
            status_message=STATUS_MESSAGES.get(status, "unknown status"),
            **{
                "theta_max [rad]": float(np.asarray(self.theta_max)),
                "eta [rad]": float(np.asarray(self.eta)),
                "b [m]": float(np.asarray(self.b)),
            },
        )
        if "t_heel" in self.extras:  # Housner with a moving wall: where its validity ends
            df.attrs["t_heel [s]"] = float(np.asarray(self.extras["t_heel"]))
        return df

    @property
    def d_over_b(self):
        """Top displacement over thickness, ``d/b`` [-]."""
        return self.d / self.b

    @property
    def theta_over_eta(self):
        """Normalised rotation ``theta/eta`` [-]."""
        return self.theta / self.eta

    @property
    def ok(self):
        """True where the run finished without a numerical failure."""
        return self.status == STATUS_OK

    def peaks(self, min_separation: float = 0.0):
        """Local maxima of ``|theta|`` (one per half-cycle), refined by a parabola through 3 samples.

        Runs on concrete (NumPy) values; not for use under jit.

        Returns:
            ``(t_peak, abs_theta_peak)`` as NumPy arrays [s], [rad].
        """
        return find_peaks(np.asarray(self.t), np.abs(np.asarray(self.theta)), min_separation)

    def bounces(self, mode: Mode | str | None = None):
        """Bounce peak times and amplitudes ``|theta_k|``, ``k >= 1``, of a free-rocking history
        released from rest: :func:`bounce_peaks` on the saved samples (the finder of
        :meth:`e_exp` and of the calibration's verdict). Runs on concrete (NumPy) values.

        Args:
            mode: :class:`rockjax.Parapet` / ``"two_sided"`` or :class:`rockjax.Facade` /
                ``"one_sided"`` (a facade: the rebounds off the wall);
                default (None) :func:`rocking_mode` of this history.

        Returns:
            ``(t_k, abs_theta_k)`` as NumPy arrays [s], [rad].
        """
        mode = rocking_mode(self) if mode is None else mode
        return bounce_peaks(self.t, self.theta, self.eta, mode)

    def e_exp(
        self, n_bounces: int = 3, theta0: float | None = None, mode: Mode | str | None = None
    ):
        """Experimental coefficient of restitution of bounces 1..n from peak rotations, Eq. (6).

        ``e_exp,n = [ (1 - (1 - |theta_n|/eta)^2) / (1 - (1 - |theta_0|/eta)^2) ]^(1/(2n))``

        The bounces are those of :meth:`bounces` (one finder for responses and calibrations: a
        facade's wall chatter is not a bounce).

        Args:
            n_bounces: How many bounces to evaluate.
            theta0: Release rotation [rad]; default the first sample's ``|theta|``.
            mode: As :meth:`bounces`; default (None) :func:`rocking_mode`.

        Returns:
            NumPy array of ``e_exp`` for bounces 1..n (NaN where the bounce did not happen).
        """
        _, amp = self.bounces(mode)
        eta = float(self.eta)
        th0 = abs(float(self.theta[0])) if theta0 is None else abs(theta0)
        padded = np.full(n_bounces, np.nan)  # a missing bounce gives NaN
        padded[: min(n_bounces, amp.size)] = amp[:n_bounces]
        return np.asarray(_e_exp_jit(padded, th0, eta, np.arange(1, n_bounces + 1)))


# Per-sample extras of the simulators whose units are known, for Response.to_dataframe.
_EXTRA_UNITS = {"x": "m", "y": "m", "n_impacts": "-", "t_last_impact": "s", "pivot": "-"}


def one_run_times(resp) -> np.ndarray:
    """The sample times [s] of one concrete run, for its ``to_dataframe``: a traced run
    (inside ``jit``/``vmap``) and a batch of runs are refused, with the fix."""
    kind = type(resp).__name__
    t = _concrete(resp.t)
    if t is None:
        raise ValueError(f"{kind}.to_dataframe needs concrete values: call it outside jit/vmap.")
    if t.ndim != 1:
        raise ValueError(
            f"{kind}.to_dataframe takes one run; this {kind} holds a batch (t has shape "
            f"{t.shape}). Pick run i first: jax.tree.map(lambda x: x[i], resp)."
        )
    return t


def _concrete(x):
    """``x`` as a NumPy array, or None for a tracer (inside jit/vmap/grad)."""
    try:
        return np.asarray(x)
    except (TypeError, jax.errors.TracerArrayConversionError):
        return None


def _model(resp: Response) -> str:
    """The simulator behind a Response, from the extras each one saves."""
    if "n_impacts" in resp.extras:
        return "Housner"
    if "d_max" in resp.extras:
        return "DEM"
    return "model unknown"


def _summary(resp: Response) -> str:
    values = [_concrete(x) for x in (resp.t, resp.theta_max, resp.eta, resp.b)]
    values += [_concrete(resp.overturned), _concrete(resp.status)]
    if any(v is None for v in values):  # traced: the structure is all there is to show
        return eqx.tree_pformat(resp)
    t, theta_max, eta, b, overturned, status = values
    ratio = theta_max / eta
    parts = [_model(resp)]
    if np.ptp(eta) == 0 and np.ptp(b) == 0:
        b0, eta0 = float(b.flat[0]), float(eta.flat[0])
        parts.append(f"block {b0:.4g} x {b0 / math.tan(eta0):.4g} m")
    n_t = t.shape[-1]
    t_row = t.reshape(-1, n_t)[0]
    span = f"{float(t_row[-1] - t_row[0]):.4g} s in {n_t} samples"
    if t.ndim == 1:
        standing = "overturned" if bool(overturned) else "standing"
        code = int(status)
        text = STATUS_MESSAGES.get(code, "unknown status").split(":")[0]
        head = ", ".join(parts)
        return (
            f"Response({head}, {span}: peak |theta|/eta {float(ratio):.4g}, {standing}, "
            f"status {code} ({text}))"
        )
    n_runs = int(np.prod(t.shape[:-1]))
    parts.insert(1, f"batch {t.shape[:-1]} of {n_runs} runs")
    head = ", ".join(parts)
    return (
        f"Response({head}, {span}: peak |theta|/eta {np.nanmin(ratio):.4g} to "
        f"{np.nanmax(ratio):.4g}, {int(np.sum(overturned))} overturned, "
        f"{int(np.sum(status != STATUS_OK))} with status != 0)"
    )


def e_exp(theta_n, theta0, eta, n):
    """Eq. (6): coefficient of restitution from the n-th bounce peak ``|theta_n|`` [rad].

    Args:
        theta_n: Peak rotation after the n-th impact [rad].
        theta0: Release rotation [rad].
        eta: Slenderness angle [rad].
        n: Bounce number (1, 2, ...).
    """
    num = 1.0 - (1.0 - jnp.abs(theta_n) / eta) ** 2
    den = 1.0 - (1.0 - jnp.abs(theta0) / eta) ** 2
    return (num / den) ** (1.0 / (2.0 * n))


def impact_threshold(mode: Mode | str) -> float:
    """Impact threshold of the bounce finders as a fraction of ``eta`` [-]: :data:`HYSTERESIS`
    times the mode's ``threshold_scale`` (two-sided 1, one-sided a tenth: facade bounces are
    small)."""
    return as_mode(mode).threshold_scale * HYSTERESIS


def rocking_mode(resp: Response) -> str:
    """``"one_sided"`` if the history never passes to the far side of its release by more than
    :data:`HYSTERESIS` ``eta`` (a facade: a return wall's contact penetration is far smaller),
    else ``"two_sided"``."""
    th = np.asarray(resp.theta, float)
    side = 1.0 if th[0] >= 0 else -1.0
    one_sided = np.min(side * th) > -HYSTERESIS * float(resp.eta)
    return (Facade if one_sided else Parapet).name


def bounce_peaks(t, theta, eta, mode: Mode | str) -> tuple[np.ndarray, np.ndarray]:
    """Bounce peak times [s] and amplitudes ``|theta_k|``, ``k >= 1`` [rad] of a history released
    from rest (``theta[0]``), found in NumPy on the saved samples.

    Without impact detection (an independent path from the calibration loss's
    :func:`rockjax.metrics.peaks`): the local maxima of ``y = |theta|`` (one-sided
    ``max(theta, 0)``: the rebounds), where two neighbours whose valley stays above half the
    smaller one are one flight (penalty-contact wobble on it; the larger is kept), each
    refined by a parabola through three samples and kept only if it exceeds
    :data:`RELATIVE_BOUNCE` of the previous kept one (the release first) and twice the
    :func:`impact_threshold` (micro-vibration in contact, or a facade's chatter on its wall, is
    no bounce).

    Args:
        t: Sample times [s], uniform. theta: Rotation [rad]. eta: Slenderness [rad].
        mode: :class:`rockjax.Parapet` / ``"two_sided"`` or :class:`rockjax.Facade` /
            ``"one_sided"``.
    """
    mode = as_mode(mode)
    th = np.asarray(theta, float)
    y = mode.amplitude(th)
    idx = np.flatnonzero((y[1:-1] > y[:-2]) & (y[1:-1] >= y[2:])) + 1
    merged = [0]  # the release: a noisy maximum on its flight is the release, not a bounce
    for i in idx:
        if y[merged[-1] : i + 1].min() > 0.5 * min(y[merged[-1]], y[i]):
            if y[i] > y[merged[-1]]:
                merged[-1] = i
        else:
            merged.append(i)
    merged = merged[1:]
    t = np.asarray(t, float)
    prev = abs(float(th[0]))
    floor = 2.0 * impact_threshold(mode) * float(eta)
    times, amps = [], []
    for i in merged:
        y0, y1, y2 = y[i - 1], y[i], y[i + 1]
        den = y0 - 2.0 * y1 + y2
        s = min(max(0.5 * (y0 - y2) / den, -1.0), 1.0) if den < 0 else 0.0  # vertex offset
        a = y1 - 0.25 * (y0 - y2) * s
        if a > max(floor, RELATIVE_BOUNCE * prev):
            times.append(t[i] + s * (t[i + 1] - t[i]))
            amps.append(a)
            prev = a
    return np.asarray(times, float), np.asarray(amps, float)


_e_exp_jit = jax.jit(e_exp)  # one small program instead of an eager compilation of each operation


def find_peaks(t: np.ndarray, y: np.ndarray, min_separation: float = 0.0):
    """Interior local maxima of ``y(t)`` (y >= 0), refined by a 3-point parabola; NumPy only."""
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    if y.size < 3:
        return np.empty(0), np.empty(0)
    i = np.flatnonzero((y[1:-1] > y[:-2]) & (y[1:-1] >= y[2:])) + 1
    i = i[y[i] > 0]
    h = t[1] - t[0]
    y0, y1, y2 = y[i - 1], y[i], y[i + 1]
    denom = y0 - 2 * y1 + y2
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(denom < 0, 0.5 * (y0 - y2) / denom, 0.0)
    s = np.clip(s, -1.0, 1.0)
    tp = t[i] + s * h
    yp = y1 - 0.25 * (y0 - y2) * s
    if min_separation > 0 and tp.size:
        keep = [0]
        for k in range(1, tp.size):
            if tp[k] - tp[keep[-1]] >= min_separation:
                keep.append(k)
            elif yp[k] > yp[keep[-1]]:
                keep[-1] = k
        tp, yp = tp[keep], yp[keep]
    return tp, yp
