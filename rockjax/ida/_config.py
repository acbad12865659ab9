"""The IDA's configuration: the models and modes, and the checked run parameters."""

from __future__ import annotations

import equinox as eqx
import numpy as np

from .._checks import GAP_HINT, GAP_NEEDS_ONE_SIDED, HOUSNER_GAP_UNUSED, check_gap
from .._lazy import lazy_module
from ..assembly import ASSEMBLY_GAP_UNUSED, Assembly
from ..block import Block
from ..building import ShearBuilding
from ..models import (
    DEM,
    MODEL_NAMES,
    Housner,
    Model,
    ThreeBranch,
    map_numbers,
    restitution_used,
    takes_assembly,
)
from ..modes import MODE_NAMES, Facade, Mode, Parapet
from ..supports import check_storey, check_walls_in_building

xr = lazy_module("xarray")  # loaded on first use (rockjax/_lazy.py)


MODELS = MODEL_NAMES
MODES = MODE_NAMES

DEFAULT_SCALES = np.linspace(0.05, 2.0, 40)
DEFAULT_SCALES.flags.writeable = False


def gap_unused(block, model: Model) -> str:
    """Why a facade gap would be ignored by this model and block, and what to do (the
    ``unused=`` of :func:`rockjax.as_mode`)."""
    if model.rigid:
        return HOUSNER_GAP_UNUSED
    return ASSEMBLY_GAP_UNUSED if isinstance(block, Assembly) else GAP_NEEDS_ONE_SIDED


def run_config(
    block: Block | Assembly,
    *,
    model: Model,
    mode: Mode,
    wall_motion=None,
    support_motion=None,
    storey=None,
):
    """Checked run parameters of :func:`ida`: ``(block, config, e_used)``.

    ``model`` and ``mode`` are the objects (:func:`rockjax.as_model`, :func:`rockjax.as_mode`,
    converted once by the caller). ``block`` has Python-float fields; ``config`` holds
    ``model`` (its numeric options Python floats), ``mode`` (a facade's ``gap`` a Python
    float), ``wall_motion``, ``support_motion``, ``storey`` (an int, 1 without a building) and
    ``dt_bound``, the solver step bound [s]; ``e_used`` is the Housner restitution the runs
    use (None for the DEM). Raises ValueError as :func:`ida`.
    """
    if not isinstance(model, DEM | Housner | ThreeBranch):
        raise TypeError(f"run_config takes a model object (rj.as_model); got {model!r}.")
    if not isinstance(mode, Parapet | Facade):
        raise TypeError(f"run_config takes a mode object (rj.as_mode); got {mode!r}.")
    takes_assembly(model, block)
    if isinstance(block, Assembly):
        if wall_motion is not None and support_motion is not None:
            if not isinstance(wall_motion, ShearBuilding):
                raise ValueError(
                    "ida's wall_motion with support_motion must be the same "
                    "rockjax.ShearBuilding (the return walls move with the storey the facade "
                    f"stands in); got {type(wall_motion).__name__}. Pass "
                    "wall_motion=support_motion."
                )
            # the same building, not on the roof; storey checked as simulate_assembly does
            check_walls_in_building(wall_motion, support_motion, storey)
    else:
        block = scalar_block(block)
    storey = check_support(block, support_motion, storey)
    if wall_motion is not None:
        if not isinstance(wall_motion, ShearBuilding):
            raise ValueError(
                "ida's wall_motion must be a rockjax.ShearBuilding (its response to each scaled "
                f"record drives the return walls); got {type(wall_motion).__name__}. For "
                "recorded floor motions, call the simulators with wall_motion=... per record."
            )
        if not mode.one_sided:
            raise ValueError(
                f"wall_motion moves a facade's return walls and needs mode='one_sided'; got "
                f"mode={mode.name!r}. For a parapet on a roof, run the IDA on the roof's motions "
                "(bldg.floor_motions(record)[-1])."
            )
    check_gap(mode.gap, used=not model.rigid, unused=gap_unused(block, model), hint=GAP_HINT)
    if mode.one_sided:  # a Python float: static under filter_jit, like the block
        mode = eqx.tree_at(lambda m: m.gap, mode, float(mode.gap))
    # Python floats: static under filter_jit, like the block
    model = map_numbers(model, float)
    e_used = None if not model.rigid else restitution_used(model, block, mode)
    config = dict(
        model=model,
        mode=mode,
        wall_motion=wall_motion,
        support_motion=support_motion,
        storey=storey,
        dt_bound=model.step_bound(block, mode),
    )
    return block, config, e_used


def check_support(block, support_motion, storey) -> int:
    """The storey of a wall of several blocks in a building (1 without one), checked."""
    if support_motion is None:
        if storey is not None:
            raise ValueError(
                f"storey={storey!r} needs support_motion=<rockjax.ShearBuilding> (the building "
                "whose storey the wall spans); drop storey for a wall on the ground."
            )
        return 1
    if not isinstance(block, Assembly):
        raise ValueError(
            "support_motion (the building carrying a wall of several blocks) needs an "
            "rj.Assembly, e.g. rj.Assembly.stack([block], top='restrained'); got a "
            f"{type(block).__name__}. For a facade's return walls use wall_motion=bldg with "
            "mode='one_sided'; for a parapet on a roof, run the IDA on the roof's motions."
        )
    if not isinstance(support_motion, ShearBuilding):
        raise ValueError(
            "ida's support_motion must be a rockjax.ShearBuilding (its response to each scaled "
            f"record moves the wall's supports); got {type(support_motion).__name__}. Build one "
            "with rj.ShearBuilding.uniform(n_storeys, storey_height, period)."
        )
    return check_storey(support_motion, 1 if storey is None else storey, block.top)


def scalar_block(block: Block) -> Block:
    """The block with Python-float fields: static under ``filter_jit``, hence concrete in the
    simulators (which then pick their steps as for a single run), and a compile-cache key."""
    if not isinstance(block, Block):
        raise ValueError(f"block must be a rockjax.Block; got {type(block)}.")
    values = {}
    for field in Block.FIELDS:
        v = np.asarray(getattr(block, field), dtype=float)
        if v.size != 1:
            raise ValueError(
                f"ida runs one block; got {field} with shape {v.shape}. Call rj.ida once per block."
            )
        values[field] = float(v.reshape(()))
    return Block(**values)
