"""Wall-clock timing and machine description shared by the benchmark scripts."""

import os
import platform
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


def machine() -> str:
    """CPU model and the number of cores this process may use."""
    model = platform.processor() or "?"
    try:
        with open("/proc/cpuinfo") as f:
            names = [line.split(":", 1)[1].strip() for line in f if line.startswith("model name")]
        model = names[0] if names else model
    except OSError:
        pass
    return f"{model}, {len(os.sched_getaffinity(0))} cores (nproc)"


def load() -> str:
    """The 1, 5 and 15 min load averages."""
    return " ".join(f"{x:.2f}" for x in os.getloadavg())
