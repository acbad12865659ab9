"""Facade bounce bands over a dense grid of beta: does any beta put the DEM's e_exp of bounces
1-3 (Eq. 6) in the measured bands (64-72 %, 74-86 %, 92.5-107.5 % of |e_ISR|), per joint, and
is ``rj.fit_beta``'s default facade fit (``target="bounces"``, L-BFGS) the minimum of its loss.

Per facade (one-sided, release 0.5 eta, no gap) and joint (``rj.Joint()``, the converged
integrated face law; ``rj.Joint(n_sub=2)``, the paper's two corner sub-contacts):

1. a coarse scan of ``n_coarse`` points over the default search ``[0, 16 beta_Hcrit]`` finds the
   first ``beta`` without a first bounce (``e_exp`` NaN in the NumPy peak finder);
2. a dense grid of ``n`` points over ``[0, that beta]`` gives, at each ``beta``, the fit's loss
   (``rj.calibration.stats``: mean square of ``log e_exp,n - log target_n`` over bounces 1-3)
   and ``e_exp`` 1-3 from the saved history (``Response.e_exp``, the finder of the verdict);
3. the grid minimum of the loss (parabola through the best three points) against
   ``rj.fit_beta(block, mode="one_sided", joint=joint)``.

    nice python experiments/facade_bands.py [--out experiments/results] [--n 81] [--quick]

Writes facade_bands.csv (one row per facade, joint and grid beta) and facade_bands.json (the
summary quoted in docs/calibration.md, "Facades"), and prints it.
"""

import argparse
import csv
import pathlib
import time

import equinox as eqx
import jax
import numpy as np

import rockjax as rj
from rockjax import calibration as cal

FACADES = (  # b [m], h [m], E [Pa]
    (0.20, 1.5, 1.8e9),  # the paper's facade
    (0.10, 1.0, 1.8e9),
    (0.35, 3.0, 4.05e9),
    (0.30, 1.0, 4.05e9),
)
JOINTS = {"exact": rj.Joint(), "n_sub=2": rj.Joint(n_sub=2)}


@eqx.filter_jit
def _batch(problem, betas):
    def one(beta):
        return cal.stats(problem, beta)[0], cal.dem_run(problem, beta)

    return jax.vmap(one)(betas)


def grid(problem, betas):
    """``(loss, e_exp 1-3 over |e_ISR|)`` at each of ``betas`` [s] (NaN: no such bounce)."""
    loss, runs = _batch(problem, np.asarray(betas, float))
    e_abs = abs(float(rj.e_isr(problem.block)))
    ratio = np.stack(
        [
            jax.tree.map(lambda x, i=i: x[i], runs).e_exp(3, mode="one_sided") / e_abs
            for i in range(len(betas))
        ]
    )
    return np.asarray(loss), ratio


def band_intervals(betas, ok):
    """Contiguous runs of ``ok`` along ``betas`` as ``[(first, last)]``."""
    out, start = [], None
    for i, flag in enumerate(ok):
        if flag and start is None:
            start = i
        if start is not None and (not flag or i == len(ok) - 1):
            last = i if flag else i - 1
            out.append((float(betas[start]), float(betas[last])))
            start = None
    return out


def band_distance(ratio):
    """Largest distance of a bounce's ``e_exp / |e_ISR|`` outside its band [-] (0 inside all)."""
    lo = np.array([b[0] for b in cal.BOUNCE_BANDS])
    hi = np.array([b[1] for b in cal.BOUNCE_BANDS])
    d = np.maximum(lo - ratio, ratio - hi).clip(min=0.0)
    return np.where(np.isfinite(ratio), d, np.inf).max(axis=-1)


def parabola_min(betas, loss):
    i = int(np.nanargmin(loss))
    if 0 < i < len(betas) - 1:
        y0, y1, y2 = loss[i - 1], loss[i], loss[i + 1]
        den = y0 - 2 * y1 + y2
        if den > 0:
            return float(betas[i] + 0.5 * (y0 - y2) / den * (betas[1] - betas[0]))
    return float(betas[i])


def case(b, h, E, joint_name, n, n_coarse, rows):
    blk = rj.Block(b=b, h=h, E=E)
    joint = JOINTS[joint_name]
    bh = float(rj.beta_hcrit(blk))
    problem = cal.problem(blk, mode="one_sided", joint=joint)
    bmax = float(problem.beta_cap) / 1.25
    t0 = time.perf_counter()
    coarse = np.linspace(0.0, bmax, n_coarse)
    _, r_c = grid(problem, coarse)
    gone = np.flatnonzero(~np.isfinite(r_c[:, 0]))
    edge = float(coarse[gone[0]]) if gone.size else bmax
    betas = np.linspace(0.0, edge, n)
    loss, ratio = grid(problem, betas)
    t_grid = time.perf_counter() - t0
    for beta, lo, rt in zip(betas, loss, ratio, strict=True):
        rows.append([b, h, E, joint_name, beta, beta / bh, lo, *rt])
    in_band = [
        np.isfinite(ratio[:, k]) & (ratio[:, k] >= lo) & (ratio[:, k] <= hi)
        for k, (lo, hi) in enumerate(cal.BOUNCE_BANDS)
    ]
    all_three = in_band[0] & in_band[1] & in_band[2]
    dist = band_distance(ratio)
    i_close = int(np.argmin(dist))
    beta_grid = parabola_min(betas, loss)
    t0 = time.perf_counter()
    fit = rj.fit_beta(blk, mode="one_sided", joint=joint, progress=False)
    t_fit = time.perf_counter() - t0
    spacing = float(betas[1] - betas[0])
    return {
        "b_m": b,
        "h_m": h,
        "E_Pa": E,
        "joint": joint_name,
        "e_isr": abs(float(rj.e_isr(blk))),
        "beta_hcrit_s": bh,
        "grid_end_over_hcrit": edge / bh,
        "grid_spacing_over_hcrit": spacing / bh,
        "in_band_intervals_over_hcrit": [
            [[x / bh for x in iv] for iv in band_intervals(betas, ok)] for ok in in_band
        ],
        "all_three_in_band": bool(all_three.any()),
        "n_grid_all_three": int(all_three.sum()),
        "closest_beta_over_hcrit": float(betas[i_close] / bh),
        "closest_distance_pct": 100.0 * float(dist[i_close]),
        "closest_pct": (100.0 * ratio[i_close]).tolist(),
        "grid_min_beta_over_hcrit": beta_grid / bh,
        "grid_min_loss": float(np.nanmin(loss)),
        "fit_beta_over_hcrit": fit.beta / bh,
        "fit_minus_grid_over_spacing": (fit.beta - beta_grid) / spacing,
        "fit_loss": fit.loss,
        "fit_converged": fit.converged,
        "fit_target_met": fit.target_met,
        "fit_pct": (100.0 * np.asarray(fit.e_exp) / abs(float(rj.e_isr(blk)))).tolist(),
        "fit_reason": fit.reason,
        "fit_runs": fit.n_simulations,
        "grid_seconds": t_grid,
        "fit_seconds": t_fit,
    }


def fmt_intervals(ivs):
    return " ".join(f"{a:.2f}-{b:.2f}" for a, b in ivs) or "none"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="experiments/results")
    ap.add_argument("--n", type=int, default=81, help="dense grid points per case")
    ap.add_argument("--n-coarse", type=int, default=17, help="coarse scan points per case")
    ap.add_argument("--quick", action="store_true", help="the paper's facade only")
    args = ap.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    facades = FACADES[:1] if args.quick else FACADES
    rows, summary = [], []
    for b, h, E in facades:
        for joint_name in JOINTS:
            s = case(b, h, E, joint_name, args.n, args.n_coarse, rows)
            summary.append(s)
            print(
                f"{b:g} x {h:g} m, E {E / 1e9:g} GPa, joint {joint_name}: |e_ISR| "
                f"{s['e_isr']:.4f}; grid 0-{s['grid_end_over_hcrit']:.3g} beta_Hcrit "
                f"(spacing {s['grid_spacing_over_hcrit']:.3g}); in band [beta_Hcrit]: "
                + "; ".join(
                    f"{k + 1}: {fmt_intervals(iv)}"
                    for k, iv in enumerate(s["in_band_intervals_over_hcrit"])
                )
                + f"; all three: {s['all_three_in_band']} ({s['n_grid_all_three']} points); "
                f"closest {s['closest_distance_pct']:.1f} % outside at "
                f"{s['closest_beta_over_hcrit']:.3f} ("
                + "/".join(f"{p:.1f}" for p in s["closest_pct"])
                + f" %); loss min: grid {s['grid_min_beta_over_hcrit']:.4f}, fit "
                f"{s['fit_beta_over_hcrit']:.4f} ({s['fit_minus_grid_over_spacing']:+.2f} "
                f"spacings), fit e_exp "
                + "/".join(f"{p:.1f}" for p in s["fit_pct"])
                + f" %, converged {s['fit_converged']}, target_met {s['fit_target_met']}, "
                f"{s['fit_runs']} runs, {s['fit_seconds']:.1f} s (grid {s['grid_seconds']:.0f} s)",
                flush=True,
            )
    header = [
        "b_m",
        "h_m",
        "E_Pa",
        "joint",
        "beta_s",
        "beta_over_hcrit",
        "loss",
        "pct_isr1",
        "pct_isr2",
        "pct_isr3",
    ]
    with open(out / "facade_bands.csv", "w", newline="") as f:
        csv.writer(f).writerows([header, *rows])
    rj.jsonio.write_json(out / "facade_bands.json", summary, indent=1)
    print(f"wrote {out}/facade_bands.csv and facade_bands.json")


if __name__ == "__main__":
    main()
