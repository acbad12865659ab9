"""``batch_runs``: many Housner runs, the fastest way on the current backend."""

from __future__ import annotations

import jax


def batch_runs(run, *xs):
    """``run`` over the leading axis of each of ``xs`` (one Housner simulation per element),
    the fastest way on the current backend: ``jax.lax.map`` (one run after another) on CPU,
    ``jax.vmap`` elsewhere. Use it inside ``jit`` in place of ``jax.vmap(run)(*xs)``.

    Why: the solver is a loop of passes whose branches (the flight, the impact) are taken per
    run. Under ``vmap`` every run of the batch goes through every pass that any run needs,
    each operation on a vector of a few elements; XLA:CPU then spends its time launching small
    kernels. One run after another, the loop is scalar code and skips what its own run does
    not need: 4.8x less CPU time for 64 facade runs of 40 s (0.070 s against 0.340 s,
    identical results; ``benchmarks/bench_housner_batching.py``, docs/benchmarks.md, "Batching
    on CPU: one run after another"). The DEM of a parapet (a scan without such branches) is
    the other way round and stays with ``vmap``; a facade's (its samples in open or closed
    steps, :func:`rockjax.dem.run`) goes one run after another, as Housner's.
    """
    if jax.default_backend() == "cpu":
        return jax.lax.map(lambda x: run(*x), xs)
    return jax.vmap(run)(*xs)
