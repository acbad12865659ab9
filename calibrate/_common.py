"""Shared helpers: progress lines, result writers (CSV/JSON with the producing command), fits."""

from __future__ import annotations

import csv
import shlex
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402

from rockjax import jsonio  # noqa: E402


def command_line() -> str:
    """The exact command that launched this process (``python -m calibrate ...``)."""
    return "python -m calibrate " + " ".join(shlex.quote(a) for a in sys.argv[1:])


class Progress:
    """Prints ``[study] n/N label (elapsed s)`` lines, flushed."""

    def __init__(self, study: str, total: int):
        self.study, self.total, self.n, self.t0 = study, total, 0, time.perf_counter()

    def step(self, label: str) -> None:
        """Count one geometry done and print a line with the wall time since the start [s]."""
        self.n += 1
        dt = time.perf_counter() - self.t0
        print(f"[{self.study}] {self.n}/{self.total} {label} ({dt:.0f} s)", flush=True)

    @property
    def elapsed(self) -> float:
        """Wall time since the start [s]."""
        return time.perf_counter() - self.t0


def write_csv(path: Path, rows: list[dict], note: str = "") -> None:
    """Write ``rows`` (dicts with the same keys) to CSV, headed by ``# command`` comment lines."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        f.write(f"# command: {command_line()}\n")
        if note:
            f.write(f"# {note}\n")
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})


def write_json(path: Path, payload: dict, seconds: float) -> None:
    """Write ``payload`` as JSON with the producing command, UTC date and wall time [s]."""
    path.parent.mkdir(parents=True, exist_ok=True)
    head = {
        "command": command_line(),
        "date_utc": time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime()),
        "wall_time_s": round(seconds, 1),
    }
    jsonio.write_json(path, {**head, **payload}, indent=1)


def linear_fit(x, y, intercept: float | None = None) -> dict:
    """Least-squares line ``y = a - s x``; with ``intercept`` given, ``a`` is fixed to it.

    Returns ``{"a", "slope" (s, positive for a falling line), "r2"}`` over the finite points.
    """
    x, y = np.asarray(x, float), np.asarray(y, float)
    m = np.isfinite(x) & np.isfinite(y)
    x, y = x[m], y[m]
    if intercept is None:
        k, a = np.polyfit(x, y, 1)
    else:
        a = intercept
        k = np.sum(x * (y - a)) / np.sum(x * x)
    res = y - (a + k * x)
    ss = np.sum((y - y.mean()) ** 2)
    return {"a": float(a), "slope": float(-k), "r2": float(1 - np.sum(res**2) / ss)}


def power_fit(x, y) -> dict:
    """Fit ``y = c x^k`` by least squares in log-log; returns ``{"c", "k", "r2"}`` (log space)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    m = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    lx, ly = np.log(x[m]), np.log(y[m])
    k, lc = np.polyfit(lx, ly, 1)
    res = ly - (lc + k * lx)
    r2 = 1 - np.sum(res**2) / np.sum((ly - ly.mean()) ** 2)
    return {"c": float(np.exp(lc)), "k": float(k), "r2": float(r2)}


def save_fig(fig, path: Path) -> None:
    """Save a matplotlib figure as PNG (150 dpi) and close it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    import matplotlib.pyplot as plt

    plt.close(fig)
