"""The text of a record file: its lines, whatever the encoding, and its numbers as Fortran and
C print them; shared by the AT2 and CSV readers."""

from __future__ import annotations

import codecs
import math
import re
from pathlib import Path

# A decimal number as Fortran and C print it: `.0050`, `0.005`, `5.0E-03`, `-.4524259E-02`,
# `1.0D-03` (Fortran double-precision exponent).
NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[EeDd][-+]?\d+)?"
_NUMBER_RE = re.compile(NUMBER)
_NON_FINITE = {"nan", "inf", "infinity"}


def read_lines(path: Path) -> list[str]:
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


def is_number_or_non_finite(token: str) -> bool:
    return _NUMBER_RE.fullmatch(token) is not None or token.lower().lstrip("+-") in _NON_FINITE


def to_float(path: Path, lineno: int, token: str) -> float:
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
