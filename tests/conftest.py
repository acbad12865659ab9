import jax

import rockjax  # noqa: F401  (enables float64)

jax.config.update("jax_numpy_rank_promotion", "raise")
