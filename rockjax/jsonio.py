"""JSON output: one cleaning rule for every JSON file rockjax and its scripts write, and an
atomic writer (a file is whole or absent, never half-written by a killed process)."""

from __future__ import annotations

import json
import math
import os
import uuid
from pathlib import Path
from typing import Any

import jax
import numpy as np


def jsonable(obj: Any) -> Any:
    """``obj`` with arrays as (nested) lists, NumPy and JAX scalars as Python numbers, tuples as
    lists, dict keys as strings, and NaN and infinities as ``None`` (JSON has no NaN).

    Anything else (str, None, ...) is returned as it is.
    """
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray | jax.Array):
        return jsonable(np.asarray(obj).tolist())
    if isinstance(obj, bool | np.bool_):
        return bool(obj)
    if isinstance(obj, int | np.integer):
        return int(obj)
    if isinstance(obj, float | np.floating):
        return float(obj) if math.isfinite(obj) else None
    return obj


def dumps(obj: Any, *, indent: int | None = 2, sort_keys: bool = False) -> str:
    """``json.dumps`` of :func:`jsonable` ``(obj)``; strict JSON (no NaN), no trailing newline."""
    return json.dumps(jsonable(obj), indent=indent, sort_keys=sort_keys, allow_nan=False)


def write_text(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same folder and a rename, so
    the file is whole or absent (the folder must exist)."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    try:
        tmp.write_text(text)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_json(
    path: str | os.PathLike, obj: Any, *, indent: int | None = 2, sort_keys: bool = False
) -> None:
    """Write :func:`dumps` ``(obj)`` plus a newline to ``path``, atomically (:func:`write_text`)."""
    write_text(path, dumps(obj, indent=indent, sort_keys=sort_keys) + "\n")
