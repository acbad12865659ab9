import jax
import jaxtyping
import pytest

import rockjax  # noqa: F401  (enables float64)

jax.config.update("jax_numpy_rank_promotion", "raise")


@pytest.fixture
def user_view():
    """Run as a user calls: without the test-only jaxtyping/beartype runtime checks, which would
    refuse a wrong type before the library's own check can say what to do."""
    before = jaxtyping.config.jaxtyping_disable
    jaxtyping.config.update("jaxtyping_disable", True)
    yield
    jaxtyping.config.update("jaxtyping_disable", before)
