"""Benchmarks of the multi-block DEM (``rockjax.simulate_dem``): block-steps
per second for stacks of 1, 2, 4 and 8 blocks, one history and a vmapped batch of records,
and the per-step cost of a two-block wall against the single-block ``rj.simulate_dem``.
A script that prints tables, not a test (STYLE.md section 5).

    python benchmarks/bench_assembly.py            # 1, 2, 4, 8 blocks; batch of 64 records
    python benchmarks/bench_assembly.py --quick    # 1, 2, 4 blocks; batch of 16
    python benchmarks/bench_assembly.py --quick --batch 256   # rj.ida's chunk of runs

Every run uses the same step ``dt`` for all models (the two-block wall's default step), so the
numbers compare the work per step. Times are medians of repeated calls after a warm-up (the
compile, timed separately), each ended by ``jax.block_until_ready``.
"""

from __future__ import annotations

import argparse
import os
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
from _timing import load, machine, timed  # noqa: E402

from rockjax.assembly import Assembly  # noqa: E402

BLOCK = dict(b=0.23, h=1.5)
RECORD_DT = 0.01


def _record(duration: float, pga: float, period: float = 0.4) -> rj.GroundMotion:
    return rj.GroundMotion.sine_cycle(pga=pga, period=period, dt=RECORD_DT, duration=duration)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="1, 2, 4 blocks; batch of 16")
    ap.add_argument("--batch", type=int, help="records per batch (default 64; 16 with --quick)")
    args = ap.parse_args(argv)
    sizes = (1, 2, 4) if args.quick else (1, 2, 4, 8)
    batch = args.batch or (16 if args.quick else 64)
    duration, duration_batch = 10.0, 2.0
    beta = 1e-3
    print(f"machine: {machine()}; load {load()}; jax {jax.__version__}, {jax.devices()[0]}")
    two = Assembly.stack([rj.Block(**BLOCK)] * 2, top="restrained", overburden=5e3)
    dt = rj.stable_dt_assembly(two, beta)
    n_in = int(np.ceil(RECORD_DT / dt - 1e-9))
    dt = RECORD_DT / n_in
    print(f"dt = {dt:.3e} s ({n_in} steps per record sample), beta = {beta} s, face law\n")

    rec = _record(duration, -2.0)
    steps = (rec.n) * n_in
    blk = rj.Block(**BLOCK)

    def dem():
        return rj.simulate_dem(blk, rec, beta=beta, dt=dt).theta

    t0 = time.perf_counter()
    jax.block_until_ready(dem())
    c_dem = time.perf_counter() - t0
    t_dem, t_dem_min = timed(dem, 3, warmup=False)
    print(
        f"rj.simulate_dem, 1 block, {duration:g} s: compile+run {c_dem:.1f} s, run "
        f"{t_dem:.3f} s (min {t_dem_min:.3f}), {steps / t_dem:.3g} steps/s"
    )

    print(
        f"\n{'blocks':>6} {'compile [s]':>12} {'history [s]':>12} {'block-steps/s':>14} "
        f"{'batch [s]':>10} {'block-steps/s (batch)':>22}"
    )
    per_step = {}
    for n in sizes:
        wall = Assembly.stack([rj.Block(**BLOCK)] * n, top="restrained", overburden=5e3)

        def one(wall=wall):
            return rj.simulate_assembly(wall, rec, beta=beta, dt=dt).theta

        t0 = time.perf_counter()
        jax.block_until_ready(one())
        comp = time.perf_counter() - t0
        t_one, _ = timed(one, 3, warmup=False)
        per_step[n] = t_one / steps
        recs = np.stack(
            [np.asarray(_record(duration_batch, -a).ag) for a in np.linspace(1.0, 4.0, batch)]
        )

        def many(wall=wall, recs=recs):
            return jax.vmap(
                lambda ag: (
                    rj.simulate_assembly(
                        wall, rj.GroundMotion(ag=ag, dt=RECORD_DT), beta=beta, dt=dt
                    ).theta
                )
            )(recs)

        t_b, _ = timed(many, 2)
        steps_b = recs.shape[0] * recs.shape[1] * n_in
        print(
            f"{n:>6} {comp:>12.1f} {t_one:>12.3f} {n * steps / t_one:>14.3g} "
            f"{t_b:>10.3f} {n * steps_b / t_b:>22.3g}"
        )
    ratio = per_step[2] / (t_dem / steps)
    print(
        f"\nper-step cost, 2-block wall / rj.simulate_dem single block, {duration:g} s history: "
        f"{ratio:.2f}x (target <= 2.5x; a call's fixed cost weighs on runs this short)"
    )
    _ratio_long(blk, two, dt, beta, batch)
    print(f"load at the end: {load()}")


def _ratio_long(blk, two, dt, beta, batch, duration=60.0, rounds=5):
    """The per-step ratio where the per-call cost does not count: a 60 s history (an eager
    call, the block's numbers passed to the compiled program as data; and under ``jax.jit``
    with the model closed over, its numbers constants), and a jitted vmap over ``batch``
    records of 10 s, the models timed in interleaved rounds (a load burst hits all alike);
    ratio of the minima. The one-block assembly (the same block restrained at
    its top, where this record leaves it) shows the batched assembly kernel's own cost."""
    rec = _record(duration, -2.0)
    recs = np.stack([np.asarray(_record(10.0, -a).ag) for a in np.linspace(1.0, 4.0, batch)])

    def compiled(model):
        # the model closed over: its numbers are constants of the program, as in a user's jit
        f = jax.jit(
            lambda ag: (
                rj.simulate_dem(
                    model, rj.GroundMotion(ag=ag, dt=RECORD_DT), beta=beta, dt=dt, throw=False
                ).theta
            )
        )
        ag = jnp.asarray(rec.ag)
        return lambda: f(ag)

    def batched(model):
        def run(ag):
            return rj.simulate_dem(model, rj.GroundMotion(ag=ag, dt=RECORD_DT), beta=beta, dt=dt)

        f = jax.jit(jax.vmap(lambda ag: run(ag).theta_max))
        return lambda: f(recs)

    rows = {
        "history, 1 block (simulate_dem)": lambda: (
            rj.simulate_dem(blk, rec, beta=beta, dt=dt).theta
        ),
        "history, 2-block wall": lambda: rj.simulate_dem(two, rec, beta=beta, dt=dt).theta,
        "jit history, 1 block": compiled(blk),
        "jit history, 2-block wall": compiled(two),
        f"jit(vmap) x {batch}, 1 block": batched(blk),
        f"jit(vmap) x {batch}, 2-block wall": batched(two),
        f"jit(vmap) x {batch}, 1-block assembly": batched(Assembly.stack([blk], top="restrained")),
    }
    times = {k: [] for k in rows}
    for f in rows.values():
        jax.block_until_ready(f())
    for _ in range(rounds):
        for k, f in rows.items():
            t0 = time.perf_counter()
            jax.block_until_ready(f())
            times[k].append(time.perf_counter() - t0)
    best = {k: min(v) for k, v in times.items()}
    print(
        f"\nper-step ratio, {duration:g} s history and jit(vmap) of {batch} x 10 s "
        f"(min of {rounds} interleaved rounds):"
    )
    for k, t in best.items():
        print(f"  {k:36s} {t:8.3f} s")
    keys = list(best)
    print(
        f"  2-block wall / 1 block: history {best[keys[1]] / best[keys[0]]:.2f}x, "
        f"jit history {best[keys[3]] / best[keys[2]]:.2f}x, "
        f"batched {best[keys[5]] / best[keys[4]]:.2f}x (target <= 2.5x)"
    )


if __name__ == "__main__":
    main()
