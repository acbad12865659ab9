"""Ground motions: a uniformly sampled horizontal (and optional vertical) acceleration record."""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike, Float

from ._checks import check_positive, concrete
from .constants import G


class GroundMotion(eqx.Module):
    """A ground acceleration record sampled at a uniform step.

    Positive ``ag`` accelerates the base toward +x, which drives ``theta`` negative
    (see :class:`rockjax.Block` for the sign convention).

    Args:
        ag: Horizontal ground acceleration [m/s^2], shape ``(time,)``; sample ``k`` is at ``k*dt``.
        dt: Sampling step [s].
        name: A label for plots and datasets.
        ag_v: Optional vertical ground acceleration [m/s^2] (positive up), same shape as ``ag``.
    """

    ag: Float[ArrayLike, " time"]
    # dt is static: it fixes the number of steps of every simulation, which must be concrete.
    dt: float = eqx.field(static=True)
    name: str = eqx.field(static=True, default="record")
    ag_v: Float[ArrayLike, " time"] | None = None

    def __check_init__(self):
        check_positive("dt", self.dt, "s", "Use the record's sampling step, e.g. dt=0.01.")
        for label, arr in (("ag", self.ag), ("ag_v", self.ag_v)):
            if arr is None:
                continue
            a = concrete(arr)
            if a is None:
                continue
            if a.ndim != 1 or a.size < 2:
                raise ValueError(
                    f"{label} must be a 1-D acceleration series in m/s^2 with at least 2 samples; "
                    f"got shape {a.shape}. Pass one record at a time (batches go through rj.ida)."
                )
            bad = np.flatnonzero(~np.isfinite(a))
            if bad.size:
                raise ValueError(
                    f"{label} of record {self.name!r} has {bad.size} non-finite samples (first at "
                    f"index {bad[0]}, t={bad[0] * self.dt:.4f} s). Clean or trim the record first."
                )
        if self.ag_v is not None and np.shape(self.ag_v) != np.shape(self.ag):
            raise ValueError(
                f"ag_v must have the same shape as ag; got {np.shape(self.ag_v)} and {np.shape(self.ag)}."
            )

    # ----------------------------------------------------------------- constructors
    @classmethod
    def from_g(cls, ag_g, dt: float, name: str = "record", ag_v_g=None) -> GroundMotion:
        """Build from accelerations in units of g (as PEER and FEMA P695 store them)."""
        ag = np.asarray(ag_g, dtype=float) * G
        ag_v = None if ag_v_g is None else np.asarray(ag_v_g, dtype=float) * G
        return cls(ag=ag, dt=dt, name=name, ag_v=ag_v)

    @classmethod
    def from_time_series(cls, t, ag, name: str = "record", rtol: float = 1e-6) -> GroundMotion:
        """Build from sample times ``t`` [s] and accelerations ``ag`` [m/s^2]; ``t`` must be uniform."""
        t = np.asarray(t, dtype=float)
        ag = np.asarray(ag, dtype=float)
        if t.ndim != 1 or t.shape != ag.shape or t.size < 2:
            raise ValueError(
                f"t and ag must be 1-D of equal length >= 2; got {t.shape} and {ag.shape}."
            )
        steps = np.diff(t)
        dt = float(np.mean(steps))
        worst = int(np.argmax(np.abs(steps - dt)))
        if dt <= 0 or np.abs(steps[worst] - dt) > rtol * dt:
            raise ValueError(
                f"record {name!r} is not uniformly sampled: step {worst} is {steps[worst]:.6g} s "
                f"against a mean of {dt:.6g} s. Resample it to a uniform step first."
            )
        return cls(ag=ag, dt=dt, name=name)

    @classmethod
    def ricker(
        cls,
        pga: float,
        period: float,
        *,
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
            dt: Sampling step [s].
            duration: Record length [s]; default ``t0 + 4 T``.
            t0: Time of the central peak [s]; default ``1.5 T``.
        """
        check_positive("period", period, "s")
        t0 = 1.5 * period if t0 is None else t0
        duration = t0 + 4.0 * period if duration is None else duration
        t = _time_axis(duration, dt)
        u = (np.pi * (t - t0) / period) ** 2
        ag = pga * (1.0 - 2.0 * u) * np.exp(-u)
        return cls(ag=ag, dt=dt, name=name or f"ricker_T{period:g}s")

    @classmethod
    def sine_cycle(
        cls,
        pga: float,
        period: float,
        *,
        dt: float = 0.005,
        duration: float | None = None,
        t0: float = 0.0,
        name: str | None = None,
    ) -> GroundMotion:
        """One full sine cycle ``ag = pga sin(2 pi (t - t0) / T)`` for ``t0 <= t <= t0 + T``, zero after.

        Args:
            pga: Amplitude [m/s^2] (its sign sets the direction of the first half-cycle).
            period: Pulse period T [s].
            dt: Sampling step [s].
            duration: Record length [s]; default ``t0 + 5 T``.
            t0: Pulse start [s].
        """
        check_positive("period", period, "s")
        duration = t0 + 5.0 * period if duration is None else duration
        t = _time_axis(duration, dt)
        tau = t - t0
        ag = np.where((tau >= 0) & (tau <= period), pga * np.sin(2 * np.pi * tau / period), 0.0)
        return cls(ag=ag, dt=dt, name=name or f"sine_T{period:g}s")

    @classmethod
    def zeros(cls, duration: float, dt: float = 0.005, name: str = "free") -> GroundMotion:
        """No ground motion (free rocking) for ``duration`` seconds."""
        return cls(ag=np.zeros(_time_axis(duration, dt).size), dt=dt, name=name)

    # ----------------------------------------------------------------- derived
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
        return jnp.max(jnp.abs(jnp.asarray(self.ag)))

    def scaled(self, factor) -> GroundMotion:
        """The record times ``factor`` (horizontal and vertical)."""
        ag_v = None if self.ag_v is None else self.ag_v * factor
        return GroundMotion(ag=self.ag * factor, dt=self.dt, name=self.name, ag_v=ag_v)


def _time_axis(duration: float, dt: float) -> np.ndarray:
    check_positive("duration", duration, "s")
    check_positive("dt", dt, "s")
    n = int(math.floor(duration / dt + 1e-9)) + 1
    return np.arange(n) * dt
