"""Bare-lax helpers of the Housner solver's per-pass code: ``where``, ``clip``, ``floordiv``
and ``mod`` (what ``jnp.where``, ``jnp.clip``, ``//`` and ``%`` compute, without a nested jit
each), ``cond`` (a ``lax.cond`` differentiated as a select of both branches) and ``safe`` (a
divisor guarded in masked-out branches)."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp


def where(pred, a, b):
    """``jnp.where(pred, a, b)`` as one ``lax.select`` (same values, same derivatives)."""
    dtype = jnp.result_type(a, b)
    shape = jnp.broadcast_shapes(jnp.shape(pred), jnp.shape(a), jnp.shape(b))

    def fit(x, dt):
        x = jax.lax.convert_element_type(x, dt)
        if x.shape == shape:
            return x
        return jax.lax.broadcast_in_dim(x, shape, tuple(range(len(shape) - x.ndim, len(shape))))

    return jax.lax.select(fit(pred, bool), fit(a, dtype), fit(b, dtype))


def clip(x, lo, hi):
    """``jnp.clip(x, lo, hi)`` (its definition: ``minimum(maximum(x, lo), hi)``)."""
    return jnp.minimum(jnp.maximum(x, lo), hi)


def floordiv(k, n: int):
    """``k // n`` for ``k >= 0`` (an int array) and a static ``n >= 1``."""
    return k if n == 1 else jax.lax.div(k, jnp.asarray(n, k.dtype))


def mod(k, n: int):
    """``k % n`` for ``k >= 0`` (an int array) and a static ``n >= 1``."""
    return jnp.zeros_like(k) if n == 1 else jax.lax.rem(k, jnp.asarray(n, k.dtype))


def cond(pred, on_true, on_false):
    """``lax.cond(pred, on_true, on_false)`` for branches without arguments, differentiated as
    a ``select`` of both branches.

    The solver's ``cond``s only skip work (a branch's result where ``pred`` fails is never
    read), so both forms have the same values and derivatives. Linearising a ``cond`` nested
    in the checkpointed loop's backward pass made up most of the time to trace ``grad`` of a
    run; its derivative rule here is straight-line code. The run itself keeps the ``cond``.
    Under differentiation the branch not taken is evaluated too, on the same inputs, so it
    must give finite derivatives there (``tests/test_housner.py``: at rest, rocking and
    overturning).
    """
    branches = (eqx.filter_closure_convert(on_true), eqx.filter_closure_convert(on_false))
    arrays, static = eqx.partition(branches, eqx.is_array)
    leaves, treedef = jax.tree.flatten(arrays)

    def rebuild(leaves):
        return eqx.combine(jax.tree.unflatten(treedef, leaves), static)

    @jax.custom_jvp
    def run(pred, *leaves):
        on_true, on_false = rebuild(leaves)
        return jax.lax.cond(pred, lambda: on_true(), lambda: on_false())

    @run.defjvp
    def run_jvp(primals, tangents):
        a, da = jax.jvp(lambda *ls: rebuild(ls)[0](), primals[1:], tangents[1:])
        b, db = jax.jvp(lambda *ls: rebuild(ls)[1](), primals[1:], tangents[1:])

        def pick(x, y):
            if jnp.result_type(x) == jax.dtypes.float0:  # (integer outputs: no tangent)
                return x
            return where(primals[0], x, y)

        return jax.tree.map(pick, a, b), jax.tree.map(pick, da, db)

    return run(pred, *leaves)


TINY = 1e-30  # guards divisions in masked branches so their (unused) gradients stay finite


def safe(x):
    """``x``, or 1 where ``|x|`` is negligible (only reached in masked-out branches)."""
    return where(jnp.abs(x) > TINY, x, 1.0)
