"""Convergence of the sampled spectral peak with the sub-steps per oscillator period.

rockjax.spectra takes the spectral peak over the computed samples; the exact recurrence has no
stability limit, so the only error is the peak missed between samples. This script measures it
on the FEMA P695 near-field records (both components of the 28 records) for periods from
0.02 s to 5 s: for each number N of sub-steps per period of the shortest oscillator, the
largest relative error of Sa against a reference with 16 times finer sub-steps.

    python experiments/spectra_convergence.py
"""

import math
import time

import numpy as np

import rockjax as rj
from rockjax import spectra

PERIODS = np.geomspace(0.02, 5.0, 40)


def sa(gm, periods, n_sub):
    return np.asarray(spectra.response_spectrum(gm, periods, n_sub=n_sub).sa)


def main():
    recs = rj.records.fema_p695("nearfield")
    print(
        f"{len(recs)} components, dt from {min(r.dt for r in recs)} to "
        f"{max(r.dt for r in recs)} s; periods {PERIODS[0]}..{PERIODS[-1]} s"
    )
    print("N (sub-steps per shortest period) | max rel. error of Sa | median | time [s]")
    for n_per in (5, 10, 20, 40, 80):
        errs, t_run = [], 0.0
        for r in recs:
            # one n_sub per record, as the automatic choice makes it, and a 16x finer reference
            n_sub = max(1, math.ceil(n_per * r.dt / PERIODS[0] - 1e-9))
            start = time.perf_counter()
            got = sa(r, PERIODS, n_sub)
            t_run += time.perf_counter() - start
            ref = sa(r, PERIODS, 16 * n_sub)
            errs.append(np.max(np.abs(got / ref - 1.0)))
        errs = np.array(errs)
        print(f"{n_per:4d} | {errs.max():.2e} | {np.median(errs):.2e} | {t_run:.1f}")


if __name__ == "__main__":
    main()
