"""A user's own batch of DEM facades: ``jax.jit(jax.vmap(...))`` over runs against a loop of
one compiled run each, and ``rj.ida`` over the same runs.

A facade of one block takes open steps where its return wall is out of reach (docs/theory.md,
"Open steps"). Under ``vmap`` a batch takes, each sample, the open steps if any of its runs
does and the steps of ``dt`` if any does, so a batch gains less from them than runs one after
another; this script measures what a user's ``vmap`` of facades costs. Eight far-field
components recorded at 0.01 s (FEMA P695, each normalised to PGA = 1 g) at PGAs 0.1, 0.3,
0.6 and 1.0 g: 32 runs of the 0.2 x 1.5 m block, 1 mm gap, ``beta`` 3.01e-4 s (its facade
fit, experiments/results/facade_ida_step/beta.json), the step passed as data (so the steps a
sample are data, as in eager calls).

    python benchmarks/bench_facade_batch.py
    PYTHONPATH=<another checkout> python benchmarks/bench_facade_batch.py   # that code, alike

Prints the wall time of each (the smallest of three warm calls; the loop once, warm) and the
largest difference of the peak ``d/b`` between the batch and the loop (docs/benchmarks.md,
"Facade IDA: open steps off the wall").
"""

from __future__ import annotations

import time

import jax
import jax.numpy as jnp
import numpy as np

import rockjax as rj

BLOCK = rj.Block(b=0.2, h=1.5)
BETA = 3.01e-4  # [s]
GAP = 0.001  # [m]
RECORD_DT = 0.01  # [s]
PGAS_G = np.array([0.1, 0.3, 0.6, 1.0])
N_RECORDS = 8


def main() -> None:
    print(f"rockjax {rj.__file__}")
    recs = [r.scaled_to_pga(target_pga_g=1.0) for r in rj.records.fema_p695("farfield")]
    recs = [r for r in recs if abs(r.dt - RECORD_DT) < 1e-12][:N_RECORDS]
    n = max(r.n for r in recs)
    ag = np.zeros((len(recs), n))
    for i, r in enumerate(recs):
        ag[i, : r.n] = r.ag
    mode = rj.Facade(gap=GAP)
    dt = RECORD_DT / np.ceil(RECORD_DT / float(rj.stable_dt(BLOCK, BETA, mode=mode)) - 1e-9)
    rec_idx, scale = (a.ravel() for a in np.meshgrid(np.arange(len(recs)), PGAS_G, indexing="ij"))
    ag = jnp.asarray(ag)

    def one(i, s):
        motion = rj.GroundMotion(ag=s * ag[i], dt=RECORD_DT)
        r = rj.simulate_dem(BLOCK, motion, beta=BETA, mode=mode, dt=jnp.asarray(dt), throw=False)
        return r.extras["d_max"] / BLOCK.b

    batch = jax.jit(jax.vmap(one))
    d_batch = np.asarray(jax.block_until_ready(batch(rec_idx, scale)))
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        jax.block_until_ready(batch(rec_idx, scale))
        times.append(time.perf_counter() - t0)
    single = jax.jit(one)
    jax.block_until_ready(single(rec_idx[0], scale[0]))
    t0 = time.perf_counter()
    d_loop = np.array([float(single(i, s)) for i, s in zip(rec_idx, scale)])
    t_loop = time.perf_counter() - t0
    kw = dict(model=rj.DEM(beta=BETA), mode=mode, progress=False)
    rj.ida(BLOCK, recs, PGAS_G, **kw)
    t0 = time.perf_counter()
    rj.ida(BLOCK, recs, PGAS_G, **kw)
    t_ida = time.perf_counter() - t0
    print(f"{rec_idx.size} facade runs of {n} samples, dt {dt:.3g} s:")
    print(f"  jit(vmap) batch      {min(times):6.2f} s")
    print(f"  loop of jit runs     {t_loop:6.2f} s")
    print(f"  rj.ida               {t_ida:6.2f} s")
    print(f"  batch vs loop, peak d/b: largest difference {np.max(np.abs(d_batch - d_loop)):.1e}")


if __name__ == "__main__":
    main()
