"""Boundary checks on concrete inputs: clear ValueErrors that name the value, its unit and the fix.

Traced values (inside jit/vmap/grad) cannot be checked here; those are checked in-graph with
``equinox.error_if`` by the simulators.
"""

import numpy as np


def concrete(x):
    """Return ``x`` as a NumPy array if it is concrete, or None if it is a tracer."""
    try:
        return np.asarray(x, dtype=float)
    except Exception:  # a jax Tracer raises a TracerArrayConversionError subclass here
        return None


def check_number(name: str, value, unit: str) -> None:
    """Refuse text where a number is expected (NumPy would read "0.25" as 0.25 here, and JAX
    would then fail deep inside a computation)."""
    if isinstance(value, str | bytes):
        raise ValueError(
            f"{name} must be a number in {unit}, not text; got {name}={value!r}. "
            f"Write {name}={value.strip() if isinstance(value, str) else value!r} without quotes."
        )


def check_positive(name: str, value, unit: str, hint: str = "") -> None:
    check_number(name, value, unit)
    v = concrete(value)
    if v is None:
        return
    if not np.all(np.isfinite(v)) or not np.all(v > 0):
        fix = f" {hint}" if hint else ""
        raise ValueError(
            f"{name} must be a positive finite number in {unit}; got {name}={value}.{fix}"
        )


def check_nonnegative(name: str, value, unit: str, hint: str = "") -> None:
    check_number(name, value, unit)
    v = concrete(value)
    if v is None:
        return
    if not np.all(np.isfinite(v)) or not np.all(v >= 0):
        fix = f" {hint}" if hint else ""
        raise ValueError(f"{name} must be finite and >= 0 in {unit}; got {name}={value}.{fix}")


def check_choice(name: str, value, choices) -> None:
    if value not in choices:
        raise ValueError(f"{name} must be one of {sorted(choices)}; got {name}={value!r}.")


def check_scales(scales) -> np.ndarray:
    """Scale factors [-] as a float array: 1-D, finite, >= 0 and strictly increasing."""
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
