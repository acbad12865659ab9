"""The DEM's histories against those stored from an earlier version of its code
(tests/data/reference_histories.npz, written by tests/data/make_reference_histories.py).

These pin the DEM's arithmetic, not its physics: a rewrite of the solver's code (one kernel
for the block and the assembly, a new module layout) must reproduce them to round-off. The
physics is checked elsewhere against independent references (test_dem.py, test_assembly*.py).
A deliberate change of the physics regenerates the file and says which cases moved and why
(docs/verification.md, "Stored DEM histories").
"""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

DATA = Path(__file__).parent / "data"
ROUND_OFF = 1e-12
"""[rad] A history reproduced by the same arithmetic in another order: a few ulps of theta
per step, accumulated over a few thousand steps (measured 1e-16-1e-14 for reordered sums)."""

_spec = importlib.util.spec_from_file_location("make_refs", DATA / "make_reference_histories.py")
make_refs = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(make_refs)
STORED = np.load(DATA / "reference_histories.npz")
CASES = make_refs.cases()


@pytest.mark.parametrize("name", sorted(CASES))
def test_history_reproduced(name):
    body, motion, kw = CASES[name]
    got = make_refs.run(body, motion, kw)
    np.testing.assert_array_equal(got["t"], STORED[f"{name}/t"])
    np.testing.assert_allclose(got["theta"], STORED[f"{name}/theta"], rtol=0, atol=ROUND_OFF)
    for key in ("x", "y"):
        np.testing.assert_allclose(got[key], STORED[f"{name}/{key}"], rtol=0, atol=ROUND_OFF)
