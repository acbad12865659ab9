"""Housner peaks between samples just above the uplift threshold: rockjax's ``theta_max`` at
its default step (and a quarter of it) against the event-driven reference of
``tests/test_housner_events.py``, with the conditioning screen.

Run: ``python experiments/housner_peaks.py`` (about 10 min on one core; references cached in
``experiments/results/housner_peaks_reference.json``). Writes
``experiments/results/housner_peaks.csv``, prints a table and the well-conditioned cases in the
form of ``NEAR_CASES`` of the test.

Cases: 6 s of each FEMA P695 far-field component with native step 0.01 s (from 2 s before its
largest ``|a_g|``; one-sided signed so that it pushes the block off the wall), scaled to PGA =
1.05, 1.15 or 1.3 ``g tan(eta)``, on the 0.2 x 1.5 m, 0.25 x 3 m and 0.375 x 6.44 m blocks, two-
and one-sided, ``e`` the model default; two (block, PGA) pairs per component and mode, in turn.

Screen: the reference runs at the scale and at ``(1 -+ 1e-4)`` of it; a case is kept when
the block lifts, none of the three overturns and their peaks ``max|theta|/eta`` differ by less
than half the test tolerance, ``0.5 (PEAK_RTOL peak + NEAR_PEAK_ATOL)``.
"""

from __future__ import annotations

import csv
import json
import math
import pathlib
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests"))
from test_housner_events import (  # noqa: E402
    DT,
    NEAR_BLOCKS,
    NEAR_PEAK_ATOL,
    NEAR_PGAS,
    PEAK_RTOL,
    load_near_records,
    near_reference,
    near_rockjax,
)

RESULTS = pathlib.Path(__file__).parent / "results"
# Well-conditioned, but off for a reason other than the peak estimate (docs/verification.md):
# the reference goes on chattering (e = 0.995) where rockjax's rest rule rests the block by
# its second clause (a rebound whose gravity-only hop is below REST_HOP eta); the first
# flight's peak agrees to 1e-7, and with REST_HOP = 1e-12 rockjax gives the reference's peak.
REST_RULE = {("FF21a", 0.375, 6.44, "two_sided", 1.05)}


def candidates(keys):
    """Two (block, PGA) pairs per component and mode, cycling through the blocks and PGAs."""
    out = []
    for i, key in enumerate(sorted(keys)):
        for m, mode in enumerate(("two_sided", "one_sided")):
            for j in range(2):
                b, h = NEAR_BLOCKS[(i + j) % 3]
                pga = NEAR_PGAS[(i + m + 2 * j) % 3]
                out.append((key, b, h, mode, pga))
    return out


def main():
    recs = load_near_records()
    cases = candidates(recs)
    cache_path = RESULTS / "housner_peaks_reference.json"
    cache = json.loads(cache_path.read_text()) if cache_path.exists() else {}
    t0 = time.time()
    for i, case in enumerate(cases):
        key = "|".join(map(str, case))
        if key in cache:
            continue
        runs = [near_reference(recs, case, f) for f in (1.0, 1.0 - 1e-4, 1.0 + 1e-4)]
        cache[key] = dict(
            peaks=[r["theta_max"] / r["eta"] for r in runs],
            over=[r["overturned"] for r in runs],
            impacts=runs[0]["n_impacts"],
        )
        cache_path.write_text(json.dumps(cache, indent=0))
        print(f"  reference {i + 1}/{len(cases)} ({time.time() - t0:.0f} s)", flush=True)
    runs = {dt: near_rockjax(recs, cases, dt) for dt in (None, DT / 4)}
    rows, kept = [], []
    for case in cases:
        ref = cache["|".join(map(str, case))]
        peak = ref["peaks"][0]
        spread = max(ref["peaks"]) - min(ref["peaks"])
        ok = (
            peak > 0 and not any(ref["over"]) and spread < 0.5 * (PEAK_RTOL * peak + NEAR_PEAK_ATOL)
        )
        row = dict(
            record=case[0],
            b=case[1],
            h=case[2],
            mode=case[3],
            pga_g_tan_eta=case[4],
            ref=peak,
            ref_spread=spread,
            ref_impacts=ref["impacts"],
            conditioned=ok,
        )
        for dt, name in ((None, "default"), (DT / 4, "quarter")):
            got, over, status = runs[dt][case]
            row[name] = got
            row[f"{name}_status"] = status
            row[f"{name}_err"] = (got - peak) / peak if peak > 0 and not over else math.nan
            row[f"{name}_within"] = abs(got - peak) <= PEAK_RTOL * peak + NEAR_PEAK_ATOL
        rows.append(row)
        row["rest_rule"] = case in REST_RULE
        if ok and case not in REST_RULE:
            kept.append((*case, float(f"{peak:.9g}")))
    with open(RESULTS / "housner_peaks.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(
        f"{'record':7s} {'block':9s} {'mode':9s} {'PGA':>5s} {'ref/eta':>10s} {'spread':>8s} "
        f"{'impacts':>7s} {'default err':>11s} {'dt/4 err':>9s}"
    )
    for r in rows:
        print(
            f"{r['record']:7s} {r['b']:.3g}x{r['h']:<5.3g} {r['mode']:9s} {r['pga_g_tan_eta']:5.2f} "
            f"{r['ref']:10.3e} {r['ref_spread']:8.1e} {r['ref_impacts']:7d} "
            f"{r['default_err']:11.2e} {r['quarter_err']:9.2e}"
            + ("" if r["conditioned"] else "  (screened out)")
            + ("  (rest rule)" if r["rest_rule"] else "")
        )
    good = [r for r in rows if r["conditioned"] and not r["rest_rule"]]
    for name in ("default", "quarter"):
        worst = max(abs(r[f"{name}_err"]) for r in good)
        within = sum(r[f"{name}_within"] for r in good)
        print(f"{name}: {within}/{len(good)} within tolerance, worst relative error {worst:.2e}")
    n_cond = sum(r["conditioned"] for r in rows)
    print(f"well-conditioned: {n_cond} of {len(rows)}; compared: {len(good)}")
    print("NEAR_CASES = [")
    for c in kept:
        print(f"    {c!r},")
    print("]")


if __name__ == "__main__":
    main()
