"""DEM pushover of the paper's four walls (Section 4, Fig. 9): capacity curves of the facades.

Walls (h, b) = (1.50, 0.170), (3.00, 0.250), (6.44, 0.375), (8.00, 0.375) m, E = 1800 MPa,
rho = 1800 kg/m^3, phi = 30 deg, facades (``mode="one_sided"``, pulled outward, away from
their return wall), the integrated face joint, beta = beta_DeJong, the default pull rate;
each also at half the rate (loading-rate check). Next to each DEM curve: the rigid block's
lambda(theta) and the closed-form statics of the rigid block on the Winkler joint
(docs/pushover.md). The descending branch's linear fit over 0.3 <= d/b <= 0.8 gives its
intercept with lambda = 0 (the three-branch law's Delta_u, as d/b).

    python experiments/pushover_walls.py [--out experiments/results] [--fig docs/figures]

Writes pushover_walls.csv (the curves), pushover_walls_summary.csv (one row per wall) and
the figure pushover_walls.png, and prints the numbers quoted in docs/pushover.md.
"""

import argparse
import csv
import importlib.util
import pathlib
import time
import types

import numpy as np

import rockjax as rj
from rockjax.constants import G
from rockjax.pushover import PULL_TIME, pushover

WALLS = ((1.50, 0.170), (3.00, 0.250), (6.44, 0.375), (8.00, 0.375))


def winkler_lambda(theta, b, h, weight, k):
    """The rigid block on a tensionless Winkler joint (docs/pushover.md, "Flexible joint")."""
    c, s = np.cos(theta), np.sin(theta)
    ell = np.sqrt(2 * weight / (k * np.maximum(s, 1e-300)))
    partial = ell < b
    t_r = np.where(partial, b / 2 - ell / 3, k * s * b**3 / (12 * weight))
    t_s = np.where(partial, b / 2 - ell / 2, 0.0)
    return (t_r * c - 0.5 * h * s) / (0.5 * h * c + t_s * s)


def fit_law(d, lam, lam0):
    """The three-branch law fitted to the curve down to lambda = 0 (rockjax.three_branch, when
    present), or None."""
    if importlib.util.find_spec("rockjax.three_branch") is None:
        return None
    from rockjax.three_branch import fit_three_branch

    i_peak = int(np.argmax(lam))
    below = np.nonzero(lam[i_peak:] < 0)[0]
    end = i_peak + below[0] if below.size else d.size - 1
    keep = np.arange(d.size) <= end
    fit = fit_three_branch(types.SimpleNamespace(d_over_b=d[keep], load_multiplier=lam[keep]))
    law = fit.law
    return dict(
        lambda_0_fit=float(law.lambda_0),
        Delta_1=float(law.Delta_1),
        Delta_2=float(law.Delta_2),
        Delta_u=float(law.Delta_u),
        fit_rmse_over_lambda_rigid=float(fit.rmse) / lam0,
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="experiments/results")
    ap.add_argument("--fig", default="docs/figures")
    args = ap.parse_args()
    out, fig_dir = pathlib.Path(args.out), pathlib.Path(args.fig)
    out.mkdir(parents=True, exist_ok=True)
    fig_dir.mkdir(parents=True, exist_ok=True)

    rows, summary, curves = [], [], []
    for h, b in WALLS:
        blk = rj.Block(b=b, h=h, E=1.8e9, rho=1800.0)
        t0 = time.perf_counter()
        cap = pushover(blk, "one_sided")
        wall_s = time.perf_counter() - t0
        slow = pushover(blk, "one_sided", duration=2 * PULL_TIME / float(blk.p))
        lam, d, theta = (np.asarray(x) for x in (cap.load_multiplier, cap.d_over_b, cap.theta))
        lam0 = float(cap.lambda_rigid)
        lam_slow, d_slow = np.asarray(slow.load_multiplier), np.asarray(slow.d_over_b)
        grid = np.linspace(0.02, 0.95, 200)
        rate = np.max(np.abs(np.interp(grid, d, lam) - np.interp(grid, d_slow, lam_slow))) / lam0
        weight = float(blk.m) * G
        k = float(blk.j_kn * blk.length)
        ref = winkler_lambda(theta, b, h, weight, k)
        moved = theta > 1e-6
        winkler_err = np.max(np.abs(lam - ref)[moved]) / lam0
        desc = (d >= 0.3) & (d <= 0.8)
        slope, icpt = np.polyfit(d[desc], lam[desc], 1)
        i_peak = int(np.argmax(lam))
        law = fit_law(d, lam, lam0)
        summary.append(
            dict(
                h=h,
                b=b,
                lambda_rigid=lam0,
                lambda_peak=float(lam[i_peak]),
                peak_over_rigid=float(lam[i_peak]) / lam0,
                d_over_b_at_peak=float(d[i_peak]),
                delta_u_over_b=-icpt / slope,
                rate_change_over_lambda_rigid=rate,
                winkler_error_over_lambda_rigid=winkler_err,
                run_s=wall_s,
                **({} if law is None else law),
            )
        )
        for i in range(lam.size):
            rows.append(dict(h=h, b=b, d_over_b=d[i], theta=theta[i], load_multiplier=lam[i]))
        curves.append((h, b, d, lam, theta, lam0, ref, law))
        print(
            f"h={h:5.2f} b={b:.3f}: lambda_0={lam0:.4f} peak={lam[i_peak]:.4f} "
            f"({lam[i_peak] / lam0:.3f} lambda_0) at d/b={d[i_peak]:.3f}; Delta_u/b="
            f"{-icpt / slope:.3f}; half rate: {rate:.1e} lambda_0; vs Winkler statics "
            f"{winkler_err:.1e} lambda_0; {wall_s:.1f} s"
        )
        if law is not None:
            print(
                "    three-branch fit: lambda_0={lambda_0_fit:.4f} Delta_1={Delta_1:.3f} "
                "Delta_2={Delta_2:.3f} Delta_u={Delta_u:.3f} rmse={fit_rmse_over_lambda_rigid:.1e}"
                " lambda_0".format(**law)
            )

    with open(out / "pushover_walls.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    with open(out / "pushover_walls_summary.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(summary[0]))
        w.writeheader()
        w.writerows(summary)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(9, 7), constrained_layout=True)
    for ax, (h, b, d, lam, theta, lam0, ref, law) in zip(axes.flat, curves):
        rigid = (b * np.cos(theta) - h * np.sin(theta)) / (h * np.cos(theta) + b * np.sin(theta))
        ax.plot(d, lam, "k-", lw=1.8, label="DEM pushover")
        ax.plot(d, ref, "C1--", lw=1.0, label="Winkler joint, statics")
        ax.plot(d, rigid, "C0:", lw=1.2, label="rigid block")
        if law is not None:
            x = [0.0, law["Delta_1"], law["Delta_2"], law["Delta_u"]]
            lam_p = law["lambda_0_fit"] * (1 - law["Delta_2"] / law["Delta_u"])
            ax.plot(x, [0.0, lam_p, lam_p, 0.0], "C2-.", lw=1.0, label="three-branch fit")
        ax.axhline(lam0, color="0.6", lw=0.6)
        ax.set_title(f"h = {h:.2f} m, b = {b:.3f} m")
        ax.set_xlabel("d / b [-]")
        ax.set_ylabel("load multiplier lambda [-]")
        ax.set_xlim(0, 1)
        ax.set_ylim(0, 1.1 * lam0)
    axes.flat[0].legend(fontsize=8)
    fig.suptitle("Facade pushover, E = 1800 MPa, rho = 1800 kg/m3, phi = 30 deg")
    fig.savefig(fig_dir / "pushover_walls.png", dpi=130)
    print(f"wrote {out / 'pushover_walls.csv'}, {fig_dir / 'pushover_walls.png'}")


if __name__ == "__main__":
    main()
