"""The collapsing scale intervals of an IDA, per record."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .._lazy import lazy_module
from ..response import STATUS_OK

xr = lazy_module("xarray")  # loaded on first use (rockjax/_lazy.py)


class CollapseIntervals(NamedTuple):
    """Result of :func:`collapse_intervals`.

    Attributes:
        intervals: Record name -> list of ``(lo, hi)`` scale factors: the lowest and highest
            sampled scale of each contiguous run of collapsed scales, in increasing order.
        lowest: Lowest collapsed scale factor per record [-] (NaN where none collapsed), an
            ``xarray.DataArray`` over ``record``.
    """

    intervals: dict[str, list[tuple[float, float]]]
    lowest: xr.DataArray


def collapse_intervals(ds: xr.Dataset) -> CollapseIntervals:
    """Contiguous intervals of collapsing scale factors per record, from an :func:`ida` Dataset.

    IDA curves of rocking blocks are not monotonic: a record that overturns a block at one
    scale may leave it standing at a larger one ("resurrection"), so there can be several
    intervals. An interval ``(lo, hi)`` spans sampled scales: every sampled scale from ``lo`` to
    ``hi`` collapsed, and the sampled scales next to it (if any) did not. Runs with a nonzero
    ``status`` are left out (their neighbours decide), so a failed run neither splits nor
    creates an interval.

    Args:
        ds: A Dataset with dims ``("record", "scale")`` and variables ``collapse`` and
            ``status``, as :func:`ida` returns.

    Returns:
        A :class:`CollapseIntervals` ``(intervals, lowest)``.

    Raises:
        ValueError: if ``ds`` lacks the ``collapse`` or ``status`` variables.
    """
    for var in ("collapse", "status"):
        if var not in ds:
            raise ValueError(
                f"ds has no {var!r} variable; pass the Dataset that rj.ida returns "
                f"(it has {sorted(ds.data_vars)})."
            )
    ds = ds.sortby("scale")
    scales = np.asarray(ds["scale"], float)
    collapse = np.asarray(ds["collapse"].transpose("record", "scale"), bool)
    ok = np.asarray(ds["status"].transpose("record", "scale")) == STATUS_OK
    names = [str(r) for r in np.asarray(ds["record"])]
    intervals: dict[str, list[tuple[float, float]]] = {}
    lowest = np.full(len(names), np.nan)
    for i, name in enumerate(names):
        s, c = scales[ok[i]], collapse[i][ok[i]]
        edges = np.diff(np.concatenate([[0], c.astype(np.int8), [0]]))
        starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
        intervals[name] = [(float(s[a]), float(s[b])) for a, b in zip(starts, stops)]
        if starts.size:
            lowest[i] = s[starts[0]]
    da = xr.DataArray(lowest, coords={"record": ds["record"]}, dims=("record",))
    da.attrs["long_name"] = "lowest collapse scale factor"
    return CollapseIntervals(intervals=intervals, lowest=da)


# ----------------------------------------------------------------------------- plan, run, assemble
