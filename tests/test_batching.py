"""Tests of rockjax.batching: chunks of a vmap batch in threads against single runs, the calls
in threads (which run alone, how many at once), the wide batch's compiler options, and bad
arguments."""

import threading
import time

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax.batching import WIDE_BATCH, WIDE_BATCH_OPTIONS, batch_options, in_threads

RTOL = 1e-12
"""A batch against single runs, or two compilations of one batch: the same float64
operations, up to XLA's fusion choices (round-off, not grown: the runs are short)."""

BLOCK = rj.Block(b=0.2, h=1.0)
BETA = 2e-3  # [s]
REC = rj.GroundMotion.ricker(3.0, 0.4, dt=0.01, duration=0.6)
DT = float(rj.stable_dt(BLOCK, BETA))


def one(scale):
    """One DEM run of the record at ``scale``: a pytree of outputs."""
    r = rj.simulate_dem(
        BLOCK, rj.GroundMotion(ag=scale * jnp.asarray(REC.ag), dt=REC.dt), beta=BETA, dt=DT
    )
    return {"theta_max": r.theta_max, "theta": r.theta}


def _single_runs(scales):
    run = jax.jit(one)
    outs = [jax.device_get(run(s)) for s in scales]
    return {k: np.stack([o[k] for o in outs]) for k in outs[0]}


def test_chunks_in_threads_match_single_runs():
    """Seven runs in chunks of three (the last padded) on two threads, called twice (the
    second call runs every chunk in the threads): the stacked outputs of seven single runs."""
    scales = np.linspace(0.4, 1.6, 7)
    ref = _single_runs(scales)
    batched = rj.vmap_chunks(one, chunk_size=3, threads=2)
    for _ in range(2):
        out = batched(scales)
        assert set(out) == set(ref)
        for k in ref:
            assert isinstance(out[k], np.ndarray)
            assert out[k].shape == ref[k].shape
            np.testing.assert_allclose(out[k], ref[k], rtol=RTOL, atol=1e-15)
    assert np.ptp(ref["theta_max"]) > 1e-3  # the runs differ: a mix-up of rows would show


class _Calls:
    """Calls that record how many run at once, in which thread, and how many tasks were
    taken while they ran."""

    def __init__(self):
        self.lock = threading.Lock()
        self.running = 0
        self.taken = 0
        self.seen = []  # per call: (its index, calls running with it, tasks taken, thread)

    def tasks(self, alone):
        for i, a in enumerate(alone):
            with self.lock:
                self.taken += 1
            yield (lambda i=i: self.call(i)), a

    def call(self, i):
        with self.lock:
            self.running += 1
            self.seen.append((i, self.running, self.taken, threading.get_ident()))
        time.sleep(0.02)
        with self.lock:
            self.running -= 1
        return 10 * i


def test_in_threads_runs_alone_tasks_alone():
    """Eight calls on three threads, the first and the fifth alone: every result once, at
    most three calls at once, the alone ones by themselves and in the caller's thread, and at
    most one task made ahead of the running calls."""
    calls = _Calls()
    alone = [True, False, False, False, True, False, False, False]
    got = dict(in_threads(calls.tasks(alone), 3))
    assert got == {i: 10 * i for i in range(8)}
    seen = {i: rest for i, *rest in calls.seen}
    assert max(running for running, _, _ in seen.values()) == 3  # the threads were used
    for i in (0, 4):
        assert seen[i][0] == 1
        assert seen[i][2] == threading.get_ident()
    # by the time call i starts: tasks 0..i, at most two submitted after it, one made ahead
    assert all(taken <= i + 4 for i, (_, taken, _) in seen.items())


def test_in_threads_one_thread_runs_in_order_here():
    """One thread: every call in the caller's thread, one after another, in order."""
    calls = _Calls()
    got = list(in_threads(calls.tasks([False] * 4), 1))
    assert got == [(i, 10 * i) for i in range(4)]
    assert [(i, r, t) for i, r, _, t in calls.seen] == [
        (i, 1, threading.get_ident()) for i in range(4)
    ]


def test_in_threads_passes_errors_on():
    """A call that raises raises in the caller."""

    def bad():
        raise ValueError("from a thread")

    tasks = [(lambda: 1, False), (bad, False), (lambda: 3, False)]
    with pytest.raises(ValueError, match="from a thread"):
        list(in_threads(iter(tasks), 2))


def test_inside_jit_is_vmap():
    scales = np.array([0.5, 1.5])
    out = jax.jit(rj.vmap_chunks(one, chunk_size=1))(scales)
    np.testing.assert_allclose(out["theta_max"], _single_runs(scales)["theta_max"], rtol=RTOL)


def test_wide_batch_options_drop_the_hoisting_pass():
    """The pass leaves its mark (``xla_cpu_small_call``) on a hoisted loop; the wide options
    compile the same batch without it, to the same results."""
    assert batch_options(WIDE_BATCH - 1) == {}
    assert batch_options(WIDE_BATCH) == WIDE_BATCH_OPTIONS
    scales = np.linspace(0.4, 1.6, WIDE_BATCH)
    hoisted = jax.jit(jax.vmap(one)).lower(scales).compile()
    wide = jax.jit(jax.vmap(one), compiler_options=WIDE_BATCH_OPTIONS).lower(scales).compile()
    assert "xla_cpu_small_call" in hoisted.as_text()
    assert "xla_cpu_small_call" not in wide.as_text()
    a, b = hoisted(scales), wide(scales)
    np.testing.assert_allclose(b["theta"], a["theta"], rtol=RTOL, atol=1e-15)


@pytest.mark.parametrize(
    "kwargs, match", [({"chunk_size": 0}, "chunk_size"), ({"threads": 0}, "threads")]
)
def test_bad_options_say_which(kwargs, match):
    with pytest.raises(ValueError, match=match):
        rj.vmap_chunks(one, **kwargs)


def test_unequal_batch_axes_say_how_to_fix():
    with pytest.raises(ValueError, match="leading.*Close over"):
        rj.vmap_chunks(lambda a, b: a + b)(np.ones(3), np.ones(4))
    with pytest.raises(ValueError, match="leading"):
        rj.vmap_chunks(lambda a, b: a + b)(np.ones(3), 1.0)
    with pytest.raises(ValueError, match="empty"):
        rj.vmap_chunks(lambda a: a)(np.ones((0, 2)))
