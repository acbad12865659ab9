"""How accurate a DEM facade IDA is at its default steps, against steps four times finer.

The far-field IDA of ``experiments/facade_ida_step.py`` (the 0.2 x 1.5 m facade, 1 mm gap,
``beta`` = 3.01e-4 s; 44 components x 20 PGAs of 0.05-2 g) through ``rj.ida`` at the default
steps, against a reference run by run with every step a quarter of ``rj.stable_dt`` (a concrete
step inside ``jit``: no open steps). Each call adds one labelled IDA (the code imported: put
another checkout first on ``PYTHONPATH`` to run that code's IDA) and prints every labelled IDA
in the folder against the reference: the runs whose collapse flag differs, and the relative
error of the peak ``d/b`` of the runs that stand in both and rock (reference ``d/b >= 0.01``):
median, 90th and 95th percentiles, largest.

    python experiments/facade_ida_accuracy.py --label now [--out experiments/results/facade_ida_accuracy]
    PYTHONPATH=<checkout> python experiments/facade_ida_accuracy.py --label before

The reference takes about 4 min on two cores, once (kept as ``reference.npz``).
"""

from __future__ import annotations

import argparse
import pathlib
import time

import jax
import jax.numpy as jnp
import numpy as np

import rockjax as rj

BLOCK = rj.Block(b=0.2, h=1.5)
BETA = 3.01e-4  # [s]
MODE = rj.Facade(gap=0.001)
SCALES_G = np.geomspace(0.05, 2.0, 20)
ROCKS = 0.01


def records():
    return [r.scaled_to_pga(target_pga_g=1.0) for r in rj.records.fema_p695("farfield")]


def reference(recs) -> dict:
    dt = rj.stable_dt(BLOCK, BETA, mode=MODE) / 4
    d = np.zeros((len(recs), SCALES_G.size))
    c = np.zeros_like(d, bool)
    for i, rec in enumerate(recs):

        def run(ag, rec=rec):
            gm = rj.GroundMotion(ag=ag, dt=rec.dt)
            return rj.simulate_dem(BLOCK, gm, beta=BETA, mode=MODE, dt=dt, throw=False)

        run = jax.jit(run)
        for j, s in enumerate(SCALES_G):
            r = run(jnp.asarray(rec.ag * s))
            d[i, j], c[i, j] = float(r.extras["d_max"]) / BLOCK.b, bool(r.overturned)
    return {"d": d, "c": c}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--label", required=True)
    ap.add_argument("--out", default="experiments/results/facade_ida_accuracy")
    args = ap.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    print(f"rockjax {rj.__file__}", flush=True)
    recs = records()
    if not (out / "reference.npz").is_file():
        t0 = time.perf_counter()
        np.savez(out / "reference.npz", **reference(recs))
        print(f"reference: {time.perf_counter() - t0:.0f} s", flush=True)
    ds = rj.ida(BLOCK, recs, SCALES_G, model=rj.DEM(beta=BETA), mode=MODE, progress=False)
    np.savez(
        out / f"{args.label}.npz",
        d=ds["max_d_over_b"].values,
        c=ds["collapse"].values,
        s=ds["status"].values,
    )
    ref = np.load(out / "reference.npz")
    for path in sorted(out.glob("*.npz")):
        if path.stem == "reference":
            continue
        x = np.load(path)
        ok = x["s"] == 0
        stand = ok & ~x["c"] & ~ref["c"] & (ref["d"] >= ROCKS)
        err = np.abs(x["d"][stand] / ref["d"][stand] - 1.0)
        q = np.quantile(err, [0.5, 0.9, 0.95])
        print(
            f"  {path.stem:<10} collapse flags differ {int(np.sum(x['c'][ok] != ref['c'][ok]))} "
            f"of {int(ok.sum())}; peak d/b of {int(stand.sum())} runs: median {q[0]:.1e}, "
            f"p90 {q[1]:.1e}, p95 {q[2]:.1e}, max {err.max():.1e}"
        )


if __name__ == "__main__":
    main()
