"""The paper's history error as the calibration loss (``rj.fit_beta(loss="history")``) against a
dense grid of that error, and the two losses' beta, on parapets and facades.

Per block: ``rj.fit_beta(block, e, loss="history")`` (L-BFGS on the weighted-mean time-history
error against Housner with ``e``: ``e_H``, Eq. 2, two-sided; ``|e_ISR|``, Eq. 5, one-sided,
from the bounce-loss optimum), and the history error on a grid of ``n`` points over
``[lo, hi] x`` the bounce-loss optimum (``rj.calibration.history_stat_batch``, the fit's own
statistic): the grid's global minimum and the grid's local minimum nearest the start.

    nice python experiments/history_loss.py [--out experiments/results] [--n 46]

Writes history_loss.csv (the grids) and history_loss.json (the summary quoted in
docs/calibration.md, "The history error as the loss"), and prints it.
"""

import argparse
import csv
import pathlib
import time

import numpy as np

import rockjax as rj
from rockjax import calibration as cal

BLOCKS = (  # b [m], h [m], mode
    (0.17, 1.5, "two_sided"),
    (0.20, 2.0, "two_sided"),
    (0.25, 3.0, "two_sided"),
    (0.20, 1.5, "one_sided"),
    (0.10, 1.0, "one_sided"),
    (0.35, 3.0, "one_sided"),
)


def target_e(blk, mode):
    return float(rj.e_housner(blk)) if mode == "two_sided" else abs(float(rj.e_isr(blk)))


def local_minima(err):
    i = np.arange(1, err.size - 1)
    return i[(err[i] <= err[i - 1]) & (err[i] <= err[i + 1])]


def case(b, h, mode, n, lo, hi, rows):
    blk = rj.Block(b=b, h=h)
    e = target_e(blk, mode)
    t0 = time.perf_counter()
    fit = rj.fit_beta(blk, e, target="e", mode=mode, loss="history", progress=False)
    t_fit = time.perf_counter() - t0
    beta_peaks = fit.beta_start  # the bounce-loss optimum it started from
    problem = cal.problem(blk, e, target="e", mode=mode)
    betas = beta_peaks * np.linspace(lo, hi, n)
    err = np.asarray(cal.history_stat_batch(problem, betas))
    for beta, x in zip(betas, err, strict=True):
        rows.append([b, h, mode, beta, beta / beta_peaks, x])
    mins = local_minima(err)
    i_start = int(np.argmin(np.abs(betas - beta_peaks)))
    near = int(mins[np.argmin(np.abs(mins - i_start))]) if mins.size else int(np.argmin(err))
    spacing = float(betas[1] - betas[0])
    return {
        "b_m": b,
        "h_m": h,
        "mode": mode,
        "e": e,
        "beta_peaks_s": beta_peaks,
        "history_error_at_peaks": float(np.interp(beta_peaks, betas, err)),
        "beta_history_s": fit.beta,
        "history_over_peaks": fit.beta / beta_peaks,
        "history_error_fit": fit.loss,
        "fit_converged": fit.converged,
        "fit_reason": fit.reason,
        "fit_target_met": fit.target_met,
        "fit_e_effective": fit.e_effective,
        "fit_runs": fit.n_simulations,
        "fit_seconds": t_fit,
        "grid_over_peaks": [lo, hi, n],
        "grid_global_min_over_peaks": float(betas[int(np.argmin(err))] / beta_peaks),
        "grid_global_min_error": float(err.min()),
        "grid_nearest_local_min_over_peaks": float(betas[near] / beta_peaks),
        "grid_nearest_local_min_error": float(err[near]),
        "fit_minus_nearest_over_spacing": (fit.beta - float(betas[near])) / spacing,
        "n_local_minima": int(mins.size),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="experiments/results")
    ap.add_argument("--n", type=int, default=46, help="grid points per block")
    ap.add_argument("--lo", type=float, default=0.5, help="grid start / bounce-loss beta")
    ap.add_argument("--hi", type=float, default=2.0, help="grid end / bounce-loss beta")
    args = ap.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows, summary = [], []
    for b, h, mode in BLOCKS:
        s = case(b, h, mode, args.n, args.lo, args.hi, rows)
        summary.append(s)
        print(
            f"{b:g} x {h:g} m {mode}, e {s['e']:.4f}: bounce loss beta {s['beta_peaks_s']:.4g} s "
            f"(history error {s['history_error_at_peaks']:.3g}); history loss beta "
            f"{s['beta_history_s']:.4g} s = {s['history_over_peaks']:.3f} x (error "
            f"{s['history_error_fit']:.3g}, converged {s['fit_converged']}, e_effective "
            f"{s['fit_e_effective']:.4f}, {s['fit_runs']} runs, {s['fit_seconds']:.0f} s); grid: "
            f"nearest local min {s['grid_nearest_local_min_over_peaks']:.3f} x (error "
            f"{s['grid_nearest_local_min_error']:.3g}; fit {s['fit_minus_nearest_over_spacing']:+.2f}"
            f" spacings), global min {s['grid_global_min_over_peaks']:.3f} x (error "
            f"{s['grid_global_min_error']:.3g}), {s['n_local_minima']} local minima"
            + (f"; {s['fit_reason']}" if s["fit_reason"] else ""),
            flush=True,
        )
    header = ["b_m", "h_m", "mode", "beta_s", "beta_over_peaks", "history_error"]
    with open(out / "history_loss.csv", "w", newline="") as f:
        csv.writer(f).writerows([header, *rows])
    rj.jsonio.write_json(out / "history_loss.json", summary, indent=1)
    print(f"wrote {out}/history_loss.csv and history_loss.json")


if __name__ == "__main__":
    main()
