"""An IDA's results as an ``xarray.Dataset`` with its coordinates and attributes."""

from __future__ import annotations

import datetime

import numpy as np

from .._lazy import lazy_module
from ..assembly import Assembly
from ..block import Block
from ..constants import G
from ._plan import Plan

xr = lazy_module("xarray")  # loaded on first use (rockjax/_lazy.py)


def to_dataset(plan: Plan, grids: dict[str, np.ndarray]) -> xr.Dataset:
    """The labelled Dataset of :func:`ida` from the plan and the EDP grids."""
    records, block, config = plan.records, plan.block, plan.config
    with np.errstate(over="ignore"):  # a huge scale may overflow to inf, as it does in the run
        pga_scaled = plan.pga[:, None] * plan.scales[None, :]
        im_scaled = plan.im_record[:, None] * plan.scales[None, :]
    im = plan.im
    dims = ("record", "scale")
    data_vars = {
        "max_d_over_b": (dims, grids["max_d_over_b"], var_attrs("peak |d|/b, top centre", "1")),
        "max_theta_over_eta": (dims, grids["max_theta_over_eta"], var_attrs("theta_max/eta", "1")),
        "collapse": (dims, grids["collapse"], {"long_name": "overturned"}),
        "status": (dims, grids["status"], {"long_name": "0 ok, else STATUS_MESSAGES code"}),
        "pga_scaled": (dims, pga_scaled, var_attrs("scaled peak ground acceleration", "m/s^2")),
        "im": (dims, im_scaled, var_attrs(f"{im.name}: scaled {im.long_name}", im.units)),
    }
    if "t_heel" in grids:
        data_vars["t_heel"] = (
            dims,
            grids["t_heel"],
            var_attrs("first time the rigid block would rock on its heel (inf: never)", "s"),
        )
    if im.is_acceleration:
        data_vars["im_g"] = (dims, im_scaled / G, var_attrs(f"{im.name}: scaled, in g", "g"))
    names = [r.name for r in records]
    coords = {
        "record": names,
        "scale": ("scale", plan.scales, {"units": "1"}),
        "name": ("record", names),
        "pga": (
            "record",
            plan.pga,
            var_attrs("peak ground acceleration of the record as run", "m/s^2"),
        ),
        "pgv": ("record", plan.pgv, var_attrs("peak ground velocity of the record", "m/s")),
        "im_record": (
            "record",
            plan.im_record,
            var_attrs(f"{im.name}: {im.long_name} of the record (scale 1)", im.units),
        ),
        "dt": ("record", np.array([r.dt for r in records], float), var_attrs("record step", "s")),
        "dt_step": ("record", plan.dt_step, var_attrs("solver step of the record's runs", "s")),
        "duration": (
            "record",
            np.array([r.duration for r in records], float),
            var_attrs("record duration", "s"),
        ),
    }
    keys = sorted({key for r in records for key, _ in r.meta})
    for key in keys:
        coords[f"meta_{key}"] = ("record", [r.metadata.get(key, "") for r in records])
    from .. import __version__  # at call time: the package sets it after importing this module

    model = config["model"]
    attrs = {
        "model": model.name,
        "mode": config["mode"].name,
        "im": im.name,
        **block_attrs(block),
        "gap": float(config["mode"].gap),
        "tail": plan.tail,
        "t_end": plan.t_end,
        "rockjax_version": __version__,
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
    }
    if plan.e_used is not None:  # a rigid model: the restitution its runs used
        attrs["e"] = plan.e_used
        attrs["e_source"] = "given" if model.e is not None else "default (Eq. 2 or Eq. 5)"
    attrs |= model.attrs()
    if config["wall_motion"] is not None:
        attrs["building_periods"] = np.asarray(config["wall_motion"].periods, float)
    if config["support_motion"] is not None:
        attrs["building_periods"] = np.asarray(config["support_motion"].periods, float)
        attrs["storey"] = config["storey"]
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)


# ----------------------------------------------------------------------------- helpers


def block_attrs(block) -> dict:
    """The block's fields for the Dataset's attrs (per block, bottom to top, for an assembly)."""
    if not isinstance(block, Assembly):
        return {field: float(getattr(block, field)) for field in Block.FIELDS}
    out = {
        field: np.array([float(getattr(b, field)) for b in block.blocks]) for field in Block.FIELDS
    }
    out.update(
        n_blocks=len(block.blocks),
        top=block.top,
        top_gap=float(block.gap),
        overburden=float(block.overburden),
    )
    return out


def var_attrs(long_name: str, units: str) -> dict:
    return {"long_name": long_name, "units": units}
