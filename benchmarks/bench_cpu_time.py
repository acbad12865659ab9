"""The DEM's per-step cost in process CPU time, which other jobs on the machine disturb much
less than wall time: one 20 s history under the caller's ``jit`` (0.25 x 3 m and 0.2 x 1.5 m,
``beta_DeJong``, the face law and two corner contacts), and a ``jit(vmap)`` batch of 1024
runs of a 2 s record (0.25 x 3 m).

    python benchmarks/bench_cpu_time.py [--pin CORE] [--no-batch]
    PYTHONPATH=<another checkout> python benchmarks/bench_cpu_time.py   # that code, alike

Run both, alternated, to compare two versions of the code side by side (docs/benchmarks.md,
"One kernel for a block and an assembly": single history, batch). ``--pin CORE`` runs the
process on that core alone (``os.sched_setaffinity``), so that XLA's threads and other jobs
do not share it with the history (the batch, which XLA spreads over the cores, is then a
one-core figure). It does not remove the machine's own noise: on 2026-11-29 pinned runs of
one version spread by 3 % in one hour and by 20 % in the next, so alternate the versions over
several rounds. ``--no-batch`` skips the batches.
"""

from __future__ import annotations

import argparse
import os
import time

import jax
import jax.numpy as jnp
import numpy as np

import rockjax as rj

RECORD_DT = 0.01  # [s]


def cpu_times(f, x, repeats: int) -> tuple[float, float]:
    """``(min, median)`` process CPU seconds of ``f(x)`` after a first (compiling) call."""
    jax.block_until_ready(f(x))
    times = []
    for _ in range(repeats):
        t0 = time.process_time()
        jax.block_until_ready(f(x))
        times.append(time.process_time() - t0)
    return min(times), float(np.median(times))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pin", type=int, default=None, help="run on this core alone")
    ap.add_argument("--no-batch", action="store_true", help="one history only")
    args = ap.parse_args()
    if args.pin is not None:
        os.sched_setaffinity(0, {args.pin})
    print(
        f"rockjax {rj.__file__}" + (f" (pinned to core {args.pin})" if args.pin is not None else "")
    )
    for b, h in ((0.25, 3.0), (0.2, 1.5)):
        block = rj.Block(b=b, h=h)
        beta = float(rj.beta_dejong(block))
        for joint in (rj.Joint(), rj.Joint(n_sub=2)):
            dt = rj.stable_dt(block, beta, joint=joint)
            for duration, n in ((20.0, 1), (2.0, 1024)):
                if n > 1 and (b != 0.25 or args.no_batch):
                    continue
                rec = rj.GroundMotion.ricker(pga=3.0, period=0.5, dt=RECORD_DT, duration=duration)
                ag = jnp.asarray(rec.ag)

                def one(scale, block=block, beta=beta, dt=dt, joint=joint, ag=ag):
                    motion = rj.GroundMotion(ag=scale * ag, dt=RECORD_DT)
                    kw = dict(beta=beta, dt=dt, joint=joint, throw=False)
                    return rj.simulate_dem(block, motion, **kw).theta_max

                r = rj.simulate_dem(block, rec, beta=beta, dt=dt, joint=joint)
                steps = rec.n * round(RECORD_DT / float(r.extras["dt"]))
                label = f"{b} x {h} m, n_sub {joint.n_sub}"
                if n == 1:
                    best, med = cpu_times(jax.jit(one), jnp.ones(()), 15)
                    print(
                        f"  {label}: one history under jit, median {med * 1e3:.2f} ms "
                        f"(min {best * 1e3:.2f}), {med / steps * 1e9:.1f} ns/step"
                    )
                else:
                    best, med = cpu_times(jax.jit(jax.vmap(one)), jnp.linspace(0.5, 1.5, n), 5)
                    print(
                        f"  {label}: batch of {n}, {n * steps / med:.3g} block-steps/s "
                        f"(best {n * steps / best:.3g})"
                    )


if __name__ == "__main__":
    main()
