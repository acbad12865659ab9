"""Batched single blocks at the workload of the batch targets: 1024 runs of a 20 s record
(0.25 x 3 m, ``beta_DeJong``, default step), the integrated joint (target 5e7 block-steps/s)
and two corner contacts (target 1e8), run as one ``jax.jit(jax.vmap(...))`` batch, as
chunks of that batch in threads (what ``rj.ida`` does on a host CPU), each chunk compiled
plainly and with the wide batch's compiler options (``rj.batching.WIDE_BATCH_OPTIONS``), and
through ``rj.vmap_chunks`` (its defaults: chunks of 256, the options from 128 runs).

    python benchmarks/bench_batch.py [--chunks 64,128,256] [--repeats 3]

Block-steps/s of wall time (and per CPU second: the process CPU time, all threads) from the
median of ``--repeats`` warm calls. Results: docs/benchmarks.md, "Batches at the target's
workload" and "Wide batches".
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from concurrent.futures import ThreadPoolExecutor

try:
    import rockjax as rj
except ImportError:  # run from a checkout without installing
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    import rockjax as rj

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from _timing import load, machine  # noqa: E402

from rockjax.batching import host_threads  # noqa: E402

RUNS = 1024
RECORD_DT = 0.01  # [s]
DURATION = 20.0  # [s]
TARGETS = {"exact": 5e7, 2: 1e8}  # block-steps/s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--chunks", default="64,128,256", help="chunk sizes for the threads")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    threads = host_threads()
    print(f"{machine()}; load {load()}; {RUNS} runs of {DURATION:g} s; {threads} threads")
    block = rj.Block(b=0.25, h=3.0)
    beta = float(rj.beta_dejong(block))
    rec = rj.GroundMotion.ricker(pga=3.0, period=0.5, dt=RECORD_DT, duration=DURATION)
    ag = jnp.asarray(rec.ag)
    scales = np.linspace(0.5, 1.5, RUNS)
    for n_sub, target in TARGETS.items():
        joint = rj.Joint(n_sub=n_sub)
        dt = rj.stable_dt(block, beta, joint=joint)

        def one(scale, dt=dt, joint=joint):
            motion = rj.GroundMotion(ag=scale * ag, dt=RECORD_DT)
            return rj.simulate_dem(block, motion, beta=beta, dt=dt, joint=joint, throw=False)

        def theta_max(s, one=one):
            return one(s).theta_max

        batch = jax.jit(jax.vmap(theta_max))
        wide = jax.jit(jax.vmap(theta_max), compiler_options=rj.batching.WIDE_BATCH_OPTIONS)
        steps = RUNS * rec.n * round(RECORD_DT / dt)
        ways = {"jit(vmap) of all runs": lambda: batch(scales)}
        for size in (int(c) for c in args.chunks.split(",")):
            parts = [scales[i : i + size] for i in range(0, RUNS, size)]
            for name, program in (("", batch), (", wide options", wide)):

                def threaded(parts=parts, program=program):
                    with ThreadPoolExecutor(threads) as pool:
                        return list(pool.map(lambda x: jax.block_until_ready(program(x)), parts))

                jax.block_until_ready(program(parts[0]))  # (compiled before timing)
                ways[f"chunks of {size} in {threads} threads{name}"] = threaded
        chunked = rj.vmap_chunks(theta_max)
        ways["rj.vmap_chunks(one)"] = lambda: chunked(scales)
        print(f"joint n_sub={n_sub!r} ({steps // RUNS} steps a run), target {target:.0e}:")
        for how, fn in ways.items():
            jax.block_until_ready(fn())
            wall, cpu = [], []
            for _ in range(args.repeats):
                t0, c0 = time.perf_counter(), time.process_time()
                jax.block_until_ready(fn())
                wall.append(time.perf_counter() - t0)
                cpu.append(time.process_time() - c0)
            rate = steps / statistics.median(wall)
            print(
                f"  {how:<44} {rate:9.3g} block-steps/s ({rate / target:.2f} of the target), "
                f"{steps / statistics.median(cpu):9.3g} per CPU second"
            )
    print(f"load at end {load()}")


if __name__ == "__main__":
    main()
