"""Tests of rockjax.compilation: length buckets, padding, the persistent cache, notices.

References: the definitions themselves (a bucket is the least ``minimum * growth^k >= n``,
checked by enumeration), JAX's own configuration for the cache, and, for the cache across
processes, a second process that finds the first one's programs on disk (slow test). Kept
programs (``persistent_jit``): a new wrapper, as in a new process, loads what the first one
exported (its result equal to the bit, and to Eq. 2 written here), each static value keys its
own program, and what cannot be kept is still run correctly.
"""

import json
import logging
import os
import subprocess
import sys
import textwrap

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import count_compiles

import rockjax as rj
from rockjax import compilation, dem


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


def test_cut_undoes_the_padding_in_one_transfer_and_keeps_nones():
    x = np.arange(6.0)
    series = {"a": compilation.pad_to(x, 9), "b": None, "c": jnp.asarray(np.arange(18.0) * 2.0)}
    got, (nested,) = compilation.cut_to((series, (series["c"],)), 6)
    np.testing.assert_array_equal(nested, got["c"])
    np.testing.assert_array_equal(got["a"], x)
    np.testing.assert_array_equal(got["c"], np.arange(6.0) * 2.0)
    assert got["b"] is None
    assert all(isinstance(got[k], jax.Array) for k in ("a", "c"))


def test_value_key_tells_values_apart_and_refuses_tracers():
    key = compilation.value_key
    assert key((np.float64(0.25), {"k": np.arange(3.0)})) == key(
        (np.float64(0.25), {"k": np.arange(3.0)})
    )
    assert key(np.float64(0.25)) != key(np.float64(0.2500000000000001))
    assert key(np.arange(3.0)) != key(np.arange(3.0).reshape(3, 1))  # the shape counts
    assert key(np.arange(3.0)) != key(np.arange(3, dtype=np.float32))  # and the type
    assert key(0.0) != key(-0.0) and key(1) != key(1.0)  # (equal in Python, not as inputs)
    assert key(rj.Block(b=0.25, h=3.0)) == key(rj.Block(b=0.25, h=3.0))
    assert key(rj.Joint()) != key(rj.Joint(n_sub=2))  # static fields are in the structure
    seen = []
    jax.jit(lambda v: seen.append(key(v)) or v)(1.0)
    assert seen == [None]


def test_memoized_reuses_results_by_value_only():
    calls = []

    def f(a, *, scale):
        calls.append(1)
        return jnp.asarray(a) * scale

    g = compilation.memoized(f, maxsize=2)
    one = g(np.arange(3.0), scale=2.0)
    assert g(np.arange(3.0), scale=2.0) is one and len(calls) == 1  # the same values
    np.testing.assert_array_equal(g(np.arange(3.0) + 1.0, scale=2.0), [2.0, 4.0, 6.0])
    np.testing.assert_array_equal(g(np.arange(3.0), scale=3.0), [0.0, 3.0, 6.0])
    assert len(calls) == 3
    g(np.arange(3.0), scale=2.0)  # evicted (maxsize 2): computed again
    assert len(calls) == 4
    # traced arguments run the function
    np.testing.assert_array_equal(jax.jit(lambda a: g(a, scale=2.0))(np.ones(3)), 2.0 * np.ones(3))
    assert len(calls) == 5
    # so does a call with kept values while a jit is traced (its outputs are the trace's)
    np.testing.assert_array_equal(jax.jit(lambda: g(np.arange(3.0), scale=2.0))(), [0, 2, 4])
    assert len(calls) == 6 and compilation.tracing() is False


def test_eager_dem_runs_in_a_loop_are_their_own_runs():
    """The eager run keeps its set-up by value (``memoized``) and its single-block assembly
    (``as_assembly``). Reference: each run under the caller's ``jit``, which keeps nothing
    (traced). A loop over beta and blocks gives each eager run that history (a stale set-up
    would repeat the first run's), also for blocks whose numbers are JAX arrays."""
    rec = rj.GroundMotion.ricker(pga=4.0, period=0.4, dt=0.01, duration=1.5)
    cases = [(0.25, 3.0, 0.01), (0.25, 3.0, 0.02), (0.2, 1.5, 0.01), (0.25, 3.0, 0.01)]
    got = [rj.simulate_dem(rj.Block(b=b, h=h), rec, beta=beta).theta for b, h, beta in cases]
    arrays = [
        rj.simulate_dem(rj.Block(b=jnp.asarray(b), h=jnp.asarray(h)), rec, beta=beta).theta
        for b, h, beta in cases
    ]
    for (b, h, beta), eager, eager_arrays in zip(cases, got, arrays):
        block = rj.Block(b=b, h=h)
        dt = rj.stable_dt(block, beta)
        traced = jax.jit(lambda: rj.simulate_dem(block, rec, beta=beta, dt=dt).theta)()
        peak = float(np.max(np.abs(traced)))
        # the same steps, the block's numbers constants or data: round-off apart
        np.testing.assert_allclose(eager, traced, rtol=0, atol=1e-9 * peak)
        np.testing.assert_array_equal(eager_arrays, eager)
    assert np.max(np.abs(got[0] - got[1])) > 1e-4  # beta changed the history
    assert np.max(np.abs(got[0] - got[2])) > 1e-4  # so did the block
    np.testing.assert_array_equal(got[0], got[3])


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


_DEFAULT_CACHE_PROCESS = textwrap.dedent(
    """
    import json, os, sys
    import jax, jax.numpy as jnp
    import rockjax as rj
    folder = rj.compilation.cache_dir()
    before = folder is not None and folder.exists()
    f = rj.compilation.persistent_jit(rj.relations.e_housner)
    e = float(f(jnp.asarray(0.2)))
    json.dump({"before": before, "jax": jax.config.jax_compilation_cache_dir, "e": e,
               "sources": dict(f.sources)}, sys.stdout)
    """
)


@pytest.mark.parametrize("case", ["default", "jax's own", "off"])
def test_the_cache_is_on_from_the_first_eager_compile(tmp_path, case):
    # In a new process: importing rockjax writes nothing; the first eager compile turns the
    # cache on in the default folder (the program kept there), unless JAX's cache was set or
    # the variable says off. Reference: the folders on disk and JAX's own configuration.
    env = {k: v for k, v in os.environ.items() if k not in ("JAX_COMPILATION_CACHE_DIR",)}
    env.pop(compilation.CACHE_ENV, None)
    env["XDG_CACHE_HOME"] = str(tmp_path / "xdg")  # the default folder, here
    default = tmp_path / "xdg" / "rockjax" / "jax"
    if case == "jax's own":
        env["JAX_COMPILATION_CACHE_DIR"] = str(tmp_path / "own")
    if case == "off":
        env[compilation.CACHE_ENV] = "off"
    out = subprocess.run(
        [sys.executable, "-c", _DEFAULT_CACHE_PROCESS],
        env=env,
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr
    got = json.loads(out.stdout)
    assert not got["before"]
    np.testing.assert_allclose(got["e"], _e_h(0.2), rtol=1e-15)
    if case == "default":
        assert got["jax"] == str(default)
        assert got["sources"] == {"exported": 1}
        assert len(list((default / compilation.EXPORT_SUBDIR).glob("e_housner-*"))) == 1
    else:
        assert got["jax"] == (str(tmp_path / "own") if case == "jax's own" else None)
        assert got["sources"] == {} and not default.exists()


@pytest.mark.slow
def test_a_second_process_loads_the_solver_from_the_cache(tmp_path):
    # The first process compiles and writes the cache; the second, with a record of another
    # length (same bucket), loads the solver from it instead of compiling it.
    env = os.environ | {compilation.CACHE_ENV: str(tmp_path / "cache")}

    def cache_hits(duration, compiles):
        out = subprocess.run(
            [sys.executable, "-c", _SECOND_PROCESS, str(duration)],
            env=env,
            capture_output=True,
            text=True,
        )
        assert out.returncode == 0, out.stderr
        # the notice comes only with a compilation
        assert ("compiling the Housner solver" in out.stderr) == compiles, out.stderr
        return int(out.stdout.split()[-1])

    assert cache_hits(4.0, compiles=True) == 0
    # the program is kept traced (exported) and its compiled form is in JAX's cache
    assert len(list((tmp_path / "cache" / compilation.EXPORT_SUBDIR).glob("solve-*"))) == 1
    assert any(path.name.startswith("jit_call") for path in (tmp_path / "cache").iterdir())
    assert cache_hits(6.0, compiles=False) >= 1


# ----------------------------------------------------------------------------- XLA:CPU's option

_XLA_OPTION_PROCESS = textwrap.dedent(
    """
    import json, os, sys, warnings
    if sys.argv[1] == "started":  # the user's JAX computation before `import rockjax`
        import jax.numpy as jnp
        jnp.zeros(1).block_until_ready()
    import rockjax as rj
    from jax._src import xla_bridge  # JAX's own answer, independent of rockjax's
    got = {"after_import": os.environ.get("XLA_FLAGS"),
           "started_by_import": sys.argv[1] != "started" and xla_bridge.backends_are_initialized()}
    if sys.argv[1] == "merge":  # configure_cpu on given flags, before the backend starts
        for given in ("--a=1", "--xla_backend_extra_options=k=v --b", "--xla_backend_extra_options="):
            os.environ["XLA_FLAGS"] = given
            got[given] = [rj.compilation.configure_cpu(keep_user_flags=True),
                          rj.compilation.configure_cpu(), os.environ["XLA_FLAGS"]]
        os.environ["XLA_FLAGS"] = "--xla_force_host_platform_device_count=2"
        got["devices"] = [rj.compilation.configure_cpu(), os.environ["XLA_FLAGS"]]
        import jax
        got["devices"].append(jax.local_device_count())  # XLA parsed the merged flags
    f = rj.compilation.persistent_jit(rj.relations.e_housner)
    float(f(0.2))  # the first compile: the notice, if any
    os.environ["XLA_FLAGS"] = "--c"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got["late"] = [rj.compilation.configure_cpu(), os.environ["XLA_FLAGS"],
                       [str(w.category.__name__) for w in caught]]
    json.dump(got, sys.stdout)
    """
)


@pytest.mark.parametrize("case", ["unset", "user's flags", "opted out", "started", "merge"])
def test_the_xla_option_is_added_only_where_the_user_chose_nothing(case):
    # In a new process (XLA reads XLA_FLAGS once). Reference: the variable as set by hand,
    # JAX's own record of whether its backend started, XLA's device count from the merged
    # flags, and the notice on stderr.
    opt = "--xla_backend_extra_options=" + compilation.XLA_CPU_OPTION
    env = {k: v for k, v in os.environ.items() if k not in ("XLA_FLAGS", compilation.NO_TUNING_ENV)}
    if case == "user's flags":
        env["XLA_FLAGS"] = "--xla_force_host_platform_device_count=1"
    if case == "opted out":
        env[compilation.NO_TUNING_ENV] = "1"
    out = subprocess.run(
        [sys.executable, "-c", _XLA_OPTION_PROCESS, case], env=env, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    got = json.loads(out.stdout)
    assert not got["started_by_import"]  # else the option would come too late
    notice = "is set without" if case == "user's flags" else "started before `import rockjax`"
    said = [line for line in out.stderr.splitlines() if compilation.XLA_CPU_OPTION in line]
    assert said == ([] if case in ("unset", "opted out", "merge") else [said[0]])
    if said:
        assert notice in said[0] and "configure_cpu()" in said[0]
    want_after_import = {
        "unset": opt,
        "merge": opt,
        "user's flags": env.get("XLA_FLAGS"),
        "opted out": None,
        "started": None,
    }[case]
    assert got["after_import"] == want_after_import
    if case == "merge":
        assert got["--a=1"] == [False, True, f"--a=1 {opt}"]
        assert got["--xla_backend_extra_options=k=v --b"] == [
            False,
            True,
            f"--xla_backend_extra_options=k=v,{compilation.XLA_CPU_OPTION} --b",
        ]
        assert got["--xla_backend_extra_options="] == [False, True, opt]
        assert got["devices"] == [True, f"--xla_force_host_platform_device_count=2 {opt}", 2]
    # after the backend started: too late, said by a warning, the variable left as it was
    assert got["late"] == (
        [False, "--c", []] if case == "opted out" else [False, "--c", ["RuntimeWarning"]]
    )


# ----------------------------------------------------------------------------- kept programs


@pytest.fixture
def kept(tmp_path):
    """The persistent cache in a fresh folder, and its kept programs' folder; JAX's cache
    settings restored afterwards (which also stops keeping programs)."""
    before = jax.config.jax_compilation_cache_dir
    before_min = jax.config.jax_persistent_cache_min_compile_time_secs
    path = compilation.enable_cache(tmp_path / "cache")
    yield path / compilation.EXPORT_SUBDIR
    jax.config.update("jax_compilation_cache_dir", before)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", before_min)


def _e_h(eta):
    """Eq. (2), written here: 1 - 1.5 sin^2(eta)."""
    return 1.0 - 1.5 * np.sin(eta) ** 2


def test_a_kept_program_is_loaded_instead_of_traced(kept):
    eta = jnp.asarray(0.2)
    first = compilation.persistent_jit(rj.relations.e_housner)
    want = first(eta)
    assert dict(first.sources) == {"exported": 1}
    assert len(list(kept.glob("e_housner-*.jaxexp"))) == 1
    first(eta)  # the same program, from memory
    assert dict(first.sources) == {"exported": 1}
    # a new wrapper has nothing in memory, as in a new process: it loads the kept program
    second = compilation.persistent_jit(rj.relations.e_housner)
    got = second(eta)
    assert dict(second.sources) == {"loaded": 1}
    assert float(got) == float(want)
    np.testing.assert_allclose(float(got), _e_h(0.2), rtol=1e-15)


def test_kept_programs_are_keyed_by_static_values(kept):
    # a Block of Python floats is static under filter_jit: each value is its own program
    f = compilation.persistent_jit(rj.relations.e_housner)
    a, b = rj.Block(b=0.25, h=1.5), rj.Block(b=0.3, h=1.5)
    got = [float(f(a)), float(f(b)), float(f(a))]
    assert dict(f.sources) == {"exported": 2}
    assert len(list(kept.glob("e_housner-*.jaxexp"))) == 2
    e_a, e_b = _e_h(np.arctan(0.25 / 1.5)), _e_h(np.arctan(0.3 / 1.5))
    np.testing.assert_allclose(got, [e_a, e_b, e_a], rtol=1e-14)
    again = compilation.persistent_jit(rj.relations.e_housner)
    assert float(again(b)) == got[1] and dict(again.sources) == {"loaded": 1}


def test_kept_programs_are_keyed_by_class_attributes(kept, monkeypatch):
    # a study may change a mode's class attribute (its open-step accuracy); a new process
    # must then trace its own program, not load one traced at the old value
    facade, eta = rj.Facade(gap=0.001), jnp.asarray(0.2)
    first = compilation.persistent_jit(rj.Facade.default_e)
    want = float(first(facade, eta))
    assert dict(first.sources) == {"exported": 1}
    monkeypatch.setattr(rj.Facade, "dt_accuracy_open", 0.25)
    changed = compilation.persistent_jit(rj.Facade.default_e)  # as in a new process
    assert float(changed(facade, eta)) == want
    assert dict(changed.sources) == {"exported": 1}
    assert len(list(kept.glob("default_e-*.jaxexp"))) == 2
    monkeypatch.undo()
    again = compilation.persistent_jit(rj.Facade.default_e)
    assert float(again(facade, eta)) == want and dict(again.sources) == {"loaded": 1}


def test_traced_calls_and_functions_from_elsewhere_are_not_kept(kept):
    f = compilation.persistent_jit(rj.relations.e_housner)
    slope = jax.grad(f)(0.2)  # a tracer inside grad: filter_jit's
    np.testing.assert_allclose(float(slope), -3.0 * np.sin(0.2) * np.cos(0.2), rtol=1e-14)
    assert dict(f.sources) == {"plain": 1}

    def twice(x):  # not rockjax's: its source is not in the key
        return 2.0 * x

    g = compilation.persistent_jit(twice)
    assert float(g(jnp.asarray(1.5))) == 3.0 and dict(g.sources) == {"plain": 1}
    # rockjax's function with a function from elsewhere as an argument
    h = compilation.persistent_jit(rj.relations.e_housner)
    with pytest.raises(TypeError):
        h(twice)  # filter_jit's own error for a function where an angle belongs
    assert dict(h.sources) == {"plain": 1}
    assert not kept.exists() or not list(kept.iterdir())


def test_a_key_array_argument_goes_to_filter_jit(kept):
    # NumPy cannot name a key array's dtype: such a call is filter_jit's, not an error
    f = compilation.persistent_jit(jax.random.uniform)
    want = jax.random.uniform(jax.random.key(0))
    assert float(f(jax.random.key(0))) == float(want)
    assert dict(f.sources) == {"plain": 1}


def test_a_program_with_a_callback_runs_but_is_not_kept(kept, caplog):
    # free_rocking_period checks theta0 < eta with eqx.error_if: a Python callback
    f = compilation.persistent_jit(rj.relations.free_rocking_period)
    args = (jnp.asarray(2.0), jnp.asarray(0.2), jnp.asarray(0.1))
    with caplog.at_level(logging.INFO, logger="rockjax"):
        got = [float(f(*args)), float(f(*args))]
    assert caplog.records == []  # expected of a callback: no notice
    assert dict(f.sources) == {"not kept": 1}  # traced once, then run from memory
    assert got[0] == got[1] == pytest.approx(4.0 / 2.0 * np.arccosh(1.0 / (1.0 - 0.5)), rel=1e-14)
    assert not kept.exists() or not list(kept.iterdir())
    with pytest.raises(Exception, match="theta0"):  # eqx.error_if's runtime error
        f(jnp.asarray(2.0), jnp.asarray(0.2), jnp.asarray(0.3)).block_until_ready()


def test_a_damaged_kept_program_is_exported_again(kept, caplog):
    eta = jnp.asarray(0.3)
    compilation.persistent_jit(rj.relations.e_housner)(eta)
    (path,) = kept.glob("e_housner-*.jaxexp")
    path.write_bytes(b"not a program")
    f = compilation.persistent_jit(rj.relations.e_housner)
    with caplog.at_level(logging.INFO, logger="rockjax"):
        np.testing.assert_allclose(float(f(eta)), _e_h(0.3), rtol=1e-15)
    assert dict(f.sources) == {"exported": 1}
    assert path.read_bytes() != b"not a program"
    (said,) = [r.getMessage() for r in caplog.records]  # what failed, and what rockjax does
    assert str(path) in said and "could not be loaded" in said and "again" in said


def test_an_unwritable_kept_folder_is_said_once_and_the_programs_run(kept, caplog):
    kept.parent.mkdir(parents=True, exist_ok=True)
    kept.write_text("a file where the kept programs' folder belongs")
    with caplog.at_level(logging.INFO, logger="rockjax"):
        for eta in (0.2, 0.3):  # two programs (Python floats are static), one notice
            f = compilation.persistent_jit(rj.relations.e_housner)
            np.testing.assert_allclose(float(f(eta)), _e_h(eta), rtol=1e-15)
            assert dict(f.sources) == {"exported": 1}  # from memory
    (said,) = [r.getMessage() for r in caplog.records]
    assert str(kept) in said and compilation.CACHE_ENV in said


def test_without_the_cache_a_persistent_jit_is_filter_jit():
    assert compilation.cache_dir() is None or jax.config.jax_compilation_cache_dir != str(
        compilation.cache_dir()
    )
    f = compilation.persistent_jit(rj.relations.e_housner)
    np.testing.assert_allclose(float(f(jnp.asarray(0.2))), _e_h(0.2), rtol=1e-15)
    assert dict(f.sources) == {}


# ----------------------------------------------------------------------------- the DEM

DEM_SAME_RTOL = 1e-9  # [-] of a series' amplitude: the padded and the unpadded programs are
# the same arithmetic, rounded differently where XLA fuses them differently (measured 3e-13 over
# a few impacts; impacts amplify round-off, far from this bound over a few seconds)
DEM_DT = 0.01  # [s] record step of the DEM records (one step: one n_in, one compiled program)


def _dem_pulse(n, amp_g=0.2, dt=DEM_DT):
    """One sine cycle of ``amp_g`` g, 0.5 s, then quiet (``n`` samples): the parapet rocks."""
    t = np.arange(n) * dt
    ag = np.where(t < 0.5, amp_g * 9.80665 * np.sin(2 * np.pi * t / 0.5), 0.0)
    return rj.GroundMotion(ag=ag, dt=dt)


def _dem_unpadded(block, gm, resp, *, mode="two_sided", gap=0.0, beta=0.0, save=(), wall=None):
    """The same run through ``dem.run`` at the record's own length (no padding, no true
    length): the program ``simulate_dem`` ran before records were padded."""
    params = dem.dem_params(block, beta, mode=mode, gap=gap)
    dt = float(resp.extras["dt"])
    n_in = round(gm.dt / dt)
    ag = np.asarray(gm.ag, dtype=float)
    kw = {}
    if "dt_open" in resp.extras:  # a facade's open steps: the steps a sample as data
        n_in = np.int32(n_in)
        kw["n_open"] = np.int32(round(gm.dt / float(resp.extras["dt_open"])))
    r = dem.run(
        params, dem.initial_state(block, params), ag, np.zeros_like(ag), np.asarray(dt),
        np.asarray(gm.dt), n_in, save, True, None, wall, **kw,
    )  # fmt: skip
    return dem.block_response(r, jnp.asarray(block.b, float))


def _assert_same(got, want):
    assert set(got.extras) == set(want.extras)
    for a, b in zip(jax.tree.leaves(got), jax.tree.leaves(want)):
        a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
        assert a.shape == b.shape
        # near a series' zero crossings only an error relative to its amplitude is meaningful
        scale = np.max(np.abs(b), initial=1.0)
        np.testing.assert_allclose(a, b, rtol=DEM_SAME_RTOL, atol=DEM_SAME_RTOL * scale)


@pytest.fixture(scope="module")
def parapet():
    return rj.Block(b=0.25, h=1.5)


def _count_compiles(run):
    with count_compiles() as compiles:
        out = run()
    return compiles, out


def test_dem_records_of_one_bucket_compile_once_and_match_the_unpadded_run(parapet):
    # Reference: the unpadded run (dem.run at the record's own length), which is what
    # simulate_dem ran before; and a count of XLA compilations (none after the first record).
    lengths = (230, 301, 417, 555)
    assert len({dem.padded_length(n) for n in lengths}) == 1
    rj.simulate_dem(parapet, _dem_pulse(lengths[0]), save=("energy",))  # compiles (or reuses)
    compiles, resps = _count_compiles(
        lambda: [rj.simulate_dem(parapet, _dem_pulse(n), save=("energy",)) for n in lengths[1:]]
    )
    assert compiles == []
    for n, resp in zip(lengths[1:], resps):
        assert resp.theta.shape == resp.energy.shape == resp.extras["x"].shape == (n,)
        assert resp.theta.dtype == jnp.float64
        np.testing.assert_array_equal(resp.t, np.arange(n) * DEM_DT)
    assert 0.2 < float(resps[-1].theta_max / parapet.eta) < 1  # it rocks, to 0.4 eta
    gm = _dem_pulse(lengths[-1])
    _assert_same(resps[-1], _dem_unpadded(parapet, gm, resps[-1], save=("energy",)))


def test_dem_padding_changes_nothing_even_wild_padding(parapet):
    # Reference: the unpadded run. The true length travels as data: samples past it are
    # skipped and the state, the maxima, `overturned` and `status` frozen, so even a padding
    # that would overturn the block (or is not finite) changes nothing, also when the block
    # overturns inside the record; the pad here is not the repeated last sample simulate_dem
    # uses, so this checks the freeze itself.
    for amp_g in (0.2, 0.3):  # rocks (to 0.4 eta); overturns
        gm = _dem_pulse(300, amp_g=amp_g)
        params = dem.dem_params(parapet, 1e-3)
        s0 = dem.initial_state(parapet, params)
        dt = dem.stable_dt(parapet, 1e-3)
        n_in = int(np.ceil(DEM_DT / dt - 1e-9))
        step = np.asarray(DEM_DT / n_in)
        ag = np.asarray(gm.ag)
        n_pad = 2 * dem.SCAN_CHUNK + 17  # not whole chunks: the chunk shrinks to divide it
        wild = np.concatenate([ag, np.full(n_pad - ag.size, 50.0)])
        args = (np.asarray(DEM_DT), n_in, ("forces",), False)
        padded = dem.run(params, s0, wild, np.zeros(n_pad), step, *args, n=np.int32(300))
        want = dem.run(params, s0, ag, np.zeros(300), step, *args)
        assert bool(want.overturned) == (amp_g > 0.25)
        assert int(padded.status) == int(want.status) == 0
        for a, b in zip(jax.tree.leaves(padded), jax.tree.leaves(want)):
            a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
            if a.ndim and a.shape[0] == n_pad:
                a = a[:300]
            scale = np.max(np.abs(b), initial=1.0)
            np.testing.assert_allclose(a, b, rtol=DEM_SAME_RTOL, atol=DEM_SAME_RTOL * scale)


def test_dem_facade_with_a_moving_wall_pads_the_wall_too():
    # Reference: the unpadded run with the same wall history. The wall's samples are padded
    # with the record (its last position and velocity repeated), so its work and the contact
    # with it match on the true samples.
    facade = rj.Block(b=0.2, h=1.5)
    n = 180
    gm = _dem_pulse(n, amp_g=0.5)
    t = np.arange(n) * DEM_DT
    u = 2e-3 * np.sin(np.pi * t / 1.8) ** 2
    v = 2e-3 * np.pi / 1.8 * np.sin(2 * np.pi * t / 1.8)
    kw = dict(mode="one_sided", gap=1e-3, beta=1e-3, save=("energy",))
    resp = rj.simulate_dem(facade, gm, wall_motion=(u, v), **kw)
    assert resp.extras["work_wall"].shape == (n,)
    assert np.max(np.abs(np.asarray(resp.extras["work_wall"]))) > 0
    _assert_same(resp, _dem_unpadded(facade, gm, resp, wall=(u, v), **kw))


def test_dem_traced_records_are_not_padded(parapet):
    # Inside the caller's jit the record keeps its shape (no bucket) and the result is the
    # eager (padded) one.
    gm = _dem_pulse(230)
    dt = rj.stable_dt(parapet)
    eager = rj.simulate_dem(parapet, gm, dt=dt)

    @jax.jit
    def run(ag):
        return rj.simulate_dem(parapet, rj.GroundMotion(ag=ag, dt=DEM_DT), dt=dt).theta

    traced = run(jnp.asarray(gm.ag))
    assert traced.shape == (230,)
    scale = np.max(np.abs(np.asarray(eager.theta)))
    np.testing.assert_allclose(traced, eager.theta, rtol=DEM_SAME_RTOL, atol=DEM_SAME_RTOL * scale)


def test_a_compiling_dem_call_says_so_once(parapet, caplog):
    # Reference: a count of XLA compilations. The notice comes with the one call that
    # compiles, and says what it compiles; another record, beta or time step of the same kind
    # runs that program, silently.
    kw = dict(save=("forces", "energy"))  # a configuration that no other test compiles
    with caplog.at_level(logging.INFO, logger="rockjax"), count_compiles() as compiles:
        r1 = rj.simulate_dem(parapet, _dem_pulse(200), **kw)
        n_first = len(compiles)
        r2 = rj.simulate_dem(parapet, _dem_pulse(260), beta=2e-3, **kw)
        r3 = rj.simulate_dem(parapet, _dem_pulse(260), dt=float(r1.extras["dt"]) / 2, **kw)
    assert n_first >= 1 and len(compiles) == n_first
    assert float(r3.extras["dt"]) < float(r2.extras["dt"]) < float(r1.extras["dt"])
    notes = [r.getMessage() for r in caplog.records if "compiling the DEM" in r.getMessage()]
    assert notes == [
        "rockjax: compiling the DEM solver (a block, two-sided, integrated joint, saving forces, "
        f"energy) for records of <= {dem.padded_length(200)} samples (once per session: every "
        "beta, gap, time step and record of this kind reuses it)..."
    ]
    assert r2.extras["normal_forces"].shape[0] == 260


def test_a_loop_over_beta_scale_and_geometry_compiles_the_dem_once():
    # Reference: a count of XLA compilations (programs compiled or loaded from the persistent
    # cache). The number of steps a sample changes with beta and the geometry (the default
    # step); it is data, so after the first call the loop compiles nothing.
    blocks = [rj.Block(b=b, h=h) for b, h in ((0.25, 1.5), (0.2, 1.0), (0.3, 2.5))]
    gm = _dem_pulse(150, amp_g=0.25)
    kw = dict(mode="one_sided", save=("energy",))  # a configuration no other test compiles
    rj.simulate_dem(blocks[0], gm, beta=1e-4, gap=1e-3, **kw)
    with count_compiles() as compiles:
        steps = set()
        for blk in blocks:
            for beta in np.geomspace(1e-4, 3e-3, 4):  # NumPy floats after a Python float
                for scale in (0.5, 1.5):
                    motion = rj.GroundMotion(ag=scale * np.asarray(gm.ag), dt=gm.dt)
                    r = rj.simulate_dem(blk, motion, beta=beta, gap=2e-3, **kw)
                    steps.add(round(DEM_DT / float(r.extras["dt"])))
    assert len(steps) >= 5  # the loop runs many numbers of steps a sample
    assert compiles == []


def _has_callback(fn, *args):
    """Whether the compiled program of ``fn(*args)`` calls back into Python (what
    ``eqx.error_if`` compiles to; such a program is never written to the persistent cache)."""
    text = jax.jit(fn).lower(*args).as_text()
    return "callback" in text


def test_an_eager_dem_call_compiles_no_error_callback(parapet):
    # The eager program checks its status in Python after the run (so it can enter the
    # persistent cache); under the caller's jit, throw=True still compiles eqx.error_if.
    gm = _dem_pulse(50)
    dt = rj.stable_dt(parapet)
    params = dem.dem_params(parapet)
    s0 = dem.initial_state(parapet, params)
    ag = jnp.asarray(gm.ag)

    def run(throw):
        def f(a):
            return dem.run(
                params, s0, a, jnp.zeros_like(a), np.asarray(dt), np.asarray(DEM_DT), 1, (), throw
            ).theta

        return f

    assert _has_callback(run(True), ag)
    assert not _has_callback(run(False), ag)
    rj.simulate_dem(parapet, gm, dt=dt, throw=False)
    # throw=True runs the program throw=False compiled, and checks the status in Python
    again, r = _count_compiles(lambda: rj.simulate_dem(parapet, gm, dt=dt, throw=True))
    assert not again and int(r.status) == rj.response.STATUS_OK


_SECOND_DEM_PROCESS = _SECOND_PROCESS.replace(
    "rj.simulate_housner(block, gm)", "rj.simulate_dem(block, gm, beta=1e-3)"
)


@pytest.mark.slow
def test_a_second_process_loads_the_dem_from_the_cache(tmp_path):
    # As for the Housner solver: the eager DEM program carries no error callback, so the first
    # process writes it to the cache and the second (another length, same bucket) loads it.
    env = os.environ | {compilation.CACHE_ENV: str(tmp_path / "cache")}

    def cache_hits(duration, compiles):
        out = subprocess.run(
            [sys.executable, "-c", _SECOND_DEM_PROCESS, str(duration)],
            env=env,
            capture_output=True,
            text=True,
        )
        assert out.returncode == 0, out.stderr
        # the notice only where the solver is compiled, not where it is loaded
        assert ("compiling the DEM solver" in out.stderr) == compiles, out.stderr
        return int(out.stdout.split()[-1])

    assert cache_hits(4.0, compiles=True) == 0
    exported = tmp_path / "cache" / compilation.EXPORT_SUBDIR
    assert len(list(exported.glob("run_block-*"))) == 1
    assert cache_hits(6.0, compiles=False) >= 1


def test_dem_in_a_building_compiles_once_per_bucket():
    # A facade whose return walls move with a building: the building's response is solved on
    # the record padded to the DEM's bucket, so records of other lengths in that bucket
    # compile nothing (neither the building nor the DEM); reference for the values: the wall
    # history from the unpadded record, as array pairs.
    from rockjax.building import ShearBuilding
    from rockjax.supports import wall_top_motion

    facade = rj.Block(b=0.2, h=1.5)
    bldg = ShearBuilding.uniform(n_storeys=2, storey_height=3.0, period=0.2, damping=0.05)
    # corner contacts: the smaller program (the first call compiles for ~6 s)
    kw = dict(mode="one_sided", beta=1e-3, gap=1e-3, joint=rj.Joint(n_sub=2))
    rj.simulate_dem(facade, _dem_pulse(150, amp_g=0.5), wall_motion=bldg, **kw)
    compiles, resps = _count_compiles(
        lambda: [
            rj.simulate_dem(facade, _dem_pulse(n, amp_g=0.5), wall_motion=bldg, **kw)
            for n in (170, 190)
        ]
    )
    assert compiles == []
    gm = _dem_pulse(190, amp_g=0.5)
    u, v = wall_top_motion(bldg, gm, 1.5)
    ref = rj.simulate_dem(facade, gm, wall_motion=(np.asarray(u), np.asarray(v)), **kw)
    assert resps[-1].theta.shape == (190,)
    assert float(ref.theta_max) > 0.1 * float(facade.eta)  # it rocks
    scale = float(np.max(np.abs(ref.theta)))
    np.testing.assert_allclose(resps[-1].theta, ref.theta, rtol=0, atol=DEM_SAME_RTOL * scale)


def test_housner_in_a_building_compiles_once_per_bucket():
    # The analytical facade with the building's walls: the building is solved on the record
    # padded to its bucket, so records of other lengths in that bucket compile nothing;
    # reference for the values: the wall history from the unpadded record, as array pairs.
    from rockjax.building import ShearBuilding
    from rockjax.supports import wall_top_motion

    facade = rj.Block(b=0.2, h=1.5)
    bldg = ShearBuilding.uniform(n_storeys=2, storey_height=3.0, period=0.2, damping=0.05)
    kw = dict(mode="one_sided", e=0.9)
    rj.simulate_housner(facade, _dem_pulse(150, amp_g=0.5), wall_motion=bldg, **kw)
    compiles, resps = _count_compiles(
        lambda: [
            rj.simulate_housner(facade, _dem_pulse(n, amp_g=0.5), wall_motion=bldg, **kw)
            for n in (170, 190)
        ]
    )
    assert compiles == []
    gm = _dem_pulse(190, amp_g=0.5)
    u, v = wall_top_motion(bldg, gm, 1.5)
    ref = rj.simulate_housner(facade, gm, wall_motion=(np.asarray(u), np.asarray(v)), **kw)
    assert resps[-1].theta.shape == (190,)
    assert float(ref.theta_max) > 0.1 * float(facade.eta)  # it rocks
    np.testing.assert_allclose(resps[-1].theta, ref.theta, rtol=0, atol=1e-12)
