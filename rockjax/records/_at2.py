"""PEER NGA ``.AT2`` acceleration files: :func:`read_at2` (the header variants, units and
description) and :func:`write_at2`."""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import numpy as np

from .._checks import check_positive
from ..constants import G
from ..motion import GroundMotion
from ._text import NUMBER, read_lines, to_float

# `NPTS=  7814, DT= .0050 SEC,` (NGA-West2, PEER-SMD, older PEA, hand-edited files) ...
_NPTS_RE = re.compile(r"\bNPTS\s*=\s*(\d+)", re.IGNORECASE)
_DT_RE = re.compile(rf"\bDT\s*=\s*({NUMBER})", re.IGNORECASE)
# ... or `4164    0.0100    NPTS, DT` (NGA-West1: the numbers first).
_WEST1_RE = re.compile(rf"^\s*(\d+)\s+({NUMBER})\s+NPTS\s*,\s*DT\b", re.IGNORECASE)
_UNITS_RE = re.compile(r"\bUNITS\s+OF\s+(\S+)", re.IGNORECASE)
_DATE_RE = re.compile(r"\b\d{1,2}/\d{1,2}/\d{2,4}\b")
_NPTS_EXAMPLE = "'NPTS=  7814, DT= .0050 SEC' (or '4164    0.0100    NPTS, DT')"


def read_at2(path: str | os.PathLike, *, g: float = G) -> GroundMotion:
    """Read a PEER NGA ``.AT2`` acceleration file.

    Header variants accepted (docs/verification.md, "PEER .AT2 record files"): NGA-West2 ``NPTS=  7814, DT= .0050 SEC,``;
    PEER-SMD 2000 and older PEA ``NPTS=  7802, DT= .00500 SEC``; NGA-West1
    ``4164    0.0100    NPTS, DT``; hand-edited ``NPTS=  8000, DT= .0050`` without ``SEC``;
    any text after ``SEC,`` (filter notes). ``DT`` may read ``.0050``, ``0.005``, ``5.0E-03``
    or ``5.0D-03``. Every number after the NPTS/DT line is a sample, in any layout (5 per
    line, 1 per line, a short last line), separated by blanks or commas; CRLF line ends and
    blank lines are fine.

    The units are those the header states (``UNITS OF G``, normally on line 3); ``CM/S^2``
    (``CM/SEC/SEC``, ``CM/S/S``, ``GAL``) and ``M/S^2`` are converted too. A header that
    states no units is read as g, the AT2 convention, and says so in ``metadata["units"]``.

    The name is the file stem (``RSN1063_NORTHR_RRS228``). ``metadata`` holds ``file``,
    ``title`` (line 1), ``header`` (line 2 as written) and ``units``, and, when line 2 reads
    ``event, date, station, component`` (NGA-West2) or ``event date time, station,
    component`` (PEER-SMD), also ``event``, ``date``, ``station`` and ``component``.

    Args:
        path: The ``.AT2`` file.
        g: Standard gravity [m/s^2] for records in units of g.

    Returns:
        The record, accelerations in m/s^2.

    Raises:
        ValueError: for a velocity (``.VT2``) or displacement (``.DT2``) file, or a malformed
            file: empty, no NPTS/DT line, ``DT <= 0``, a token that is not a number, a NaN or
            infinite sample, unknown units, or a sample count that differs from ``NPTS``.
            The message names the file and the line.
    """
    path = Path(path)
    check_positive("g", g, "m/s^2", "The default is standard gravity, 9.80665.")
    kinds = {".VT2": "velocity", ".DT2": "displacement"}
    if path.suffix.upper() in kinds:
        raise ValueError(
            f"{path}: a PEER {path.suffix} file holds a {kinds[path.suffix.upper()]} time "
            "series; read_at2 reads accelerations. Read the matching .AT2 file instead."
        )
    lines = read_lines(path)

    at = next((i for i, line in enumerate(lines) if "NPTS" in line.upper()), None)
    if at is None:
        raise ValueError(
            f"{path}: no NPTS/DT line found in its {len(lines)} lines. An AT2 header's line 4 "
            f"reads like {_NPTS_EXAMPLE}. Add it, or read a bare series with "
            "read_csv(path, time_column=False, dt=...)."
        )
    npts, dt = _parse_npts_dt(path, at + 1, lines[at])
    header = [line.strip() for line in lines[:at]]
    factor, units = _header_units(path, header, g)

    values, last = _read_values(path, lines, first=at + 1)
    if npts < 2:
        raise ValueError(
            f"{path}, line {at + 1}: NPTS={npts}; a record needs at least 2 samples. "
            "Check the NPTS field and the data below it."
        )
    if values.size != npts:
        hint = (
            "The file looks truncated: download it again, or set NPTS to the number of values "
            "if the shorter record is intended."
            if values.size < npts
            else "Check the NPTS field, or delete the extra values at the end of the file."
        )
        where = f"lines {at + 2}-{last}" if last > at + 1 else f"after line {at + 1}"
        raise ValueError(
            f"{path}, line {at + 1}: NPTS={npts} but {values.size} values were found "
            f"({where}). {hint}"
        )

    meta = {"file": path.name, "units": units}
    if header:
        meta["title"] = header[0]
    if len(header) >= 2:
        meta["header"] = header[1]
        meta.update(_describe(header[1]))
    return GroundMotion(ag=values * factor, dt=dt, name=path.stem, meta=tuple(meta.items()))


def write_at2(
    path: str | os.PathLike,
    motion: GroundMotion,
    *,
    g: float = G,
    significant_digits: int = 7,
) -> None:
    """Write a record as a PEER NGA-West2 style ``.AT2`` file, in units of g.

    Four header lines (title; ``event, date, station, component`` from the record's
    metadata, else its ``header`` entry, else its name; ``ACCELERATION TIME SERIES IN UNITS
    OF G``; ``NPTS=  7814, DT= 0.005 SEC,``) and then the samples, 5 per line, in E format
    with ``significant_digits`` digits (NGA-West2 prints 7: ``  3.654112E-04``), so a round
    trip through :func:`read_at2` keeps each sample to a relative ``0.5 * 10**(1 -
    significant_digits)``. ``DT`` is written with all its digits (``repr``), not rounded to
    4 decimals as in NGA files, so the time axis survives the round trip exactly.

    Args:
        path: The file to write (overwritten if it exists).
        motion: The record; only its horizontal ``ag`` is written.
        g: Standard gravity [m/s^2] used to convert to units of g.
        significant_digits: Digits per sample, 1 to 17.

    Raises:
        ValueError: if ``motion`` has a vertical component (an AT2 file holds one component)
            or ``significant_digits`` is out of range.
    """
    check_positive("g", g, "m/s^2", "The default is standard gravity, 9.80665.")
    if isinstance(significant_digits, bool) or significant_digits not in range(1, 18):
        raise ValueError(
            f"significant_digits must be an integer from 1 to 17; got {significant_digits!r}. "
            "NGA-West2 files use 7; 17 writes float64 samples exactly."
        )
    if motion.ag_v is not None:
        raise ValueError(
            f"record {motion.name!r} has a vertical component ag_v; an AT2 file holds one "
            "component. Write each to its own file: write_at2(path_v, GroundMotion(ag="
            "motion.ag_v, dt=motion.dt)) and the horizontal one with ag_v=None."
        )
    info = motion.metadata
    fields = [info.get(key) for key in ("event", "date", "station", "component")]
    if all(fields):
        describe = ", ".join(fields)
    else:
        describe = info.get("header", motion.name)
    lines = [
        "PEER NGA STRONG MOTION DATABASE RECORD",
        describe,
        "ACCELERATION TIME SERIES IN UNITS OF G",
        f"NPTS={motion.n:>6d}, DT= {float(motion.dt)!r} SEC,",
    ]
    ag_g = np.asarray(motion.ag, dtype=float) / g
    width, decimals = significant_digits + 6, significant_digits - 1
    # one blank before every field keeps 3-digit exponents (1.0E-100) from touching
    cells = [f" {x:{width}.{decimals}E}" for x in ag_g]
    lines += ["".join(cells[i : i + 5]) for i in range(0, len(cells), 5)]
    Path(path).write_text("\n".join(lines) + "\n", encoding="ascii")


def _parse_npts_dt(path: Path, lineno: int, line: str) -> tuple[int, float]:
    if (west1 := _WEST1_RE.search(line)) is not None:
        npts_text, dt_text = west1.groups()
    else:
        npts, dt = _NPTS_RE.search(line), _DT_RE.search(line)
        if npts is None or dt is None:
            missing = " and ".join(k for k, m in (("NPTS", npts), ("DT", dt)) if m is None)
            raise ValueError(
                f"{path}, line {lineno}: cannot read {missing} from {line.strip()!r}. "
                f"Expected {_NPTS_EXAMPLE}."
            )
        npts_text, dt_text = npts.group(1), dt.group(1)
    dt = float(dt_text.replace("D", "E").replace("d", "e"))
    if not math.isfinite(dt) or dt <= 0.0:
        raise ValueError(
            f"{path}, line {lineno}: DT={dt_text} s; the sampling step must be positive. "
            "Correct the DT field, e.g. 'DT= .0050 SEC'."
        )
    return int(npts_text), dt


def _header_units(path: Path, header: list[str], g: float) -> tuple[float, str]:
    # line 3 states the units in every PEER variant; look at the others only if it does not
    order = [2, *(i for i in range(len(header)) if i != 2)]
    for i in (i for i in order if i < len(header)):
        found = _UNITS_RE.search(header[i])
        if found is None:
            continue
        upper = header[i].upper()
        for kind in ("VELOCITY", "DISPLACEMENT"):
            if kind in upper:
                raise ValueError(
                    f"{path}, line {i + 1}: the header says this is a {kind.lower()} time series "
                    f"({header[i]!r}); read_at2 reads accelerations. Read the matching .AT2 file."
                )
        token = found.group(1).strip(".,;:").upper()
        unit = token.replace("**", "^").replace("SEC", "S")
        unit = re.sub(r"/S(?:/S|\^?2)$", "/S^2", unit)
        factors = {"G": g, "GAL": 0.01, "CM/S^2": 0.01, "M/S^2": 1.0}
        if unit not in factors:
            raise ValueError(
                f"{path}, line {i + 1}: unknown units {token!r}. Accepted: G, CM/S^2 "
                "(CM/SEC/SEC, CM/S/S, GAL) and M/S^2; convert the file or fix the units text."
            )
        return factors[unit], token
    return g, "G (assumed: the header states no units)"


def _read_values(path: Path, lines: list[str], first: int) -> tuple[np.ndarray, int]:
    """All numbers on lines[first:], and the (1-based) number of the last line holding one."""
    values, last = [], first
    for lineno, line in enumerate(lines[first:], start=first + 1):
        tokens = [tok for tok in re.split(r"[\s,]+", line) if tok]
        if tokens:
            values.extend(to_float(path, lineno, tok) for tok in tokens)
            last = lineno
    return np.asarray(values, dtype=float), last


def _describe(line: str) -> dict[str, str]:
    """Event, date, station and component from header line 2, where its layout is recognised."""
    fields = [field.strip() for field in line.split(",")]
    if len(fields) == 4 and _DATE_RE.fullmatch(fields[1]):  # NGA-West2
        return dict(zip(("event", "date", "station", "component"), fields, strict=True))
    if len(fields) == 3 and (date := _DATE_RE.search(fields[0])) is not None:  # PEER-SMD
        event = fields[0][: date.start()].strip()
        return {
            "event": event,
            "date": fields[0][date.start() :].strip(),
            "station": fields[1],
            "component": fields[2],
        }
    return {}
