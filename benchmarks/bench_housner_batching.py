"""Benchmark: batching many runs on CPU, ``jax.vmap`` against one run after another
(``jax.lax.map``, what :func:`rockjax.housner.batch_runs` does on CPU), side by side.

Housner: the paper's 0.25 x 3 m facade (``mode="one_sided"``) on the first four FEMA P695
near-field components of step 0.005 s (8001 samples, 40 s) x 16 scales (0.1-1.6) = 64 runs,
with a fixed return wall and with the wall moving with a 3-storey shear building (T1 = 0.3 s,
5 %; ``wall_motion=(u_top, v_top)`` precomputed, as ``rj.ida`` passes it). The DEM: the same
facade, 2 records x 4 scales, 10 s (``beta_DeJong``). Every row is one ``jit`` of the whole
batch; CPU time (``time.process_time``, all threads) of the warm call, the minimum of
``--repeat`` interleaved rounds (a load burst hits every row alike). Results are checked equal
between the two ways.

    python benchmarks/bench_housner_batching.py [--repeat 5]

About 2 min on 2 cores.
"""

from __future__ import annotations

import argparse
import datetime
import math
import platform
import time

import jax
import jax.numpy as jnp
import numpy as np
from _timing import load, machine

import rockjax as rj
from rockjax.building import ShearBuilding
from rockjax.supports import wall_top_motion


def _records(dt: float, count: int, n: int) -> np.ndarray:
    recs = [r for r in rj.records.fema_p695("nearfield") if math.isclose(r.dt, dt)][:count]
    ag = np.zeros((len(recs), n))
    for i, r in enumerate(recs):
        ag[i, : min(r.n, n)] = np.asarray(r.ag)[:n]
    return ag


def _time(rows, args, repeat):
    out = {}
    for label, fn in rows:
        out[label] = [jax.block_until_ready(fn(*args)), []]
    for _ in range(repeat):
        for label, fn in rows:
            c = time.process_time()
            jax.block_until_ready(fn(*args))
            out[label][1].append(time.process_time() - c)
    return {label: (res, min(ts)) for label, (res, ts) in out.items()}


def housner_rows(block, repeat):
    scales = np.linspace(0.1, 1.6, 16)
    ag = _records(0.005, 4, 8001)
    runs = jnp.asarray(np.repeat(ag, scales.size, 0) * np.tile(scales, len(ag))[:, None])
    bldg = ShearBuilding.uniform(n_storeys=3, storey_height=3.0, period=0.3, damping=0.05)

    def motion(a):
        return rj.GroundMotion(ag=a, dt=0.005)

    u, v = jax.jit(jax.vmap(lambda a: wall_top_motion(bldg, motion(a), block.h)))(runs)
    dt = rj.housner.P_DT_TARGET / float(block.p)

    def one(a, uu, vv, wall):
        w = (uu, vv) if wall else None
        r = rj.simulate_housner(
            block, motion(a), mode="one_sided", dt=dt, throw=False, wall_motion=w
        )
        return r.theta_max

    rows = []
    for wall in (False, True):
        name = "moving wall" if wall else "fixed wall"

        def f(a, uu, vv, w=wall):
            return one(a, uu, vv, w)

        rows.append((f"Housner, {name}: vmap", jax.jit(jax.vmap(f))))
        rows.append(
            (
                f"Housner, {name}: lax.map",
                jax.jit(lambda A, U, V, f=f: jax.lax.map(lambda x: f(*x), (A, U, V))),
            )
        )
    print(f"\n  Housner: {runs.shape[0]} runs of {runs.shape[1]} samples (dt 0.005 s)")
    return _time(rows, (runs, u, v), repeat)


def dem_rows(block, repeat):
    scales = np.array([0.5, 1.0, 1.5, 2.0])
    ag = _records(0.01, 2, 1001)
    runs = jnp.asarray(np.repeat(ag, scales.size, 0) * np.tile(scales, len(ag))[:, None])
    beta = float(rj.beta_dejong(block))
    dt = rj.stable_dt(block, beta, mode="one_sided")

    def one(a):
        gm = rj.GroundMotion(ag=a, dt=0.01)
        r = rj.simulate_dem(block, gm, beta=beta, mode="one_sided", dt=dt, throw=False)
        return r.theta_max

    rows = [
        ("DEM, fixed wall: vmap", jax.jit(jax.vmap(one))),
        ("DEM, fixed wall: lax.map", jax.jit(lambda A: jax.lax.map(one, A))),
    ]
    print(f"  DEM: {runs.shape[0]} runs of {runs.shape[1]} samples (dt 0.01 s, step {dt:.3g} s)")
    return _time(rows, (runs,), repeat)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    print(
        "rockjax batching benchmark  "
        f"{datetime.datetime.now(datetime.UTC).isoformat(timespec='seconds')}\n"
        f"  python {platform.python_version()}, jax {jax.__version__} "
        f"({jax.default_backend()}), {machine()}; load at start {load()}"
    )
    block = rj.Block(b=0.25, h=3.0)
    results = housner_rows(block, args.repeat)
    results |= dem_rows(block, args.repeat)
    print(f"\n  {'batch':36s} {'CPU min [s]':>12s} {'vmap / lax.map':>15s}  same result")
    labels = list(results)
    for vm, lm in zip(labels[::2], labels[1::2], strict=True):
        (r_v, t_v), (r_m, t_m) = results[vm], results[lm]
        same = float(jnp.max(jnp.abs(r_v - r_m)))
        print(f"  {vm:36s} {t_v:12.3f}")
        print(f"  {lm:36s} {t_m:12.3f} {t_v / t_m:15.2f}  max diff {same:.1e} rad")
    print(f"\n  load at end {load()}")


if __name__ == "__main__":
    main()
