"""How accurate a DEM facade IDA is at its default steps, against steps four times finer.

The far-field IDA of ``experiments/facade_ida_step.py`` (the 0.2 x 1.5 m facade, 1 mm gap,
``beta`` = 3.01e-4 s; 44 components x 20 PGAs of 0.05-2 g) through ``rj.ida`` at the default
steps, against a reference run by run with every step a quarter of ``rj.stable_dt`` (a concrete
step inside ``jit``: no open steps). Each call adds one labelled IDA (the code imported: put
another checkout first on ``PYTHONPATH`` to run that code's IDA; ``--open`` sets
``rj.Facade.dt_accuracy_open`` for this process) and prints
every labelled IDA in the folder against the reference: the runs whose collapse flag differs,
and the relative error of the peak ``d/b`` of the runs that stand in both and rock (reference
``d/b >= 0.01``): median, 90th and 95th percentiles, largest, the count over 2 %; then the same
over the runs whose reference is conditioned.

Conditioning: the reference is run a second time with every PGA scaled by ``1 + 1e-6``. Near
collapse the rocking is chaotic, and a run whose peak that change moves by more than
``CONDITIONED`` (1e-4: the change grown over 100 times) says nothing about the step: it is
left out of the second set of figures (as a run whose collapse flag it changes).

    python experiments/facade_ida_accuracy.py --label now [--out experiments/results/facade_ida_accuracy]
    python experiments/facade_ida_accuracy.py --label open0.35 --open 0.35
    PYTHONPATH=<checkout> python experiments/facade_ida_accuracy.py --label before

The reference takes about 4 min on two cores, and its perturbed copy as long, once each (kept
as ``reference.npz`` and ``reference_perturbed.npz``).
"""

from __future__ import annotations

import argparse
import pathlib
import time

import jax
import jax.numpy as jnp
import numpy as np
from peak_errors import peak_errors

import rockjax as rj

BLOCK = rj.Block(b=0.2, h=1.5)
BETA = 3.01e-4  # [s]
MODE = rj.Facade(gap=0.001)
SCALES_G = np.geomspace(0.05, 2.0, 20)
PERTURBATION = 1e-6  # relative change of every PGA in the reference's perturbed copy
CONDITIONED = 1e-4  # largest relative change of a conditioned reference's peak d/b


def records():
    return [r.scaled_to_pga(target_pga_g=1.0) for r in rj.records.fema_p695("farfield")]


def reference(recs, factor: float = 1.0) -> dict:
    """Every run with every step a quarter of ``rj.stable_dt``, its PGA times ``factor``."""
    dt = rj.stable_dt(BLOCK, BETA, mode=MODE) / 4
    d = np.zeros((len(recs), SCALES_G.size))
    c = np.zeros_like(d, bool)
    for i, rec in enumerate(recs):

        def run(ag, rec=rec):
            gm = rj.GroundMotion(ag=ag, dt=rec.dt)
            return rj.simulate_dem(BLOCK, gm, beta=BETA, mode=MODE, dt=dt, throw=False)

        run = jax.jit(run)
        for j, s in enumerate(SCALES_G * factor):
            r = run(jnp.asarray(rec.ag * s))
            d[i, j], c[i, j] = float(r.extras["d_max"]) / BLOCK.b, bool(r.overturned)
    return {"d": d, "c": c}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--label", required=True)
    ap.add_argument("--open", type=float, default=None, help="rj.Facade.dt_accuracy_open")
    ap.add_argument("--out", default="experiments/results/facade_ida_accuracy")
    args = ap.parse_args()
    if args.open is not None:
        # set before the first run: a program kept on disk is keyed by the mode's class
        # attributes too, so no later process loads a program traced at this accuracy
        rj.Facade.dt_accuracy_open = args.open
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    print(f"rockjax {rj.__file__}; open steps at {rj.Facade.dt_accuracy_open}", flush=True)
    recs = records()
    for name, factor in (("reference", 1.0), ("reference_perturbed", 1.0 + PERTURBATION)):
        if not (out / f"{name}.npz").is_file():
            t0 = time.perf_counter()
            np.savez(out / f"{name}.npz", **reference(recs, factor))
            print(f"{name}: {time.perf_counter() - t0:.0f} s", flush=True)
    ds = rj.ida(BLOCK, recs, SCALES_G, model=rj.DEM(beta=BETA), mode=MODE, progress=False)
    np.savez(
        out / f"{args.label}.npz",
        d=ds["max_d_over_b"].values,
        c=ds["collapse"].values,
        s=ds["status"].values,
    )
    ref = np.load(out / "reference.npz")
    pert = np.load(out / "reference_perturbed.npz")
    change = np.abs(pert["d"] / ref["d"] - 1.0)
    conditioned = (pert["c"] == ref["c"]) & (ref["c"] | (change <= CONDITIONED))
    print(
        f"reference, PGA x (1 + {PERTURBATION:g}): {int(np.sum(pert['c'] != ref['c']))} collapse "
        f"flags differ; {int(np.sum(~conditioned))} of {ref['c'].size} runs not conditioned "
        f"(peak d/b moved by more than {CONDITIONED:g})"
    )
    for path in sorted(out.glob("*.npz")):
        if path.stem.startswith("reference"):
            continue
        x = np.load(path)
        for title, keep in (("every run", np.ones_like(conditioned)), ("conditioned", conditioned)):
            e = peak_errors(x["d"], x["c"], ref["d"], ref["c"], (x["s"] == 0) & keep)
            print(
                f"  {path.stem:<10} {title:<12} collapse flags differ {e['collapse_differs']} "
                f"of {e['runs']}; peak d/b of {e['rocking_standing']} runs: median "
                f"{e['err_median']:.1e}, p90 {e['err_p90']:.1e}, p95 {e['err_p95']:.1e}, max "
                f"{e['err_max']:.1e}; over 2 %: {e['err_over_2pct']}"
            )


if __name__ == "__main__":
    main()
