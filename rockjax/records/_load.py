"""Many records at once: :func:`load` of set names, ``.AT2`` files and folders of them."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from ..motion import GroundMotion
from ._at2 import read_at2
from ._fema import FEMA_P695_SETS, fema_p695


def load(
    specs: str | os.PathLike | Sequence[str | os.PathLike], *, normalized: bool = False
) -> list[GroundMotion]:
    """Records from a list of FEMA P695 set names, PEER ``.AT2`` files or folders of them.

    Args:
        specs: Each entry is a set name of :data:`FEMA_P695_SETS` (:func:`fema_p695`), an
            ``.AT2`` file (:func:`read_at2`) or a folder whose ``.AT2`` files (any case of the
            suffix) are read in name order. One entry may be given alone.
        normalized: FEMA P695 sets: the normalized records (see :func:`fema_p695`).

    Returns:
        The records, in the order of ``specs``.

    Raises:
        ValueError: an entry that is no set name, file or folder, or a folder with no ``.AT2``
            file (the message starts with the entry), or a malformed file.
    """
    if isinstance(specs, str | os.PathLike):
        specs = [specs]
    motions: list[GroundMotion] = []
    for spec in specs:
        if isinstance(spec, str) and spec in FEMA_P695_SETS:
            motions += fema_p695(spec, normalized=normalized)
            continue
        path = Path(spec)
        if path.is_dir():
            files = sorted(f for f in path.iterdir() if f.suffix.upper() == ".AT2")
            if not files:
                raise ValueError(f"{os.fspath(spec)}: the folder holds no .AT2 files.")
            motions += [read_at2(f) for f in files]
        elif path.is_file():
            motions.append(read_at2(path))
        else:
            raise ValueError(
                f"{os.fspath(spec)}: no such file or folder, and not a record set "
                f"({', '.join(FEMA_P695_SETS)})."
            )
    return motions
