"""What the DEM facade IDA costs, and which step its outputs need.

A facade's DEM step is set for its bounces where its return wall is in reach
(``rj.Facade.dt_accuracy`` = 0.35: rebound peaks within 2 % of a 16x finer step,
docs/verification.md), and for its base alone elsewhere (its open steps); a parapet's for its
first impact (1.0). An IDA reads two numbers of each run: the peak ``d/b`` and the collapse flag. This
study runs the FEMA P695 far-field set (44 components, each normalised to PGA = 1 g) at 20
PGAs (0.05-2 g, geometric) on the 0.2 x 1.5 m block with a 1 mm gap (``rj.Facade(gap=0.001)``) at its calibrated ``beta``:

1. **Cost**: the same IDA as a parapet, as a facade at the default step, with Housner, and as
   a facade whose return wall is out of reach (a 0.5 m gap: every sample in open steps, the
   floor of a facade's cost under its open steps' accuracy), as a parapet at the
   facade's step accuracy (``rj.Facade.dt_accuracy``: the two at equal accuracy), and as a
   parapet at its own calibrated ``beta`` (the parapet study a user would run),
   each timed on its second call (warm: compiled), with its chunks in threads (the default,
   ``rockjax.ida.host_threads``) and one at a time (``devices`` named). Run it with another
   checkout on ``PYTHONPATH`` to time that code alike.
2. **Step**: the facade IDA at ``accuracy`` 0.35 (the default), 0.7 and 1.0 against a
   reference at 0.175 (half the default step): the share of runs whose collapse flag agrees,
   and the error of the peak ``d/b`` of the runs that stand in both, relative to the
   reference's (median, 95th percentile, largest), over the runs that rock (reference
   ``d/b >= 0.01``).
3. **The parapets compared** (``--parapets``): how accurate the parapet IDAs of part 1 are,
   the parapet at the facade's ``beta`` and at its own (``beta`` fitted to Housner's
   ``e_H``, ``rj.fit_beta(block, e=rj.e_housner(block))``), each at ``accuracy`` 1.0 (its
   default) and 0.35 against a reference at a quarter of 0.35, compared as in part 2; and
   the reference's own conditioning: the reference again with every PGA scaled by
   ``1 + 1e-6``, compared with it alike (rocking under records is chaotic near overturning:
   what that perturbation changes, no step can be asked to hold).

    python experiments/facade_ida_step.py [--out experiments/results/facade_ida_step] [--cost | --parapets]

``beta`` is fitted once (``rj.fit_beta(block, mode=rj.Facade(gap=0.001))``, the facade's
default target: its bounces) and kept in ``beta.json``, the parapet's own likewise in
``parapet_beta.json``. Writes ``summary.json`` and prints the
tables quoted in docs/benchmarks.md ("Facade IDA: cost and step").
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import time
import warnings

import jax
import numpy as np
from peak_errors import peak_errors

import rockjax as rj
from rockjax.ida import host_threads

BLOCK = rj.Block(b=0.2, h=1.5)
GAP = 0.001  # [m]
SCALES_G = np.geomspace(0.05, 2.0, 20)  # PGA of the scaled record [g]
REFERENCE_ACCURACY = 0.175
ACCURACIES = (0.35, 0.7, 1.0)
FAR_GAP = 0.5  # [m]: a return wall the block never reaches (cost part only)
EQUAL = "parapet DEM, facade accuracy"  # (cost part only)
OWN = "parapet DEM, its own beta"  # (cost part only)
PERTURBATION = 1e-6  # relative change of every PGA that screens a reference (part 3)


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def records():
    """The far-field set, each component normalised to PGA = 1 g: a scale is the PGA in g."""
    return [r.scaled_to_pga(target_pga_g=1.0) for r in rj.records.fema_p695("farfield")]


def beta_of(path: pathlib.Path, about: dict, **fit) -> float:
    """``beta`` [s] kept in ``path``, or ``rj.fit_beta(BLOCK, **fit)`` kept there with
    ``about`` (what it was fitted for)."""
    if path.is_file():
        return float(json.loads(path.read_text())["beta"])
    beta = float(rj.fit_beta(BLOCK, **fit).beta)
    path.write_text(json.dumps({"beta": beta, "block": [0.2, 1.5]} | about))
    return beta


def ida(recs, scales, model, mode, chunk_size=None, devices=None):
    t0 = time.perf_counter()
    ds = rj.ida(
        BLOCK, recs, scales, model=model, mode=mode, chunk_size=chunk_size, progress=False,
        devices=devices,
    )  # fmt: skip
    return ds, time.perf_counter() - t0


def compare(ds, ref) -> dict:
    """:func:`peak_errors` of an IDA Dataset against the reference's, over the runs that
    finished in both."""
    ok = (ds["status"].values == 0) & (ref["status"].values == 0)
    return peak_errors(
        ds["max_d_over_b"].values, ds["collapse"].values,
        ref["max_d_over_b"].values, ref["collapse"].values, ok,
    )  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="experiments/results/facade_ida_step")
    ap.add_argument("--quick", action="store_true", help="4 components x 5 scales (a smoke run)")
    part = ap.add_mutually_exclusive_group()
    part.add_argument("--cost", action="store_true", help="part 1 only (the cost)")
    part.add_argument(
        "--parapets", action="store_true", help="part 3 only (the compared parapets' accuracy)"
    )
    args = ap.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    facade = rj.Facade(gap=GAP)
    recs = records()
    scales = SCALES_G
    if args.quick:
        recs, scales = recs[:4], SCALES_G[::4]
    beta = beta_of(out / "beta.json", {"gap": GAP}, mode=facade)
    # (the 0.5 m gap is meant: the warning that it is wider than any joint is not for it)
    warnings.filterwarnings("ignore", message="gap=0.5 m is wider")
    print(f"rockjax {rj.__file__}")
    print(f"facade IDA study: {len(recs)} far-field components x {scales.size} scales, "
          f"0.2 x 1.5 m, gap {GAP} m, beta {beta:.4g} s; load {load()}", flush=True)  # fmt: skip
    # the parapet's own: fitted to Housner's e_H
    beta_p = beta_of(out / "parapet_beta.json", {"e": "e_H"}, e=rj.e_housner(BLOCK))
    print(f"the parapet's own beta (fitted to e_H): {beta_p:.4g} s", flush=True)
    summary: dict = {"beta": beta, "n_records": len(recs), "n_scales": int(scales.size)}
    if args.parapets:
        summary["parapets"] = parapets(recs, scales, {"facade's": beta, "own": beta_p})
        (out / "summary_parapets.json").write_text(json.dumps(summary, indent=2))
        print(f"load at end {load()}")
        return

    # 1. cost, warm
    cost = {}
    for name, model, mode, chunk in (
        ("parapet DEM", rj.DEM(beta=beta), rj.Parapet(), None),
        ("facade DEM", rj.DEM(beta=beta), facade, None),
        ("facade Housner", rj.Housner(), facade.without_gap(), None),  # flush on its walls
        # the floor of the facade's cost: its wall never in reach (every sample in open steps;
        # it rocks as the parapet does)
        ("facade DEM, wall out of reach", rj.DEM(beta=beta), rj.Facade(gap=FAR_GAP), None),
        # the parapet at the facade's step accuracy: what the facade's wall and open steps
        # cost at equal accuracy
        (EQUAL, rj.DEM(beta=beta, accuracy=rj.Facade.dt_accuracy), rj.Parapet(), None),
        # the same block as a parapet study runs it: at its own calibrated beta, default step
        (OWN, rj.DEM(beta=beta_p), rj.Parapet(), None),
    ):
        _, first = ida(recs, scales, model, mode, chunk)
        ds, warm = ida(recs, scales, model, mode, chunk)
        # the chunks one at a time (devices named), as before they ran in threads
        one, serial = ida(recs, scales, model, mode, chunk, devices=jax.local_devices())
        same = bool(one.drop_attrs().identical(ds.drop_attrs()))
        cost[name] = {"first_s": first, "warm_s": warm, "one_thread_s": serial, "same": same}
        print(
            f"  {name:<26} first call {first:7.1f} s, warm {warm:7.1f} s; one chunk at a "
            f"time {serial:7.1f} s ({serial / warm:.2f}x; results identical: {same})",
            flush=True,
        )
    ratio = cost["facade DEM"]["warm_s"] / cost["parapet DEM"]["warm_s"]
    floor = cost["facade DEM, wall out of reach"]["warm_s"] / cost["parapet DEM"]["warm_s"]
    equal = cost["facade DEM"]["warm_s"] / cost[EQUAL]["warm_s"]
    own = cost["facade DEM"]["warm_s"] / cost[OWN]["warm_s"]
    print(
        f"  facade / parapet (warm): {ratio:.2f}x; with its wall out of reach {floor:.2f}x; "
        f"facade / parapet at the facade's accuracy {equal:.2f}x; facade / parapet at its "
        f"own beta {own:.2f}x; threads {host_threads()}",
        flush=True,
    )
    summary["cost"] = cost
    if args.cost:
        print(f"load at end {load()}")
        return

    # 2. the step the IDA's outputs need
    ref, t_ref = ida(recs, scales, rj.DEM(beta=beta, accuracy=REFERENCE_ACCURACY), facade)
    print(f"  reference, accuracy {REFERENCE_ACCURACY}: {t_ref:.1f} s", flush=True)
    steps = {}
    for acc in ACCURACIES:
        ds, t = ida(recs, scales, rj.DEM(beta=beta, accuracy=acc), facade)
        row = compare(ds, ref) | {"time_s": t}
        steps[str(acc)] = row
        print(
            f"  accuracy {acc:<5} {t:7.1f} s; collapse flags agree {row['collapse_agrees']:.2%} "
            f"({row['collapse_differs']} differ); peak d/b of {row['rocking_standing']} rocking "
            f"runs: median {row['err_median']:.2e}, p95 {row['err_p95']:.2e}, "
            f"max {row['err_max']:.2e}",
            flush=True,
        )
    summary["step"] = steps
    summary["load_end"] = load()
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    print(f"load at end {load()}")


def parapets(recs, scales, betas: dict) -> dict:
    """Part 3: each parapet IDA of part 1 against a reference at a quarter of the facade's
    step accuracy, and that reference's conditioning (:data:`PERTURBATION`)."""
    acc_ref = 0.25 * rj.Facade.dt_accuracy
    rows = {}
    for name, beta in betas.items():
        model = rj.DEM(beta=beta, accuracy=acc_ref)
        ref, t_ref = ida(recs, scales, model, rj.Parapet())
        moved, _ = ida(recs, scales * (1.0 + PERTURBATION), model, rj.Parapet())
        print(f"  parapet, {name} beta {beta:.4g} s: reference (accuracy {acc_ref}) "
              f"{t_ref:.1f} s", flush=True)  # fmt: skip
        rows[name] = {"beta": beta, f"PGA x (1 + {PERTURBATION:g})": compare(moved, ref)}
        for acc in (1.0, rj.Facade.dt_accuracy):
            ds, t = ida(recs, scales, rj.DEM(beta=beta, accuracy=acc), rj.Parapet())
            rows[name][f"accuracy {acc}"] = compare(ds, ref) | {"time_s": t}
        for label, row in rows[name].items():
            if label == "beta":
                continue
            print(
                f"    {label:<22} collapse flags differ {row['collapse_differs']:3d}; peak d/b "
                f"of {row['rocking_standing']} rocking runs: median {row['err_median']:.2e}, "
                f"p95 {row['err_p95']:.2e}, max {row['err_max']:.2e}",
                flush=True,
            )
    return rows


if __name__ == "__main__":
    main()
