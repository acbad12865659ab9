"""Pulse identification (the paper's Fig. 8): the analytic pulse that best fits a record.

A record's low-pass filtered acceleration is compared with three pulse shapes of
:class:`rockjax.GroundMotion`: the symmetric Ricker wavelet (``"MH"``, Mexican hat), the
antisymmetric Ricker (``"AR"``) and the one-sine cycle (``"SC"``). For each shape and each
period on a grid, the best time shift comes from the cross-correlation of the template with the
record (FFT, all shifts at once) and the best amplitude in closed form (linear least squares);
the best period is then refined by a parabola through the grid's best three. The fit reports
``r2``: the fraction of the filtered record's energy (``sum a^2``) that the pulse explains.

Filtering: zero-phase, in the frequency domain, with a raised-cosine roll-off from ``f_cut`` to
``1.5 f_cut`` (no ringing from a brick-wall cut).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ._checks import check_choice, check_number, check_positive
from .motion import GroundMotion

SHAPES = ("MH", "AR", "SC")
DEFAULT_PERIODS = np.geomspace(0.2, 5.0, 61)
DEFAULT_PERIODS.flags.writeable = False
DEFAULT_F_CUT = 3.0
"""Low-pass corner [Hz]: keeps pulses of period >= ~0.3 s, removes the high-frequency content."""


@dataclasses.dataclass(frozen=True)
class PulseFit:
    """The best pulse of one shape for a record.

    Attributes:
        shape: ``"MH"``, ``"AR"`` or ``"SC"``.
        period: Pulse period T [s] (as in the :class:`GroundMotion` constructors).
        amplitude: Peak acceleration of the pulse [m/s^2], signed as the constructors take it.
        t0: The constructor's ``t0`` [s] (Ricker: centre; one-sine: start).
        r2: Fraction of the filtered record's energy the pulse explains [-] (1 = exact).
        pulse: The fitted pulse on the record's time axis.
    """

    shape: str
    period: float
    amplitude: float
    t0: float
    r2: float
    pulse: GroundMotion


def lowpass(motion: GroundMotion, f_cut: float = DEFAULT_F_CUT) -> GroundMotion:
    """Zero-phase low-pass filter of ``motion.ag`` [m/s^2] with corner ``f_cut`` [Hz].

    The gain is 1 below ``f_cut``, a raised cosine down to 0 at ``1.5 f_cut``, 0 above. The
    record is zero-padded to twice its length first, so the filter does not wrap around.
    """
    _check_motion(motion)
    check_positive("f_cut", f_cut, "Hz", "e.g. f_cut=3.0", scalar=True)
    a = np.asarray(motion.ag, float)
    n = a.size
    spec = np.fft.rfft(a, 2 * n)
    f = np.fft.rfftfreq(2 * n, motion.dt)
    x = np.clip((f - f_cut) / (0.5 * f_cut), 0.0, 1.0)
    gain = 0.5 * (1.0 + np.cos(np.pi * x))
    out = np.fft.irfft(spec * gain, 2 * n)[:n]
    return GroundMotion(ag=out, dt=motion.dt, name=f"{motion.name}_lp{f_cut:g}Hz")


def _check_motion(motion) -> None:
    if not isinstance(motion, GroundMotion):
        raise ValueError(
            f"motion must be a rockjax.GroundMotion; got {type(motion).__name__}. Wrap an "
            "array of accelerations [m/s^2] as rj.GroundMotion(ag=ag, dt=dt)."
        )


def _template(shape: str, period: float, dt: float) -> tuple[np.ndarray, float]:
    """Unit pulse sampled from its start, and the offset from the start to ``t0`` [s]."""
    if shape == "MH":
        gm, lead = GroundMotion.ricker(1.0, period, dt=dt, t0=1.5 * period), 1.5 * period
        return np.asarray(gm.ag)[: int(round(3.0 * period / dt)) + 1], lead
    if shape == "AR":
        gm = GroundMotion.ricker_antisymmetric(1.0, period, dt=dt, t0=1.5 * period)
        return np.asarray(gm.ag)[: int(round(3.0 * period / dt)) + 1], 1.5 * period
    gm = GroundMotion.sine_cycle(1.0, period, dt=dt, t0=0.0)
    return np.asarray(gm.ag)[: int(round(period / dt)) + 1], 0.0


def _best_shift(a: np.ndarray, s: np.ndarray, energy: float):
    """Best start index, amplitude and explained energy of template ``s`` in record ``a``."""
    n, m = a.size, s.size
    size = 1 << int(np.ceil(np.log2(n + m)))
    # c[k] = sum_t a[t + k] s[t]: template starting at sample k (negative k wrap to the end)
    c = np.fft.irfft(np.fft.rfft(a, size) * np.conj(np.fft.rfft(s, size)), size)
    shifts = np.concatenate([np.arange(0, n), np.arange(-m + 1, 0)])
    c = np.concatenate([c[:n], c[size - m + 1 :]])
    # the template's energy inside the record, for each shift (partial overlap at the ends)
    s2 = np.concatenate([[0.0], np.cumsum(s * s)])
    lo = np.clip(-shifts, 0, m)
    hi = np.clip(n - shifts, 0, m)
    norm = s2[hi] - s2[lo]
    with np.errstate(divide="ignore", invalid="ignore"):
        explained = np.where(norm > 0, c * c / norm, 0.0)
    k = int(np.argmax(explained))
    amp = c[k] / norm[k] if norm[k] > 0 else 0.0
    return int(shifts[k]), float(amp), float(explained[k] / energy)


def fit_pulse(
    motion: GroundMotion,
    shape: str,
    *,
    periods=DEFAULT_PERIODS,
    f_cut: float | None = DEFAULT_F_CUT,
) -> PulseFit:
    """The best pulse of one ``shape`` for ``motion`` (filtered by :func:`lowpass` first).

    Args:
        motion: The record.
        shape: ``"MH"``, ``"AR"`` or ``"SC"``.
        periods: Candidate periods [s] (increasing), refined by a parabola around the best.
        f_cut: Low-pass corner [Hz]; None compares the raw record.

    Returns:
        A :class:`PulseFit`.
    """
    _check_motion(motion)
    check_choice("shape", shape, SHAPES)
    check_number("periods", periods, "s", "e.g. periods=np.geomspace(0.2, 5.0, 61).")
    periods = np.asarray(periods, float)
    if (
        periods.ndim != 1
        or periods.size < 3
        or not np.all(np.isfinite(periods))
        or np.any(np.diff(periods) <= 0)
        or periods[0] <= 0
    ):
        raise ValueError(
            f"periods must be at least 3 increasing positive periods in s; got periods={periods}. "
            "E.g. periods=np.geomspace(0.2, 5.0, 61) (the default)."
        )
    rec = motion if f_cut is None else lowpass(motion, f_cut)
    a = np.asarray(rec.ag, float)
    energy = float(np.sum(a * a))
    if not energy > 0:
        raise ValueError(f"record {motion.name!r} is all zeros: no pulse to fit.")
    r2 = np.array([_best_shift(a, _template(shape, T, rec.dt)[0], energy)[2] for T in periods])
    i = int(np.argmax(r2))
    period = float(periods[i])
    if 0 < i < periods.size - 1:  # parabola in log(period) through the best three
        x = np.log(periods[i - 1 : i + 2])
        y = r2[i - 1 : i + 2]
        den = (x[0] - x[1]) * (x[0] - x[2]) * (x[1] - x[2])
        a2 = (x[2] * (y[1] - y[0]) + x[1] * (y[0] - y[2]) + x[0] * (y[2] - y[1])) / den
        b2 = (
            x[2] ** 2 * (y[0] - y[1]) + x[1] ** 2 * (y[2] - y[0]) + x[0] ** 2 * (y[1] - y[2])
        ) / den
        if a2 < 0:
            period = float(np.exp(np.clip(-b2 / (2 * a2), x[0], x[2])))
    s, lead = _template(shape, period, rec.dt)
    k, amp, r2_best = _best_shift(a, s, energy)
    t0 = k * rec.dt + lead
    pulse = _build(shape, amp, period, t0, rec.dt, rec.duration, motion.name)
    return PulseFit(shape, period, amp, float(t0), r2_best, pulse)


def pulse(
    shape: str,
    pga: float,
    period: float,
    *,
    dt: float = 0.005,
    duration: float | None = None,
    t0: float | None = None,
    name: str | None = None,
) -> GroundMotion:
    """The analytic pulse of one of the shapes :func:`identify_pulse` compares.

    ``"MH"`` is :meth:`rockjax.GroundMotion.ricker` (the symmetric Ricker wavelet), ``"AR"``
    :meth:`rockjax.GroundMotion.ricker_antisymmetric` and ``"SC"``
    :meth:`rockjax.GroundMotion.sine_cycle` (one sine cycle), each with its constructor's
    defaults for what is not given.

    Args:
        shape: ``"MH"``, ``"AR"`` or ``"SC"`` (:data:`SHAPES`).
        pga: Peak ground acceleration [m/s^2] (its sign sets the direction).
        period: Pulse period T [s].
        dt: Sampling step [s].
        duration: Record length [s]; default the constructor's (``t0 + 4 T`` for the Ricker
            wavelets, ``t0 + 5 T`` for the sine cycle).
        t0: The constructor's ``t0`` [s] (Ricker: centre, default ``1.5 T``; sine cycle:
            start, default 0).
        name: Label; default the constructor's.

    Returns:
        The sampled pulse as a :class:`rockjax.GroundMotion`.

    Raises:
        ValueError: for an unknown shape, or a value the constructor refuses.
    """
    check_choice("shape", shape, SHAPES)
    if shape == "MH":
        return GroundMotion.ricker(pga, period, dt=dt, duration=duration, t0=t0, name=name)
    if shape == "AR":
        return GroundMotion.ricker_antisymmetric(
            pga, period, dt=dt, duration=duration, t0=t0, name=name
        )
    start = 0.0 if t0 is None else t0
    return GroundMotion.sine_cycle(pga, period, dt=dt, duration=duration, t0=start, name=name)


def _build(shape, amp, period, t0, dt, duration, name) -> GroundMotion:
    label = f"{name}_{shape}_T{period:.3g}s"
    if shape != "SC" or t0 >= 0:
        return pulse(shape, amp, period, dt=dt, duration=duration, t0=t0, name=label)
    # a sine cycle starting before the record: keep the samples inside it
    full = GroundMotion.sine_cycle(amp, period, dt=dt, duration=duration - t0, t0=0.0)
    skip = int(round(-t0 / dt))
    n = int(round(duration / dt)) + 1
    return GroundMotion(ag=np.asarray(full.ag)[skip : skip + n], dt=dt, name=label)


def identify_pulse(
    motion: GroundMotion,
    *,
    shapes=SHAPES,
    periods=DEFAULT_PERIODS,
    f_cut: float | None = DEFAULT_F_CUT,
) -> tuple[PulseFit, dict[str, PulseFit]]:
    """The best-fitting pulse shape for a record (paper Fig. 8).

    Returns:
        ``(best, fits)``: the fit with the highest ``r2``, and every shape's fit by name.
    """
    if isinstance(shapes, str) or not all(isinstance(sh, str) for sh in shapes) or not shapes:
        raise ValueError(
            f"shapes must be a non-empty sequence of shape names from {SHAPES}; got "
            f"shapes={shapes!r}. E.g. shapes=('MH',) for the Ricker wavelet alone."
        )
    for sh in shapes:
        if sh not in SHAPES:
            raise ValueError(
                f"shapes holds {sh!r}, which is no pulse shape; each entry must be one of "
                f"{SHAPES}, e.g. shapes=('MH', 'SC')."
            )
    fits = {sh: fit_pulse(motion, sh, periods=periods, f_cut=f_cut) for sh in shapes}
    best = max(fits.values(), key=lambda f: f.r2)
    return best, fits
