"""jaxtyping aliases shared across rockjax."""

from jaxtyping import Array, ArrayLike, Bool, Float, Int

Scalar = Float[Array, ""]
ScalarLike = Float[ArrayLike, ""]
TimeSeries = Float[Array, " time"]
BoolScalar = Bool[Array, ""]
IntScalar = Int[Array, ""]

__all__ = ["Scalar", "ScalarLike", "TimeSeries", "BoolScalar", "IntScalar"]
