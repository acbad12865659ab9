"""Running the OpenQuake engine on a job folder and reading its damages back.

The engine (AGPL-3) is called as a separate program, ``python -m openquake.commands``, files in
and files out; rockjax never imports it. Its database and datastores go to a folder of the job
(``datadir``), not to ``~/oqdata``: the engine keeps its database at ``~/oqdata/db.sqlite3``, so
the engine's process gets ``HOME`` and ``OQ_DATADIR`` pointed there.
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

from .._lazy import lazy_module

pd = lazy_module("pandas")  # loaded on first use (rockjax/_lazy.py); xarray's dependency

INSTALL_HINT = (
    "the OpenQuake engine is not installed in this Python: from a rockjax checkout run "
    "`pip install -e '.[openquake]'` and then `pip install --no-deps openquake-engine==X` with "
    "the version pyproject.toml pins ([tool.rockjax] openquake-engine); ./test.sh does both "
    "(docs/openquake.md, 'Installing the engine', says why --no-deps)"
)


def engine_available() -> bool:
    """Whether the OpenQuake engine is importable by this Python (without importing it)."""
    try:
        return importlib.util.find_spec("openquake.commands") is not None
    except ModuleNotFoundError:
        return False


def _engine_env(datadir: Path, distribute: str, jit: bool) -> dict:
    home = datadir / "home"
    (home / "oqdata").mkdir(parents=True, exist_ok=True)
    env = dict(os.environ)
    env.update(HOME=str(home), OQ_DATADIR=str(datadir), OQ_DISTRIBUTE=distribute)
    if not jit:
        env["NUMBA_DISABLE_JIT"] = "1"
    env.pop("OQ_DATABASE", None)  # a server elsewhere would not see this job's files
    return env


def _oq(args: list[str], env: dict, cwd: Path, timeout: float | None) -> str:
    cmd = [sys.executable, "-m", "openquake.commands", *args]
    done = subprocess.run(
        cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout, check=False
    )
    if done.returncode != 0:
        tail = (done.stdout + done.stderr)[-4000:]
        raise RuntimeError(f"`oq {' '.join(args)}` failed (exit {done.returncode}):\n{tail}")
    return done.stdout + done.stderr


def run_job(
    job_ini: str | os.PathLike,
    *,
    datadir: str | os.PathLike | None = None,
    distribute: str = "no",
    jit: bool = False,
    timeout: float | None = 600.0,
) -> pd.DataFrame:
    """Run ``oq run job.ini`` and return the expected damage of every asset.

    Args:
        job_ini: The job file (e.g. from :func:`rockjax.openquake.scenario_job`).
        datadir: Folder of the engine's database and datastores; default ``oqdata`` next to
            the job file.
        distribute: The engine's ``OQ_DISTRIBUTE``: ``"no"`` (default: in this process's
            child, one core; a scenario of thousands of assets takes seconds) or
            ``"processpool"`` (every core).
        jit: Let numba compile the engine's kernels. Off by default: on a fresh install the
            first run compiles them for about a minute of CPU (then cached in the engine's
            folder), while a scenario of 1000 assets runs in about 10 s without them, with
            the same damages (measured: identical to the last digit of the export). Turn it on
            for event-based jobs with many events.
        timeout: Seconds before the engine's process is stopped (None: no limit).

    Returns:
        One row per asset (index ``asset_id``) with ``taxonomy``, ``lon``, ``lat`` and one
        column per damage state, ``no_damage`` then the limit states (e.g. ``collapse``): the
        expected number of the asset's buildings in each state (fractions for ``number=1``),
        as the engine exports them (``avg_damages-rlzs``, 7 significant digits).

    Raises:
        ImportError: if the engine is not installed (with the install commands).
        RuntimeError: if the engine fails, with the end of its log.
    """
    if not engine_available():
        raise ImportError(INSTALL_HINT)
    job_ini = Path(job_ini).resolve()
    if not job_ini.is_file():
        raise ValueError(f"job_ini={os.fspath(job_ini)!r} is not a file; write it first.")
    datadir = Path(datadir).resolve() if datadir is not None else job_ini.parent / "oqdata"
    env = _engine_env(datadir, distribute, jit)
    _oq(["run", str(job_ini)], env, job_ini.parent, timeout)
    out = datadir / "export"
    out.mkdir(exist_ok=True)
    for old in out.glob("avg_damages-rlz-*.csv"):
        old.unlink()
    _oq(["export", "damages-rlzs", "-1", "-e", "csv", "-d", str(out)], env, out, timeout)
    files = sorted(out.glob("avg_damages-rlz-*.csv"))
    if len(files) != 1:
        raise RuntimeError(
            f"the engine exported {len(files)} damage files to {out}; expected one "
            "(one realisation: ground-motion fields given as CSV)."
        )
    return read_damages(files[0])


def read_damages(path: str | os.PathLike) -> pd.DataFrame:
    """Read an ``avg_damages-rlz-*.csv`` export of the engine (per-asset expected damage).

    The loss-type prefix of the damage-state columns is dropped (``nonstructural-collapse``
    -> ``collapse``).
    """
    df = pd.read_csv(path, comment="#")
    df = df.rename(columns=lambda c: c.split("-", 1)[1] if "-" in c else c)
    return df.set_index("asset_id")
