r"""A linear shear building: floor motions (exact for a piecewise-linear ground acceleration),
floor spectra, and the motion of return walls for facades in a building.

The building is a chain of ``n`` floor masses ``m_i`` [kg] joined by storey springs ``k_i``
[N/m] (storey ``i`` joins floor ``i - 1`` to floor ``i``; floor 0 is the ground), with floor
``i`` at height ``z_i`` above the ground. Its floor displacements ``u`` relative to the ground
obey

$$M \ddot u + C \dot u + K u = -M \mathbf{1}\, a_g(t),$$

with ``M = diag(m)``, ``K`` tridiagonal (``K_ii = k_i + k_{i+1}``, ``K_i,i+1 = -k_{i+1}``) and a
classical damping ``C`` (modal: the same ratio ``zeta`` in every mode; or Rayleigh,
``C = a0 M + a1 K`` with ``zeta`` in modes 1 and 2). In the mass-normalised modes ``phi_j``
(``phi_j^T M phi_j = 1``) with participation factors ``Gamma_j = phi_j^T M 1``,
``u = sum_j phi_j Gamma_j D_j`` where each ``D_j`` is the relative displacement of a single
oscillator ``D'' + 2 zeta_j omega_j D' + omega_j^2 D = -a_g``, advanced over each record step
by the exact recurrence for a ground acceleration linear in the step (Nigam and Jennings 1969;
derivation in docs/building.md). Floor absolute accelerations are
``u'' + a_g = -sum_j phi_j Gamma_j (2 zeta_j omega_j D_j' + omega_j^2 D_j)`` (since
``sum_j phi_j Gamma_j = 1``), exact at the record samples.

Everything is JAX: a :class:`ShearBuilding` can be built inside ``jax.vmap`` or differentiated
(stiffnesses, masses, period, damping), and :meth:`ShearBuilding.response` vmaps over records.

References:
    Nigam, N. C. and Jennings, P. C. (1969). Calculation of response spectra from
    strong-motion earthquake records. BSSA 59(2), 909-922.
    Chopra, A. K. (2017). Dynamics of Structures, 5th ed., chapters 5 (piecewise-exact
    recurrence), 11 (Rayleigh damping) and 13 (modal analysis).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._checks import (
    check_below,
    check_choice,
    check_number,
    check_scalar,
    concrete,
    warn_implausible,
)
from ._types import ScalarLike
from .constants import G
from .motion import PLAUSIBLE_LIMIT_G, GroundMotion
from .spectra import DEFAULT_DAMPING, Spectrum, response_spectrum

DAMPING_MODELS = ("modal", "rayleigh")
"""The damping models of :class:`ShearBuilding`: ``"modal"`` (ratio ``damping`` in every mode)
and ``"rayleigh"`` (``C = a0 M + a1 K`` with ratio ``damping`` in modes 1 and 2)."""

DEFAULT_FLOOR_MASS = 1.0e5
"""Floor mass of :meth:`ShearBuilding.uniform` [kg] (100 t, a URM floor of ~150 m^2). Floor
motions depend only on the ratios k/m, so it matters only for the stiffnesses reported."""

MAX_STOREY_HEIGHT = 20.0
"""Largest storey height accepted [m]: storeys are 2.5-6 m, an industrial hall's up to about
15 m; above 20 m the input is taken for millimetres typed for metres (3000 for 3 m)."""

MAX_HEIGHT = 1000.0
"""Largest height above the base accepted for a wall or facade [m] (taller than any building):
above it the input is taken for millimetres typed for metres."""

MAX_PERIOD_PER_STOREY = 0.5
"""Largest fundamental period per storey run without a warning [s] (with at least
:data:`MAX_PERIOD`): buildings run about 0.1 s per storey (URM 0.05-0.15 s), so five times
that is a very flexible building at most, and more is likely a frequency in Hz typed for a
period (``period=10`` for 0.1 s)."""

MAX_PERIOD = 3.0
"""Fundamental period [s] run without a warning however few the storeys: a base-isolated
building of one or two storeys reaches 2-3 s."""

MM_FIX = (
    "rockjax works in metres: did you give millimetres? Divide by 1000 (e.g. {}=3.0 for 3000 mm)."
)
"""The fix of a length given in millimetres (``MM_FIX.format(<argument name>)``)."""


def _series(name: str, value, unit: str, hint: str):
    """A 1-D float64 array of positive numbers (concrete values checked, tracers passed)."""
    check_number(name, value, unit, hint)
    c = concrete(value)
    if c is None:  # traced (the building is built inside jit/vmap/grad)
        arr = jnp.asarray(value, dtype=jnp.float64)
    else:
        arr = jnp.asarray(c)
    if arr.ndim == 0:
        arr = arr[None]
    if arr.ndim != 1 or arr.shape[0] < 1:
        raise ValueError(
            f"{name} must be a 1-D array with one value in {unit} per storey; got shape "
            f"{arr.shape}. {hint}"
        )
    if c is not None and (not np.all(np.isfinite(c)) or not np.all(c > 0)):
        raise ValueError(
            f"{name} must be positive finite numbers in {unit}; got {name}={c.tolist()}. {hint}"
        )
    return arr


def _check_damping(damping) -> jax.Array:
    check_scalar("damping", damping, "[-]", "e.g. damping=0.05 for 5 %.")
    d = concrete(damping)
    if d is not None and not (np.isfinite(d) and 0.0 <= float(d) < 1.0):
        raise ValueError(
            f"damping (the modal damping ratio, dimensionless) must lie in [0, 1); got "
            f"damping={damping}. Use e.g. damping=0.05 for 5 %."
        )
    return jnp.asarray(damping, dtype=jnp.float64).reshape(())


class ShearBuilding(eqx.Module):
    """A linear shear building: floor masses on storey springs, with classical damping.

    Storey ``i`` (1-based) is the spring ``stiffnesses[i-1]`` between floor ``i - 1`` (floor 0
    is the ground) and floor ``i``, of height ``storey_heights[i-1]``; floor ``i`` carries
    ``masses[i-1]``. Build a regular building with :meth:`uniform`.

    Args:
        masses: Floor masses [kg], bottom floor first, shape ``(storey,)``.
        stiffnesses: Storey lateral stiffnesses [N/m], bottom storey first.
        storey_heights: Storey heights [m], bottom storey first; each at most
            :data:`MAX_STOREY_HEIGHT` (above: millimetres, refused).
        damping: Damping ratio zeta [-], ``0 <= zeta < 1``; default 5 %.
        damping_model: ``"modal"`` (default): ``zeta`` in every mode; ``"rayleigh"``:
            ``C = a0 M + a1 K`` with ``zeta`` in modes 1 and 2, so higher modes are damped
            more (a one-storey building has one mode, damped ``zeta`` either way).

    Raises:
        ValueError: on arrays of different lengths, values that are not positive finite
            numbers, a damping ratio outside ``[0, 1)``, or an unknown ``damping_model``.
    """

    masses: Float[Array, " storey"]
    stiffnesses: Float[Array, " storey"]
    storey_heights: Float[Array, " storey"]
    damping: Float[Array, ""]
    damping_model: Literal["modal", "rayleigh"] = eqx.field(static=True)

    def __init__(
        self,
        masses: Float[ArrayLike, " storey"] | Sequence[float],
        stiffnesses: Float[ArrayLike, " storey"] | Sequence[float],
        storey_heights: Float[ArrayLike, " storey"] | Sequence[float],
        damping: ScalarLike = DEFAULT_DAMPING,
        damping_model: Literal["modal", "rayleigh"] = "modal",
    ):
        self.masses = _series("masses", masses, "kg", "Give one floor mass per storey.")
        self.stiffnesses = _series(
            "stiffnesses",
            stiffnesses,
            "N/m",
            "Give one storey stiffness per storey (or use ShearBuilding.uniform(period=...)).",
        )
        self.storey_heights = _series(
            "storey_heights", storey_heights, "m", "Give one storey height per storey, e.g. 3.0."
        )
        check_below(
            "storey_heights",
            concrete(storey_heights),
            MAX_STOREY_HEIGHT,
            "m",
            MM_FIX.format("storey_heights"),
        )
        n = {a.shape[0] for a in (self.masses, self.stiffnesses, self.storey_heights)}
        if len(n) != 1:
            raise ValueError(
                "masses, stiffnesses and storey_heights need one value per storey each; got "
                f"{self.masses.shape[0]}, {self.stiffnesses.shape[0]} and "
                f"{self.storey_heights.shape[0]} values."
            )
        self.damping = _check_damping(damping)
        check_choice("damping_model", damping_model, DAMPING_MODELS)
        self.damping_model = damping_model

    @classmethod
    def uniform(
        cls,
        n_storeys: int,
        storey_height: ScalarLike,
        period: ScalarLike,
        damping: ScalarLike = DEFAULT_DAMPING,
        *,
        mass: ScalarLike = DEFAULT_FLOOR_MASS,
        damping_model: Literal["modal", "rayleigh"] = "modal",
    ) -> ShearBuilding:
        r"""A regular building: equal floor masses, storey stiffnesses and storey heights.

        The stiffness ``k`` is set so that the fundamental period equals ``period``, with the
        closed-form frequencies of a uniform fixed-free chain of ``n`` masses,

        $$\omega_j = 2\sqrt{k/m}\,\sin\frac{(2j - 1)\pi}{2(2n + 1)}, \qquad j = 1..n.$$

        Args:
            n_storeys: Number of storeys (floors above the ground), an int >= 1.
            storey_height: Height of every storey [m], at most :data:`MAX_STOREY_HEIGHT`.
            period: Fundamental period T1 [s]; one above :data:`MAX_PERIOD` and
                :data:`MAX_PERIOD_PER_STOREY` per storey is run with a
                ``rockjax.PlausibilityWarning`` (likely a frequency in Hz).
            damping: Damping ratio zeta [-]; default 5 %.
            mass: Mass of every floor [kg]; default :data:`DEFAULT_FLOOR_MASS`.
            damping_model: ``"modal"`` or ``"rayleigh"`` (see :class:`ShearBuilding`).

        Returns:
            The :class:`ShearBuilding`.
        """
        if isinstance(n_storeys, bool) or not isinstance(n_storeys, int | np.integer):
            raise ValueError(
                f"n_storeys must be an int >= 1 (floors above the ground); got {n_storeys!r}."
            )
        if n_storeys < 1:
            raise ValueError(f"n_storeys must be an int >= 1; got n_storeys={n_storeys}.")
        n = int(n_storeys)
        for name, value, unit, hint in (
            ("storey_height", storey_height, "m", "e.g. storey_height=3.0."),
            ("period", period, "s", "e.g. period=0.3 (about 0.1 s per storey for URM)."),
            ("mass", mass, "kg", "e.g. mass=1e5 (100 t)."),
        ):
            check_scalar(name, value, unit, hint)
            if (v := concrete(value)) is not None and not (np.isfinite(v) and v > 0):
                raise ValueError(
                    f"{name} must be a positive finite number in {unit}; got {name}={value}. {hint}"
                )
        check_below(
            "storey_height",
            concrete(storey_height),
            MAX_STOREY_HEIGHT,
            "m",
            MM_FIX.format("storey_height"),
        )
        t_max = max(MAX_PERIOD, MAX_PERIOD_PER_STOREY * n)
        if (t1 := concrete(period)) is not None and t1 > t_max:
            warn_implausible(
                f"period={float(t1):g} s is long for {n} storeys (buildings run about 0.1 s per "
                f"storey; above {t_max:g} s only as a frequency in Hz or a unit slip). period "
                f"is the fundamental period in s: did you give a frequency in Hz? Use "
                f"period=1/f (e.g. period=0.1 for 10 Hz)."
            )
        omega1 = 2.0 * jnp.pi / jnp.asarray(period, dtype=jnp.float64)
        ratio = 2.0 * math.sin(math.pi / (2.0 * (2 * n + 1)))  # omega_1 / sqrt(k / m)
        k = jnp.asarray(mass, dtype=jnp.float64) * (omega1 / ratio) ** 2
        ones = jnp.ones(n)
        return cls(
            masses=mass * ones,
            stiffnesses=k * ones,
            storey_heights=storey_height * ones,
            damping=damping,
            damping_model=damping_model,
        )

    # ------------------------------------------------------------------ modal properties
    @property
    def n_storeys(self) -> int:
        """Number of storeys (floors above the ground)."""
        return int(self.masses.shape[-1])

    @property
    def heights(self) -> Float[Array, " storey"]:
        """Heights of floors 1..n above the ground [m]."""
        return jnp.cumsum(self.storey_heights, axis=-1)

    @property
    def omegas(self) -> Float[Array, " mode"]:
        """Modal circular frequencies omega_j [rad/s], ascending."""
        return _modal(self)[0]

    @property
    def periods(self) -> Float[Array, " mode"]:
        """Modal periods T_j = 2 pi / omega_j [s], fundamental first."""
        return 2.0 * jnp.pi / self.omegas

    @property
    def modes(self) -> Float[Array, "mode storey"]:
        """Mode shapes, one row per mode (fundamental first), scaled to 1 at the roof."""
        phi = _modal(self)[1]  # (floor, mode)
        return (phi / phi[-1:, :]).T

    @property
    def participation_factors(self) -> Float[Array, " mode"]:
        """Participation factors ``Gamma_j = phi_j^T M 1 / phi_j^T M phi_j`` of the modes of
        :attr:`modes` (roof-normalised), so the roof's share of mode ``j`` is ``Gamma_j`` [-]."""
        shapes = self.modes
        return (shapes @ self.masses) / ((shapes * shapes) @ self.masses)

    @property
    def damping_ratios(self) -> Float[Array, " mode"]:
        """Damping ratio of each mode [-] (all ``damping`` for the modal model)."""
        return _modal(self)[2]

    # ------------------------------------------------------------------ responses
    def response(self, motion: GroundMotion) -> BuildingResponse:
        """The floor response to a ground motion, from rest, at the record samples.

        Exact for the ground acceleration linear between its samples (as the rocking
        simulators take it), at any ``dt``.

        Args:
            motion: The ground motion (its horizontal ``ag`` [m/s^2]).

        Returns:
            A :class:`BuildingResponse`: absolute floor accelerations, displacements and
            velocities relative to the ground, shape ``(storey, time)``.
        """
        if not isinstance(motion, GroundMotion):
            raise ValueError(
                f"motion must be a rockjax.GroundMotion; got {type(motion).__name__}. Wrap an "
                "array with rj.GroundMotion(ag=..., dt=...)."
            )
        motion.check_finite()
        acc, u, v = _response(self, jnp.asarray(motion.ag, dtype=jnp.float64), motion.dt)
        return BuildingResponse(
            acceleration=acc, displacement=u, velocity=v, heights=self.heights, dt=motion.dt
        )

    def floor_motions(self, motion: GroundMotion) -> list[GroundMotion]:
        """The absolute acceleration of each floor as a GroundMotion (floor 1 first).

        Each has the record's ``dt``, the name ``"<motion.name> floor <i>"`` and the record's
        metadata plus ``floor`` (and ``height_m`` for a concrete building). A floor record,
        like any record, is linear between its samples where the floor's exact motion is not:
        the difference is of order ``(omega_n dt)^2`` for the highest mode ``omega_n``.

        Args:
            motion: The ground motion.

        Returns:
            A list of ``n_storeys`` GroundMotions.
        """
        resp = self.response(motion)
        heights = concrete(self.heights)
        floors = []
        for i in range(self.n_storeys):
            acc = resp.acceleration[i]
            if (c := concrete(acc)) is not None:
                acc = c
                peak_g = float(np.max(np.abs(c))) / G
                if peak_g > PLAUSIBLE_LIMIT_G:
                    raise ValueError(
                        f"floor {i + 1} of the building peaks at {peak_g:.3g} g under record "
                        f"{motion.name!r} (PGA {float(motion.pga_g):.3g} g), above the "
                        f"plausibility limit of a GroundMotion ({PLAUSIBLE_LIMIT_G:g} g). Check "
                        "the record's units and scale (m/s^2) and the building's damping; "
                        "bldg.response(motion).acceleration gives the floor accelerations "
                        "without this check."
                    )
            meta = (*motion.meta, ("floor", str(i + 1)))
            if heights is not None:
                meta = (*meta, ("height_m", f"{heights[i]:g}"))
            floors.append(
                GroundMotion(ag=acc, dt=motion.dt, name=f"{motion.name} floor {i + 1}", meta=meta)
            )
        return floors


class BuildingResponse(eqx.Module):
    """The response of a :class:`ShearBuilding` to a ground motion, at the record samples.

    Attributes:
        acceleration: Absolute floor accelerations [m/s^2], shape ``(storey, time)``.
        displacement: Floor displacements relative to the ground [m], ``(storey, time)``.
        velocity: Floor velocities relative to the ground [m/s], ``(storey, time)``.
        heights: Floor heights above the ground [m], ``(storey,)``.
        dt: Sampling step [s].
    """

    acceleration: Float[Array, "storey time"]
    displacement: Float[Array, "storey time"]
    velocity: Float[Array, "storey time"]
    heights: Float[Array, " storey"]
    dt: float = eqx.field(static=True)

    @property
    def t(self) -> np.ndarray:
        """Sample times [s]."""
        return np.arange(self.acceleration.shape[-1]) * self.dt

    @property
    def drift(self) -> Float[Array, "storey time"]:
        """Storey drifts ``u_i - u_{i-1}`` [m] (storey 1 first)."""
        u = self.displacement
        return u - jnp.concatenate([jnp.zeros_like(u[..., :1, :]), u[..., :-1, :]], axis=-2)


def floor_spectra(
    building: ShearBuilding,
    motion: GroundMotion,
    periods: Float[ArrayLike, " period"] | Sequence[float],
    damping: ScalarLike = DEFAULT_DAMPING,
    *,
    n_sub: int | None = None,
) -> Spectrum:
    """Floor response spectra: :func:`rockjax.response_spectrum` of each floor's acceleration.

    Args:
        building: The building.
        motion: The ground motion.
        periods: Oscillator periods T [s], 1-D, >= 0 (``T = 0`` gives the peak floor
            acceleration).
        damping: Damping ratio of the oscillators [-]; default 5 %.
        n_sub: Sub-steps per record step, as in :func:`rockjax.response_spectrum`.

    Returns:
        A :class:`rockjax.spectra.Spectrum` whose ``sd`` and ``sa`` have shape
        ``(storey, period)``, floor 1 first.
    """
    if not isinstance(building, ShearBuilding):
        raise ValueError(
            f"building must be a rockjax.ShearBuilding; got {type(building).__name__}."
        )
    resp = building.response(motion)
    specs = [
        response_spectrum(resp.acceleration[i], periods, damping, dt=motion.dt, n_sub=n_sub)
        for i in range(building.n_storeys)
    ]
    return Spectrum(
        periods=specs[0].periods,
        damping=specs[0].damping,
        sd=jnp.stack([s.sd for s in specs]),
        sa=jnp.stack([s.sa for s in specs]),
    )


# ------------------------------------------------------------------------------- return walls


# ------------------------------------------------------------------------------- kernel


def _stiffness_matrix(k):
    """Tridiagonal storey stiffness matrix [N/m] of the chain fixed at the ground."""
    k_above = jnp.concatenate([k[1:], jnp.zeros(1)])
    return jnp.diag(k + k_above) - jnp.diag(k[1:], 1) - jnp.diag(k[1:], -1)


def _modes(building: ShearBuilding):
    """``(omega [rad/s] (mode,), phi (floor, mode) with phi^T M phi = I)``: the symmetric
    eigenproblem ``M^-1/2 K M^-1/2 psi = omega^2 psi``, ``phi = M^-1/2 psi``."""
    s = 1.0 / jnp.sqrt(building.masses)
    a = s[:, None] * _stiffness_matrix(building.stiffnesses) * s[None, :]
    lam, psi = jnp.linalg.eigh(a)
    return jnp.sqrt(lam), s[:, None] * psi


def _modal_damping(building: ShearBuilding, omega):
    """Damping ratio of each mode: ``zeta`` (modal), or Rayleigh's
    ``a0 / (2 omega) + a1 omega / 2`` with ``zeta`` at omega_1 and omega_2."""
    zeta = building.damping
    if building.damping_model == "modal" or omega.shape[0] < 2:
        return jnp.broadcast_to(zeta, omega.shape)
    w1, w2 = omega[0], omega[1]
    a0 = 2.0 * zeta * w1 * w2 / (w1 + w2)  # [1/s]
    a1 = 2.0 * zeta / (w1 + w2)  # [s]
    return a0 / (2.0 * omega) + a1 * omega / 2.0


def _recurrence(omega, zeta, h):
    """Exact one-step map of ``x = (D, V)`` of ``D'' + 2 zeta omega D' + omega^2 D = -a`` with
    ``a`` linear over the step ``h``: ``x' = Phi x + q0 a_k + q1 a_{k+1}`` (docs/building.md).
    Each entry has the shape of ``omega`` (one oscillator per mode)."""
    zw = zeta * omega
    wd = omega * jnp.sqrt(1.0 - zeta * zeta)
    decay = jnp.exp(-zw * h)
    cos, sin = jnp.cos(wd * h), jnp.sin(wd * h)
    phi = (
        decay * (cos + zw / wd * sin),
        decay * sin / wd,
        -decay * omega * omega / wd * sin,
        decay * (cos - zw / wd * sin),
    )
    w2 = omega * omega
    # A^-1 = [[-2 zeta / omega, -1 / omega^2], [1, 0]] applied to the second columns of
    # Phi - I (giving int_0^h Phi e2) and of that integral minus h I (int_0^h Phi(h - s) s e2)
    int0 = ((-2.0 * zw * phi[1] - (phi[3] - 1.0)) / w2, phi[1])
    int1 = ((-2.0 * zw * int0[0] - (int0[1] - h)) / w2, int0[0])
    # the load is -a e2 with a = a_k + (a_{k+1} - a_k) s / h
    q0 = tuple(-(i0 - i1 / h) for i0, i1 in zip(int0, int1, strict=True))
    q1 = tuple(-i1 / h for i1 in int1)
    return phi, q0, q1


@eqx.filter_jit
def _modal(building: ShearBuilding):
    """``(omega, phi, zeta)``: one compiled call for the properties (eager eigh and friends
    would compile op by op)."""
    omega, phi = _modes(building)
    return omega, phi, _modal_damping(building, omega)


@eqx.filter_jit
def _response(building: ShearBuilding, ag, dt: float):
    """Absolute floor accelerations, relative displacements and velocities, each
    ``(floor, time)``."""
    omega, phi, zeta = _modal(building)
    zeta = eqx.error_if(
        zeta,
        jnp.any(zeta >= 1.0),
        "Rayleigh damping gives a mode a damping ratio >= 1 (overdamped): lower damping or "
        "use damping_model='modal'.",
    )
    gamma = phi.T @ building.masses  # (mode,)
    (p00, p01, p10, p11), (q0d, q0v), (q1d, q1v) = _recurrence(omega, zeta, dt)

    def step(carry, a):
        d, v = carry
        a0, a1 = a
        d_new = p00 * d + p01 * v + q0d * a0 + q1d * a1
        v_new = p10 * d + p11 * v + q0v * a0 + q1v * a1
        return (d_new, v_new), (d_new, v_new)

    zero = jnp.zeros_like(omega)
    # No jax.checkpoint around the step: it is linear, so reverse mode keeps only the modal
    # states, (time, mode) arrays no larger than the output.
    _, (d, v) = jax.lax.scan(step, (zero, zero), (ag[:-1], ag[1:]))
    d = jnp.concatenate([zero[None, :], d])  # (time, mode)
    v = jnp.concatenate([zero[None, :], v])
    shares = phi * gamma[None, :]  # (floor, mode): column j is phi_j Gamma_j
    acc = -((2.0 * zeta * omega)[None, :] * v + (omega * omega)[None, :] * d)
    return shares @ acc.T, shares @ d.T, shares @ v.T
