"""One 20 s parapet history as a user runs it: the eager call ``rj.simulate_dem(block, rec,
beta=beta)`` (its Response dropped at once, and kept until the next call returns, as
``r = rj.simulate_dem(...)`` in a loop keeps it) and the same run under the caller's
``jax.jit`` with the block closed over, at the
calibrated ``beta`` (``rj.fit_beta`` to Housner's ``e``) and at ``beta_DeJong``; the 0.25 x 3 m
block, default joint and step, a Ricker record (3 m/s^2, 0.5 s, dt 0.01 s). Against the 3 ms
target; with ``--against CHECKOUT``, that code in alternation with this one, side by side.

    python benchmarks/bench_history.py [--against <other checkout>] [--rounds 3] [--pin CORE]

Each figure is the median (and minimum) wall time of 41 calls after three warm-up calls, in a
fresh process per version and round (the versions alternate: the machine's load drifts), and
the median process CPU time of a call over the rounds (all threads: the work done, which the
machine's scheduling disturbs less than the wall time of an eager call, whose dispatch and
wait cross threads).
``--pin CORE`` runs every process on that core alone (``os.sched_setaffinity``). The calibrated
``beta`` is fitted once, by this checkout, and passed to every process. Results:
docs/benchmarks.md, "One history as a user runs it".
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

TARGET_S = 3e-3
RECORD_DT = 0.01  # [s]
DURATION = 20.0  # [s]
CALLS = 41


def worker(betas: list[float]) -> list[dict]:
    import jax
    import jax.numpy as jnp

    import rockjax as rj

    block = rj.Block(b=0.25, h=3.0)
    rec = rj.GroundMotion.ricker(pga=3.0, period=0.5, dt=RECORD_DT, duration=DURATION)
    ag = jnp.asarray(rec.ag)
    out = []
    for beta in betas:
        dt = rj.stable_dt(block, beta)

        def closed(scale, beta=beta, dt=dt):
            motion = rj.GroundMotion(ag=scale * ag, dt=RECORD_DT)
            return rj.simulate_dem(block, motion, beta=beta, dt=dt, throw=False).theta

        last: list = []

        def kept(beta=beta, last=last):
            # as `r = rj.simulate_dem(...)` in a loop: the previous Response lives until the
            # new one exists (glibc's heap then keeps its pages; docs/benchmarks.md)
            last[:] = [rj.simulate_dem(block, rec, beta=beta)]
            return last[0].theta

        runs = {
            "eager call": lambda beta=beta: rj.simulate_dem(block, rec, beta=beta).theta,
            "eager call, Response kept": kept,
            "jit, block closed over": lambda f=jax.jit(closed): f(1.0),
        }
        for how, fn in runs.items():
            for _ in range(3):
                jax.block_until_ready(fn())
            ts, cpu = [], []
            for _ in range(CALLS):
                t0, c0 = time.perf_counter(), time.process_time()
                jax.block_until_ready(fn())
                ts.append(time.perf_counter() - t0)
                cpu.append(time.process_time() - c0)
            steps = rec.n * round(RECORD_DT / dt)
            med, least, cpu = statistics.median(ts), min(ts), statistics.median(cpu)
            out.append(dict(beta=beta, how=how, med=med, min=least, cpu=cpu, steps=steps))
    return out


def run_worker(pythonpath: str | None, betas: list[float], pin: int | None) -> list[dict]:
    env = dict(os.environ)
    if pythonpath:
        env["PYTHONPATH"] = pythonpath + os.pathsep + env.get("PYTHONPATH", "")
    cmd = [sys.executable, __file__, "--worker", json.dumps(betas)]
    if pin is not None:
        cmd += ["--pin", str(pin)]
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--against", help="another checkout, timed in alternation with this one")
    ap.add_argument("--rounds", type=int, default=3, help="alternations (default 3)")
    ap.add_argument("--pin", type=int, default=None, help="run on this core alone")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.pin is not None:
        os.sched_setaffinity(0, {args.pin})
    if args.worker:
        print(json.dumps(worker(json.loads(args.worker))))
        return
    here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    sys.path.insert(0, here)
    import rockjax as rj

    block = rj.Block(b=0.25, h=3.0)
    fit = rj.fit_beta(block, e=rj.e_housner(block))
    betas = [float(fit.beta), float(rj.beta_dejong(block))]
    versions = {"this checkout": here}
    if args.against:
        versions = {"against": os.path.abspath(args.against), **versions}
    print(
        f"One {DURATION:g} s history, 0.25 x 3 m, default joint and step; calibrated beta "
        f"{betas[0]:.6g} s (fit_beta to e_H), beta_DeJong {betas[1]:.6g} s. Load at start: "
        f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}"
        + (f"; pinned to core {args.pin}" if args.pin is not None else "")
    )
    results: dict = {name: [] for name in versions}
    for r in range(args.rounds):
        for name, path in versions.items():
            results[name].append(run_worker(path, betas, args.pin))
    rows = {}
    for name, rounds in results.items():
        for rnd in rounds:
            for x in rnd:
                key = (x["beta"], x["how"])
                rows.setdefault(key, {}).setdefault(name, []).append(x)
    head = "  ".join(f"{name + ' [ms]':>40}" for name in versions)
    print(
        f"  {'beta [s]':<11}{'how':<27}{'steps':>7}  {head}" + ("  ratio" if args.against else "")
    )
    for (beta, how), by in rows.items():
        cells, meds = [], {}
        for name in versions:
            xs = by[name]
            meds[name] = statistics.median(x["med"] for x in xs)
            each = " / ".join(f"{x['med'] * 1e3:.2f}" for x in xs)
            cpu = statistics.median(x["cpu"] for x in xs) * 1e3
            cells.append(f"{each} (min {min(x['min'] for x in xs) * 1e3:.2f}, cpu {cpu:.2f})")
        steps = by[next(iter(versions))][0]["steps"]
        line = f"  {beta:<11.6g}{how:<27}{steps:>7}  " + "  ".join(f"{c:>40}" for c in cells)
        if args.against:
            line += f"  {meds['this checkout'] / meds['against']:.2f}"
        mark = "meets" if meds["this checkout"] <= TARGET_S else "misses"
        print(line + f"   {mark} {TARGET_S * 1e3:g} ms")
    print(f"Load at end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
