"""Wall-clock timing shared by the benchmark scripts."""

import statistics
import time

import jax


def timed(fn, repeats: int, warmup: bool = True):
    """(median, min) wall time [s] of ``fn()`` over ``repeats`` calls (after one warm-up)."""
    if warmup:
        jax.block_until_ready(fn())
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        jax.block_until_ready(fn())
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts), min(ts)
