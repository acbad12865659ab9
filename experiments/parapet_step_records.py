"""Which step a DEM parapet's peak needs on real records, near the uplift threshold and above.

A parapet's default step (``rj.Parapet.dt_accuracy`` = 1.0 with the integrated face law) is
set for its first impact: the first-impact restitution within 1e-3 of its ``dt -> 0`` limit
(docs/verification.md, "DEM time step: convergence"). An IDA reads another number, the peak
``d/b`` under a record. This study runs two parapets, the 0.2 x 1.5 m and the paper's
0.25 x 3 m block, each at ``beta_DeJong`` and at the ``beta`` fitted to Housner's
restitution ``e_H`` (``rj.fit_beta(block, e=rj.e_housner(block))``, 2.5-6 times smaller: a
larger default step), under every second component of the FEMA P695
far-field set (22, each normalised to PGA = 1 g) at PGAs from below the quasi-static uplift
acceleration ``g b / h`` to about three times it, through ``rj.ida``, at ``accuracy`` 1.0 (the
default), 0.7 and 0.5, and 1.8 (where ``omega_max dt`` at ``beta_DeJong`` is what the
default gives at the fitted ``beta``), against a reference at 0.25 (a quarter of the default
step). Each fitted ``beta`` runs again rounded to four digits: the largest errors come from a
few runs near a bifurcation, which a change of ``beta`` in its fifth digit moves.

Rocking under a record is chaotic near overturning: a run whose reference is not converged
says nothing about the default. So the reference is screened for conditioning: a run counts
where the reference and a run at half its step (accuracy 0.125) agree in the collapse flag
and in the peak ``d/b`` to :data:`CONDITIONED` (relative); the others are counted apart.

It prints, per block, ``beta`` and accuracy, the conditioned runs whose collapse flag differs
from the reference's, and the relative error of the peak ``d/b`` of the conditioned runs
that stand in both, in two bands of the reference's peak: ``d/b >= 0.01`` (rocking) and
``0.001 <= d/b < 0.01`` (at the uplift threshold): median, 95th percentile, largest, and the
record and PGA of the largest, and how many are off by more than 5 %; and the same over every
run, unscreened. Quoted in
docs/verification.md ("Parapets on records: the default step").

    python experiments/parapet_step_records.py [--out experiments/results/parapet_step_records]
"""

from __future__ import annotations

import argparse
import itertools
import json
import pathlib
import time

import numpy as np

import rockjax as rj
from rockjax.constants import G

BLOCKS = {"0.2 x 1.5 m": rj.Block(b=0.2, h=1.5), "0.25 x 3 m": rj.Block(b=0.25, h=3.0)}
UPLIFT_MULTIPLES = np.array([0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 3.0])  # x the uplift PGA g b / h
ACCURACIES = (1.8, 1.0, 0.7, 0.5)  # 1.8: omega_max dt at beta_DeJong as at the fitted beta
REFERENCE_ACCURACY = 0.25
CHECK_ACCURACY = 0.125  # half the reference's step: screens the reference
CONDITIONED = 1e-3
"""Largest relative difference of the peak ``d/b`` between the reference and the run at half
its step for a run to count as conditioned (both converge as ``dt^2``, so the reference's own
error is about a third of it)."""
BANDS = {"rocking (d/b >= 0.01)": (0.01, np.inf), "uplift (0.001 <= d/b < 0.01)": (1e-3, 0.01)}


def conditioned(ref, check) -> np.ndarray:
    """The runs whose reference is converged: the same collapse flag and peak ``d/b`` within
    :data:`CONDITIONED` at half its step."""
    ok = (ref["status"].values == 0) & (check["status"].values == 0)
    same = ref["collapse"].values == check["collapse"].values
    d, d2 = ref["max_d_over_b"].values, check["max_d_over_b"].values
    close = np.abs(d2 / np.where(d > 0, d, 1.0) - 1.0) <= CONDITIONED
    return ok & same & (ref["collapse"].values | close)


def compare(ds, ref, band, keep) -> dict:
    ok = (ds["status"].values == 0) & (ref["status"].values == 0) & keep
    c, c_ref = ds["collapse"].values, ref["collapse"].values
    d, d_ref = ds["max_d_over_b"].values, ref["max_d_over_b"].values
    lo, hi = band
    sel = ok & ~c & ~c_ref & (d_ref >= lo) & (d_ref < hi)
    err = np.full(d.shape, np.nan)
    err[sel] = np.abs(d[sel] / d_ref[sel] - 1.0)
    out = {"runs": int(sel.sum()), "collapse_differs": int(np.sum(c[ok] != c_ref[ok]))}
    if sel.any():
        i, j = np.unravel_index(np.nanargmax(err), err.shape)
        e = err[sel]
        out |= {
            "over_5pct": int(np.sum(e > 0.05)),
            "median": float(np.median(e)),
            "p95": float(np.percentile(e, 95)),
            "max": float(e.max()),
            "worst": f"{ds['record'].values[i]} at {float(ds['pga_scaled'].values[i, j]) / G:.3g} g",
            "worst_d_over_b": [float(d[i, j]), float(d_ref[i, j])],
        }
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="experiments/results/parapet_step_records")
    args = ap.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    recs = [r.scaled_to_pga(target_pga_g=1.0) for r in rj.records.fema_p695("farfield")][::2]
    print(f"rockjax {rj.__file__}; {len(recs)} far-field components", flush=True)
    summary: dict = {}
    cases = []
    for name, block in BLOCKS.items():
        fit = rj.fit_beta(block, e=rj.e_housner(block))
        cases.append((f"{name}, beta_DeJong", block, float(rj.beta_dejong(block))))
        cases.append((f"{name}, beta fitted to e_H", block, float(fit.beta)))
        # the same rounded to 4 digits: how much the tail hangs on a few runs near a bifurcation
        rounded = float(f"{float(fit.beta):.4g}")
        cases.append((f"{name}, beta fitted to e_H rounded to {rounded:.4g} s", block, rounded))
    for name, block, beta in cases:
        pgas = UPLIFT_MULTIPLES * block.b / block.h  # [g]
        print(f"{name}: beta {beta:.4g} s, PGA {np.round(pgas, 3).tolist()} g", flush=True)

        def ida(acc, block=block, beta=beta, pgas=pgas):
            t0 = time.perf_counter()
            model = rj.DEM(beta=beta, accuracy=acc)
            ds = rj.ida(block, recs, pgas, model=model, progress=False)
            return ds, time.perf_counter() - t0

        ref, t_ref = ida(REFERENCE_ACCURACY)
        check, t_check = ida(CHECK_ACCURACY)
        keep = conditioned(ref, check)
        print(
            f"  reference, accuracy {REFERENCE_ACCURACY}: {t_ref:.1f} s; at {CHECK_ACCURACY}: "
            f"{t_check:.1f} s; conditioned runs {int(keep.sum())} of {keep.size}",
            flush=True,
        )
        rows = {"conditioned_runs": int(keep.sum()), "runs": int(keep.size)}
        for acc in ACCURACIES:
            ds, t = ida(acc)
            rows[str(acc)] = {"time_s": t}
            every = np.ones_like(keep)
            for (label, band), screened in itertools.product(BANDS.items(), (True, False)):
                row = compare(ds, ref, band, keep if screened else every)
                label = label + ("" if screened else ", unscreened")
                rows[str(acc)][label] = row
                stats = (
                    f"{row['over_5pct']} off by > 5 %; median {row['median']:.1e}, p95 {row['p95']:.1e}, max {row['max']:.1e} "
                    f"({row['worst']}: d/b {row['worst_d_over_b'][0]:.4f} against "
                    f"{row['worst_d_over_b'][1]:.4f})"
                    if row["runs"]
                    else "no runs"
                )
                print(
                    f"  accuracy {acc} ({t:.1f} s), {label}: {row['runs']} runs, collapse "
                    f"flags differ {row['collapse_differs']}; {stats}",
                    flush=True,
                )
        summary[name] = {"beta": beta, "pga_g": pgas.tolist(), "accuracies": rows}
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    print(f"wrote {out / 'summary.json'}")


if __name__ == "__main__":
    main()
