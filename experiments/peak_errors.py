"""How far an IDA's peaks are from a reference IDA of the same runs: the measure of the facade
step studies (``facade_ida_step.py``, ``facade_open_steps.py``, ``facade_ida_accuracy.py``).

A run counts when both it and its reference finished (status 0); its peak ``d/b`` is
compared where neither collapsed and the reference rocks (``d/b >= ROCKS``): the relative
error ``|d / d_ref - 1|``. Collapse flags are compared over every run that counts.
"""

from __future__ import annotations

import numpy as np

ROCKS = 0.01
"""Peak ``d/b`` of the reference from which a run counts as rocking [-]: below it the block
barely lifts and a relative error of its peak says little."""

OVER = 0.02
"""The error counted as large [-]: the 2 % to which the default steps are held."""


def peak_errors(d, c, d_ref, c_ref, ok=None) -> dict:
    """Peak ``d/b`` errors and collapse disagreements of runs against their reference.

    Args:
        d, c: Peak ``d/b`` [-] and collapse flags of the runs (arrays of one shape).
        d_ref, c_ref: The same of the reference runs.
        ok: Which runs count (e.g. both statuses 0, or the reference conditioned); None: all.

    Returns:
        ``runs`` (counted), ``collapse_agrees`` (their fraction), ``collapse_differs``,
        ``rocking_standing`` (the runs whose peak is compared) and, over those, the relative
        error's ``err_median``, ``err_p90``, ``err_p95``, ``err_max`` and ``err_over_2pct``
        (how many exceed :data:`OVER`).
    """
    d, d_ref = np.asarray(d, float), np.asarray(d_ref, float)
    c, c_ref = np.asarray(c, bool), np.asarray(c_ref, bool)
    ok = np.ones(d.shape, bool) if ok is None else np.asarray(ok, bool)
    stand = ok & ~c & ~c_ref & (d_ref >= ROCKS)
    err = np.abs(d[stand] / d_ref[stand] - 1.0)
    q = np.quantile(err, [0.5, 0.9, 0.95]) if err.size else np.full(3, np.nan)
    return {
        "runs": int(ok.sum()),
        "collapse_agrees": float(np.mean(c[ok] == c_ref[ok])),
        "collapse_differs": int(np.sum(c[ok] != c_ref[ok])),
        "rocking_standing": int(stand.sum()),
        "err_median": float(q[0]),
        "err_p90": float(q[1]),
        "err_p95": float(q[2]),
        "err_max": float(err.max()) if err.size else float("nan"),
        "err_over_2pct": int(np.sum(err > OVER)),
    }
