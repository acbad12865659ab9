r"""Elastic response spectra and the intensity measures of records: PGA, PGV and Sa(T).

The response spectrum of an acceleration record ``a_g`` is the peak response of a linear
single-degree-of-freedom oscillator of period ``T`` and damping ratio ``zeta`` on that ground,

$$\ddot u + 2\zeta\omega\dot u + \omega^2 u = -a_g(t), \qquad \omega = 2\pi/T,$$

with ``u`` its displacement relative to the ground, starting from rest:
``Sd(T) = max_t |u|`` [m], the pseudo-spectral acceleration ``Sa(T) = omega^2 Sd`` [m/s^2]
and the pseudo-spectral velocity ``Sv(T) = omega Sd`` [m/s]. ``Sa(0)`` is the PGA.

Method. The record is taken as linear between its samples (as the simulators take it), and
for that excitation the oscillator's state ``x = (u, du/dt)`` advances over a step ``h`` by
the exact recurrence of Nigam and Jennings (1969),
``x_{k+1} = Phi x_k + g0 a_k + g1 a_{k+1}``, with ``Phi = exp(M h)`` the transition matrix of
``M = [[0, 1], [-omega^2, -2 zeta omega]]`` (closed form for ``0 <= zeta < 1``) and
``g0 = -(G1 - G2 / h) e2``, ``g1 = -(G2 / h) e2`` (``e2 = (0, 1)``), where
``G1 = int_0^h Phi(r) dr = M^-1 (Phi - I)`` and ``G2 = int_0^h Phi(h - s) s ds = M^-1 (G1 - h I)``
(integration by parts). The recurrence is exact at any ``h``, so no stability limit applies;
what ``h`` does control is how well the peak of ``u`` is caught, since the peak is taken over
the computed samples. Each record step is therefore split into ``n_sub`` equal sub-steps (the
excitation stays the same straight line), with ``n_sub`` chosen so that the shortest nonzero
period gets at least :data:`STEPS_PER_PERIOD` sub-steps (at most :data:`MAX_N_SUB`).

Convergence of that default (``python experiments/spectra_convergence.py``: the 56 FEMA P695
near-field components, dt 0.0024-0.02 s, 40 periods from 0.02 to 5 s; largest and median
relative error of Sa against 16 times finer sub-steps; the error falls as ``N^-2``, the peak of
a sampled sinusoid):

=====================  ==========  ==========
sub-steps per period   max error   median
=====================  ==========  ==========
5                      3.6e-2      3.0e-3
10                     1.7e-2      9.6e-4
20                     5.6e-3      3.2e-4
40 (the default)       1.3e-3      8.9e-5
80                     3.4e-4      1.9e-5
=====================  ==========  ==========

Below ``T = 40 dt / 64 = 0.6 dt`` the cap leaves fewer sub-steps per period, but there the
oscillator follows the ground nearly quasi-statically and its peaks fall close to the record
samples: at T = 0.1, 0.3, 0.6 and 1 dt on four near-field components (dt 0.01 and 0.02 s) the
capped default is within 5e-4 of 512 sub-steps.

Two horizontal components ``(a_x, a_y)`` give the rotated spectra of Boore (2010): for each
angle ``psi`` in ``[0, 180)`` degrees the oscillator response to
``a_x cos psi + a_y sin psi`` (by linearity ``u_x cos psi + u_y sin psi``) has a peak
``Sd(T, psi)``; RotD50 is the median over the angles, RotD100 the maximum.

Why not a library. ``pyrotd`` (frequency-domain transfer functions, NumPy) and ``eqsig``
(time domain, NumPy) are maintained and do this for NumPy arrays, but neither runs under
``jax.jit``/``jax.vmap`` or gives derivatives, and the project batches and differentiates
through its inputs. The exact recurrence is a few lines of ``lax.scan``, vectorised over the
periods, differentiable in the record, the periods and the damping, and checked in
tests/test_spectra.py against closed forms and an independent ``scipy.integrate.solve_ivp``
integration.

Recompilation. Records are zero-padded to a bucketed length (with the peaks masked past the
real end), so a loop over records of different lengths compiles a handful of shapes, not one
per record.

References:
    Nigam, N. C. and Jennings, P. C. (1969). Calculation of response spectra from
    strong-motion earthquake records. BSSA 59(2), 909-922.
    Boore, D. M. (2010). Orientation-independent, nongeometric-mean measures of seismic
    intensity from two horizontal components of motion. BSSA 100(4), 1830-1835.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._checks import check_number, concrete
from .compilation import persistent_jit
from .constants import G
from .motion import GroundMotion

DEFAULT_DAMPING = 0.05
"""Damping ratio of the oscillators [-]: 5 %, the convention of design spectra and of Sa(T)."""

STEPS_PER_PERIOD = 40
"""Sub-steps per period of the shortest oscillator (the automatic ``n_sub``): a sampled
sinusoid misses its peak by at most ``1 - cos(pi / 40) = 0.3 %`` (module docstring: 0.13 % at
most on the FEMA P695 near-field set)."""

MAX_N_SUB = 64
"""Most sub-steps per record step of the automatic ``n_sub`` (bounds the work and memory)."""

_ANGLES = 180  # rotation angles of RotD spectra: 1 degree apart, as Boore (2010)


class Spectrum(eqx.Module):
    """Response spectrum of one horizontal component: peaks of linear oscillators.

    Attributes:
        periods: Oscillator periods T [s], shape ``(period,)``.
        damping: Damping ratio zeta [-].
        sd: Spectral displacement ``max|u|`` [m], shape ``(period,)``.
        sa: Pseudo-spectral acceleration ``omega^2 Sd`` [m/s^2] (the PGA at ``T = 0``).
    """

    periods: Float[Array, " period"]
    damping: Float[Array, ""]
    sd: Float[Array, "*batch period"]
    sa: Float[Array, "*batch period"]

    @property
    def sa_g(self) -> Float[Array, "*batch period"]:
        """Pseudo-spectral acceleration in units of g [-]."""
        return self.sa / G

    @property
    def sv(self) -> Float[Array, "*batch period"]:
        """Pseudo-spectral velocity ``omega Sd`` [m/s] (0 at ``T = 0``)."""
        periods = jnp.broadcast_to(self.periods, jnp.shape(self.sd))
        return jnp.where(periods > 0, _omega(periods) * self.sd, 0.0)

    def to_dataframe(self, labels: Sequence[str] | None = None):
        """The spectrum as a ``pandas.DataFrame``, one row per period.

        The index is ``"T [s]"``; the columns carry their units in their names:
        ``"Sa [m/s^2]"``, ``"Sa [g]"``, ``"Sd [m]"`` and ``"Sv [m/s]"``. A spectrum of several
        motions (``sa`` of shape ``(motion, period)``, e.g. :func:`rockjax.floor_spectra`'s,
        one row per floor) gives these four columns per motion, suffixed with its label:
        ``"Sa [g] floor 1"``. ``df.attrs["damping [-]"]`` holds the damping ratio. Write it
        with ``df.to_csv(path)``.

        Args:
            labels: One label per motion of a 2-D spectrum; default ``"0"``, ``"1"``, ...
                Not given for a 1-D spectrum.

        Returns:
            The ``pandas.DataFrame``.

        Raises:
            ValueError: inside ``jit``/``vmap``, for a spectrum of more than two axes, or
                labels that do not match the motions.
        """
        import pandas as pd

        periods, sd, sa = concrete(self.periods), concrete(self.sd), concrete(self.sa)
        if periods is None or sd is None or sa is None:
            raise ValueError("Spectrum.to_dataframe needs concrete values: call it outside jit.")
        sv = np.asarray(self.sv, dtype=float)
        values = {"Sa [m/s^2]": sa, "Sa [g]": sa / G, "Sd [m]": sd, "Sv [m/s]": sv}
        if sd.ndim == 1:
            if labels is not None:
                raise ValueError(
                    f"labels name the motions of a 2-D spectrum; this one is 1-D (one motion). "
                    f"Drop labels={labels!r}."
                )
            columns = values
        elif sd.ndim == 2:
            n = sd.shape[0]
            labels = [str(k) for k in range(n)] if labels is None else [str(v) for v in labels]
            if len(labels) != n:
                raise ValueError(
                    f"labels must give one label per motion: {n} (the rows of sa); got "
                    f"{len(labels)}."
                )
            columns = {
                f"{name} {label}": v[k]
                for k, label in enumerate(labels)
                for name, v in values.items()
            }
        else:
            raise ValueError(
                f"Spectrum.to_dataframe takes a spectrum of one motion or one row of motions; "
                f"sa has shape {sa.shape}. Index it first, e.g. spec.sa[i]."
            )
        df = pd.DataFrame(columns, index=pd.Index(periods, name="T [s]"))
        df.attrs["damping [-]"] = float(concrete(self.damping))
        return df


class RotDSpectrum(eqx.Module):
    """Rotated response spectra of two horizontal components (Boore 2010).

    Attributes:
        periods: Oscillator periods T [s], shape ``(period,)``.
        damping: Damping ratio zeta [-].
        angles: Rotation angles psi [rad] in ``[0, pi)``, shape ``(angle,)``.
        sd_angles: Peak displacement of the component at each angle [m], ``(angle, period)``.
        sa_angles: Its pseudo-acceleration ``omega^2 Sd`` [m/s^2] (the PGA at ``T = 0``).
    """

    periods: Float[Array, " period"]
    damping: Float[Array, ""]
    angles: Float[Array, " angle"]
    sd_angles: Float[Array, "*batch angle period"]
    sa_angles: Float[Array, "*batch angle period"]

    def rotd(self, percentile: float | int) -> Spectrum:
        """RotDnn: the ``percentile`` over the angles (50: median, 100: maximum, 0: minimum).

        Args:
            percentile: Percentile over the rotation angles [%], in ``[0, 100]``.
        """
        if (p := concrete(percentile)) is not None and not 0.0 <= float(p) <= 100.0:
            raise ValueError(
                f"percentile must be in [0, 100] %; got percentile={percentile}. RotD50 is 50."
            )
        return Spectrum(
            periods=self.periods,
            damping=self.damping,
            sd=jnp.percentile(self.sd_angles, percentile, axis=-2),
            sa=jnp.percentile(self.sa_angles, percentile, axis=-2),
        )

    def to_dataframe(self):
        """RotD50 and RotD100 as a ``pandas.DataFrame``, one row per period.

        The index is ``"T [s]"``; the columns are :meth:`Spectrum.to_dataframe`'s of
        :attr:`rotd50` and of :attr:`rotd100`, suffixed ``" RotD50"`` and ``" RotD100"``
        (``"Sa [g] RotD50"``); ``df.attrs`` holds ``damping [-]`` and ``n_angles``. Write it
        with ``df.to_csv(path)``.

        Returns:
            The ``pandas.DataFrame``.

        Raises:
            ValueError: inside ``jit``/``vmap``, or for a batch of spectra.
        """
        import pandas as pd

        if np.ndim(self.sd_angles) != 2:
            raise ValueError(
                "RotDSpectrum.to_dataframe takes the spectra of one pair of components; "
                f"sd_angles has shape {np.shape(self.sd_angles)}. Index one pair first."
            )
        parts = [
            spec.to_dataframe().add_suffix(f" {name}")
            for name, spec in (("RotD50", self.rotd50), ("RotD100", self.rotd100))
        ]
        df = pd.concat(parts, axis=1)
        df.attrs.update(parts[0].attrs, n_angles=int(np.shape(self.angles)[0]))
        return df

    @property
    def rotd50(self) -> Spectrum:
        """RotD50: the median over the angles."""
        return self.rotd(50.0)

    @property
    def rotd100(self) -> Spectrum:
        """RotD100: the maximum over the angles."""
        return Spectrum(
            periods=self.periods,
            damping=self.damping,
            sd=jnp.max(self.sd_angles, axis=-2),
            sa=jnp.max(self.sa_angles, axis=-2),
        )


def response_spectrum(
    motion: GroundMotion | Float[ArrayLike, " time"],
    periods: Float[ArrayLike, " period"] | Sequence[float],
    damping: Float[ArrayLike, ""] = DEFAULT_DAMPING,
    *,
    dt: float | None = None,
    n_sub: int | None = None,
) -> Spectrum:
    """Pseudo-acceleration and displacement response spectra of one horizontal component.

    Args:
        motion: A :class:`rockjax.GroundMotion` (its horizontal ``ag``), or an acceleration
            array [m/s^2] sampled every ``dt`` (e.g. a floor motion).
        periods: Oscillator periods T [s], 1-D, >= 0 (``T = 0`` gives the PGA).
        damping: Damping ratio zeta [-], ``0 <= zeta < 1``; default 5 %.
        dt: Sampling step [s] of an array ``motion`` (not given with a GroundMotion).
        n_sub: Sub-steps per record step; default from the shortest period (see the module
            docstring). Give it when ``periods`` are traced (under ``jit`` or ``grad``).

    Returns:
        A :class:`Spectrum`.

    Raises:
        ValueError: on a bad record, period, damping, ``dt`` or ``n_sub``.
    """
    ag, step = _record(motion, dt, "motion")
    periods, damping, n_sub = _check_oscillators(periods, damping, n_sub, step)
    n = ag.shape[-1]
    ag_pad = _pad(ag[None, :])
    sd = _peaks(ag_pad, jnp.asarray(n), periods, damping, None, jnp.asarray(step), n_sub=n_sub)[0]
    pga = _xp(ag).max(_xp(ag).abs(ag))
    return Spectrum(
        periods=periods, damping=damping, sd=sd, sa=_pseudo_acceleration(periods, sd, pga)
    )


def rotd_spectrum(
    motion_x: GroundMotion | Float[ArrayLike, " time"],
    motion_y: GroundMotion | Float[ArrayLike, " time"],
    periods: Float[ArrayLike, " period"] | Sequence[float],
    damping: Float[ArrayLike, ""] = DEFAULT_DAMPING,
    *,
    dt: float | None = None,
    n_angles: int = _ANGLES,
    n_sub: int | None = None,
) -> RotDSpectrum:
    """Rotated response spectra (RotD50, RotD100, any RotDnn) of two horizontal components.

    Args:
        motion_x: First horizontal component, a GroundMotion or an array [m/s^2].
        motion_y: Second horizontal component, orthogonal to the first, same step and length.
        periods: Oscillator periods T [s], 1-D, >= 0.
        damping: Damping ratio zeta [-], ``0 <= zeta < 1``; default 5 %.
        dt: Sampling step [s] of array components.
        n_angles: Rotation angles, ``180 / n_angles`` degrees apart from 0; default 180 (1
            degree, as Boore 2010).
        n_sub: Sub-steps per record step, as in :func:`response_spectrum`.

    Returns:
        A :class:`RotDSpectrum`; ``.rotd50`` and ``.rotd100`` are :class:`Spectrum` objects.

    Raises:
        ValueError: on bad input, or components of different steps or lengths.
    """
    ax, step_x = _record(motion_x, dt, "motion_x")
    ay, step_y = _record(motion_y, dt, "motion_y")
    if not math.isclose(step_x, step_y, rel_tol=1e-9) or ax.shape != ay.shape:
        raise ValueError(
            f"motion_x and motion_y must share dt and length; got dt {step_x} and {step_y} s, "
            f"{ax.shape[-1]} and {ay.shape[-1]} samples. Resample or trim one of them first."
        )
    if isinstance(n_angles, bool) or not isinstance(n_angles, int) or n_angles < 1:
        raise ValueError(f"n_angles must be an int >= 1; got n_angles={n_angles!r}. Use 180.")
    periods, damping, n_sub = _check_oscillators(periods, damping, n_sub, step_x)
    angles = np.arange(n_angles) * (np.pi / n_angles)
    n = ax.shape[-1]
    xp = _xp(ax, ay)
    both = _pad(xp.stack([ax, ay]))
    sd = _peaks(both, jnp.asarray(n), periods, damping, angles, jnp.asarray(step_x), n_sub=n_sub)
    # the ground's own peak per angle (T = 0): the linear interpolant peaks at a sample
    rotated = np.cos(angles)[:, None] * ax[None, :] + np.sin(angles)[:, None] * ay[None, :]
    pga = xp.max(xp.abs(rotated), axis=1)
    sa = _pseudo_acceleration(periods, sd, pga[:, None])
    return RotDSpectrum(
        periods=periods, damping=damping, angles=jnp.asarray(angles), sd_angles=sd, sa_angles=sa
    )


# ----------------------------------------------------------------------------- intensity measures


class IntensityMeasure(NamedTuple):
    """A parsed intensity measure (:func:`parse_im`).

    Attributes:
        name: Canonical name: ``"pga"``, ``"pgv"`` or ``"sa(T)"`` (``T`` in s, e.g. ``"sa(0.5)"``).
        kind: ``"pga"``, ``"pgv"`` or ``"sa"``.
        period: ``T`` [s] of ``"sa"``; None otherwise.
        units: ``"m/s^2"`` (PGA, Sa) or ``"m/s"`` (PGV).
        long_name: A description for labels and Dataset attributes.
    """

    name: str
    kind: str
    period: float | None
    units: str
    long_name: str

    @property
    def is_acceleration(self) -> bool:
        """Whether the IM is an acceleration (reported in g as well)."""
        return self.units == "m/s^2"


_SA = re.compile(r"^\s*sa\s*\(\s*([^()\s]+?)\s*(?:s)?\s*\)\s*$", re.IGNORECASE)


def is_im_name(im: str) -> bool:
    """Whether ``im`` names an intensity measure (``pga``, ``pgv``, ``sa(...)``), well formed
    or not; a Dataset variable such as ``"pga_scaled"`` or ``"scale"`` is not one."""
    s = im.strip().lower()
    return s in ("pga", "pgv") or s.startswith("sa(")


def parse_im(im: str) -> IntensityMeasure:
    """Parse an intensity measure name: ``"pga"``, ``"pgv"`` or ``"sa(T)"`` (e.g. ``"sa(0.5)"``).

    ``sa(T)`` is the 5 %-damped pseudo-spectral acceleration at the period ``T`` [s]
    (``"Sa(0.5)"`` and ``"sa(0.5 s)"`` are accepted too).

    Raises:
        ValueError: for any other string, with the accepted forms.
    """
    if not isinstance(im, str):
        raise ValueError(f"im must be a string such as 'pga', 'pgv' or 'sa(0.5)'; got {im!r}.")
    s = im.strip().lower()
    if s == "pga":
        return IntensityMeasure("pga", "pga", None, "m/s^2", "peak ground acceleration")
    if s == "pgv":
        return IntensityMeasure("pgv", "pgv", None, "m/s", "peak ground velocity")
    match = _SA.match(s)
    period = None
    if match:
        try:
            period = float(match.group(1))
        except ValueError:
            period = None
    if period is None or not math.isfinite(period) or period < 0:
        raise ValueError(
            f"im must be 'pga', 'pgv' or 'sa(T)' with T the period in s, e.g. 'sa(0.5)'; got "
            f"im={im!r}."
        )
    if period == 0.0:
        raise ValueError("im='sa(0)' is the PGA; use im='pga'.")
    name = f"sa({period:g})"
    long_name = (
        f"pseudo-spectral acceleration at T = {period:g} s, {100 * DEFAULT_DAMPING:g} % damping"
    )
    return IntensityMeasure(name, "sa", period, "m/s^2", long_name)


def intensity(motion: GroundMotion, im: str) -> Float[Array, ""]:
    """The intensity measure ``im`` (:func:`parse_im`) of a record, in its SI units.

    ``"pga"``: :attr:`GroundMotion.pga` [m/s^2]; ``"pgv"``: :attr:`GroundMotion.pgv` [m/s];
    ``"sa(T)"``: :func:`response_spectrum` at ``T`` with 5 % damping [m/s^2]. Every one is
    proportional to the record's amplitude, so a record scaled by ``s`` has ``s`` times the IM.
    """
    spec = parse_im(im)
    if not isinstance(motion, GroundMotion):
        raise ValueError(f"motion must be a rockjax.GroundMotion; got {type(motion)}.")
    if spec.kind == "pga":
        return motion.pga
    if spec.kind == "pgv":
        return motion.pgv
    return response_spectrum(motion, np.array([spec.period])).sa[0]


# ----------------------------------------------------------------------------- kernel


def _omega(periods):
    safe = jnp.where(periods > 0, periods, 1.0)  # the double where: finite gradients at T = 0
    return 2.0 * jnp.pi / safe


def _pseudo_acceleration(periods, sd, pga):
    """``omega^2 sd``, and ``pga`` at ``T = 0`` (``periods`` is the last axis of ``sd``)."""
    periods = jnp.broadcast_to(periods, sd.shape)
    return jnp.where(periods > 0, _omega(periods) ** 2 * sd, jnp.broadcast_to(pga, sd.shape))


def _coefficients(omega, zeta, h):
    """Exact one-step recurrence of the oscillator under a linear excitation (module docstring):
    ``Phi`` (4 arrays) and the load vectors ``g0``, ``g1`` (2 arrays each), per period."""
    zw = zeta * omega
    wd = omega * jnp.sqrt(1.0 - zeta * zeta)
    decay = jnp.exp(-zw * h)
    c, s = jnp.cos(wd * h), jnp.sin(wd * h)
    p00 = decay * (c + zw / wd * s)
    p01 = decay * s / wd
    p10 = -decay * omega * omega / wd * s
    p11 = decay * (c - zw / wd * s)
    w2 = omega * omega
    # second columns of G1 = M^-1 (Phi - I) and G2 = M^-1 (G1 - h I),
    # with M^-1 = [[-2 zeta / omega, -1 / omega^2], [1, 0]]
    g1_u = (-2.0 * zw * p01 - (p11 - 1.0)) / w2
    g1_v = p01
    g2_u = (-2.0 * zw * g1_u - (g1_v - h)) / w2
    g2_v = g1_u
    # x' = Phi x + (G1 - G2 / h) f a_k + (G2 / h) f a_{k+1}, f = (0, -1)
    g0 = (-(g1_u - g2_u / h), -(g1_v - g2_v / h))
    g1 = (-g2_u / h, -g2_v / h)
    return (p00, p01, p10, p11), g0, g1


@persistent_jit
def _peaks(ag, n_valid, periods, zeta, angles, dt, *, n_sub: int):
    """Peak ``|u|`` of each component ``ag[c]`` (shape ``(component, period)``), or with
    ``angles`` of ``u_0 cos psi + u_1 sin psi`` (shape ``(angle, period)``), over the first
    ``n_valid`` samples of the zero-padded components. ``n_valid`` and ``dt`` are data (one
    compilation serves records of any step and of lengths in one bucket); ``n_sub`` is a
    shape."""
    h = dt / n_sub
    coef = _coefficients(_omega(periods)[None, :], zeta, h)  # each (1, period)
    (p00, p01, p10, p11), (g0u, g0v), (g1u, g1v) = coef
    n_comp, n = ag.shape
    frac = (jnp.arange(n_sub) / n_sub)[None, None, :]
    fine = ag[:, :-1, None] + (ag[:, 1:, None] - ag[:, :-1, None]) * frac  # exact sub-samples
    fine = jnp.concatenate([fine.reshape(n_comp, -1), ag[:, -1:]], axis=1)
    last = (n_valid - 1) * n_sub  # index of the last real fine sample
    if angles is None:
        peak0 = jnp.zeros((n_comp, periods.shape[0]))
    else:
        cs = jnp.stack([jnp.cos(angles), jnp.sin(angles)])  # (2, angle)
        peak0 = jnp.zeros((angles.shape[0], periods.shape[0]))

    def step(carry, xs):
        u, v, peak = carry
        a0, a1, k = xs
        a0, a1 = a0[:, None], a1[:, None]
        u_new = p00 * u + p01 * v + g0u * a0 + g1u * a1
        v_new = p10 * u + p11 * v + g0v * a0 + g1v * a1
        if angles is None:
            amp = jnp.abs(u_new)
        else:
            amp = jnp.abs(jnp.einsum("ca,cp->ap", cs, u_new))
        peak = jnp.where(k + 1 <= last, jnp.maximum(peak, amp), peak)
        return (u_new, v_new, peak), None

    # T = 0 has no oscillator (its spectral displacement is 0; Sa is the PGA)

    zeros = jnp.zeros((n_comp, periods.shape[0]))
    xs = (fine[:, :-1].T, fine[:, 1:].T, jnp.arange(fine.shape[1] - 1))
    (_, _, peak), _ = jax.lax.scan(step, (zeros, zeros, peak0), xs)
    return jnp.where(jnp.broadcast_to(periods, peak.shape) > 0, peak, 0.0)


# ----------------------------------------------------------------------------- input checks


def _bucket(n: int) -> int:
    """The padded length of an ``n``-sample record: the next of 2^k and 3 * 2^(k-1) (at most
    1.5 times ``n``), so records of many lengths share a few compiled shapes."""
    size = 8
    while size < n:
        size = size * 3 // 2 if size & (size - 1) == 0 else size * 4 // 3
    return size


def _xp(*arrays):
    """NumPy for concrete inputs (no eager JAX op, which would compile for every record
    length), jax.numpy for traced ones."""
    return np if all(isinstance(a, np.ndarray) for a in arrays) else jnp


def _pad(ag):
    n = ag.shape[-1]
    return _xp(ag).pad(ag, ((0, 0), (0, _bucket(n) - n)))


def _as_float(a):
    """A concrete array as a NumPy float64 array; a tracer as it is."""
    c = concrete(a)
    return jnp.asarray(a, dtype=jnp.float64) if c is None else c


def _record(motion, dt, label: str):
    """``(ag [m/s^2] as a float64 array, dt [s])`` from a GroundMotion or an array + ``dt``."""
    if isinstance(motion, GroundMotion):
        if dt is not None and not math.isclose(float(dt), motion.dt, rel_tol=1e-9):
            raise ValueError(
                f"{label} is a GroundMotion with dt={motion.dt} s; leave dt=None (got dt={dt})."
            )
        return _as_float(motion.ag), float(motion.dt)
    if dt is None:
        raise ValueError(
            f"{label} is an array, so dt (its sampling step in s) is needed, e.g. dt=0.01; or "
            "pass a rockjax.GroundMotion."
        )
    # GroundMotion checks the array (1-D, finite, >= 2 samples, plausible in m/s^2) and dt
    gm = GroundMotion(ag=motion, dt=dt, name=label)
    return _as_float(gm.ag), float(gm.dt)


def _check_oscillators(periods, damping, n_sub, dt: float):
    """Checked ``(periods as a float64 array, damping, n_sub)``."""
    check_number("periods", periods, "s", "e.g. periods=np.geomspace(0.05, 5, 50).")
    check_number("damping", damping, "[-]", "e.g. damping=0.05 for 5 %.")
    p = concrete(periods)  # before jnp.asarray, which under jit makes even constants traced
    periods = jnp.asarray(periods, dtype=jnp.float64)
    if periods.ndim != 1 or periods.shape[0] < 1:
        raise ValueError(
            f"periods must be a 1-D array of periods in s, e.g. np.geomspace(0.05, 5, 50); got "
            f"shape {periods.shape}."
        )
    if p is not None and (not np.all(np.isfinite(p)) or np.any(p < 0)):
        raise ValueError(f"periods must be finite and >= 0 in s; got periods={p}.")
    d = concrete(damping)
    if d is not None and (d.ndim != 0 or not 0.0 <= float(d) < 1.0):
        raise ValueError(
            f"damping must be a damping ratio in [0, 1) [-] (0.05 is 5 %); got damping={damping}."
        )
    if n_sub is None:
        if p is None:
            raise ValueError(
                "periods are traced (under jit, vmap over periods, or grad), so the number of "
                "sub-steps cannot be chosen from them: pass n_sub=, e.g. n_sub=8."
            )
        positive = p[p > 0]
        n_sub = 1
        if positive.size:
            n_sub = math.ceil(STEPS_PER_PERIOD * dt / float(positive.min()) - 1e-9)
            n_sub = int(min(max(n_sub, 1), MAX_N_SUB))
    elif isinstance(n_sub, bool) or not isinstance(n_sub, int) or n_sub < 1:
        raise ValueError(f"n_sub must be an int >= 1 (sub-steps per record step); got {n_sub!r}.")
    return periods, jnp.asarray(damping, dtype=jnp.float64), n_sub
