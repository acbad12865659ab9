"""Keeping a piece of a time step as one XLA computation.

The steppers are unrolled scalar arithmetic, and XLA's CPU fusion copies a producer into every
consumer it feeds: a value read by many parts of a step (the block elimination of an
assembly, a moving wall's geometry) is then recomputed in each of them. ``optimization_barrier``
does not survive to XLA:CPU's fusion; a ``cond`` does, and so does a reduction.

:func:`sum_together` is the reduction: the face laws sum a dozen quantities over their
integration points, all from the same point law, and one variadic reduction computes them in
one loop that evaluates the point law once per point (summed one by one, or stacked and then
summed, XLA:CPU evaluated the point law again for every sum).

Under ``vmap`` a ``cond`` costs time instead (its results are materialised as vectors and the
batch's predicate reduced every step), so :func:`one_computation` is used in one history
(the DEM driver's ``one_history``, any run that is not batched: the end kinematics of its
faces) and for the step's solve in a history and in an assembly's batch; docs/benchmarks.md
"One history", docs/assemblies.md "Performance". :func:`computed_once` (a reduction again)
keeps single values whole in batches and histories alike, and a batch of single blocks' solve
(docs/benchmarks.md, "Batches of single blocks: the solve without a cond").
"""

import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.numpy as jnp


def one_computation(f, *args):
    """``f(*args)`` kept as one XLA computation (a ``cond`` on a predicate XLA cannot fold:
    true unless the first array input is NaN, where the other branch gives NaN as well).

    Measured: inlined, an assembly's block elimination was recomputed inside each of the 3 n
    velocity updates that read its result: the compiled two-block step had 7481 operations,
    4653 with the elimination kept whole (its traced program has about 1500), and a 10 s
    history of it ran in 0.028-0.030 s instead of 0.056-0.062 s (the two versions in
    alternation; docs/assemblies.md, "Performance"). Python numbers in ``args`` (the folded
    zeros and ones of an assembly's sparse products) stay Python numbers inside.
    """
    dynamic, static = eqx.partition(args, eqx.is_array)
    first = jax.tree.leaves(dynamic)[0]
    ok = eqxi.unvmap_any(first == first)

    def run(d):
        return f(*eqx.combine(d, static))

    def nan(d):
        return jax.tree.map(lambda a: jnp.full(a.shape, jnp.nan, a.dtype), jax.eval_shape(run, d))

    return jax.lax.cond(ok, run, nan, dynamic)


def _add(a, b):
    return tuple(x + y for x, y in zip(a, b))


@jax.custom_jvp
def _sums(*terms):
    return jax.lax.reduce(terms, tuple(0.0 for _ in terms), _add, (terms[0].ndim - 1,))


@_sums.defjvp
def _sums_jvp(primals, tangents):
    # the sums are linear: each tangent summed by JAX's own reduction, which forward mode,
    # reverse mode and vmap all handle (JAX's rule for a variadic reduction fails on a term
    # whose tangent is a symbolic zero, e.g. one that does not depend on the input)
    return _sums(*primals), tuple(jnp.sum(t, axis=-1) for t in tangents)


def sum_together(*terms):
    """The sums of ``terms`` (arrays, broadcast to one shape) over their last axis, as one
    XLA reduction with as many outputs: each element of every term is computed once, with what
    the terms share, and the sums are computed once, however many consumers read them.
    Derivatives sum each term's tangent on its own.

    Measured: the integrated face law's sums over its Gauss points as this reduction instead
    of sums of scalars (docs/benchmarks.md, "One reduction per face").
    """
    shape = jnp.broadcast_shapes(*(jnp.shape(t) for t in terms))
    return _sums(*(jnp.broadcast_to(jnp.asarray(t, float), shape) for t in terms))


def computed_once(*values):
    """``values`` (arrays of one shape) as they are, each computed once whatever reads it:
    summed with a zero in one reduction (:func:`sum_together`), which XLA:CPU does not copy
    into its consumers. For a few values that many others are built from: a face's cuts and
    (in a traced run) its end kinematics, an assembly's dashpot moments and top restraint
    (docs/assemblies.md "Performance", docs/benchmarks.md "Values read by many"). Unlike
    :func:`one_computation` it suits a batch as well as one history.

    Pass the values kept whole together: one reduction with many outputs. A reduction of one
    output over a few thousand values or more XLA:CPU (jaxlib 0.10) hands to its YNNPACK
    library, where a batch of 16 stacks of 20-100 blocks took 1.4-1.7x the CPU time a
    block-step (1.5-2.0x the time on one core; :func:`rockjax.dem._stacked.solve_chain`); a
    reduction of several outputs it compiles itself."""
    return sum_together(*(jnp.stack([v, jnp.zeros_like(v)], axis=-1) for v in values))
