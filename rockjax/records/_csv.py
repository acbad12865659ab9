"""Plain text and CSV record files: :func:`read_csv`, with the units each column's header
states or ``units=`` gives (never guessed), and the checks of the time column."""

from __future__ import annotations

import math
import os
import re
from pathlib import Path
from typing import Literal

import numpy as np

from .._checks import check_choice, check_positive, time_steps
from ..constants import G
from ..motion import PLAUSIBLE_LIMIT_G, GroundMotion
from ._table import (
    Table,
    column_index,
    column_label,
    column_name,
    describe_columns,
    read_table,
    too_few_rows,
)

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

    table = read_table(path, header, delimiter, decimal)
    n_cols = table.values.shape[1]
    t_idx = None if time_column is False else column_index(path, table, time_column, "time_column")
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
                f"{describe_columns(table, t_idx)}. Pass column= (a 0-based index or a header "
                "name) to pick the acceleration, or check delimiter= and time_column=."
            )
        a_idx = others[0]
    else:
        a_idx = column_index(path, table, column, "column")
        if a_idx == t_idx:
            raise ValueError(
                f"{path}: column={column!r} is also the time column; pick an acceleration "
                f"column: {describe_columns(table, t_idx)}."
            )
    if len(table.lines) < 2:
        raise ValueError(too_few_rows(path, len(table.lines)))
    for j in (a_idx,) if t_idx is None else (t_idx, a_idx):
        bad = np.flatnonzero(~np.isfinite(table.values[:, j]))
        if bad.size:
            lineno = table.lines[bad[0]]
            raise ValueError(
                f"{path}, line {lineno}: non-finite sample {table.tokens[bad[0]][j]!r} in column "
                f"{column_label(table, j)} ({bad.size} in all). Records must be finite: clean "
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
            f"{path}: column {column_label(table, a_idx)} peaks at {peak / G:.3g} g read with "
            f"{read_as}, above the plausibility limit of {PLAUSIBLE_LIMIT_G:g} g for a "
            f"ground acceleration: the file is probably in other units. {fix}"
        )
    name = path.stem if name is None else name
    meta = {"file": path.name, "units": units, "units_from": units_from}
    meta["column"] = column_name(table, a_idx)
    if table.header is not None:
        meta["header"] = table.header
    if t_idx is None:
        motion = GroundMotion(ag=raw * factor, dt=float(dt), name=name)
        if resample is not None:
            motion = _resample_uniform(path, motion, float(resample), meta)
        return motion.with_metadata(**meta)

    meta["time_column"] = column_name(table, t_idx)
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
            f"{column_label(table, t_idx)})."
        )
    if time_from is None and float(np.median(steps)) > MAX_PLAUSIBLE_STEP:
        raise ValueError(
            f"{path}: the time column {column_label(table, t_idx)} steps by "
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


def _acceleration_units(path: Path, table: Table, j: int, units: str | None) -> tuple[str, str]:
    """The units of column ``j`` [one of CSV_UNITS] and where they come from (``"header"`` or
    ``"units="``): the header's where it states them, checked against ``units``."""
    label = column_label(table, j)
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


def _time_units(path: Path, table: Table, j: int, time_units: str | None) -> tuple[str, str | None]:
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
        path, "time_units", time_units, said, f"the time column {column_label(table, j)}"
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
