"""Results of eager set-up programs kept by the values of their inputs (re-exported by
:mod:`rockjax.compilation`): a loop of eager runs of one block over a record set sets up once."""

from __future__ import annotations

import collections
import functools
import threading
from collections.abc import Hashable

import jax
import numpy as np


def value_key(tree) -> Hashable | None:
    """A hashable key of ``tree``'s values: its structure (static fields included) and the
    bytes, shape and type of each concrete array or number; None where a leaf is traced or a
    static value is unhashable. Two trees with equal keys give a pure program the same
    inputs, so its outputs can be reused (:func:`memoized`)."""
    flat, treedef = jax.tree.flatten(tree)
    key = [treedef]
    for x in flat:
        if isinstance(x, jax.core.Tracer):
            return None
        if isinstance(x, (np.ndarray, np.generic, jax.Array, bool, int, float, complex)):
            a = np.asarray(x)  # (bytes: 0.0 and -0.0 differ, as do 1 and 1.0 by their type)
            key.append((type(x).__name__, a.dtype.str, a.shape, a.tobytes()))
        elif isinstance(x, (str, type(None))):
            key.append(x)
        else:
            return None
    key = tuple(key)
    try:
        hash(key)
    except TypeError:  # an unhashable static value in the structure
        return None
    return key


def memoized(fn, maxsize: int = 64):
    """``fn`` (a pure function of arrays and static values, e.g. a compiled set-up) with its
    last ``maxsize`` results kept by the values of its arguments (:func:`value_key`): a call
    whose arguments equal an earlier call's returns that call's outputs (JAX arrays are
    immutable, so sharing them is safe) without dispatching the program again. Calls with
    traced arguments, and any call while a ``jit`` is being traced (:func:`tracing`: there
    ``fn``'s outputs are the trace's values, not arrays), run ``fn``. Thread-safe."""
    kept: collections.OrderedDict = collections.OrderedDict()
    lock = threading.Lock()

    @functools.wraps(fn)
    def call(*args, **kwargs):
        key = None if tracing() else value_key((args, kwargs))
        if key is None:
            return fn(*args, **kwargs)
        with lock:
            if key in kept:
                kept.move_to_end(key)
                return kept[key]
        out = fn(*args, **kwargs)
        with lock:
            kept[key] = out
            while len(kept) > maxsize:
                kept.popitem(last=False)
        return out

    call.cache_clear = kept.clear
    return call


def tracing() -> bool:
    """Whether a ``jit`` (or another staging transform) is being traced here: an operation on
    a constant is then staged into the trace instead of run (about 0.01 ms to ask)."""
    return isinstance(jax.lax.stop_gradient(np.float64(0.0)), jax.core.Tracer)
