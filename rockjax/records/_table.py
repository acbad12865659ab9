"""The numbers of a text table (a CSV or whitespace-separated record file): rows, separators,
the header's column names, and the choice of a column by index or name."""

from __future__ import annotations

import re
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ._text import is_number_or_non_finite, read_lines


class Table(NamedTuple):
    """The numbers of a text table, with the (1-based) line of every row and its fields."""

    values: np.ndarray  # (rows, columns); NaN/inf kept, checked per column read
    lines: list[int]
    tokens: list[list[str]]
    header: str | None
    names: list[str] | None


_COMMENT_RE = re.compile(r"#.*$")  # as numpy.loadtxt: a comment runs from any # to the line end


def read_table(path: Path, header: bool | None, delimiter: str | None, decimal: str) -> Table:
    rows: list[list[str]] = []
    lines: list[int] = []
    head_text = None
    split = None
    for lineno, line in enumerate(read_lines(path), start=1):
        text = _COMMENT_RE.sub("", line).strip()
        if not text:
            continue
        if head_text is None and not rows:
            if header is None:  # a header has no field that reads as a number
                if delimiter is None:
                    fields = [tok for tok in re.split(r"[\s,;]+", text) if tok]
                else:
                    fields = _splitter(text, delimiter, decimal)(text)
                is_header = not any(is_number_or_non_finite(tok) for tok in fields)
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
            if not is_number_or_non_finite(tok):
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
        raise ValueError(too_few_rows(path, 0))
    values = np.array([[_number(tok) for tok in row] for row in rows], dtype=float)
    names = None
    if head_text is not None:
        names = _header_names(head_text, delimiter, len(rows[0]), decimal)
    return Table(values, lines, rows, head_text, names)


def too_few_rows(path: Path, n: int) -> str:
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


def column_index(path: Path, table: Table, spec, label: str) -> int:
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
                f"instead: {describe_columns(table, None)}."
            )
        matches = [j for j, nm in enumerate(table.names) if nm == spec]
        if not matches:
            matches = [j for j, nm in enumerate(table.names) if nm.lower() == spec.lower()]
        if len(matches) != 1:
            what = "is not a column name" if not matches else "names several columns"
            raise ValueError(
                f"{path}: {label}={spec!r} {what}; the columns are {describe_columns(table, None)}."
            )
        return matches[0]
    j = int(spec)
    if not -n <= j < n:
        raise ValueError(
            f"{path}: {label}={j} is out of range: the file has {n} columns, "
            f"{describe_columns(table, None)} (0-based)."
        )
    return j % n


def _number(token: str) -> float:
    """A field already checked by :func:`is_number_or_non_finite` as a float (NaN, inf kept;
    an overflowing exponent gives inf, refused where the column is read)."""
    return float(token.replace("D", "E").replace("d", "e"))


def column_label(table: Table, j: int) -> str:
    return f"{j} ({table.names[j]!r})" if table.names is not None else str(j)


def column_name(table: Table, j: int) -> str:
    return table.names[j] if table.names is not None else str(j)


def describe_columns(table: Table, t_idx: int | None) -> str:
    parts = []
    for j in range(table.values.shape[1]):
        text = column_label(table, j)
        parts.append(text + (" [time]" if j == t_idx else ""))
    return ", ".join(parts)
