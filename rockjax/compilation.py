"""Compile once: record lengths as data, the persistent compilation cache, compile notices.

XLA compiles a function once per combination of input shapes. A simulator whose arrays have the
record's length would compile again for every record of a new length (about a second each, more
under ``grad``). rockjax avoids this in three ways:

* **Buckets.** A record of ``n`` samples is padded to :func:`bucket_length` ``(n)`` samples and its
  true length travels as data (an integer array), so every record whose length falls in one
  bucket shares one compiled program. :func:`pad_to` pads by repeating the last sample, which
  leaves a solver that holds the record at its last sample beyond the end unchanged.
* **The persistent cache.** :func:`enable_cache` points JAX's on-disk compilation cache at
  ``~/.cache/rockjax/jax`` (or ``$ROCKJAX_CACHE_DIR``), so a new process loads what an earlier
  one compiled instead of compiling it again. The command line enables it at startup; in a
  notebook or script call ``rj.enable_compilation_cache()`` once. ``ROCKJAX_CACHE_DIR=off``
  disables it. JAX does not cache a program that calls back into Python, as ``eqx.error_if``
  does, so the eager calls of ``simulate_housner`` and ``simulate_dem`` compile their runs
  without it and check the returned status in Python afterwards (the same errors); under a
  caller's ``jit`` with ``throw=True`` the check stays in the program, which is then not cached.
* **Notices.** The first call that compiles a solver says so in one line ("compiling the Housner
  solver for records of <= 32768 samples (once per session)..."), through the ``rockjax``
  logger when logging is configured, else on stderr. Silence them with
  ``logging.getLogger("rockjax").setLevel(logging.WARNING)``.
"""

from __future__ import annotations

import logging
import math
import os
import sys
from collections.abc import Hashable
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from ._checks import concrete

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

CACHE_MIN_COMPILE_S = 0.2
"""Programs that took less than this to compile [s] are not written to the persistent cache
(JAX's default is 1 s; the solvers' smaller programs add up at startup)."""

_OFF = ("", "0", "off", "no", "false", "none")
_LOG = logging.getLogger("rockjax")
_NOTICED: set[Hashable] = set()


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

    A concrete ``x`` is padded in NumPy (no compilation per length); a traced one with
    ``jnp.pad``. Returns a JAX array of ``length`` samples (``jnp.asarray`` of a NumPy array
    would compile a copy once per length; ``jax.device_put`` does not).
    """
    n = np.shape(x)[0]
    if length < n:
        raise ValueError(f"length must be >= the {n} samples of x; got length={length}.")
    v = concrete(x)
    if v is not None:
        return jax.device_put(np.pad(v, (0, length - n), mode="edge"))
    return jnp.pad(jnp.asarray(x, dtype=float), (0, length - n), mode="edge")


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
        _notice(f"rockjax: no compilation cache ({err}); set {CACHE_ENV} to a writable folder.")
        return None
    jax.config.update("jax_compilation_cache_dir", str(path))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", CACHE_MIN_COMPILE_S)
    return path


def notice_once(key: Hashable, message: str) -> bool:
    """Say ``message`` (one line) the first time ``key`` is seen in this process.

    Returns:
        True if the notice was given now (the caller is about to compile).
    """
    if key in _NOTICED:
        return False
    _NOTICED.add(key)
    _notice(message)
    return True


def _notice(message: str) -> None:
    if _LOG.level > logging.INFO:
        return  # silenced
    if _LOG.hasHandlers():
        _LOG.info(message)
    else:
        print(message, file=sys.stderr, flush=True)


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
