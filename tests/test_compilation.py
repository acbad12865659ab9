"""Tests of rockjax.compilation: length buckets, padding, the persistent cache, notices.

References: the definitions themselves (a bucket is the least ``minimum * growth^k >= n``,
checked by enumeration), JAX's own configuration for the cache, and, for the cache across
processes, a second process that finds the first one's programs on disk (slow test).
"""

import logging
import os
import subprocess
import sys
import textwrap

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax import compilation


def _least_bucket(n, growth, minimum):
    """The bucket by enumeration of ``minimum * growth^k``, k = 0, 1, ..."""
    k = 0
    while minimum * growth**k < n:
        k += 1
    return minimum * growth**k


@pytest.mark.parametrize("growth, minimum", [(2.0, 2**15), (1.25, 1000), (1.5, 1)])
def test_bucket_is_the_least_power_of_growth_that_holds_n(growth, minimum):
    ns = [n for n in (1, 2, minimum - 1, minimum, minimum + 1, 3 * minimum + 7, 10**6) if n >= 1]
    for n in ns:
        got = compilation.bucket_length(n, growth=growth, minimum=minimum)
        want = _least_bucket(n, growth, minimum)
        assert n <= got < want + 1  # `want` up to the rounding up of a non-integer length
        assert got <= max(minimum, growth * n + 1)  # padding bounded by the growth


def test_default_buckets_hold_the_record_sets_in_one_bucket():
    lengths = [r.n for r in rj.records.fema_p695("farfield")]
    assert len({compilation.bucket_length(n) for n in lengths}) == 1


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(n=0), r"\bn must be"),
        (dict(n=10, growth=1.0), r"\bgrowth must be"),
        (dict(n=10, minimum=0), r"\bminimum must be"),
    ],
)
def test_bucket_refuses_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        compilation.bucket_length(**kwargs)


def test_pad_repeats_the_last_sample_concrete_or_traced():
    x = np.array([1.0, -2.0, 3.5])
    want = np.array([1.0, -2.0, 3.5, 3.5, 3.5])
    np.testing.assert_array_equal(compilation.pad_to(x, 5), want)
    np.testing.assert_array_equal(jax.jit(lambda v: compilation.pad_to(v, 5))(jnp.asarray(x)), want)
    with pytest.raises(ValueError, match="length must be >= the 3 samples"):
        compilation.pad_to(x, 2)


def test_cache_dir_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.delenv(compilation.CACHE_ENV, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert compilation.cache_dir() == tmp_path / "rockjax" / "jax"
    monkeypatch.setenv(compilation.CACHE_ENV, str(tmp_path / "elsewhere"))
    assert compilation.cache_dir() == tmp_path / "elsewhere"
    for off in ("off", "0", "", "False"):
        monkeypatch.setenv(compilation.CACHE_ENV, off)
        assert compilation.cache_dir() is None
        assert compilation.enable_cache() is None


def test_enable_cache_points_jax_at_the_folder(tmp_path):
    before = jax.config.jax_compilation_cache_dir
    before_min = jax.config.jax_persistent_cache_min_compile_time_secs
    try:
        path = compilation.enable_cache(tmp_path / "cache")
        assert path == tmp_path / "cache" and path.is_dir()
        assert jax.config.jax_compilation_cache_dir == str(path)
    finally:
        jax.config.update("jax_compilation_cache_dir", before)
        jax.config.update("jax_persistent_cache_min_compile_time_secs", before_min)


def test_enable_cache_in_an_unwritable_place_says_why_and_goes_on(tmp_path, caplog):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    before = jax.config.jax_compilation_cache_dir
    with caplog.at_level(logging.INFO, logger="rockjax"):
        assert compilation.enable_cache(blocker / "cache") is None
    assert jax.config.jax_compilation_cache_dir == before
    assert any(compilation.CACHE_ENV in r.getMessage() for r in caplog.records)


def test_notice_once_says_it_once(caplog):
    key = ("test_compilation", object())
    with caplog.at_level(logging.INFO, logger="rockjax"):
        assert compilation.notice_once(key, "rockjax: compiling a thing (once per session)...")
        assert not compilation.notice_once(key, "rockjax: compiling a thing (once per session)...")
    assert [r.getMessage() for r in caplog.records] == [
        "rockjax: compiling a thing (once per session)..."
    ]


def test_a_silenced_logger_gives_no_notice(caplog, capsys):
    logger = logging.getLogger("rockjax")
    before = logger.level
    logger.setLevel(logging.WARNING)
    try:
        assert compilation.notice_once(("silenced", object()), "rockjax: compiling...")
    finally:
        logger.setLevel(before)
    assert caplog.records == [] and capsys.readouterr().err == ""


def test_is_traced_tells_a_tracer_from_a_value():
    assert not compilation.is_traced(1.0, np.zeros(3), {"a": jnp.ones(2)})
    assert jax.jit(lambda x: compilation.is_traced(0.0, (x,)))(1.0)


_SECOND_PROCESS = textwrap.dedent(
    """
    import sys
    import jax
    import rockjax as rj
    hits = []
    jax.monitoring.register_event_listener(
        lambda event, **kw: hits.append(event) if event.endswith("cache_hits") else None
    )
    rj.enable_compilation_cache()
    block = rj.Block(b=0.25, h=1.5)
    gm = rj.GroundMotion.ricker(pga_g=0.3, period=0.5, duration=float(sys.argv[1]), dt=0.01)
    rj.simulate_housner(block, gm).theta.block_until_ready()
    print(len(hits))
    """
)


@pytest.mark.slow
def test_a_second_process_loads_the_solver_from_the_cache(tmp_path):
    # The first process compiles and writes the cache; the second, with a record of another
    # length (same bucket), loads the solver from it instead of compiling it.
    env = os.environ | {compilation.CACHE_ENV: str(tmp_path / "cache")}

    def cache_hits(duration):
        out = subprocess.run(
            [sys.executable, "-c", _SECOND_PROCESS, str(duration)],
            env=env,
            capture_output=True,
            text=True,
        )
        assert out.returncode == 0, out.stderr
        assert "compiling the Housner solver" in out.stderr, out.stderr
        return int(out.stdout.split()[-1])

    assert cache_hits(4.0) == 0
    assert any(path.name.startswith("jit__simulate") for path in (tmp_path / "cache").iterdir())
    assert cache_hits(6.0) >= 1
