"""Ground motions: a uniformly sampled horizontal (and optional vertical) acceleration record."""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike, Float

from ._checks import MAX_SAMPLES as MAX_SAMPLES
from ._checks import (
    check_number,
    check_positive,
    check_samples,
    check_scalar,
    concrete,
    time_steps,
)
from ._types import Scalar, ScalarLike, TimeSeries
from .constants import G

PLAUSIBLE_LIMIT_G = 10.0
"""Plausibility limit of a ground acceleration [g]: a record or a PGA above it raises.

Strong-motion records peak at a few g; a peak above 10 g almost always means a record in cm/s^2
(or mm/s^2) passed where rockjax takes m/s^2 (a 0.3 g record is 294 cm/s^2)."""


def _step(dt) -> float:
    """The sampling step [s] as a Python float, checked (the converter of ``GroundMotion.dt``)."""
    if isinstance(dt, jax.core.Tracer):
        raise ValueError(
            "dt (the sampling step, in s) must be a concrete number: it fixes the number of "
            "steps, so it cannot be traced under jit/vmap/grad. Build the GroundMotion outside "
            "the transform, or close over dt."
        )
    check_positive("dt", dt, "s", "Use the record's sampling step, e.g. dt=0.01.", scalar=True)
    return float(np.asarray(dt, dtype=float))


def _series(a):
    """A list or tuple of numbers as a float64 array (stored as given, ``ag=[0.0, 1.0]`` would
    make ``scaled(2.0)`` multiply a list); anything else as given, for the checks of
    ``GroundMotion.__check_init__`` (text, bools and objects are refused there, not converted)."""
    if isinstance(a, list | tuple):
        try:
            v = np.asarray(a)
        except (TypeError, ValueError, jax.errors.TracerArrayConversionError):
            return a
        if v.dtype.kind in "iuf":
            return v.astype(float)
    return a


class GroundMotion(eqx.Module):
    """A ground acceleration record sampled at a uniform step.

    Positive ``ag`` accelerates the base toward +x, which drives ``theta`` negative
    (see :class:`rockjax.Block` for the sign convention).

    Args:
        ag: Horizontal ground acceleration [m/s^2], shape ``(time,)``; sample ``k`` is at ``k*dt``.
        dt: Sampling step [s].
        name: A label for plots and datasets.
        ag_v: Optional vertical ground acceleration [m/s^2] (positive up), same shape as ``ag``.
        meta: Descriptive metadata as ``(key, value)`` pairs of strings (event, date, station,
            component, source file, ...), e.g. ``(("event", "Northridge-01"), ("component",
            "228"))``. Read it as a dict with :attr:`metadata` and extend it with
            :meth:`with_metadata`. It never enters a computation.
    """

    ag: Float[ArrayLike, " time"] = eqx.field(converter=_series)
    # dt is static: it fixes the number of steps of every simulation, which must be concrete.
    # The converter checks it before equinox stores it (an array would be stored as static).
    dt: float = eqx.field(static=True, converter=_step)
    name: str = eqx.field(static=True, default="record")
    ag_v: Float[ArrayLike, " time"] | None = eqx.field(default=None, converter=_series)
    # A tuple of string pairs rather than a dict: a dict would be a pytree whose values JAX
    # traces, while a static field must be hashable (equinox compares static fields to decide
    # on recompiling). Records with different meta (or name) have different treedefs: batch
    # records by stacking their `ag` arrays, not by stacking GroundMotion modules.
    meta: tuple[tuple[str, str], ...] = eqx.field(static=True, default=())

    def __check_init__(self):
        for label, arr in (("ag", self.ag), ("ag_v", self.ag_v)):
            if arr is None:
                continue
            check_number(label, arr, "m/s^2", "Pass an array of accelerations, e.g. np.array(...).")
            a = concrete(arr)
            if a is None:
                continue
            if a.ndim != 1 or a.size < 2:
                raise ValueError(
                    f"{label} must be a 1-D acceleration series in m/s^2 with at least 2 samples; "
                    f"got shape {a.shape}. Pass one record at a time (batches go through rj.ida)."
                )
            _check_finite_series(label, a, self)
            _check_plausible_acceleration(label, float(np.max(np.abs(a))), f"record {self.name!r}")
        if self.ag_v is not None and np.shape(self.ag_v) != np.shape(self.ag):
            raise ValueError(
                f"ag_v must have the same shape as ag; got {np.shape(self.ag_v)} and {np.shape(self.ag)}."
            )
        if not isinstance(self.meta, tuple) or not all(
            isinstance(item, tuple)
            and len(item) == 2
            and all(isinstance(part, str) for part in item)
            for item in self.meta
        ):
            raise ValueError(
                f"meta must be a tuple of (key, value) string pairs; got meta={self.meta!r}. "
                "Use record.with_metadata(event='...', station='...') to add entries."
            )

    # ----------------------------------------------------------------- constructors
    @classmethod
    def from_g(cls, ag_g, dt: float, name: str = "record", ag_v_g=None) -> GroundMotion:
        """Build from accelerations in units of g (as PEER and FEMA P695 store them)."""
        for label, arr in (("ag_g", ag_g), ("ag_v_g", ag_v_g)):
            if arr is None:
                continue
            check_number(label, arr, "g", "e.g. ag_g=np.array([0.0, 0.1, -0.05]).")
            if (a := concrete(arr)) is not None and a.size and np.all(np.isfinite(a)):
                _check_plausible_acceleration(
                    label, float(np.max(np.abs(a))) * G, f"record {name!r}"
                )
        ag = np.asarray(ag_g, dtype=float) * G
        ag_v = None if ag_v_g is None else np.asarray(ag_v_g, dtype=float) * G
        return cls(ag=ag, dt=dt, name=name, ag_v=ag_v)

    @classmethod
    def from_time_series(cls, t, ag, name: str = "record", rtol: float = 1e-6) -> GroundMotion:
        """Build from sample times ``t`` [s] and accelerations ``ag`` [m/s^2]; ``t`` must be uniform."""
        check_number("t", t, "s", "Pass the sample times, e.g. np.arange(n) * 0.01.")
        check_number("ag", ag, "m/s^2", "Pass the accelerations as numbers.")
        t = np.asarray(t, dtype=float)
        ag = np.asarray(ag, dtype=float)
        if t.ndim != 1 or t.shape != ag.shape or t.size < 2:
            raise ValueError(
                f"t and ag must be 1-D of equal length >= 2; got t of shape {t.shape} and ag "
                f"of shape {ag.shape}. Pass one time and one acceleration per sample."
            )
        bad = np.flatnonzero(~np.isfinite(t))
        if bad.size:
            raise ValueError(
                f"t (sample times of record {name!r}) must be finite; t[{bad[0]}] = {t[bad[0]]}. "
                "Remove or fix that sample."
            )
        ts = time_steps(t, rtol)
        if ts.first_back is not None:
            k = ts.first_back
            raise ValueError(
                f"t (sample times of record {name!r}) must increase: t[{k}] = {t[k]:.6g} s is "
                f"followed by t[{k + 1}] = {t[k + 1]:.6g} s. Sort the samples by time and drop "
                "repeated times (or check that the time column is the first)."
            )
        dt, worst = ts.mean, ts.worst
        if ts.off.any():
            raise ValueError(
                f"t (sample times of record {name!r}) is not uniformly sampled: step {worst} "
                f"(t[{worst}] = {t[worst]:.6g} s to t[{worst + 1}] = {t[worst + 1]:.6g} s) is "
                f"{ts.steps[worst]:.6g} s against a mean of {dt:.6g} s (rtol={rtol:g}). Resample "
                "the record to a uniform step first, e.g. np.interp(np.arange(t[0], t[-1], dt), "
                "t, ag)."
            )
        return cls(ag=ag, dt=dt, name=name)

    @classmethod
    def ricker(
        cls,
        pga: float | None = None,
        period: float | None = None,
        *,
        pga_g: float | None = None,
        dt: float = 0.005,
        duration: float | None = None,
        t0: float | None = None,
        name: str | None = None,
    ) -> GroundMotion:
        """Symmetric Ricker wavelet ("Mexican hat") pulse.

        ``ag(t) = pga (1 - 2 pi^2 tau^2 / T^2) exp(-pi^2 tau^2 / T^2)``, ``tau = t - t0``; the
        peak (``pga`` at ``t0``) is the pulse's centre and ``T = period`` is the period at the
        peak of its Fourier spectrum.

        Args:
            pga: Peak ground acceleration [m/s^2] (its sign sets the pulse direction).
            period: Pulse period T [s].
            pga_g: The same peak in g (e.g. ``pga_g=0.4``); give ``pga`` or ``pga_g``.
            dt: Sampling step [s].
            duration: Record length [s]; default ``t0 + 4 T``.
            t0: Time of the central peak [s]; default ``1.5 T``.
        """
        pga = _pulse_amplitude("ricker", pga, pga_g, period, t0)
        t0 = 1.5 * period if t0 is None else t0
        duration = t0 + 4.0 * period if duration is None else duration
        t = _time_axis(duration, dt)
        u = (np.pi * (t - t0) / period) ** 2
        ag = pga * (1.0 - 2.0 * u) * np.exp(-u)
        return cls(ag=ag, dt=dt, name=name or f"ricker_T{period:g}s")

    @classmethod
    def sine_cycle(
        cls,
        pga: float | None = None,
        period: float | None = None,
        *,
        pga_g: float | None = None,
        dt: float = 0.005,
        duration: float | None = None,
        t0: float = 0.0,
        name: str | None = None,
    ) -> GroundMotion:
        """One full sine cycle ``ag = pga sin(2 pi (t - t0) / T)`` for ``t0 <= t <= t0 + T``, zero after.

        Args:
            pga: Amplitude [m/s^2] (its sign sets the direction of the first half-cycle).
            period: Pulse period T [s].
            pga_g: The same amplitude in g; give ``pga`` or ``pga_g``.
            dt: Sampling step [s].
            duration: Record length [s]; default ``t0 + 5 T``.
            t0: Pulse start [s].
        """
        pga = _pulse_amplitude("sine_cycle", pga, pga_g, period, t0)
        duration = t0 + 5.0 * period if duration is None else duration
        t = _time_axis(duration, dt)
        tau = t - t0
        ag = np.where((tau >= 0) & (tau <= period), pga * np.sin(2 * np.pi * tau / period), 0.0)
        return cls(ag=ag, dt=dt, name=name or f"sine_T{period:g}s")

    @classmethod
    def ricker_antisymmetric(
        cls,
        pga: float | None = None,
        period: float | None = None,
        *,
        pga_g: float | None = None,
        dt: float = 0.005,
        duration: float | None = None,
        t0: float | None = None,
        name: str | None = None,
    ) -> GroundMotion:
        r"""Antisymmetric Ricker wavelet: the third derivative of a Gaussian.

        ``ag(t) = -pga f(tau) / f_max`` with ``tau = t - t0`` and

        $$f(\tau) = \frac{\tau}{T}\left(3 - 2\pi^2\frac{\tau^2}{T^2}\right)\exp\left(-\pi^2\frac{\tau^2}{T^2}\right),$$

        normalised by its closed-form peak ``f_max = sqrt(6 x1) exp(-x1) / pi`` at
        ``pi^2 tau^2 / T^2 = x1 = (3 - sqrt 6) / 2``, so the analytic peak is ``|pga|``.
        The shape, in time order: a small side lobe (``-0.272 pga`` at ``t0 - 0.525 T``), the
        first main lobe (``+pga`` at ``t0 - 0.167 T``), a zero crossing at ``t0``, the second
        main lobe (``-pga`` at ``t0 + 0.167 T``) and a small side lobe (``+0.272 pga`` at
        ``t0 + 0.525 T``); the main lobes cross zero at ``t0 +- T sqrt(3/2) / pi``. So the sign
        of ``pga`` is the sign of the first main lobe. The wavelet is odd about ``t0``: it has
        zero mean, and its ground velocity and displacement return to zero after the pulse.
        Its Fourier amplitude peaks at period ``2 T / sqrt 6 = 0.816 T`` (the symmetric
        :meth:`ricker` peaks at ``T``).

        The record is the analytic wavelet sampled every ``dt``: its sampled peak falls short
        of ``|pga|`` by at most a fraction ``pi^2 dt^2 / T^2`` because the peaks lie between
        samples; use :meth:`scaled_to_pga` for an exact sampled peak.

        Args:
            pga: Peak ground acceleration [m/s^2]; its sign is the sign of the first main lobe.
            period: Wavelet parameter T [s] in the formula above.
            pga_g: The same peak in g; give ``pga`` or ``pga_g``.
            dt: Sampling step [s].
            duration: Record length [s]; default ``t0 + 4 T``.
            t0: Centre of the wavelet (its central zero crossing) [s]; default ``1.5 T``.
            name: Label; default ``"ricker_anti_T<period>s"``.

        Returns:
            The sampled pulse as a GroundMotion.

        References:
            Vassiliou, M. F. and Makris, N. (2011). Estimating time scales and length scales in
            pulselike earthquake acceleration records with wavelet analysis. BSSA 101(2).
        """
        pga = _pulse_amplitude("ricker_antisymmetric", pga, pga_g, period, t0)
        t0 = 1.5 * period if t0 is None else t0
        duration = t0 + 4.0 * period if duration is None else duration
        t = _time_axis(duration, dt)
        x = (np.pi * (t - t0) / period) ** 2
        f = (t - t0) / period * (3.0 - 2.0 * x) * np.exp(-x)
        x1 = 0.5 * (3.0 - math.sqrt(6.0))
        f_max = math.sqrt(6.0 * x1) * math.exp(-x1) / math.pi
        return cls(ag=-pga * f / f_max, dt=dt, name=name or f"ricker_anti_T{period:g}s")

    @classmethod
    def cosine_cycle(
        cls,
        pga: float | None = None,
        period: float | None = None,
        *,
        pga_g: float | None = None,
        dt: float = 0.005,
        duration: float | None = None,
        t0: float = 0.0,
        name: str | None = None,
    ) -> GroundMotion:
        """One-cosine acceleration pulse (Makris's type-B pulse), with jumps at both ends.

        ``ag(t) = pga cos(2 pi tau / T)`` for ``0 < tau < T`` (``tau = t - t0``), zero outside.
        The acceleration jumps from 0 to ``pga`` at ``t0`` and from ``pga`` back to 0 at
        ``t0 + T``. A sample that falls exactly on a jump takes the value with which the linear
        interpolant of the samples (what the simulators and the trapezoid rule see) carries the
        pulse's exact impulse: ``pga / 2``, the mean of the one-sided limits, inside the record,
        but ``pga`` at the record's first or last sample (e.g. the default ``t0 = 0``).
        Keep ``t0`` and ``T`` multiples of ``dt``: a jump that falls between samples is smeared
        over a step and leaves a residual velocity of order ``pga dt``.

        The ground velocity is one full sine cycle (forward and back),
        ``v = pga T / (2 pi) sin(2 pi tau / T)``, so ``PGV = |pga| T / (2 pi)``; the displacement
        ``pga T^2 / (4 pi^2) (1 - cos(2 pi tau / T))`` peaks at ``|pga| T^2 / (2 pi^2)`` and
        returns to zero.

        Args:
            pga: Amplitude [m/s^2]; its sign is the direction of the initial acceleration.
            period: Pulse period T [s].
            pga_g: The same amplitude in g; give ``pga`` or ``pga_g``.
            dt: Sampling step [s].
            duration: Record length [s]; default ``t0 + 5 T``.
            t0: Pulse start [s].
            name: Label; default ``"cosine_T<period>s"``.

        Returns:
            The sampled pulse as a GroundMotion.

        References:
            Makris, N. and Roussos, Y. (2000). Rocking response of rigid blocks under
            near-source ground motions. Geotechnique 50(3), 243-262.
        """
        pga = _pulse_amplitude("cosine_cycle", pga, pga_g, period, t0)
        duration = t0 + 5.0 * period if duration is None else duration
        t = _time_axis(duration, dt)
        tau = t - t0
        on_edge = 1e-9 * dt  # a sample within this of a jump is "on" it (round-off in t)
        inside = (tau > on_edge) & (tau < period - on_edge)
        edge = (np.abs(tau) <= on_edge) | (np.abs(tau - period) <= on_edge)
        ag = np.where(inside, pga * np.cos(2 * np.pi * tau / period), 0.0)
        ag = np.where(edge, 0.5 * pga, ag)
        ag[[0, -1]] = np.where(edge[[0, -1]], pga, ag[[0, -1]])
        return cls(ag=ag, dt=dt, name=name or f"cosine_T{period:g}s")

    @classmethod
    def zeros(cls, duration: float, dt: float = 0.005, name: str = "free") -> GroundMotion:
        """No ground motion (free rocking) for ``duration`` seconds."""
        return cls(ag=np.zeros(_time_axis(duration, dt).size), dt=dt, name=name)

    # ----------------------------------------------------------------- derived
    def check_finite(self) -> None:
        """Raise a ValueError naming the series and the first sample if a concrete ``ag`` or
        ``ag_v`` has a NaN or infinite sample (construction checks this; the simulators check
        again, since a record can be changed afterwards, e.g. with ``equinox.tree_at``)."""
        for label, arr in (("ag", self.ag), ("ag_v", self.ag_v)):
            a = None if arr is None else concrete(arr)
            if a is not None:
                _check_finite_series(label, a, self)

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(np.shape(self.ag)[0])

    @property
    def t(self):
        """Sample times [s]."""
        return np.arange(self.n) * self.dt

    @property
    def duration(self) -> float:
        """Time of the last sample [s]."""
        return (self.n - 1) * self.dt

    @property
    def pga(self):
        """Peak ground acceleration [m/s^2]."""
        return _peak_abs(self.ag)

    @property
    def pga_g(self):
        """Peak ground acceleration in units of g [-] (``pga / 9.80665``)."""
        return self.pga / G

    @property
    def metadata(self) -> dict[str, str]:
        """The ``meta`` pairs as a new dict (editing it does not change the record)."""
        return dict(self.meta)

    def with_metadata(self, **items: str | int | float) -> GroundMotion:
        """The same record with ``items`` added to its metadata (as strings; existing keys replaced).

        Example: ``gm.with_metadata(event="Northridge-01", azimuth_deg=228)``.
        """
        merged = {**self.metadata, **{key: str(value) for key, value in items.items()}}
        return GroundMotion(
            ag=self.ag, dt=self.dt, name=self.name, ag_v=self.ag_v, meta=tuple(merged.items())
        )

    def _with_series(self, ag, ag_v, dt: float | None = None) -> GroundMotion:
        dt = self.dt if dt is None else dt
        return GroundMotion(ag=ag, dt=dt, name=self.name, ag_v=ag_v, meta=self.meta)

    def scaled(self, factor) -> GroundMotion:
        """The record times ``factor`` (horizontal and vertical).

        Raises:
            ValueError: if a concrete ``factor`` is not a finite number (a traced one, e.g.
                under ``vmap`` over scale factors, is not checked).
        """
        check_number("factor", factor, "[-]", "e.g. factor=0.5.")
        if (f := concrete(factor)) is not None and not np.all(np.isfinite(f)):
            raise ValueError(f"factor must be finite [-]; got factor={factor!r}. E.g. factor=0.5.")
        ag_v = None if self.ag_v is None else self.ag_v * factor
        return self._with_series(self.ag * factor, ag_v)

    def scaled_to_pga(
        self, target_pga: ScalarLike | None = None, *, target_pga_g: ScalarLike | None = None
    ) -> GroundMotion:
        """The record scaled so that its horizontal peak ``max|ag|`` equals ``target_pga``.

        The vertical component, if any, is scaled by the same factor ``target_pga / pga``.

        Args:
            target_pga: Target peak ground acceleration [m/s^2], a positive magnitude.
            target_pga_g: The same target in g (``scaled_to_pga(target_pga_g=0.3)``); give
                ``target_pga`` or ``target_pga_g``.

        Raises:
            ValueError: if not exactly one target is given, the target is not positive or above
                10 g, or the record is all zeros.
        """
        if (target_pga is None) == (target_pga_g is None):
            raise ValueError(
                "scaled_to_pga needs exactly one of target_pga [m/s^2] or target_pga_g [g]; got "
                f"target_pga={target_pga!r}, target_pga_g={target_pga_g!r}. E.g. "
                "scaled_to_pga(target_pga_g=0.3) or scaled_to_pga(0.3 * rockjax.constants.G)."
            )
        if target_pga_g is not None:
            check_positive("target_pga_g", target_pga_g, "g", "Pass a magnitude, e.g. 0.3.")
            if (v := concrete(target_pga_g)) is not None:
                _check_plausible_acceleration("target_pga_g", float(np.max(v)) * G, "the target")
            target_pga = target_pga_g * G
        else:
            check_positive(
                "target_pga",
                target_pga,
                "m/s^2",
                "Pass a magnitude, e.g. 0.3 * rockjax.constants.G, or target_pga_g=0.3.",
            )
            if (v := concrete(target_pga)) is not None:
                _check_plausible_acceleration("target_pga", float(np.max(v)), "the target")
        peak = self.pga
        if (p := concrete(peak)) is not None and p == 0.0:
            raise ValueError(
                f"record {self.name!r} is all zeros (pga = 0), so it cannot be scaled to a PGA."
            )
        return self.scaled(target_pga / peak)

    def resampled(self, dt_new: float) -> GroundMotion:
        """The record linearly interpolated onto a uniform grid of step ``dt_new``.

        The new samples are at ``k dt_new`` for ``0 <= k dt_new <= duration``: the record keeps
        its duration when ``dt_new`` divides it, else it ends at the last new sample before
        ``duration``. No anti-alias filter is applied: when downsampling (``dt_new > dt``),
        content above the new Nyquist frequency ``1 / (2 dt_new)`` aliases, so low-pass the
        record first if it has any.

        Args:
            dt_new: New sampling step [s].

        Raises:
            ValueError: if ``dt_new`` is not positive or is longer than the record.
        """
        check_positive("dt_new", dt_new, "s", "e.g. dt_new=0.005.", scalar=True)
        dt_new = float(dt_new)
        if dt_new > self.duration * (1.0 + 1e-12):
            raise ValueError(
                f"dt_new={dt_new} s is longer than record {self.name!r} ({self.duration} s); "
                "the resampled record would have a single sample. Use a smaller dt_new."
            )
        t_new = _time_axis(self.duration, dt_new, dt_name="dt_new")
        t_old = self.t

        def interp(a):
            return jnp.interp(t_new, t_old, jnp.asarray(a))

        ag_v = None if self.ag_v is None else interp(self.ag_v)
        return self._with_series(interp(self.ag), ag_v, dt=dt_new)

    def baseline_corrected(self, order: int = 1) -> GroundMotion:
        """The record with a polynomial velocity trend removed (a baseline correction).

        The ground velocity ``v`` (trapezoid rule, from rest) is fitted by least squares with a
        polynomial ``p(t)`` of degree ``order``; the corrected acceleration is
        ``ag - dp/dt``. Its velocity is therefore ``v - (p(t) - p(0))`` (exactly for
        ``order <= 2``, to O(dt^2) above, because the trapezoid rule integrates ``dp/dt``), so
        it still starts from rest, and it has no polynomial trend of degree ``1..order`` left.
        ``order=1`` removes a constant acceleration offset (a linear velocity drift); ``order=2``
        also removes a linear one. Each component (horizontal and vertical) is corrected on
        its own. This is a simple correction for offsets and drift, not a substitute for
        the filtering in the PEER processing.

        Args:
            order: Degree of the velocity polynomial [-], an integer >= 1.

        Raises:
            ValueError: if ``order`` is not an integer in ``1 .. n - 1``.
        """
        if isinstance(order, bool) or not isinstance(order, int) or not 1 <= order < self.n:
            raise ValueError(
                f"order must be an integer from 1 to n - 1 = {self.n - 1}; got order={order!r}. "
                "order=1 removes a linear velocity drift, order=2 a quadratic one."
            )
        t_end = self.duration
        s = self.t / t_end  # fit in [0, 1]: a well-conditioned Vandermonde matrix
        powers = np.arange(order + 1)
        vander = s[:, None] ** powers[None, :]
        fit = np.linalg.pinv(vander)  # (order + 1, n): coefficients = fit @ v
        # d/dt of sum_k c_k s^k is sum_{k>=1} k c_k s^(k-1) / t_end
        d_vander = powers[None, 1:] * s[:, None] ** (powers[None, 1:] - 1) / t_end

        def correct(a):
            a = jnp.asarray(a)
            coef = jnp.asarray(fit) @ _cumtrapz(a, self.dt)
            return a - jnp.asarray(d_vander) @ coef[1:]

        ag_v = None if self.ag_v is None else correct(self.ag_v)
        return self._with_series(correct(self.ag), ag_v)

    # ----------------------------------------------------------------- intensity measures
    def velocity(self) -> TimeSeries:
        """Ground velocity [m/s]: ``ag`` integrated with the trapezoid rule, from rest."""
        return _cumtrapz(jnp.asarray(self.ag), self.dt)

    def displacement(self) -> TimeSeries:
        """Ground displacement [m]: :meth:`velocity` integrated with the trapezoid rule, from rest."""
        return _cumtrapz(self.velocity(), self.dt)

    @property
    def pgv(self) -> Scalar:
        """Peak ground velocity ``max|v|`` [m/s] (trapezoid rule, from rest, no correction)."""
        return _peak_abs(self.velocity())

    @property
    def pgd(self) -> Scalar:
        """Peak ground displacement ``max|d|`` [m] (trapezoid rule twice, from rest, no correction)."""
        return _peak_abs(self.displacement())

    @property
    def arias_intensity(self) -> Scalar:
        r"""Arias intensity of the horizontal record [m/s], trapezoid rule.

        $$I_A = \frac{\pi}{2g}\int_0^{t_{end}} a_g(t)^2\,dt, \qquad g = 9.80665\ \mathrm{m/s^2}$$

        References:
            Arias, A. (1970). A measure of earthquake intensity. In Seismic Design for Nuclear
            Power Plants (R. J. Hansen, ed.), MIT Press, 438-483.
        """
        return _cumulative_arias(jnp.asarray(self.ag), self.dt)[-1]

    def significant_duration(self, lo: float = 0.05, hi: float = 0.95) -> Scalar:
        """Significant duration [s]: the time in which the Arias intensity grows from ``lo`` to ``hi``.

        ``D = t_hi - t_lo`` where ``t_q`` is the first time at which the normalised cumulative
        Arias intensity (the Husid curve) ``I_A(t) / I_A(t_end)`` reaches ``q``, linearly
        interpolated within the sampling step. The defaults give Trifunac and Brady's D5-95.

        Args:
            lo: Lower fraction of the total Arias intensity [-], ``0 < lo < hi``.
            hi: Upper fraction [-], ``lo < hi < 1``.

        Raises:
            ValueError: if the fractions are out of range or the record is all zeros.

        References:
            Trifunac, M. D. and Brady, A. G. (1975). A study on the duration of strong
            earthquake ground motion. BSSA 65(3), 581-626.
        """
        if not 0.0 < lo < hi < 1.0:
            raise ValueError(
                f"need 0 < lo < hi < 1 (fractions of the Arias intensity); got lo={lo}, hi={hi}. "
                "Trifunac-Brady D5-95 is lo=0.05, hi=0.95."
            )
        cum = _cumulative_arias(jnp.asarray(self.ag), self.dt)
        if (total := concrete(cum[-1])) is not None and total == 0.0:
            raise ValueError(
                f"record {self.name!r} is all zeros: its Arias intensity is 0 and it has no "
                "significant duration."
            )
        husid = cum / cum[-1]

        def first_time(q):
            # husid is non-decreasing and starts at 0 < q, so k >= 1 and husid[k-1] < q <= husid[k]
            k = jnp.clip(jnp.searchsorted(husid, q, side="left"), 1, self.n - 1)
            h0, h1 = husid[k - 1], husid[k]
            return (k - 1 + (q - h0) / (h1 - h0)) * self.dt

        return first_time(hi) - first_time(lo)


def _check_finite_series(label: str, a: np.ndarray, motion: GroundMotion) -> None:
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise ValueError(
            f"{label} [m/s^2] of record {motion.name!r} has {bad.size} non-finite samples "
            f"(first at index {bad[0]}, t={bad[0] * motion.dt:.4f} s). Clean or trim the record "
            "first."
        )


def _check_plausible_acceleration(name: str, peak: float, where: str) -> None:
    """Raise when an acceleration peak [m/s^2] is above :data:`PLAUSIBLE_LIMIT_G`."""
    if peak <= PLAUSIBLE_LIMIT_G * G:
        return
    if name.endswith("_g"):
        fix = (
            f"{name} is in g (0.4 for 0.4 g): did you pass m/s^2 or cm/s^2? Divide by "
            "9.80665 (m/s^2) or 980.665 (cm/s^2), or pass the value in m/s^2 without the _g."
        )
    else:
        fix = (
            "rockjax takes m/s^2: did you pass cm/s^2 or mm/s^2? Convert with ag / 100 "
            "(cm/s^2) or ag / 1000 (mm/s^2); a record in g goes through "
            "GroundMotion.from_g(ag_g, dt), a pulse takes pga_g=..., and a scaled record must "
            "stay below 10 g."
        )
    raise ValueError(
        f"{name} of {where} peaks at {peak:.4g} m/s^2 = {peak / G:.3g} g, above the "
        f"plausibility limit of {PLAUSIBLE_LIMIT_G:g} g for a ground acceleration. {fix}"
    )


def _pulse_amplitude(constructor: str, pga, pga_g, period, t0=None):
    """The signed pulse amplitude [m/s^2] from ``pga`` [m/s^2] or ``pga_g`` [g], checked."""
    if (pga is None) == (pga_g is None):
        raise ValueError(
            f"{constructor} needs exactly one of pga [m/s^2] or pga_g [g] (the signed peak "
            f"ground acceleration); got pga={pga!r}, pga_g={pga_g!r}. E.g. "
            f"GroundMotion.{constructor}(pga_g=0.4, period=0.5) or "
            f"GroundMotion.{constructor}(pga=0.4 * rockjax.constants.G, period=0.5)."
        )
    if period is None:
        raise ValueError(
            f"{constructor} needs period, the pulse period in s, e.g. period=0.5; got none."
        )
    check_positive("period", period, "s", "e.g. period=0.5.", scalar=True)
    if t0 is not None:
        check_scalar("t0", t0, "s", "e.g. t0=1.0.")
        if not np.isfinite(float(np.asarray(t0, dtype=float))):
            raise ValueError(f"t0 must be a finite time in s; got t0={t0!r}. E.g. t0=1.0.")
    name, value, unit = ("pga", pga, "m/s^2") if pga_g is None else ("pga_g", pga_g, "g")
    check_number(name, value, unit, f"e.g. {name}=0.4.")
    if (v := concrete(value)) is not None:
        if v.ndim != 0 or not np.isfinite(v):
            raise ValueError(
                f"{name} must be one finite number in {unit} (its sign sets the direction); "
                f"got {name}={value!r}."
            )
        factor = 1.0 if pga_g is None else G
        _check_plausible_acceleration(name, abs(float(v)) * factor, f"the {constructor} pulse")
    return value if pga_g is None else value * G


def _time_axis(duration: float, dt: float, dt_name: str = "dt") -> np.ndarray:
    """Sample times ``k dt`` [s] up to ``duration``, both checked (:func:`check_samples`)."""
    n = check_samples(duration, dt, dt_name=dt_name)
    return np.arange(n) * float(dt)


def _cumtrapz(y, dt: float):
    """Cumulative trapezoid integral of ``y`` sampled every ``dt``, starting at 0.

    A concrete ``y`` is integrated in NumPy: eager JAX would compile each operation anew for
    every record length (about 0.4 s per record on a loaded 2-core machine).
    """
    if (c := concrete(y)) is not None:
        steps = 0.5 * dt * (c[1:] + c[:-1])
        return jnp.asarray(np.concatenate([np.zeros(1), np.cumsum(steps)]))
    steps = 0.5 * dt * (y[1:] + y[:-1])
    return jnp.concatenate([jnp.zeros(1, dtype=steps.dtype), jnp.cumsum(steps)])


def _peak_abs(x):
    """``max|x|`` (in NumPy for a concrete ``x``, as :func:`_cumtrapz`)."""
    if (c := concrete(x)) is not None:
        return jnp.asarray(np.max(np.abs(c)))
    return jnp.max(jnp.abs(jnp.asarray(x)))


def _cumulative_arias(ag, dt: float):
    """Cumulative Arias intensity ``pi / (2 g) int_0^t ag^2`` [m/s] (trapezoid rule)."""
    return np.pi / (2.0 * G) * _cumtrapz(ag * ag, dt)
