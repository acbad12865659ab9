import os
import shutil
import tempfile

# One persistent compilation cache for the whole run, shared by the pytest-xdist workers (they
# inherit the variable from the controller, which imports this file first) and by the
# processes tests start: most of the suite's time is compiling, and the workers and the
# subprocesses compile many of the same programs. Set before JAX is imported; a cache the
# user points to is left alone. Tests that count compilations count cache hits as well
# (``helpers.count_compiles``).
_CACHE_VAR = "JAX_COMPILATION_CACHE_DIR"
_OWN_CACHE = None
if not os.environ.get(_CACHE_VAR):
    _OWN_CACHE = tempfile.mkdtemp(prefix="rockjax-tests-xla-")
    os.environ[_CACHE_VAR] = _OWN_CACHE
    os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0.2")

# Most of the suite's time is XLA compiling many programs that then run for well under a
# second: the tests compile with LLVM's cheap optimisation level (about a third less time for
# tests/test_dem.py: 127 s against 85 s, all passing). The programs are the same HLO; results
# differ from the default level only at round-off (measured 1e-14 of a DEM history's peak:
# LLVM then fuses fewer multiply-adds). Benchmarks, notebooks and the demo keep the default.
# A user's own XLA_FLAGS replace these.
os.environ.setdefault(
    "XLA_FLAGS", "--xla_backend_optimization_level=0 --xla_llvm_disable_expensive_passes=true"
)

import jax  # noqa: E402
import jaxtyping  # noqa: E402
import pytest  # noqa: E402

import rockjax  # noqa: E402  (enables float64)

# rockjax's XLA:CPU option, added to the flags above (or to the user's), before any JAX
# computation: the suite runs the time loops as users get them (docs/conventions.md, "XLA flags").
rockjax.compilation.configure_cpu()

# rockjax turns its own persistent cache on at the first eager compile, in the user's cache
# folder unless JAX's cache is set (as above): off for the suite, and for the processes it
# starts, so the tests never write to the user's cache (tests of the cache give it a folder).
os.environ[rockjax.compilation.CACHE_ENV] = "off"

jax.config.update("jax_numpy_rank_promotion", "raise")


def pytest_unconfigure(config):
    if _OWN_CACHE is not None and not hasattr(config, "workerinput"):  # the controller's own
        shutil.rmtree(_OWN_CACHE, ignore_errors=True)


@pytest.fixture
def user_view():
    """Run as a user calls: without the test-only jaxtyping/beartype runtime checks, which would
    refuse a wrong type before the library's own check can say what to do."""
    before = jaxtyping.config.jaxtyping_disable
    jaxtyping.config.update("jaxtyping_disable", True)
    yield
    jaxtyping.config.update("jaxtyping_disable", before)
