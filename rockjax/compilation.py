"""Compile once: record lengths as data, the persistent compilation cache, compile notices.

XLA compiles a function once per combination of input shapes. A simulator whose arrays have the
record's length would compile again for every record of a new length (about a second each, more
under ``grad``). rockjax avoids this, and says when it compiles:

* **Buckets.** A record of ``n`` samples is padded to :func:`bucket_length` ``(n)`` samples and its
  true length travels as data (an integer array), so every record whose length falls in one
  bucket shares one compiled program. :func:`pad_to` pads by repeating the last sample, which
  leaves a solver that holds the record at its last sample beyond the end unchanged.
* **Values as data.** What a user loops over travels as data, not as static values: the DEM's
  number of steps a sample (which changes with ``beta`` and the geometry), the block's
  numbers, ``e``, ``gap``; and a Python ``float`` and a NumPy ``float64`` give one program
  (:func:`strong_scalars`). A loop over any of them compiles once.
* **The persistent cache**, on by default. :func:`enable_cache` points JAX's on-disk
  compilation cache at ``~/.cache/rockjax/jax`` (``$XDG_CACHE_HOME/rockjax/jax``, or
  ``$ROCKJAX_CACHE_DIR``), so a new process loads what an earlier one compiled instead of
  compiling it again. The command line enables it at startup; the Python API at its first
  eager compile of a solver (:func:`use_default_cache`; nothing at import), unless a cache
  folder was already set for JAX (``JAX_COMPILATION_CACHE_DIR``). ``ROCKJAX_CACHE_DIR=off``
  disables it. JAX does not cache a program that calls back into Python, as ``eqx.error_if``
  does, so the eager calls of ``simulate_housner`` and ``simulate_dem`` compile their runs
  without it and check the returned status in Python afterwards (the same errors); under a
  caller's ``jit`` with ``throw=True`` the check stays in the program, which is then not cached.
* **Kept programs.** With the cache on, the solvers' programs (:func:`persistent_jit`) are
  also kept traced and lowered (``jax.export``) in its ``exported`` folder, so a new process
  neither traces nor lowers them: the first ``fit_beta`` of a process takes about 2 s instead
  of about 6 s (docs/benchmarks.md, "Kept programs").
* **XLA:CPU's while-loop option.** :data:`XLA_CPU_OPTION` makes XLA:CPU compile the time-stepping
  loops as one kernel (one history runs 3-30x faster; docs/benchmarks.md, "The
  small-while-loop flag"). XLA reads it from ``XLA_FLAGS`` once, when its backend starts.
  :func:`configure_cpu` adds it there; ``import rockjax`` does so only when ``XLA_FLAGS`` is
  unset and JAX's backend has not started, and never with ``ROCKJAX_NO_XLA_TUNING=1``
  (docs/conventions.md, "XLA flags"). Without it, the first compile says so once.
* **Eager calls.** An eager run pads its record in NumPy (:func:`pad_to`), cuts its outputs on
  the host in one transfer (:func:`cut_to`), and keeps its set-up's results by the values of
  its inputs (:func:`memoized`), so a loop of eager runs over a record set pays little around
  each run (docs/benchmarks.md, "One history as a user runs it").
* **Notices.** The first call that compiles a solver says so in one line ("compiling the Housner
  solver for records of <= 32768 samples (once per session)..."), through the ``rockjax``
  logger when logging is configured, else on stderr. The DEM's says which program it compiles
  and comes only when one is compiled, not when it is in memory or kept on disk
  (``persistent_jit``'s ``will_compile``). Silence them with
  ``logging.getLogger("rockjax").setLevel(logging.WARNING)``.
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import enum
import functools
import hashlib
import importlib.metadata
import inspect
import logging
import math
import os
import pickle
import re
import sys
import threading
import warnings
from collections.abc import Hashable
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._checks import concrete
from ._memo import memoized as memoized
from ._memo import tracing as tracing
from ._memo import value_key as value_key

BUCKET_GROWTH = 2.0
"""Ratio between consecutive bucket lengths [-]: a padded record is at most this many times
longer than the record."""

BUCKET_MIN = 2**15
"""Smallest bucket [samples]: 164 s at 0.005 s, so records of ordinary length (the FEMA P695
sets have 1 500 to 18 000 samples) all share the first bucket. Memory of a padded single run:
a few float64 series of this length, well under 10 MB."""

CACHE_ENV = "ROCKJAX_CACHE_DIR"
"""Environment variable that moves the persistent compilation cache (a folder) or, set to
``off``, ``0``, ``no``, ``false`` or empty, disables it."""

CACHE_MIN_COMPILE_S = 0.0
"""Programs that took less than this to compile [s] are not written to the persistent cache
(JAX's default is 1 s). Every program is written: the small eager operations of a set-up (a
block's derived quantities, the checks) take 30-40 ms each to compile, and in the first
``fit_beta`` of a process they added up to about 1 s (scratch runs; docs/benchmarks.md,
"Kept programs")."""

XLA_CPU_OPTION = "xla_cpu_small_while_loop_byte_threshold=1000000"
"""The XLA:CPU option that :func:`configure_cpu` adds to ``XLA_FLAGS`` (inside
``--xla_backend_extra_options=``). XLA:CPU compiles a while loop into a single kernel, without
a dispatch per iteration, only when the loop touches fewer bytes than this threshold (XLA's
default threshold is below what rockjax's loops touch). rockjax's time-stepping loops touch a few hundred bytes a step but run
tens of thousands of steps: above the threshold each DEM step pays about 0.5-1 us of dispatch,
below it 35-60 ns; one DEM history runs 6-28x faster with it, one Housner history 3-10x
(docs/benchmarks.md, "The small-while-loop flag"). It changes how XLA:CPU runs the loop: the
results agree to round-off (Housner's to the bit; a 20 s DEM history to 3e-13 rad)."""

NO_TUNING_ENV = "ROCKJAX_NO_XLA_TUNING"
"""Environment variable: set to ``1``, rockjax never changes ``XLA_FLAGS`` (neither at import
nor in :func:`configure_cpu`) and says nothing about :data:`XLA_CPU_OPTION`."""

_OFF = ("", "0", "off", "no", "false", "none")
_LOG = logging.getLogger("rockjax")
_NOTICED: set[Hashable] = set()
_PENDING: list[str] = []  # notice_when_compiling's message, said at the first compilation


def bucket_length(n: int, *, growth: float = BUCKET_GROWTH, minimum: int = BUCKET_MIN) -> int:
    """The padded length of a series of ``n`` samples: ``minimum * growth^k``, the smallest
    such length ``>= n``.

    Every series whose length falls in one bucket runs through one compiled program. A solver
    that stops at the true length (as ``simulate_housner`` does) pays only memory for the
    padding, so few large buckets suit it; a fixed-length scan pays time for every padded
    step, so use a small ``growth`` (e.g. 1.25: at most 25 % extra steps) there.

    Args:
        n: Samples of the series [-], ``>= 1``.
        growth: Ratio between consecutive bucket lengths [-], ``> 1``.
        minimum: The smallest bucket [samples], ``>= 1``.

    Returns:
        The bucket length [samples], ``>= n``.
    """
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
        raise ValueError(f"n must be a whole number of samples >= 1; got n={n!r}.")
    if not (np.isfinite(growth) and growth > 1):
        raise ValueError(f"growth must be a ratio > 1; got growth={growth!r}. E.g. growth=2.0.")
    if isinstance(minimum, bool) or not isinstance(minimum, int | np.integer) or minimum < 1:
        raise ValueError(f"minimum must be a whole number of samples >= 1; got {minimum!r}.")
    if n <= minimum:
        return int(minimum)
    k = math.ceil(math.log(n / minimum) / math.log(growth) - 1e-12)
    length = math.ceil(minimum * growth**k)
    while length < n:  # guard the rounding of the logarithm
        k += 1
        length = math.ceil(minimum * growth**k)
    return int(length)


def pad_to(x, length: int):
    """``x`` (1-D) padded to ``length`` samples by repeating its last sample.

    A concrete ``x`` is padded in NumPy and returned as a float64 NumPy array: no compilation
    per length, and no transfer of its own (a compiled program takes it as an argument as it
    takes a JAX array; ``jax.device_put`` of each padded series cost about 0.1 ms of an eager
    run). A traced one is padded with ``jnp.pad``.
    """
    n = np.shape(x)[0]
    if length < n:
        raise ValueError(f"length must be >= the {n} samples of x; got length={length}.")
    v = concrete(x)
    if v is not None:
        v = np.asarray(v, dtype=float)
        out = np.empty((length, *v.shape[1:]))
        out[:n] = v
        out[n:] = v[-1]
        return out
    return jnp.pad(jnp.asarray(x, dtype=float), (0, length - n), mode="edge")


def cut_to(series, n: int):
    """:func:`pad_to`'s inverse for a padded run's outputs: ``series`` (a pytree of concrete
    arrays whose first axis is time; None entries stay None) cut to their first ``n`` samples
    on the host and moved to the device in one transfer. An eager slice of a device array
    would compile once per length; one ``jax.device_put`` per series cost about 0.05 ms
    each."""
    return jax.device_put(jax.tree.map(lambda x: np.asarray(x)[:n], series))


def cache_dir() -> Path | None:
    """The persistent cache folder: ``$ROCKJAX_CACHE_DIR`` if set (None if set to ``off``),
    else ``$XDG_CACHE_HOME/rockjax/jax``, else ``~/.cache/rockjax/jax``."""
    env = os.environ.get(CACHE_ENV)
    if env is not None:
        return None if env.strip().lower() in _OFF else Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "rockjax" / "jax"


def enable_cache(directory: str | os.PathLike | None = None) -> Path | None:
    """Turn on JAX's persistent compilation cache, so later processes load compiled programs.

    Args:
        directory: The cache folder; default :func:`cache_dir` (``~/.cache/rockjax/jax``, or
            ``$ROCKJAX_CACHE_DIR``; that variable set to ``off`` disables the cache).

    Returns:
        The folder in use, or None when disabled (also when it cannot be created: the run then
        compiles as usual and a notice says why).
    """
    path = cache_dir() if directory is None else Path(directory).expanduser()
    if path is None:
        return None
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        notice(f"rockjax: no compilation cache ({err}); set {CACHE_ENV} to a writable folder.")
        return None
    jax.config.update("jax_compilation_cache_dir", str(path))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", CACHE_MIN_COMPILE_S)
    _EXPORT["cache"] = path
    return path


def use_default_cache() -> None:
    """Turn the persistent cache on in :func:`cache_dir` the first time rockjax compiles in
    this process (the Python API's default; the command line turns it on at startup). A cache
    already chosen is left alone: by :func:`enable_cache`, or a folder set for JAX itself
    (``JAX_COMPILATION_CACHE_DIR``, ``jax.config``) while ``$ROCKJAX_CACHE_DIR`` is unset;
    ``ROCKJAX_CACHE_DIR=off`` keeps it off. The first call also says, once, when XLA runs
    without :data:`XLA_CPU_OPTION` (:func:`configure_cpu`). Costs one dictionary look-up after
    the first call."""
    if _EXPORT["default"]:
        return
    _EXPORT["default"] = True
    _say_if_cpu_option_missing()
    if _EXPORT["cache"] is not None:
        return
    if os.environ.get(CACHE_ENV) is None and jax.config.jax_compilation_cache_dir:
        return
    enable_cache()


# --------------------------------------------------------------------------- XLA:CPU's option

_OPTION_KEY = XLA_CPU_OPTION.split("=")[0]
_CPU = {"late": False}  # import found JAX's backend started, XLA_FLAGS without the option


def _tuning_off() -> bool:
    return os.environ.get(NO_TUNING_ENV, "0").strip() == "1"


def _backend_started() -> bool:
    """Whether JAX's backend has started (so XLA has read ``XLA_FLAGS``). JAX has no public
    query; its internal one is looked up, and where it is missing the backend counts as not
    started (the option is then added as before, and takes effect if it is in time)."""
    try:
        from jax._src import xla_bridge
    except ImportError:
        return False
    started = getattr(xla_bridge, "backends_are_initialized", None)
    return bool(started()) if callable(started) else False


def _with_option(flags: str) -> str:
    """``flags`` with :data:`XLA_CPU_OPTION` added to their ``--xla_backend_extra_options``
    (comma-separated ``key=value`` options), or in a new such flag."""
    key = "--xla_backend_extra_options="
    if key not in flags:
        return f"{flags} {key}{XLA_CPU_OPTION}".strip()
    return re.sub(
        rf"{key}(\S*)",
        lambda m: f"{key}{m.group(1)},{XLA_CPU_OPTION}" if m.group(1) else key + XLA_CPU_OPTION,
        flags,
        count=1,
    )


def configure_cpu(*, keep_user_flags: bool = False) -> bool:
    """Add :data:`XLA_CPU_OPTION` to ``XLA_FLAGS``, so that XLA:CPU runs rockjax's time loops as
    one kernel each (one history 3-30x faster; the same results to round-off).

    XLA reads ``XLA_FLAGS`` once, when JAX's backend starts (at the first JAX computation), so
    call this before that, e.g. right after ``import rockjax``; the flags already there are
    kept. ``import rockjax`` calls it with ``keep_user_flags=True``; the ``rockjax`` command,
    the speed benchmarks and the test suite call it as is. ``ROCKJAX_NO_XLA_TUNING=1`` turns it off.
    The variable is changed in ``os.environ``, so processes started afterwards inherit it.

    Args:
        keep_user_flags: Change a non-empty ``XLA_FLAGS`` in no way, and warn of nothing (the
            first compile then says once that the option is missing). The import-time
            default; False: add the option to the flags there.

    Returns:
        True if ``XLA_FLAGS`` holds the option now (added, or there already). False if it was
        not added: ``ROCKJAX_NO_XLA_TUNING=1``; ``keep_user_flags`` and ``XLA_FLAGS`` set; or
        JAX's backend already started, too late for the option (a ``RuntimeWarning`` says so,
        unless ``keep_user_flags``).
    """
    flags = os.environ.get("XLA_FLAGS", "")
    if _OPTION_KEY in flags:
        return True
    if _tuning_off() or (keep_user_flags and flags.strip()):
        return False
    if _backend_started():
        if keep_user_flags:
            _CPU["late"] = True  # said at the first compile
        else:
            warnings.warn(
                f"rockjax.compilation.configure_cpu: JAX's backend has already started, so "
                f"XLA_FLAGS is read and {XLA_CPU_OPTION} cannot take effect in this process "
                "(XLA_FLAGS left as it was): one history runs 3-30x slower, with the same "
                "results to round-off. Call configure_cpu() before the first JAX computation.",
                RuntimeWarning,
                stacklevel=2,
            )
        return False
    os.environ["XLA_FLAGS"] = _with_option(flags)
    return True


def _say_if_cpu_option_missing() -> None:
    """One notice, at the first compile, when XLA:CPU runs without :data:`XLA_CPU_OPTION`
    (nothing with ``ROCKJAX_NO_XLA_TUNING=1``, nor on another backend)."""
    if _tuning_off() or jax.default_backend() != "cpu":
        return
    if _CPU["late"]:
        why = "JAX's backend started before `import rockjax` could add"
    elif _OPTION_KEY not in os.environ.get("XLA_FLAGS", ""):
        why = "XLA_FLAGS is set without"
    else:
        return
    notice(
        f"rockjax: {why} {XLA_CPU_OPTION}; one history runs 3-30x slower (same results). "
        "Call rockjax.compilation.configure_cpu() before the first JAX computation, or set "
        f"{NO_TUNING_ENV}=1 to run without it and without this notice."
    )


def notice_once(key: Hashable, message: str) -> bool:
    """Say ``message`` (one line) the first time ``key`` is seen in this process.

    Returns:
        True if the notice was given now (the caller is about to compile).
    """
    if key in _NOTICED:
        return False
    _NOTICED.add(key)
    notice(message)
    return True


@contextlib.contextmanager
def notice_when_compiling(message: str):
    """Within the block, say ``message`` (one line) just before the first
    :func:`persistent_jit` program that is compiled (none in memory, none kept on disk), and
    not at all when every program is ready: the notice of a driver, as ``fit_beta``, that
    runs several programs."""
    depth = len(_PENDING)
    _PENDING.append(message)
    try:
        yield
    finally:
        del _PENDING[depth:]


def _say_pending() -> None:
    """Say the innermost pending :func:`notice_when_compiling` message, once."""
    if _PENDING:
        message = _PENDING[-1]
        _PENDING[-1] = ""  # said: the block stays open, the message is spent
        if message:
            notice(message)


def notice(message: str) -> None:
    """Say ``message`` (one line): through the ``rockjax`` logger when logging is configured,
    else on stderr; nothing when that logger is silenced (level above INFO)."""
    if _LOG.level > logging.INFO:
        return  # silenced
    if _LOG.hasHandlers():
        _LOG.info(message)
    else:
        print(message, file=sys.stderr, flush=True)


def strong_scalars(tree):
    """``tree`` with its Python and NumPy real numbers as float64 NumPy scalars (arrays and
    tracers unchanged). JAX types a Python ``float`` weakly and a NumPy ``float64`` strongly,
    and compiles a program once for each: a loop over ``beta = 0.001`` then over
    ``np.linspace(...)`` values would compile it twice. Bools are left alone."""

    def strong(x):
        if isinstance(x, (float, int, np.floating, np.integer)) and not isinstance(x, bool):
            return np.asarray(x, dtype=float)
        return x

    return jax.tree.map(strong, tree)


def is_traced(*xs) -> bool:
    """True if any leaf of ``xs`` is a JAX tracer (the call is inside jit, vmap or grad)."""
    return any(isinstance(x, jax.core.Tracer) for x in jax.tree.leaves(xs))


def batch_size(*xs) -> int:
    """The number of lanes of the largest ``vmap`` batch among the leaves of ``xs`` (nested
    ``vmap``s multiply; a forward-mode tracer counts through its primal), 0 if none is
    batched. A heuristic for choosing the faster program (a batch's tracer carries a
    ``batch_dim``); a miss costs time, never a result."""

    def lanes(x):
        if getattr(x, "batch_dim", None) is not None and hasattr(x, "val"):
            inner = lanes(x.val)
            return int(x.val.shape[x.batch_dim]) * max(inner, 1)
        if hasattr(x, "primal"):
            return lanes(x.primal)
        return 0

    return max((lanes(x) for x in jax.tree.leaves(xs) if isinstance(x, jax.core.Tracer)), default=0)


def is_batched(*xs) -> bool:
    """True if any leaf of ``xs`` is batched by ``vmap`` (:func:`batch_size` > 0)."""
    return batch_size(*xs) > 0


# --------------------------------------------------------------------------- traced programs on disk

EXPORT_SUBDIR = "exported"
"""Folder, inside the persistent cache, of the traced and lowered programs that
:func:`persistent_jit` keeps (``jax.export`` artifacts)."""

_EXPORT: dict = {"cache": None, "default": False}  # enable_cache's last folder; default tried
_LIBRARIES = (
    "rockjax",
    "jax",
    "jaxlib",
    "equinox",
    "diffrax",
    "optax",
    "lineax",
    "optimistix",
    "numpy",
    "builtins",
)
"""Code whose content the key of a kept program covers: rockjax by the hash of its source,
the others (and the interpreter) by their versions. A static argument of any other code (a
user's function or class) is not keyed, so such a call is traced as usual."""

_NAMES: dict[int, tuple[object, str]] = {}


def stable_name(obj, name: str):
    """Give ``obj`` (a callable built at import, e.g. a wrapped loss) the ``name`` that keys it
    in :func:`persistent_jit`'s kept programs; returns ``obj``. Use only for objects of rockjax
    that are built once, at import, from rockjax code."""
    _NAMES[id(obj)] = (obj, name)
    return obj


class _Unkeyed(Exception):
    """A static argument whose content no key can describe: the call is traced as usual."""


def _root(module: str | None) -> str:
    return (module or "").split(".")[0]


def _import_path(obj) -> str:
    """``module.qualname`` of a function, class or wrapped function (whose ``__wrapped__``
    names it) that importing that path gives back."""
    for named in (obj, getattr(obj, "__wrapped__", None)):
        module = getattr(named, "__module__", None)
        qualname = getattr(named, "__qualname__", None)
        if not module or not qualname or _root(module) not in _LIBRARIES or "<" in qualname:
            continue
        target = sys.modules.get(module)
        for part in qualname.split("."):
            target = getattr(target, part, None)
        if target is obj:
            return f"{module}.{qualname}"
    raise _Unkeyed


def _describe(x) -> str:
    """Everything about one argument that shapes the traced program, as text: arrays by shape,
    dtype and weak type; Python values exactly; modules field by field; functions and classes
    by import path. Raises ``_Unkeyed`` for anything else."""
    if id(x) in _NAMES and _NAMES[id(x)][0] is x:
        return f"named:{_NAMES[id(x)][1]}"
    if eqx.is_array(x):
        weak = bool(getattr(x, "weak_type", False))
        return f"array{tuple(np.shape(x))}:{np.dtype(x.dtype)}:{weak}"
    if x is None or isinstance(x, (bool, int, str, bytes)):
        return f"{type(x).__name__}:{x!r}"
    if isinstance(x, float):
        return f"float:{x.hex()}"
    if isinstance(x, (tuple, list)):
        kind = type(x)
        name = kind.__name__ if kind in (tuple, list) else _import_path(kind)
        return f"{name}({','.join(_describe(v) for v in x)})"
    if isinstance(x, dict):
        items = sorted((_describe(k), _describe(v)) for k, v in x.items())
        return "dict(" + ",".join(f"{k}={v}" for k, v in items) + ")"
    if isinstance(x, type):
        return f"class:{_import_path(x)}"
    if isinstance(x, enum.Enum):
        return f"enum:{_import_path(type(x))}.{x.name}"
    if isinstance(x, np.dtype):
        return f"dtype:{x}"
    if dataclasses.is_dataclass(x):  # equinox modules: every field, static or not
        fields = ",".join(
            f"{f.name}={_describe(getattr(x, f.name, None))}" for f in dataclasses.fields(x)
        )
        constants = ",".join(
            f"{name}={_describe(getattr(type(x), name, None))}"
            for name in _class_constants(type(x))
        )
        return f"{_import_path(type(x))}({fields})[{constants}]"
    if callable(x):
        return f"fn:{_import_path(x)}"
    raise _Unkeyed


@functools.cache
def _class_constants(kind: type) -> tuple[str, ...]:
    """The names of a class's ``ClassVar`` attributes of plain values (a mode's step
    accuracies, its name), in the key of a kept program beside the fields: tracing may read
    them, and a script may change one for a study (``rj.Facade.dt_accuracy_open``), which
    must not load a program traced at the old value. Their values are read at each call."""
    names = set()
    for klass in kind.__mro__:
        for name, note in inspect.get_annotations(klass).items():
            if "ClassVar" in str(note):
                names.add(name)
    plain = (type(None), bool, int, float, str)
    return tuple(sorted(n for n in names if isinstance(getattr(kind, n, None), plain)))


@functools.cache
def _environment() -> str:
    """What else shapes a traced program: rockjax's source, the libraries' versions, the
    backend and the configuration that tracing reads."""
    digest = hashlib.sha256()
    for path in sorted(Path(__file__).parent.rglob("*.py")):
        digest.update(path.relative_to(Path(__file__).parent).as_posix().encode())
        digest.update(path.read_bytes())
    versions = [f"python={sys.version}"]  # builtins
    for dist in _LIBRARIES:
        if dist in ("rockjax", "builtins"):  # the source hash above; the interpreter's version
            continue
        try:
            versions.append(f"{dist}={importlib.metadata.version(dist)}")
        except importlib.metadata.PackageNotFoundError:
            versions.append(f"{dist}=none")
    config = [
        f"x64={jax.config.jax_enable_x64}",
        f"backend={jax.default_backend()}",
        f"promotion={jax.config.jax_numpy_dtype_promotion}",
        f"matmul={jax.config.jax_default_matmul_precision}",
        f"rank={jax.config.jax_numpy_rank_promotion}",
        f"EQX_ON_ERROR={os.environ.get('EQX_ON_ERROR', '')}",
    ]
    return digest.hexdigest() + ";" + ";".join(versions + config)


def _export_dir() -> Path | None:
    """The kept programs' folder while JAX's cache is the one :func:`enable_cache` set."""
    cache = _EXPORT["cache"]
    if cache is None or jax.config.jax_compilation_cache_dir != str(cache):
        return None
    return cache / EXPORT_SUBDIR


def _brief(err: BaseException, limit: int = 200) -> str:
    """``Type: message`` of ``err`` on one line, at most ``limit`` characters of message."""
    text = " ".join(str(err).split())
    return f"{type(err).__name__}: {text[:limit]}{'...' if len(text) > limit else ''}"


@dataclasses.dataclass(frozen=True)
class _Slot:
    """Place of the ``index``-th array output in a kept program's output skeleton."""

    index: int


def persistent_jit(fn):
    """``equinox.filter_jit(fn)`` whose traced and lowered program is also kept on disk when the
    persistent cache is on (:func:`enable_cache`), so that a new process skips tracing and
    lowering (``jax.export``); XLA's compiled program then comes from JAX's own cache.

    A kept program is keyed by everything that shapes it: the arguments (arrays by shape, dtype
    and weak type; Python values exactly; modules field by field and by the plain values of
    their class's ``ClassVar`` attributes; functions and classes by import path), the hash of
    rockjax's source, the libraries' versions, the backend and the configuration that tracing
    reads. Only functions of rockjax (or of the libraries) are kept.
    A call inside ``jit``, ``vmap`` or ``grad``, or with a function or class from elsewhere as
    an argument, is ``filter_jit``'s. A program that cannot be exported (one that calls back
    into Python, as ``eqx.error_if`` does) runs as traced, in this process only (a notice says
    why for any other reason); so does every program when the folder cannot be written (one
    notice). A damaged or unreadable kept program is exported again, with a notice. The kept programs are Python pickles, loaded
    as code is: keep the cache folder writable by you alone (the default, under your home
    folder, is). ``wrapped.sources`` counts how each program was
    obtained (``"exported"``, ``"loaded"``, ``"not kept"``; ``"plain"``: calls, with the
    cache on, passed to ``filter_jit``); ``wrapped.will_compile(*args, **kwargs)`` tells
    before a call whether it compiles a new program (none in memory, none kept on disk), for
    a notice. The first eager call turns the persistent cache on (:func:`use_default_cache`).
    """
    jitted = eqx.filter_jit(fn)
    name = f"{fn.__module__}.{fn.__qualname__}"
    # its code is covered by the key only if it is rockjax's (the source hash) or a library's
    keyed = _root(fn.__module__) in _LIBRARIES and "<" not in fn.__qualname__
    programs: dict = {}
    plain = object()
    sources: collections.Counter = collections.Counter()

    seen: set = set()  # the signatures will_compile answered for

    def kept_path(args, kwargs) -> Path | None:
        """Where the call's program is kept, or None when it cannot be kept."""
        folder = _export_dir()
        if not keyed or folder is None:
            return None
        try:
            text = "|".join((_environment(), name, _describe((args, kwargs))))
        except (_Unkeyed, RecursionError):
            return None
        key = hashlib.sha256(text.encode()).hexdigest()[:40]
        return folder / f"{fn.__name__}-{key}.jaxexp"

    def signature(args, kwargs):
        """``(leaves, avals, memo)`` of a concrete call: its arrays, their shapes and types,
        and ``memo``, which keys the programs in memory (the tree, its other values, the
        arrays' avals); None for a call inside a transform. One flattening (0.1-0.2 ms for
        the DEM's arguments; ``eqx.partition`` and two flattenings took about 0.5 ms)."""
        flat, treedef = jax.tree.flatten((args, kwargs))
        arrays = [eqx.is_array(x) for x in flat]
        leaves = [x for x, a in zip(flat, arrays) if a]
        if any(isinstance(x, jax.core.Tracer) for x in leaves):
            return None
        avals = tuple(
            (np.shape(x), np.dtype(x.dtype), bool(getattr(x, "weak_type", False))) for x in leaves
        )
        statics = tuple(None if a else x for x, a in zip(flat, arrays))
        memo = (treedef, statics, avals, _export_dir())
        hash(memo)  # TypeError: an unhashable static argument
        return leaves, avals, memo

    def export(args, kwargs, avals):
        path = kept_path(args, kwargs)
        if path is None:
            return plain
        folder = path.parent
        if path.is_file():
            try:
                blob = pickle.loads(path.read_bytes())
                exported = jax.export.deserialize(bytearray(blob["exported"]))
                sources["loaded"] += 1
                return jax.jit(exported.call), blob["skeleton"]
            except Exception as err:  # noqa: BLE001  (unpickling bytes can raise anything)
                notice(  # damaged, unreadable, or written by an incompatible version
                    f"rockjax: the kept program {path} could not be loaded "
                    f"({_brief(err)}); tracing it again and keeping it anew."
                )
        dynamic, static = eqx.partition((args, kwargs), eqx.is_array)
        treedef = jax.tree.structure(dynamic)  # its leaves: the call's arrays, in order
        skeleton = {}

        def flat(*xs):
            a, k = eqx.combine(jax.tree.unflatten(treedef, xs), static)
            out_dynamic, out_static = eqx.partition(fn(*a, **k), eqx.is_array)
            out_leaves, out_def = jax.tree.flatten(out_dynamic)
            slots = [_Slot(i) for i in range(len(out_leaves))]
            skeleton["out"] = eqx.combine(jax.tree.unflatten(out_def, slots), out_static)
            return out_leaves

        specs = [jax.ShapeDtypeStruct(*shape_dtype, weak_type=weak) for *shape_dtype, weak in avals]
        flat_jit = jax.jit(flat)
        try:
            exported = jax.export.export(flat_jit)(*specs)
            blob = pickle.dumps({"exported": exported.serialize(), "skeleton": skeleton["out"]})
        except Exception as err:  # noqa: BLE001  (each kind is passed on or said below)
            if "out" not in skeleton:
                return plain  # tracing failed: filter_jit traces again and raises the error
            # traced, but not kept: run what was traced, in this process only. A Python
            # callback (eqx.error_if) is expected (jax.export cannot serialise one); anything
            # else (an unpicklable output, a failing export) is said once.
            if not (isinstance(err, NotImplementedError) and "callback" in str(err)):
                notice_once(
                    ("not kept", name),
                    f"rockjax: the program of {name} runs but is not kept on disk "
                    f"({_brief(err)}); each new process traces it again.",
                )
            sources["not kept"] += 1
            return flat_jit, skeleton["out"]
        sources["exported"] += 1
        try:
            folder.mkdir(parents=True, exist_ok=True)
            # (one name per process and thread: two threads may keep one program at once)
            tmp = path.with_suffix(f".{os.getpid()}-{threading.get_ident()}.tmp")
            tmp.write_bytes(blob)
            os.replace(tmp, path)  # whole or absent, for processes sharing the folder
        except OSError as err:  # a read-only cache: this process keeps the program in memory
            notice_once(
                ("unwritable", folder),
                f"rockjax: cannot keep programs in {folder} ({_brief(err)}); they run from "
                f"memory and each new process traces them again. Set {CACHE_ENV} to a "
                "writable folder.",
            )
        return jax.jit(exported.call), skeleton["out"]

    last: list = []  # will_compile's signature, for the call that follows it

    def signed(args, kwargs):
        """:func:`signature`, the one will_compile just computed for these very arguments
        taken instead of computed again (it costs about 0.5 ms for the DEM's)."""
        try:  # (another thread may have taken it)
            a, k, sig = last.pop()
        except IndexError:
            return signature(args, kwargs)
        if len(a) == len(args) and all(x is y for x, y in zip(a, args)):
            if k.keys() == kwargs.keys() and all(k[n] is kwargs[n] for n in k):
                return sig
        return signature(args, kwargs)

    def will_compile(*args, **kwargs) -> bool:
        """Whether a call with these arguments compiles a new program: one this process has
        not run (nor traced), and not kept on disk. False inside a transform (the caller's
        program compiles it). Ask it just before the call: it counts the program as compiled
        from then on."""
        try:
            if not _EXPORT["default"] and signature(args, kwargs) is not None:
                use_default_cache()  # what the call would do first
            sig = signature(args, kwargs)
        except TypeError:
            return True
        last[:] = [(args, kwargs, sig)]
        if sig is None:
            return False
        memo = sig[-1]
        if memo in seen or programs.get(memo) not in (None, plain):
            return False
        seen.add(memo)
        path = kept_path(args, kwargs)
        return path is None or not path.is_file()

    @functools.wraps(fn)
    def call(*args, **kwargs):
        if not _EXPORT["default"]:  # the first eager call turns the cache on
            try:
                if signature(args, kwargs) is not None:
                    use_default_cache()
            except TypeError:  # an unhashable static argument: filter_jit below says so
                pass
        if _export_dir() is None:
            last.clear()
            if _PENDING:  # in a driver's block: its notice comes with the first new program
                try:
                    sig = signature(args, kwargs)
                except TypeError:
                    sig = None
                if sig is not None and sig[-1] not in seen:
                    seen.add(sig[-1])
                    _say_pending()
            return jitted(*args, **kwargs)
        try:
            sig = signed(args, kwargs)
        except TypeError:  # an unhashable static argument (filter_jit says so), a key array
            sig = None
        if sig is None:
            sources["plain"] += 1
            return jitted(*args, **kwargs)
        leaves, avals, memo = sig
        entry = programs.get(memo)
        if entry is None:
            if _PENDING and _PENDING[-1]:
                path = kept_path(args, kwargs)
                if path is None or not path.is_file():
                    _say_pending()
            entry = programs[memo] = export(args, kwargs, avals)
        if entry is plain:
            sources["plain"] += 1
            return jitted(*args, **kwargs)
        run, skeleton = entry
        # uncommitted, as NumPy arrays and the outputs of programs are: JAX would compile the
        # program again for a call whose arguments differ from the last call's only in being
        # committed (placed on a device explicitly; rare), and committing every argument
        # with jax.device_put cost 1-2 ms a call (the DEM's eager run takes 5-10 ms)
        out = run(*(np.asarray(x) if getattr(x, "committed", False) else x for x in leaves))
        return jax.tree.map(lambda s: out[s.index] if isinstance(s, _Slot) else s, skeleton)

    call.sources = sources
    call.will_compile = will_compile
    return call
