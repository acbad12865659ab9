"""The engine's input files besides the fragility model: exposure, taxonomy mapping, ground
motion fields and the scenario_damage job."""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np

from .. import jsonio
from .._lazy import lazy_module
from ._nrml import LOSS_CATEGORIES, NRML_NS, check_id

pd = lazy_module("pandas")  # loaded on first use (rockjax/_lazy.py); xarray's dependency

_ASSET_ID = 50  # the engine's longest asset id (and taxonomy) [characters]


def _table(inventory, what: str) -> pd.DataFrame:
    if isinstance(inventory, pd.DataFrame):
        return inventory.copy()
    if isinstance(inventory, str | os.PathLike):
        return pd.read_csv(inventory)
    raise ValueError(
        f"{what} must be a pandas DataFrame or the path of a CSV file; got {type(inventory).__name__}."
    )


def exposure(
    inventory: pd.DataFrame | str | os.PathLike,
    folder: str | os.PathLike,
    class_of: Callable[[pd.Series], str] | Mapping[str, str] | str,
    *,
    loss_category: str = "nonstructural",
    value: str | float = 1.0,
    currency: str = "EUR",
    exposure_id: str = "rockjax",
    description: str = "URM buildings with parapets and facades",
) -> dict[str, Path]:
    """Write the engine's exposure (an XML header and a CSV of assets) and the taxonomy mapping.

    Every building of the inventory is one asset (``number`` 1), its taxonomy its own id; the
    ``taxonomy_mapping.csv`` maps that taxonomy to the building's class (``risk_id``, the id of a
    fragility function; weight 1), so the engine's damage is reported per building while the
    fragility model holds one function per class.

    Args:
        inventory: One row per building, with columns ``id``, ``lon``, ``lat`` [degrees] and
            whatever ``class_of`` reads (e.g. ``storeys``, ``element``, ``b``, ``h``); a
            DataFrame or a CSV file.
        folder: Where to write ``exposure.xml``, ``exposure_assets.csv`` and
            ``taxonomy_mapping.csv`` (created if missing).
        class_of: The class of a building: a function of its row (e.g.
            :meth:`rockjax.openquake.Catalogue.class_of`), a dict from building id to class id,
            or the name of a column holding it.
        loss_category: The fragility model's loss category; it names the asset's cost column.
        value: Replacement cost of each asset's ``loss_category`` (a column name or one value
            for all) [``currency``]; damage does not use it, the engine requires it.
        currency: Unit of ``value``.
        exposure_id: The exposure's id.
        description: The exposure's description.

    Returns:
        ``{"exposure": .., "assets": .., "taxonomy_mapping": ..}``, the paths written; the job's
        ``exposure_file`` and ``taxonomy_mapping_csv``.

    Raises:
        ValueError: on missing columns, ids the engine refuses, coordinates out of range or a
            building without a class.
    """
    df = _table(inventory, "inventory")
    for col in ("id", "lon", "lat"):
        if col not in df.columns:
            raise ValueError(
                f"the inventory needs a column {col!r} (id, lon and lat in degrees); it has "
                f"{list(df.columns)}."
            )
    if loss_category not in LOSS_CATEGORIES:
        raise ValueError(f"loss_category must be one of {LOSS_CATEGORIES}; got {loss_category!r}.")
    check_id("exposure_id", exposure_id)
    ids = df["id"].astype(str)
    for i in ids:
        if not (0 < len(i) <= _ASSET_ID) or not all(c.isalnum() or c in "_-" for c in i):
            raise ValueError(
                f"building id {i!r} is no engine asset id: 1 to {_ASSET_ID} letters, digits, "
                "'_' or '-'."
            )
    if ids.duplicated().any():
        raise ValueError(f"building ids repeat: {sorted(set(ids[ids.duplicated()]))[:5]}.")
    lon, lat = df["lon"].to_numpy(float), df["lat"].to_numpy(float)
    if not (np.all(np.abs(lon) <= 180) and np.all(np.abs(lat) <= 90)):
        raise ValueError("lon must be in [-180, 180] and lat in [-90, 90] degrees (WGS84).")
    if isinstance(class_of, str):
        classes = df[class_of].astype(str).tolist()
    elif isinstance(class_of, Mapping):
        missing = [i for i in ids if i not in class_of]
        if missing:
            raise ValueError(f"class_of has no class for buildings {missing[:5]}.")
        classes = [class_of[i] for i in ids]
    else:
        classes = [class_of(row) for _, row in df.iterrows()]
    for c in set(classes):
        check_id("each class id", c)
    cost = df[value].to_numpy(float) if isinstance(value, str) else np.full(len(df), float(value))
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    assets = pd.DataFrame(
        {
            "id": ids,
            "lon": lon,
            "lat": lat,
            "taxonomy": ids,
            "number": 1,
            loss_category: cost,
            "night": 0,
        }
    )
    paths = {
        "exposure": folder / "exposure.xml",
        "assets": folder / "exposure_assets.csv",
        "taxonomy_mapping": folder / "taxonomy_mapping.csv",
    }
    jsonio.write_text(paths["assets"], assets.to_csv(index=False, float_format="%.7f"))
    mapping = pd.DataFrame({"taxonomy": ids, "risk_id": classes, "weight": 1.0})
    jsonio.write_text(paths["taxonomy_mapping"], mapping.to_csv(index=False))
    header = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<nrml xmlns="{NRML_NS}">',
        f'<exposureModel id="{exposure_id}" category="buildings" taxonomySource="rockjax">',
        f"  <description>{escape(description)}</description>",
        "  <conversions><costTypes>",
        f'    <costType name="{loss_category}" type="aggregated" unit="{escape(currency)}"/>',
        "  </costTypes></conversions>",
        "  <occupancyPeriods>night</occupancyPeriods>",
        f"  <assets>{paths['assets'].name}</assets>",
        "</exposureModel>",
        "</nrml>",
        "",
    ]
    jsonio.write_text(paths["exposure"], "\n".join(header))
    return paths


def ground_motion_fields(
    lon, lat, values, folder: str | os.PathLike, imt: str = "PGA"
) -> dict[str, Path]:
    """Write ground-motion fields as the engine reads them: ``sites.csv`` and ``gmfs.csv``.

    Args:
        lon: Site longitudes [degrees], shape ``(n_sites,)``.
        lat: Site latitudes [degrees], shape ``(n_sites,)``.
        values: The IM at every site, in the engine's unit (g for PGA and SA, cm/s for PGV):
            shape ``(n_sites,)`` for one event or ``(n_events, n_sites)``.
        folder: Where to write the two files (created if missing).
        imt: The engine's IM type, e.g. ``"PGA"`` or ``"SA(0.3)"``.

    Returns:
        ``{"sites": .., "gmfs": ..}``: the job's ``sites_csv`` and ``gmfs_file``.
    """
    lon, lat = np.asarray(lon, float).ravel(), np.asarray(lat, float).ravel()
    gmv = np.atleast_2d(np.asarray(values, float))
    if lon.shape != lat.shape or gmv.shape[1] != lon.size:
        raise ValueError(
            f"lon, lat must have one value per site and values shape (n_sites,) or (n_events, "
            f"n_sites); got {lon.shape}, {lat.shape} and {gmv.shape}."
        )
    if not np.all(np.isfinite(gmv)) or np.any(gmv < 0):
        raise ValueError("values must be finite and >= 0 (g for PGA and SA, cm/s for PGV).")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = {"sites": folder / "sites.csv", "gmfs": folder / "gmfs.csv"}
    sites = pd.DataFrame({"site_id": np.arange(lon.size), "lon": lon, "lat": lat})
    jsonio.write_text(paths["sites"], sites.to_csv(index=False, float_format="%.7f"))
    n_ev, n_site = gmv.shape
    gmfs = pd.DataFrame(
        {
            "event_id": np.repeat(np.arange(n_ev), n_site),
            "site_id": np.tile(np.arange(n_site), n_ev),
            f"gmv_{imt}": gmv.ravel(),
        }
    )
    jsonio.write_text(paths["gmfs"], gmfs.to_csv(index=False, float_format="%.10g"))
    return paths


def scenario_job(
    folder: str | os.PathLike,
    *,
    fragility: str | os.PathLike,
    exposure: str | os.PathLike,
    sites: str | os.PathLike,
    gmfs: str | os.PathLike,
    imt: str = "PGA",
    loss_category: str = "nonstructural",
    taxonomy_mapping: str | os.PathLike | None = None,
) -> Path:
    """Write a ``scenario_damage`` job with given ground-motion fields (``job.ini``).

    Paths are written relative to ``folder`` where they lie inside it.

    Args:
        folder: Where to write ``job.ini``.
        fragility: The NRML fragility model (:func:`rockjax.openquake.fragility_model`).
        exposure: The exposure XML (:func:`exposure`).
        sites: The sites CSV (:func:`ground_motion_fields`).
        gmfs: The ground-motion fields CSV.
        imt: The engine's IM type of the fields and the model.
        loss_category: The model's loss category (the key ``<loss_category>_fragility_file``).
        taxonomy_mapping: The taxonomy mapping CSV, if the assets' taxonomies are not class ids.

    Returns:
        The path of ``job.ini``.
    """
    if loss_category not in LOSS_CATEGORIES:
        raise ValueError(f"loss_category must be one of {LOSS_CATEGORIES}; got {loss_category!r}.")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)

    def rel(p) -> str:
        p = Path(p).resolve()
        try:
            return p.relative_to(folder.resolve()).as_posix()
        except ValueError:
            return p.as_posix()

    lines = [
        "[general]",
        "description = rockjax: scenario damage of parapets and facades",
        "calculation_mode = scenario_damage",
        f"exposure_file = {rel(exposure)}",
        f"{loss_category}_fragility_file = {rel(fragility)}",
        f"intensity_measure_types = {imt}",
        f"sites_csv = {rel(sites)}",
        f"gmfs_file = {rel(gmfs)}",
    ]
    if taxonomy_mapping is not None:
        lines.append(f"taxonomy_mapping_csv = {rel(taxonomy_mapping)}")
    path = folder / "job.ini"
    jsonio.write_text(path, "\n".join(lines) + "\n")
    return path
