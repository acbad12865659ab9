"""Helpers every command of the ``rockjax`` command line shares: the checks that the output
files can be written (before any run), saving a figure, and the printed and written summaries
of a block and of restitution coefficients."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .. import plot
from ..block import Block


def _check_writable(flag: str, folder: Path) -> None:
    """Fail now, not after the computation, if ``folder`` (created later if missing) cannot be
    written: its nearest existing ancestor must be a folder that takes a new file (probed with
    a temporary file, removed at once; nothing is left behind)."""
    existing = folder.absolute()
    while not existing.exists():
        existing = existing.parent
    why = None
    if not existing.is_dir():
        why = f"{existing} is a file, not a folder"
    else:
        try:
            with tempfile.NamedTemporaryFile(dir=existing, prefix=".rockjax-probe-"):
                pass
        except OSError as err:
            why = err.strerror or str(err)
    if why is not None:
        raise ValueError(
            f"{flag}: cannot write into {folder} ({why}); give a path in a folder you can write to."
        )


def check_outputs(flag: str, paths: Sequence[Path]) -> None:
    """Fail now, not after the computation, if any file the command will write cannot be
    written: each folder as :func:`_check_writable`, and each file must not be a folder nor an
    existing file that cannot be overwritten."""
    for folder in dict.fromkeys(path.parent for path in paths):
        _check_writable(flag, folder)
    for path in paths:
        if path.is_dir():
            raise ValueError(
                f"{flag}: {path} is a folder, where the command writes a file; move or rename it, "
                f"or give another {flag}."
            )
        if path.exists() and not os.access(path, os.W_OK):
            raise ValueError(
                f"{flag}: {path} exists and cannot be overwritten (no write permission); make it "
                f"writable, or give another {flag}."
            )


def save(ax, path: Path) -> str:
    ax.figure.savefig(path, dpi=130)
    plot.close(ax)
    return path.name


def fmt_e(e) -> str:
    return " ".join("  -  " if not np.isfinite(v) else f"{v:.3f}" for v in np.asarray(e))


def block_info(block: Block) -> dict:
    return {
        "b_m": float(block.b),
        "h_m": float(block.h),
        "rho_kg_m3": float(block.rho),
        "E_pa": float(block.E),
        "nu": float(block.nu),
        "eta_rad": float(block.eta),
        "p_rad_s": float(block.p),
    }
