"""Benchmark of a DEM IDA over the FEMA P695 near-field set (target: <= 60 s on 2 cores).

One geometry (the paper's 0.25 x 3 m parapet), the 56 near-field components x 40 scale factors
(0.05-2.0) = 2240 DEM runs, ``beta = beta_DeJong``, through ``rj.ida`` (records grouped by their
``dt``, one compiled batch per group, chunks of 256). Timed twice: the first call includes the
compilations (one per distinct ``dt``), the second reuses them. Side by side in the same run,
the same IDA with every record first resampled to the finest ``dt`` of the set (0.0024 s), as
``rj.ida`` did before it grouped by ``dt``, and both variants with the Housner model
(``--no-compare`` skips these).

    python benchmarks/bench_ida.py [--no-compare]     # needs the extra: pip install -e ".[records]"

Prints the table quoted in docs/benchmarks.md ("## IDA") and writes benchmarks/results/ida.json.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import pathlib
import platform
import time

import jax
import numpy as np
from _timing import load

import rockjax as rj

SCALES = np.linspace(0.05, 2.0, 40)
TARGET_S = 60.0  # the target: <= 60 s on these 2 cores, compilation included
RESULTS = pathlib.Path(__file__).parent / "results" / "ida.json"


def run(block, records, beta, model="dem"):
    t0 = time.perf_counter()
    model = rj.as_model(model, beta=beta if model == "dem" else None)
    ds = rj.ida(block, records, SCALES, model=model, progress=False)
    return ds, time.perf_counter() - t0


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--no-compare", action="store_true", help="skip the resampled-to-finest run")
    args = p.parse_args()
    print(
        f"rockjax IDA benchmark  {datetime.datetime.now(datetime.UTC).isoformat(timespec='seconds')}"
        f"\n  python {platform.python_version()}, jax {jax.__version__}, {os.cpu_count()} cores; "
        f"load at start {load()}"
    )
    records = list(rj.records.fema_p695("nearfield"))
    block = rj.Block(b=0.25, h=3.0)
    beta = float(rj.beta_dejong(block))
    dts = sorted({r.dt for r in records})
    dt_bound = rj.stable_dt(block, beta)
    print(
        f"  {len(records)} near-field components x {SCALES.size} scales = "
        f"{len(records) * SCALES.size} DEM runs; record dt in {dts} s; beta = {beta:.4g} s; "
        f"DEM step bound {dt_bound:.3g} s"
    )
    ds, t_first = run(block, records, beta)
    _, t_second = run(block, records, beta)
    block_steps = float(np.sum(ds.attrs["t_end"] / ds["dt_step"].values) * SCALES.size)
    rows = {
        "grouped_by_dt": {
            "first_call_s": t_first,
            "second_call_s": t_second,
            "block_steps": block_steps,
            "block_steps_per_s": block_steps / t_second,
            "collapsed": int(ds["collapse"].sum()),
            "failed": int((ds["status"] != 0).sum()),
        }
    }
    print(
        f"  grouped by dt: first call {t_first:.1f} s (with compilation), second {t_second:.1f} s; "
        f"{block_steps:.3g} block-steps ({block_steps / t_second:.3g}/s); "
        f"collapsed {rows['grouped_by_dt']['collapsed']}, failed {rows['grouped_by_dt']['failed']}"
    )
    if not args.no_compare:
        finest = min(dts)
        resampled = [r if r.dt == finest else r.resampled(finest) for r in records]
        ds_r, t_r = run(block, resampled, beta)
        block_steps_r = float(np.sum(ds_r.attrs["t_end"] / ds_r["dt_step"].values) * SCALES.size)
        agree = float(np.mean(ds_r["collapse"].values == ds["collapse"].values))
        rows["resampled_to_finest"] = {
            "first_call_s": t_r,
            "block_steps": block_steps_r,
            "collapse_agreement": agree,
        }
        print(
            f"  all resampled to {finest} s (the former rj.ida): {t_r:.1f} s with compilation, "
            f"{block_steps_r:.3g} block-steps; ratio {t_r / t_first:.2f}x the grouped first call; "
            f"collapse flags agree on {agree:.1%} of the runs"
        )
        # Housner: its step follows the record step, so resampling costs steps, not just time
        ds_h, th1 = run(block, records, beta, "housner")
        _, th2 = run(block, records, beta, "housner")
        ds_hr, thr = run(block, resampled, beta, "housner")
        agree_h = float(np.mean(ds_hr["collapse"].values == ds_h["collapse"].values))
        rows["housner"] = {
            "grouped_first_call_s": th1,
            "grouped_second_call_s": th2,
            "resampled_first_call_s": thr,
            "collapse_agreement": agree_h,
        }
        print(
            f"  Housner (e_H), grouped by dt: {th1:.1f} s with compilation, {th2:.1f} s warm; "
            f"resampled to {finest} s: {thr:.1f} s with compilation ({thr / th1:.2f}x); collapse "
            f"flags agree on {agree_h:.1%}"
        )
    verdict = "PASS" if t_first <= TARGET_S else "FAIL"
    print(f"  {verdict}: 56 x 40 DEM IDA <= {TARGET_S:g} s including compilation ({t_first:.1f} s)")
    print(f"  load at end {load()}")
    RESULTS.parent.mkdir(exist_ok=True)
    RESULTS.write_text(
        json.dumps(
            {
                "command": "python benchmarks/bench_ida.py",
                "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
                "n_records": len(records),
                "n_scales": int(SCALES.size),
                "beta_s": beta,
                "results": rows,
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
