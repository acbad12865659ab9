"""Benchmark of the beta calibration (``rockjax.fit_beta``): accuracy of the gradient fit from
spread starting points against the dense-grid optimum, and its wall time beside the grid and
root-find baselines. A script that prints tables, not a test (STYLE.md section 5).

    python benchmarks/bench_calibrate.py           # 6 geometries x 3 targets x 5 starts (~10 min
                                                   # on 2 shared cores, most of it compiling)
    python benchmarks/bench_calibrate.py --quick   # 1 geometry, 1 target, 2 starts

Criteria: from each start, ``|beta - beta_grid| / beta_grid <= 2 %`` (grid:
``method="grid"``, ``n_grid=256``, parabola through the best three points) and
``|e_effective - e| <= 2e-3``; a fit takes ``<= 2 s`` after compile (median over the fits).
Each geometry is compiled first (one fit of each method, untimed), then every fit is timed
by ``Calibration.seconds`` (wall time of the call, including the reachability runs and the
final DEM run). Targets: the DEM's own restitution at 0.2, 0.6 and 1.2 beta_DeJong, rounded
to 3 decimals (inside the reachable range by construction). Writes
benchmarks/results/calibrate.json. Results and their reading: docs/benchmarks.md,
"## Calibration".
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import statistics
import sys
import time

try:
    import rockjax as rj
except ImportError:  # run from a checkout without installing
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    import rockjax as rj

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from _timing import load, machine  # noqa: E402

from rockjax import calibration as cal  # noqa: E402

GEOMETRIES = [(0.25, 3.0), (0.2, 1.5), (0.4, 1.6), (0.1, 2.4), (0.3, 3.6), (0.15, 2.4)]
TARGET_FRACTIONS = (0.2, 0.6, 1.2)  # x beta_DeJong: the DEM e there is the target
START_FRACTIONS = (0.0, 0.3, 0.7, 1.1, 1.6)  # x beta_DeJong
N_GRID = 256
TOL_BETA = 0.02
TOL_E = 2e-3
TARGET_SECONDS = 2.0
RESULTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results", "calibrate.json")


def dem_e(block, betas, beta_max):
    """The DEM's least-squares restitution at ``betas`` (signed log gap against Housner with
    e = 1, i.e. ``log e_DEM``), through the same compiled batch as the grid baseline."""
    problem = cal.problem(block, 1.0, target="e", mode="two_sided", beta_max=beta_max)
    x = np.pad(np.asarray(betas, float), (0, 64 - len(betas)), mode="edge")
    gap = cal.stats_batch(problem, jnp.asarray(x))[1]
    return np.exp(np.asarray(gap)[: len(betas)])


def row(fit, kind, geo, e, beta0, bdj):
    return {
        "geometry": geo,
        "e": e,
        "method": kind,
        "beta0_over_bdj": None if beta0 is None else beta0 / bdj,
        "beta": fit.beta,
        "beta_over_bdj": fit.beta / bdj,
        "e_effective": fit.e_effective,
        "loss": fit.loss,
        "history_error": fit.history_error,
        "n_simulations": fit.n_simulations,
        "n_iterations": fit.n_iterations,
        "converged": fit.converged,
        "root_finish": fit.root_finish,
        "seconds": fit.seconds,
        "e_range": list(fit.e_range),
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="1 geometry, 1 target, 2 starts")
    p.add_argument("--out", default=RESULTS)
    args = p.parse_args()
    geos = GEOMETRIES[:1] if args.quick else GEOMETRIES
    tfr = TARGET_FRACTIONS[1:2] if args.quick else TARGET_FRACTIONS
    sfr = (START_FRACTIONS[0], START_FRACTIONS[-1]) if args.quick else START_FRACTIONS
    t_start = time.perf_counter()
    print(
        f"rockjax calibration benchmark{' (--quick)' if args.quick else ''}  "
        f"{datetime.datetime.now(datetime.UTC).isoformat(timespec='seconds')}"
    )
    print(
        f"  machine: {machine()}; python {platform.python_version()}, jax {jax.__version__}, "
        f"backend {jax.default_backend()}"
    )
    print(f"  load average at start: {load()} (1, 5, 15 min)")
    print(
        f"  fit_beta defaults: two-sided, theta0 = eta/2, 8 bounces, beta_max = 2 beta_DeJong, "
        f"onset='sub_step'; grid n_grid={N_GRID}"
    )
    rows, compile_rows = [], []
    for b, h in geos:
        geo = f"{b}x{h}"
        block = rj.Block(b=b, h=h)
        bdj = float(rj.beta_dejong(block))
        bmax = 2.0 * bdj
        cap = 1.25 * bmax
        t0 = time.perf_counter()
        targets = [round(float(x), 3) for x in dem_e(block, np.asarray(tfr) * bdj, bmax)]
        # compile: one fit of each method on the first target (untimed)
        rj.fit_beta(block, e=targets[0], beta0=0.5 * bdj)
        rj.fit_beta(block, e=targets[0], method="grid", n_grid=N_GRID)
        rj.fit_beta(block, e=targets[0], method="root")
        t_comp = time.perf_counter() - t0
        compile_rows.append({"geometry": geo, "warmup_s": t_comp})
        print(
            f"\n{geo} m (h/b {h / b:.0f}): beta_DeJong {bdj:.5g} s, e_H {float(rj.e_housner(block)):.4f}, "
            f"targets e = {targets} (DEM e at {list(tfr)} beta_DJ); warm-up {t_comp:.1f} s"
        )
        print(
            f"  {'e':>6} {'method':<6} {'beta0/bDJ':>9} {'beta/bDJ':>9} {'dbeta/grid':>10} "
            f"{'e_eff':>8} {'e_eff-e':>9} {'loss':>9} {'hist.err':>8} {'sims':>5} {'iter':>4} "
            f"{'conv':>5} {'s':>6}"
        )
        for e in targets:
            grid = rj.fit_beta(block, e=e, method="grid", n_grid=N_GRID)
            root = rj.fit_beta(block, e=e, method="root")
            fits = [(grid, "grid", None), (root, "root", None)]
            for fr in sfr:
                beta0 = float(np.clip(fr * bdj, 0.0, cap))
                fits.append((rj.fit_beta(block, e=e, beta0=beta0), "lbfgs", beta0))
            for fit, kind, beta0 in fits:
                r = row(fit, kind, geo, e, beta0, bdj)
                r["beta_grid"] = grid.beta
                r["rel_beta_err"] = abs(fit.beta - grid.beta) / grid.beta
                r["e_err"] = abs(fit.e_effective - e)
                rows.append(r)
                b0 = "-" if beta0 is None else f"{beta0 / bdj:.2f}"
                print(
                    f"  {e:>6.3f} {kind:<6} {b0:>9} {fit.beta / bdj:>9.5f} "
                    f"{r['rel_beta_err'] * 100:>9.3f}% {fit.e_effective:>8.5f} "
                    f"{fit.e_effective - e:>+9.2e} {fit.loss:>9.2e} {fit.history_error:>8.4f} "
                    f"{fit.n_simulations:>5} {fit.n_iterations:>4} {str(fit.converged):>5} "
                    f"{fit.seconds:>6.2f}{'  (root finish)' if fit.root_finish else ''}"
                )

    print(f"\nSummary ({len(geos)} geometries x {len(tfr)} targets; lbfgs from {len(sfr)} starts)")
    print(
        f"  {'method':<6} {'fits':>5} {'worst dbeta/grid':>16} {'worst |e_eff-e|':>15} "
        f"{'median s':>9} {'max s':>7} {'median sims':>11} {'max sims':>8} {'not conv.':>9} "
        f"{'root finish':>11}"
    )
    summary = {}
    for kind in ("lbfgs", "grid", "root"):
        rs = [r for r in rows if r["method"] == kind]
        s = {
            "fits": len(rs),
            "worst_rel_beta_err": max(r["rel_beta_err"] for r in rs),
            "worst_e_err": max(r["e_err"] for r in rs),
            "median_s": statistics.median(r["seconds"] for r in rs),
            "max_s": max(r["seconds"] for r in rs),
            "median_sims": statistics.median(r["n_simulations"] for r in rs),
            "max_sims": max(r["n_simulations"] for r in rs),
            "not_converged": sum(not r["converged"] for r in rs),
            "root_finish": sum(r["root_finish"] for r in rs),
        }
        summary[kind] = s
        print(
            f"  {kind:<6} {s['fits']:>5} {s['worst_rel_beta_err'] * 100:>15.3f}% "
            f"{s['worst_e_err']:>15.2e} {s['median_s']:>9.2f} {s['max_s']:>7.2f} "
            f"{s['median_sims']:>11.0f} {s['max_sims']:>8} {s['not_converged']:>9} "
            f"{s['root_finish']:>11}"
        )
    lb = summary["lbfgs"]
    crit = {
        f"lbfgs beta within {TOL_BETA:.0%} of the grid optimum (all starts)": lb[
            "worst_rel_beta_err"
        ]
        <= TOL_BETA,
        f"lbfgs |e_eff - e| <= {TOL_E:g} (all fits)": lb["worst_e_err"] <= TOL_E,
        f"lbfgs median fit time <= {TARGET_SECONDS:g} s after compile": lb["median_s"]
        <= TARGET_SECONDS,
        f"lbfgs max fit time <= {TARGET_SECONDS:g} s after compile": lb["max_s"] <= TARGET_SECONDS,
    }
    for k, v in crit.items():
        print(f"  {'PASS' if v else 'FAIL'}  {k}")
    total = time.perf_counter() - t_start
    print(f"\n  load average at end: {load()} (1, 5, 15 min); total {total:.0f} s")
    out = {
        "date_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "machine": machine(),
        "jax": jax.__version__,
        "quick": args.quick,
        "load_end": load(),
        "total_s": total,
        "compile": compile_rows,
        "summary": summary,
        "criteria": crit,
        "fits": rows,
    }
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(out, f, indent=1)
    print(f"  wrote {args.out}")


if __name__ == "__main__":
    main()
