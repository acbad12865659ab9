"""Many runs at once on a host CPU: chunks of a ``vmap`` batch, each compiled for its width,
run in threads, one per core.

XLA:CPU runs one compiled call on one core, and the calls of two Python threads at once, each
on its own core; so a batch runs fastest as chunks in as many threads as the process may use
cores (:func:`host_threads`). How a chunk's time loop is compiled depends on its width: XLA's
``small-while-loop-hoisting`` pass compiles a loop whose data are small into one kernel,
which makes a single history 8-15 times faster (docs/benchmarks.md, "The small-while-loop
flag") and batches of up to 32 runs faster too (64: even), but slows wider batches, whose
loops run faster as XLA's separate vectorised kernels. Measured on 2 cores (1024 runs of a
20 s record, 0.25 x 3 m parapet, default joint, chunks in two threads; docs/benchmarks.md,
"Wide batches"): chunks of 256 ran at 5.4-5.8e7 block-steps/s without the pass and
3.2-3.3e7 with it, chunks of 64 at 4.2e7 either way, chunks of 32 at 2.6e7 without and 3.6e7
with it.

:func:`vmap_chunks` does this for any function of one run; :func:`in_threads` runs any calls
so (the chunks of :func:`rockjax.ida`, a study's own chunks); :data:`WIDE_BATCH_OPTIONS` are
the compiler options of a wide batch, for a ``jax.jit`` of one's own::

    batch = jax.jit(jax.vmap(one_run), compiler_options=rj.batching.WIDE_BATCH_OPTIONS)
"""

from __future__ import annotations

import concurrent.futures
import functools
import os
from collections.abc import Callable, Iterable, Iterator
from typing import Any

import jax
import numpy as np

from .compilation import is_traced

HOISTING_PASS = "small-while-loop-hoisting"
"""The XLA:CPU pass that compiles a small while loop into one kernel."""
WIDE_BATCH = 128
"""Runs per compiled batch from which a batch's loops run faster without
:data:`HOISTING_PASS` on CPU (measured with the default joint: 1.15-1.25x faster at 128 runs,
1.7-1.8x at 256, 2.5x at 512; even at 64; below that the pass wins. With corner contacts:
even at 128, 1.25x faster at 256, slower below)."""
WIDE_BATCH_OPTIONS = {"xla_disable_hlo_passes": HOISTING_PASS}
"""``jax.jit(..., compiler_options=WIDE_BATCH_OPTIONS)`` for a batch of :data:`WIDE_BATCH` runs
or more on CPU (the same results, to round-off)."""
CHUNK = 256
""":func:`vmap_chunks`' default chunk: the fastest measured on 2 cores (docs/benchmarks.md,
"Wide batches": 5.4-6.0e7 block-steps/s with the default joint, against 4.8-5.2e7 at 128
and 5.6e7 at 512)."""


def host_threads() -> int:
    """The chunks to run at once on one host CPU device: one per core this process may use.
    Each runs on its own core (one compiled call per Python thread; XLA:CPU runs the calls of
    one thread one after another). Measured on 2 cores, the far-field IDA of the 0.2 x 1.5 m
    block ran 1.9-2.0x faster as a facade and 1.85-1.9x as a parapet, with the same results to
    the bit (docs/benchmarks.md, "IDA: chunks in threads"). The chunks then run in worker
    threads, which JAX settings made in the caller's thread by a context manager (e.g.
    ``jax.debug_nans(True)``) do not reach: set those with ``jax.config.update``."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # (not on every platform)
        return max(1, os.cpu_count() or 1)


def in_threads(tasks: Iterable[tuple[Callable[[], Any], bool]], threads: int) -> Iterator:
    """Run ``tasks`` ``threads`` at a time, each call in a thread of its own, and yield
    ``(i, result)`` of the ``i``-th task as each ends (not in order).

    ``tasks`` yields ``(call, alone)``: a function of no arguments, and whether it runs alone
    (e.g. it compiles, and the others would compile its program again): it waits for the
    running calls to end, and runs in the caller's thread before the next task is taken. The
    tasks are taken one at a time: the next one is made (e.g. its inputs placed) while the
    running calls go on, and waits for a free thread, so at most one task is made ahead. With
    one thread every call runs in the caller's thread, in order. Used by :func:`vmap_chunks`
    and :func:`rockjax.ida`, with :func:`host_threads` threads on a host CPU.
    """
    if threads == 1:
        for i, (call, _) in enumerate(tasks):
            yield i, call()
        return
    with concurrent.futures.ThreadPoolExecutor(threads) as pool:
        running: dict[concurrent.futures.Future, int] = {}

        def ended(limit):  # wait until fewer than `limit` calls run; the ended ones
            while len(running) >= limit:
                done, _ = concurrent.futures.wait(
                    running, return_when=concurrent.futures.FIRST_COMPLETED
                )
                yield from ((running.pop(job), job.result()) for job in done)

        for i, (call, alone) in enumerate(tasks):
            if alone:
                yield from ended(1)
                yield i, call()
            else:
                yield from ended(threads)
                running[pool.submit(call)] = i
        yield from ended(1)


def batch_options(runs: int) -> dict:
    """The compiler options for a compiled batch of ``runs`` runs on the default backend:
    :data:`WIDE_BATCH_OPTIONS` from :data:`WIDE_BATCH` runs on CPU, none otherwise."""
    if runs >= WIDE_BATCH and jax.default_backend() == "cpu":
        return dict(WIDE_BATCH_OPTIONS)
    return {}


def vmap_chunks(fn: Callable, chunk_size: int = CHUNK, threads: int | None = None) -> Callable:
    """``jax.vmap(fn)``, run as compiled chunks of ``chunk_size`` runs in threads.

    The returned function takes the arguments of ``fn``, each leaf an array with a leading
    batch axis of one length ``n`` (close over what is not batched), and returns the outputs
    of ``fn`` stacked along a leading axis of ``n``, as NumPy arrays. The batch is cut into
    chunks of ``chunk_size`` (the last padded with copies of the first run, dropped afterwards,
    so that every chunk has one shape and compiles once), each a ``jax.jit(jax.vmap(fn))``
    call with :func:`batch_options`. The first chunk of a new width runs alone (it compiles);
    the others run ``threads`` at a time (default :func:`host_threads`), each on its own
    core. Called inside a transform (``jit``, ``vmap``, ``grad``) it is ``jax.vmap(fn)``.

    A function whose loop branches differently in each run (:func:`rockjax.simulate_housner`,
    a DEM facade's open and closed steps) runs faster one run after another on CPU
    (:func:`rockjax.housner.batch_runs`, or :func:`rockjax.ida`); this is for runs that take
    the same path, such as DEM parapets.

    Args:
        fn: A function of one run, as for ``jax.vmap``.
        chunk_size: Runs per compiled call (default :data:`CHUNK`).
        threads: Chunks running at once (default :func:`host_threads`).

    Example::

        def one(scale):
            motion = rj.GroundMotion(ag=scale * ag, dt=0.01)
            return rj.simulate_dem(block, motion, beta=beta, throw=False).theta_max

        theta_max = rj.vmap_chunks(one)(np.linspace(0.5, 1.5, 1024))
    """
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, int) or chunk_size < 1:
        raise ValueError(
            f"chunk_size (runs per compiled call) must be an int >= 1; got {chunk_size!r}."
        )
    if threads is not None and (
        isinstance(threads, bool) or not isinstance(threads, int) or threads < 1
    ):
        raise ValueError(f"threads (chunks at once) must be an int >= 1 or None; got {threads!r}.")
    programs: dict[int, Callable] = {}  # by chunk width: its compiler options depend on it

    def batched(*args):
        leaves, treedef = jax.tree.flatten(args)
        if is_traced(*leaves):
            return jax.vmap(fn)(*args)
        leaves = [np.asarray(x) for x in leaves]
        sizes = {x.shape[0] if x.ndim else None for x in leaves}
        if len(sizes) != 1 or None in sizes:
            raise ValueError(
                "vmap_chunks: every argument needs one leading (batch) axis of the same length; "
                f"got shapes {[x.shape for x in leaves]}. Close over what is not batched (a "
                "lambda or functools.partial around fn)."
            )
        (n,) = sizes
        if n == 0:
            raise ValueError("vmap_chunks: the batch is empty (a leading axis of length 0).")
        size = min(chunk_size, n)
        compiles = size not in programs
        if compiles:
            programs[size] = jax.jit(jax.vmap(fn), compiler_options=batch_options(size) or None)
        starts = range(0, n, size)
        rows = np.concatenate([np.arange(n), np.zeros(len(starts) * size - n, int)])

        def chunk(start):
            part = [x[rows[start : start + size]] for x in leaves]
            return jax.device_get(programs[size](*jax.tree.unflatten(treedef, part)))

        # a chunk that compiles runs alone
        tasks = ((functools.partial(chunk, s), compiles and s == 0) for s in starts)
        parts = dict(in_threads(tasks, threads or host_threads()))
        return jax.tree.map(lambda *xs: np.concatenate(xs)[:n], *(parts[i] for i in sorted(parts)))

    return batched
