"""Boundary checks on concrete inputs: clear ValueErrors that name the value, its unit and the fix.

Traced values (inside jit/vmap/grad) cannot be checked here; those are checked in-graph with
``equinox.error_if`` by the simulators.
"""

import math
import warnings
from typing import NamedTuple

import jax
import numpy as np

MAX_SAMPLES = 10_000_000
"""Most samples a time axis may have (80 MB per float64 series): a record of 50 000 s at
0.005 s. More is taken for a unit slip (milliseconds for seconds, a step in s typed as a
rate) and refused before anything is allocated."""


def concrete(x):
    """Return ``x`` as a NumPy array if it is concrete, or None if it is a tracer."""
    try:
        return np.asarray(x, dtype=float)
    except (TypeError, ValueError):  # a tracer (TracerArrayConversionError), text, an object
        return None


def check_number(name: str, value, unit: str, hint: str = "") -> None:
    """Refuse what is not a real number (or an array of them): text (NumPy would read "0.25"
    as 0.25 here, and JAX would then fail deep inside a computation), None, a bool, a complex
    number or any other object. Tracers pass (their values are checked in-graph)."""
    if isinstance(value, jax.core.Tracer):
        return
    fix = f" {hint}" if hint else ""
    if isinstance(value, str | bytes):
        text = (value.decode(errors="replace") if isinstance(value, bytes) else value).strip()
        try:
            float(text)
            fix = f" Write {name}={text} without quotes."
        except ValueError:
            fix = f" Convert it to numbers first.{fix}"
        raise ValueError(f"{name} must be a number in {unit}, not text; got {name}={value!r}.{fix}")
    kind = None
    if value is not None and not isinstance(value, bool | np.bool_):
        try:
            kind = np.asarray(value).dtype.kind
        except jax.errors.TracerArrayConversionError:
            return  # a sequence of tracers
        except (TypeError, ValueError):  # a ragged sequence
            kind = None
    if kind not in ("i", "u", "f"):
        raise ValueError(
            f"{name} must be a real number in {unit}; got {name}={value!r} "
            f"(a {type(value).__name__}).{fix}"
        )


def check_scalar(name: str, value, unit: str, hint: str = "") -> None:
    """Refuse an array where one number is expected (a concrete value of more than one element)."""
    check_number(name, value, unit, hint)
    v = concrete(value)
    if v is not None and v.ndim != 0 and v.size != 1:
        fix = f" {hint}" if hint else ""
        raise ValueError(
            f"{name} must be one number in {unit}, not an array of shape {v.shape}; got "
            f"{name}={value!r}.{fix} To run several values, vmap over them or loop."
        )


def check_samples(duration, dt, *, duration_name: str = "duration", dt_name: str = "dt") -> int:
    """The number of samples ``floor(duration / dt) + 1`` of a time axis, both checked as
    positive finite numbers [s]; refused above :data:`MAX_SAMPLES` (a unit slip) before
    anything is allocated."""
    check_positive(duration_name, duration, "s", f"e.g. {duration_name}=10.0", scalar=True)
    check_positive(dt_name, dt, "s", f"e.g. {dt_name}=0.005", scalar=True)
    duration, dt = float(duration), float(dt)
    n = math.floor(duration / dt + 1e-9) + 1
    if n > MAX_SAMPLES:
        raise ValueError(
            f"{duration_name}={duration:g} s at {dt_name}={dt:g} s is {n:.3g} samples "
            f"({8 * n / 1e9:.3g} GB per series), above the limit of {MAX_SAMPLES:.0e} samples. "
            f"Did you give milliseconds for seconds? Use a shorter {duration_name} or a coarser "
            f"{dt_name} (records are sampled at 0.001-0.02 s)."
        )
    return n


def check_positive(name: str, value, unit: str, hint: str = "", *, scalar: bool = False) -> None:
    """Refuse a concrete value that is not a positive finite number (or, with ``scalar``,
    more than one number)."""
    (check_scalar if scalar else check_number)(name, value, unit, hint)
    v = concrete(value)
    if v is None:
        return
    if not np.all(np.isfinite(v)) or not np.all(v > 0):
        fix = f" {hint}" if hint else ""
        raise ValueError(
            f"{name} must be a positive finite number in {unit}; got {name}={value}.{fix}"
        )


def check_nonnegative(name: str, value, unit: str, hint: str = "", *, scalar: bool = False) -> None:
    (check_scalar if scalar else check_number)(name, value, unit, hint)
    v = concrete(value)
    if v is None:
        return
    if not np.all(np.isfinite(v)) or not np.all(v >= 0):
        fix = f" {hint}" if hint else ""
        raise ValueError(f"{name} must be finite and >= 0 in {unit}; got {name}={value}.{fix}")


def check_choice(name: str, value, choices) -> None:
    try:
        known = value in choices
    except TypeError:  # an unhashable value (a list, a dict) is no choice
        known = False
    if not known:
        raise ValueError(f"{name} must be one of {sorted(choices)}; got {name}={value!r}.")


def check_scales(scales) -> np.ndarray:
    """Scale factors [-] as a float array: 1-D, finite, >= 0 and strictly increasing."""
    check_number("scales", scales, "[-]", "e.g. scales=np.linspace(0.1, 2.0, 20).")
    s = np.asarray(scales, dtype=float)
    if s.ndim != 1 or s.size < 1:
        raise ValueError(f"scales must be a 1-D array of scale factors; got shape {s.shape}.")
    if not np.all(np.isfinite(s)) or np.any(s < 0):
        raise ValueError(f"scales must be finite and >= 0 [-]; got scales={s}.")
    if np.any(np.diff(s) <= 0):
        raise ValueError(
            f"scales must be strictly increasing; got scales={s}. Use np.unique(scales)."
        )
    return s


def check_below(name: str, value, limit: float, unit: str, hint: str) -> None:
    """Refuse a concrete value above ``limit`` (a unit slip, e.g. mm typed for m)."""
    v = concrete(value)
    if v is not None and np.any(v > limit):
        raise ValueError(f"{name}={value} {unit} is above {limit:g} {unit}. {hint}")


def check_above(name: str, value, limit: float, unit: str, hint: str) -> None:
    """Refuse a concrete value below ``limit`` (a unit slip, e.g. MPa typed for Pa)."""
    v = concrete(value)
    if v is not None and np.any(v < limit):
        raise ValueError(f"{name}={value} {unit} is below {limit:g} {unit}. {hint}")


class TimeSteps(NamedTuple):
    """The steps of a time axis, as the readers check it (:func:`time_steps`)."""

    steps: np.ndarray  # t[k + 1] - t[k] [s]
    first_back: int | None  # the first k with a step <= 0 (times that do not increase)
    n_back: int  # how many such steps
    mean: float  # (t[-1] - t[0]) / (n - 1) [s]
    worst: int  # the k whose step is farthest from the mean
    off: np.ndarray  # bool per step: farther from the mean than rtol * mean

    @property
    def uniform(self) -> bool:
        return self.first_back is None and not self.off.any()


def time_steps(t: np.ndarray, rtol: float) -> TimeSteps:
    """The one home of what a time axis must satisfy: increasing, and uniform to ``rtol`` of its
    mean step. Each caller words the error for its source (an array, a file's lines)."""
    steps = np.diff(t)
    back = np.flatnonzero(steps <= 0)
    mean = float((t[-1] - t[0]) / (t.size - 1))
    dev = np.abs(steps - mean)
    return TimeSteps(
        steps=steps,
        first_back=int(back[0]) if back.size else None,
        n_back=int(back.size),
        mean=mean,
        worst=int(np.argmax(dev)),
        off=dev > rtol * abs(mean),
    )


def is_array_pair(x) -> bool:
    """Whether ``x`` is a tuple of two arrays (NumPy or JAX), as ``(u_top, v_top)`` histories
    are given, as opposed to a model object or a list of ``(height, GroundMotion)`` pairs."""
    return (
        isinstance(x, tuple)
        and len(x) == 2
        and all(isinstance(a, np.ndarray | jax.Array) for a in x)
    )


def check_series_pair(arg: str, names: tuple[str, str], pair, n: int, fix: str) -> None:
    """The one home of the check of a pair of histories (a wall's or a restraint's
    displacement and velocity): each has one value per record sample, shape ``(n,)``, and is
    finite where concrete (traced values are checked by the simulators in-graph).

    Args:
        arg: The argument the pair came in, e.g. ``"wall_motion"``.
        names: The two series' names with their units, e.g. ``("u_top [m]", "v_top [m/s]")``.
        pair: The two series.
        n: The number of samples each must have.
        fix: How to make a series of the right length, for the message.
    """
    for name, a in zip(names, pair, strict=True):
        if np.shape(a) != (n,):
            raise ValueError(
                f"{arg}: {name} must have one value per record sample, shape ({n},); got shape "
                f"{np.shape(a)}. {fix}"
            )
        a_c = concrete(a)
        if a_c is not None and not np.all(np.isfinite(a_c)):
            raise ValueError(
                f"{arg}: {name} contains non-finite values (NaN or inf); clean it first."
            )


# ----------------------------------------------------------------------------- plausibility
# A value outside what the model or the structure can mean is refused when no reading of it
# is right (a unit slip: millimetres for metres); where it could still be meant, it is run
# with a warning that names the likely unit fix. Each threshold is a named constant with its
# reason where it is used.


class PlausibilityWarning(UserWarning):
    """A value that may be meant but is more likely a unit slip (the message names the fix)."""


def warn_implausible(message: str) -> None:
    """Warn that a value is implausible (:class:`PlausibilityWarning`), at the caller's
    caller (the user's line)."""
    warnings.warn(message, PlausibilityWarning, stacklevel=3)


MAX_GAP = 0.1
"""Largest gap [m] run without a warning: a facade's gap to its return walls or a top
restraint's clearance is a crack or a joint, millimetres to centimetres wide; above 0.1 m (a
brick's width) the value is more likely millimetres typed for metres (``gap=1`` for 1 mm)."""


GAP_NEEDS_ONE_SIDED = (
    "gap is the distance to a facade's return walls and needs mode='one_sided' (a facade); "
    "mode='two_sided' (a parapet) has none. Pass mode='one_sided' (or mode=rj.Facade(gap=...)), "
    "or leave gap=0."
)
"""Why a gap is refused with ``mode="two_sided"`` (:func:`check_gap`), in every entry point."""

HOUSNER_GAP_UNUSED = (
    "the Housner models have no facade gap (their facade stands flush on its return walls). "
    "Use the DEM (rj.simulate_dem, model=rj.DEM(beta=...)) for a gap, or leave gap=0 (rj.Facade())."
)
"""Why a facade's gap is refused by the Housner models (``simulate_housner``, ``ida``)."""

GAP_HINT = "gap is the facade-to-return-wall distance, e.g. 0.001."
"""The fix named for a gap that is no finite number >= 0."""


def check_gap(gap, *, used: bool, unused: str, hint: str, name: str = "gap") -> None:
    """The one home of the checks of a gap [m] (a facade's distance to its return walls, a
    top restraint's clearance): a finite number >= 0; refused where it would be ignored
    (``used`` False, ``unused`` saying why and what to do), as no gap is dropped silently;
    a warning above :data:`MAX_GAP` (a unit slip, or a very wide gap)."""
    check_nonnegative(name, gap, "m", hint, scalar=True)
    g = concrete(gap)
    if g is None:
        return
    g = float(g)
    if not used and g != 0.0:
        raise ValueError(f"{name}={g:.4g} m would be ignored: {unused}")
    if g > MAX_GAP:
        warn_implausible(
            f"{name}={g:.4g} m is wider than any crack or joint ({MAX_GAP:g} m is a brick's "
            f"width). rockjax works in metres: did you give millimetres? Divide by 1000 "
            f"(e.g. {name}=0.001 for 1 mm)."
        )


def check_kind(name: str, value, kinds: tuple[type, ...], fix: str) -> None:
    """Refuse a ``value`` that is none of ``kinds`` (e.g. None, or an Assembly given to a
    one-block function), naming the argument, what it got and the fix."""
    if not isinstance(value, kinds):
        wanted = " or ".join(f"a rockjax.{k.__name__}" for k in kinds)
        got = "None" if value is None else f"a {type(value).__name__}"
        raise ValueError(f"{name} must be {wanted}; got {got}. {fix}")
