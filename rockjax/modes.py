"""The rocking mode of a wall, one small object: a parapet (:class:`Parapet`, two-sided) or a
facade (:class:`Facade`, one-sided, against return walls a ``gap`` behind its back face).

The one home of every fact that differs between the two modes: the name the outputs carry,
the paper's friction angle, the DEM's default step accuracy, the paper's restitution, the
calibration's default target, the rocking amplitude whose peaks are bounces, the bounce
finders' impact threshold. Every public entry point takes a mode object or its name
(``"two_sided"`` / ``"one_sided"``, with ``gap=`` for a facade) and converts it once, with
:func:`as_mode`; inside, only the object travels (docs/conventions.md, "Modes").
"""

from __future__ import annotations

from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._checks import GAP_HINT, GAP_NEEDS_ONE_SIDED, check_choice, check_gap, concrete


class Parapet(eqx.Module):
    """Two-sided rocking: a parapet, free to rock about either bottom corner (the paper's
    ``mode="two_sided"``).

    Attributes:
        name: ``"two_sided"``, the name outputs, file names and attributes carry.
        one_sided: False.
        phi_deg: The paper's friction angle of its joints [deg]: 50.
        dt_accuracy: The DEM's default step accuracy ``omega_max dt (1 + zeta)`` [-] with the
            integrated face law (:data:`rockjax.dem.DT_ACCURACY`): 1.0. It bounds the first
            impact's restitution; peaks under records hold to 0.7 % at ``beta_DeJong``, but
            at the lighter ``beta`` fitted to ``e_H`` up to 7 % of runs are more than 5 % off
            (0 or 1 a case at 0.5), and at a ``beta`` 9 times lighter still the median peak
            is 1.5 % off (docs/verification.md, "Parapets on records: the default step").
        dt_accuracy_sub: The same with integer ``n_sub`` point sub-contacts
            (:data:`rockjax.dem.DT_ACCURACY_SUB`): 0.5, as a point's force switches on whole
            as it closes.
        dt_accuracy_open: The step accuracy where no return wall is in reach: a parapet
            has none, so its own, 1.0.
        dt_accuracy_open_sub: The same with integer ``n_sub``: 0.5.
        default_target: The calibration's default target (:func:`rockjax.fit_beta`): ``"e"``,
            Housner's rocking with ``e``.
        threshold_scale: The bounce finders' impact threshold in units of
            :data:`rockjax.response.HYSTERESIS` [-]: 1.
        gap: No return wall: 0 [m].
    """

    name: ClassVar[str] = "two_sided"
    one_sided: ClassVar[bool] = False
    phi_deg: ClassVar[float] = 50.0
    dt_accuracy: ClassVar[float] = 1.0
    dt_accuracy_sub: ClassVar[float] = 0.5
    dt_accuracy_open: ClassVar[float] = 1.0
    dt_accuracy_open_sub: ClassVar[float] = 0.5
    default_target: ClassVar[str] = "e"
    threshold_scale: ClassVar[float] = 1.0

    @property
    def gap(self) -> float:
        return 0.0

    def default_e(self, block_or_eta):
        """The paper's restitution [-]: Housner's ``e_H``, Eq. (2)
        (:func:`rockjax.e_housner`)."""
        from .relations import e_housner  # relations imports response, which imports modes

        return e_housner(block_or_eta)

    def e_magnitude(self, e):
        """The restitution [-] the impact rule uses: ``e`` itself (two-sided, ``0 < e <= 1``)."""
        return e

    def amplitude(self, theta):
        """The rotation whose peaks are the bounces [rad]: ``|theta|`` (NumPy in, NumPy out)."""
        return abs(theta)

    def without_gap(self) -> Parapet:
        """This mode as the rigid (Housner) model takes it, with no gap: itself."""
        return self


class Facade(eqx.Module):
    """One-sided rocking: a facade against return walls ``gap`` [m] behind its back face (-x);
    it rotates only outward, ``theta >= 0`` (the paper's ``mode="one_sided"``).

    Attributes:
        gap: Distance between the back face and the return walls at rest [m] (a finite number
            >= 0; traceable). Checked where it is built, with a
            :class:`rockjax.PlausibilityWarning` above 0.1 m (millimetres typed for metres).
        name: ``"one_sided"``.
        one_sided: True.
        phi_deg: The paper's friction angle of its joints [deg]: 30.
        dt_accuracy: The DEM's default step accuracy with the integrated face law [-]: 0.35
            (its later, small rebounds need a finer step than a parapet's first impact;
            :data:`rockjax.dem.DT_ACCURACY`).
        dt_accuracy_sub: The same with integer ``n_sub``: 0.35.
        dt_accuracy_open: The step accuracy of a one-block facade while its return wall is
            out of reach, against ``omega_max`` and ``zeta`` without the wall's springs [-]:
            0.5. Over a far-field IDA its peaks err as at 0.35 where the reference is
            conditioned; 1.0 (a parapet's) let runs near the uplift threshold err by up to
            16 % (docs/verification.md, "Open steps").
        dt_accuracy_open_sub: The same with integer ``n_sub``: 0.35.
        default_target: ``"bounces"``: the measured facade bounces as fractions of
            ``|e_1SR|`` (:data:`rockjax.calibration.BOUNCE_FRACTIONS`).
        threshold_scale: The bounce finders' impact threshold in units of
            :data:`rockjax.response.HYSTERESIS` [-]: 0.1 (facade bounces are small).
    """

    gap: float | jax.Array = 0.0

    name: ClassVar[str] = "one_sided"
    one_sided: ClassVar[bool] = True
    phi_deg: ClassVar[float] = 30.0
    dt_accuracy: ClassVar[float] = 0.35
    dt_accuracy_sub: ClassVar[float] = 0.35
    dt_accuracy_open: ClassVar[float] = 0.5
    dt_accuracy_open_sub: ClassVar[float] = 0.35
    default_target: ClassVar[str] = "bounces"
    threshold_scale: ClassVar[float] = 0.1

    def __check_init__(self):
        check_gap(self.gap, used=True, unused="", hint=GAP_HINT)

    def default_e(self, block_or_eta):
        """The paper's restitution [-]: ``e_1SR``, Eq. (5) (:func:`rockjax.e_isr`), negative
        for every wall: its magnitude is the ratio of speeds (:meth:`e_magnitude`)."""
        from .relations import e_isr  # relations imports response, which imports modes

        return e_isr(block_or_eta)

    def e_magnitude(self, e):
        """The restitution [-] the impact rule uses: ``|e|`` (a one-sided rebound keeps
        ``theta >= 0``, whatever the sign of Eq. 5)."""
        return abs(e)

    def amplitude(self, theta):
        """The rotation whose peaks are the bounces [rad]: ``max(theta, 0)``, the rebounds
        away from the wall (``theta < 0`` is the contact's penetration into it, no rocking
        energy). NumPy in, NumPy out."""
        xp = np if isinstance(theta, np.ndarray) else jnp
        return xp.maximum(theta, 0.0)

    def without_gap(self) -> Facade:
        """This mode as the rigid (Housner) model takes it: flush on its walls, ``gap = 0``."""
        return Facade()


Mode = Parapet | Facade
"""A rocking mode: :class:`Parapet` or :class:`Facade`."""

MODE_NAMES = (Parapet.name, Facade.name)
"""The modes' names, as the string form of ``mode=`` takes them."""


def as_mode(mode, gap=None, *, unused: str = GAP_NEEDS_ONE_SIDED) -> Mode:
    """The mode object of a ``mode=`` argument: a :class:`Parapet` or :class:`Facade` as it
    is, or its name ``"two_sided"`` / ``"one_sided"`` with the facade's ``gap`` [m].

    Args:
        mode: ``rj.Parapet()``, ``rj.Facade(gap=...)``, ``"two_sided"`` or ``"one_sided"``.
        gap: The facade's gap [m] given apart (the string form's ``gap=``); None: not given
            (0 for ``"one_sided"``). With a :class:`Facade` it may repeat the facade's own gap.
        unused: Why a gap given to a parapet would be ignored, and what to do (the entry
            point's own reason, e.g. an assembly's restraint has its own clearance).

    Returns:
        The :class:`Parapet` or :class:`Facade`.

    Raises:
        ValueError: an unknown mode; a gap given to a parapet; a gap given both in the
            :class:`Facade` and as ``gap=`` with different values; a gap that is no finite
            number >= 0 in metres.
    """
    if isinstance(mode, Parapet):
        if gap is not None:
            check_gap(gap, used=False, unused=unused, hint=GAP_HINT)
        return mode
    if isinstance(mode, Facade):
        if gap is not None and gap is not mode.gap:
            given, own = concrete(gap), concrete(mode.gap)
            if given is None or own is None or not np.array_equal(given, own):
                raise ValueError(
                    f"gap={gap!r} m and mode={mode!r}: the facade's gap [m] is given twice. "
                    f"Give it once: mode=rj.Facade(gap={gap!r}), or mode='one_sided', "
                    f"gap={gap!r}."
                )
        return mode
    if isinstance(mode, str):
        check_choice("mode", mode, MODE_NAMES)
        if mode == Parapet.name:
            return as_mode(Parapet(), gap, unused=unused)
        return Facade(gap=0.0 if gap is None else gap)
    raise ValueError(
        f"mode must be rj.Parapet(), rj.Facade(gap=<m>) or one of {list(MODE_NAMES)}; got "
        f"mode={mode!r}. E.g. mode=rj.Facade(gap=0.001) for a facade 1 mm off its return walls."
    )
