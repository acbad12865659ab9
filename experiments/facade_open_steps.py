"""Which accuracy a one-block facade's open steps need (``rj.Facade.dt_accuracy_open``).

A facade takes its open steps (longer: set by its base joint alone) where its return wall is
out of reach, and steps of ``dt`` (set by the wall's springs too) elsewhere (docs/theory.md,
"Time stepping"). This study runs the 0.2 x 1.5 m facade, 1 mm off its wall, at its fitted
``beta``, under every second component of the FEMA P695 far-field set (22, each normalised to
PGA = 1 g) at six PGAs (0.05-0.4 g: from below uplift to near collapse), and compares the
peak ``d/b`` of each run with a reference that steps by a quarter of ``dt`` throughout:

* the uniform default step (every step ``dt``: what a facade took before the open steps);
* the open steps at ``dt_accuracy_open`` = 1.0 (a parapet's accuracy), 0.7, 0.5 and 0.35.

It prints, per row, the runs whose collapse flag differs from the reference's, and the
relative error of the peak ``d/b`` over the runs that stand in both and rock (reference
``d/b >= 0.01``): median, 95th percentile, largest. Quoted in docs/verification.md ("Open
steps").

    python experiments/facade_open_steps.py [--out experiments/results/facade_open_steps]
"""

from __future__ import annotations

import argparse
import json
import pathlib
import time

import jax
import jax.numpy as jnp
import numpy as np
from peak_errors import ROCKS, peak_errors

import rockjax as rj

BLOCK = rj.Block(b=0.2, h=1.5)
BETA = 3.01e-4  # [s], the facade's fitted beta (experiments/facade_ida_step.py)
GAP = 0.001  # [m]
PGAS_G = (0.05, 0.1, 0.16, 0.22, 0.29, 0.4)
OPEN_ACCURACIES = (1.0, 0.7, 0.5, 0.35)


def uniform(motion: rj.GroundMotion, dt: float):
    """Every step ``dt``: a concrete step inside ``jit`` (no open steps)."""

    def run(ag):
        gm = rj.GroundMotion(ag=ag, dt=motion.dt)
        return rj.simulate_dem(BLOCK, gm, beta=BETA, mode=rj.Facade(gap=GAP), dt=dt, throw=False)

    return jax.jit(run)(jnp.asarray(motion.ag))


def peak(r) -> tuple[float, bool]:
    return float(r.extras["d_max"]) / BLOCK.b, bool(r.overturned)


def stats(rows: np.ndarray, col: int) -> dict:
    """:func:`peak_errors` of the runs in columns ``col, col + 1`` against columns 0, 1."""
    return peak_errors(rows[:, col], rows[:, col + 1], rows[:, 0], rows[:, 1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="experiments/results/facade_open_steps")
    args = ap.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    recs = [r.scaled_to_pga(target_pga_g=1.0) for r in rj.records.fema_p695("farfield")][::2]
    mode = rj.Facade(gap=GAP)
    dt = rj.stable_dt(BLOCK, BETA, mode=mode)
    default_open = rj.Facade.dt_accuracy_open
    rows = []
    try:
        for rec in recs:
            for pga in PGAS_G:
                gm = rj.GroundMotion(ag=rec.ag * pga, dt=rec.dt)
                row = [*peak(uniform(gm, dt / 4)), *peak(uniform(gm, dt))]
                for acc in OPEN_ACCURACIES:
                    # (a class attribute read by every run's set-up: data, not a new program)
                    rj.Facade.dt_accuracy_open = acc
                    row += peak(rj.simulate_dem(BLOCK, gm, beta=BETA, mode=mode, throw=False))
                rows.append(row)
            print(f"  {rec.name}: done ({time.perf_counter() - t0:.0f} s)", flush=True)
    finally:
        rj.Facade.dt_accuracy_open = default_open
    rows = np.asarray(rows, float)
    summary = {"runs": len(rows), "uniform": stats(rows, 2)}
    for i, acc in enumerate(OPEN_ACCURACIES):
        summary[f"open {acc}"] = stats(rows, 4 + 2 * i)
    print(
        f"{len(rows)} runs; peak d/b against steps of dt/4 throughout ({ROCKS}+ rocking, standing):"
    )
    for name, s in summary.items():
        if name == "runs":
            continue
        print(
            f"  {name:<9} collapse flags differ {s['collapse_differs']}, peak d/b of "
            f"{s['rocking_standing']} runs: median {s['err_median']:.1e}, p95 "
            f"{s['err_p95']:.1e}, max {s['err_max']:.1e}"
        )
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    print(f"wrote {out / 'summary.json'} ({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
