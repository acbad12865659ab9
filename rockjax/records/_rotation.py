"""Rotation of two orthogonal horizontal components of a record to any azimuth."""

from __future__ import annotations

import math

import numpy as np

from ..motion import GroundMotion


def rotate(
    a: GroundMotion,
    b: GroundMotion,
    azimuth_a_deg: float | int,
    azimuth_b_deg: float | int,
    azimuth_deg: float | int,
    *,
    name: str | None = None,
) -> GroundMotion:
    r"""Rotate two orthogonal horizontal components to the azimuth ``azimuth_deg``.

    Azimuths are clockwise from north. The record along azimuth phi is the projection

    $$a(\varphi) = a_A\cos(\varphi - \theta_A) + a_B\cos(\varphi - \theta_B),$$

    which for ``theta_B = theta_A + 90`` is
    ``a_A cos(phi - theta_A) + a_B sin(phi - theta_A)``; e.g. Nahanni S1 to 280 degrees is
    ``-0.8660 a_070 - 0.5 a_160``. Rotating to ``theta_A`` returns ``a`` and to ``theta_B``
    returns ``b`` exactly, and ``a(phi)^2 + a(phi + 90)^2 = a_A^2 + a_B^2`` at every sample.
    A vertical component, if both records carry the same one, is kept.

    Args:
        a: First horizontal component.
        b: Second horizontal component, same ``dt`` and length as ``a``.
        azimuth_a_deg: Azimuth theta_A of ``a`` [deg], clockwise from north.
        azimuth_b_deg: Azimuth theta_B of ``b`` [deg], ``theta_A +- 90``.
        azimuth_deg: Target azimuth phi [deg].
        name: Name of the result; default ``"<a.name>_rot<azimuth>"``.

    Returns:
        The rotated record; its metadata keeps the entries ``a`` and ``b`` share and adds
        ``azimuth_deg`` and ``rotated_from``.

    Raises:
        ValueError: if the components are not orthogonal, differ in ``dt`` or length, or
            carry different vertical components.
    """
    gap = (azimuth_b_deg - azimuth_a_deg) % 360.0
    if min(abs(gap - 90.0), abs(gap - 270.0)) > 1e-6:
        raise ValueError(
            f"components must be orthogonal: azimuths {azimuth_a_deg} and {azimuth_b_deg} deg "
            f"are {gap:g} deg apart (mod 360), not +-90. Check the component azimuths, e.g. "
            "70 and 160 for Nahanni S1."
        )
    if not math.isclose(a.dt, b.dt, rel_tol=1e-9) or a.n != b.n:
        raise ValueError(
            f"components must share dt and length; got {a.name!r}: dt={a.dt} s, n={a.n} and "
            f"{b.name!r}: dt={b.dt} s, n={b.n}. Resample with .resampled(dt) and trim to "
            "the common length first."
        )
    if a.ag_v is None and b.ag_v is None:
        ag_v = None
    elif (
        a.ag_v is not None
        and b.ag_v is not None
        and np.array_equal(np.asarray(a.ag_v), np.asarray(b.ag_v))
    ):
        ag_v = a.ag_v
    else:
        raise ValueError(
            f"{a.name!r} and {b.name!r} carry different vertical components (ag_v); the "
            "rotated record can keep only one. Drop ag_v from both or give both the same."
        )
    ag = _cos_deg(azimuth_deg - azimuth_a_deg) * a.ag + _cos_deg(azimuth_deg - azimuth_b_deg) * b.ag
    shared = [item for item in a.meta if item in b.meta]
    meta = dict(shared)
    meta["azimuth_deg"] = f"{azimuth_deg:g}"
    meta["rotated_from"] = f"{a.name} ({azimuth_a_deg:g} deg), {b.name} ({azimuth_b_deg:g} deg)"
    name = f"{a.name}_rot{azimuth_deg:g}" if name is None else name
    return GroundMotion(ag=ag, dt=a.dt, name=name, ag_v=ag_v, meta=tuple(meta.items()))


def _cos_deg(angle_deg: float | int) -> float:
    # exact at multiples of 90 deg, so rotating to a component's own azimuth returns it
    # bit for bit instead of mixing in 6e-17 of the other one
    quarter = angle_deg / 90.0
    if quarter == round(quarter):
        return (1.0, 0.0, -1.0, 0.0)[int(round(quarter)) % 4]
    return math.cos(math.radians(angle_deg))
