"""The IDA's configuration: the models and modes, and the checked run parameters."""

from __future__ import annotations

import equinox as eqx
import numpy as np

from .._checks import (
    GAP_HINT,
    GAP_NEEDS_ONE_SIDED,
    HOUSNER_GAP_UNUSED,
    check_choice,
    check_gap,
    check_nonnegative,
    check_scalar,
)
from .._lazy import lazy_module
from ..assembly import ASSEMBLY_GAP_UNUSED, Assembly
from ..block import Block
from ..building import ShearBuilding
from ..contact import Joint
from ..dem import stable_dt, stable_dt_assembly
from ..housner import P_DT_TARGET, check_restitution
from ..modes import MODE_NAMES, Mode, as_mode
from ..supports import check_storey, check_walls_in_building
from ..three_branch import ThreeBranchFit, ThreeBranchLaw

xr = lazy_module("xarray")  # loaded on first use (rockjax/_lazy.py)


MODELS = ("dem", "housner", "three_branch")
MODES = MODE_NAMES

DEFAULT_SCALES = np.linspace(0.05, 2.0, 40)
DEFAULT_SCALES.flags.writeable = False


def run_config(
    block: Block | Assembly,
    *,
    model: str,
    mode: Mode | str,
    beta=None,
    e=None,
    gap=None,
    joint=None,
    law=None,
    wall_motion=None,
    support_motion=None,
    storey=None,
):
    """Checked run parameters of :func:`ida`: ``(block, config, e_used)``.

    ``block`` has Python-float fields; ``config`` holds ``model``, ``mode`` (the mode object,
    a facade's ``gap`` a Python float), ``beta``, ``e`` (Python floats or None), ``joint`` (the DEM's :class:`rockjax.Joint`, None for
    Housner), ``law``, ``wall_motion``, ``support_motion``, ``storey`` (an int, 1 without a
    building) and ``dt_bound``, the solver step bound [s]; ``e_used``
    is the Housner restitution the runs use (None for the DEM). Raises ValueError as
    :func:`ida`.
    """
    check_choice("model", model, MODELS)
    if model != "dem":
        unused = HOUSNER_GAP_UNUSED
    else:
        unused = ASSEMBLY_GAP_UNUSED if isinstance(block, Assembly) else GAP_NEEDS_ONE_SIDED
    mode = as_mode(mode, gap, unused=unused)
    if isinstance(block, Assembly):
        if model != "dem":
            raise ValueError(
                f"an Assembly runs with model='dem' only; got model={model!r}. Pass "
                "model='dem' with beta=..."
            )
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
    if isinstance(law, ThreeBranchFit):  # rj.fit_three_branch(...) passed as it is
        law = law.law
    if model == "three_branch":
        if not isinstance(law, ThreeBranchLaw):
            raise ValueError(
                "model='three_branch' needs law=, a rockjax.ThreeBranchLaw, e.g. "
                f"law=rj.fit_three_branch(rj.pushover(block)).law; got law={law!r}."
            )
    elif law is not None:
        raise ValueError(
            f"law (a three-branch moment-rotation law) needs model='three_branch'; got "
            f"model={model!r}. Pass model='three_branch' or drop law."
        )
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
    check_gap(mode.gap, used=model == "dem", unused=unused, hint=GAP_HINT)
    if mode.one_sided:  # a Python float: static under filter_jit, like the block
        mode = eqx.tree_at(lambda m: m.gap, mode, float(mode.gap))
    if model == "dem":
        if e is not None:
            raise ValueError(
                f"e (restitution) is a Housner parameter; model='dem' takes beta [s]. Got e={e}."
            )
        if beta is None:
            raise ValueError(
                "model='dem' needs beta, the stiffness-proportional damping coefficient in s, "
                "e.g. beta=float(rj.beta_dejong(block)) or beta=2e-3."
            )
        check_scalar("beta", beta, "s", "ida runs one beta; call it once per value.")
        check_nonnegative("beta", beta, "s")
        beta = float(beta)  # a Python float: static under filter_jit, like the block
        joint = Joint() if joint is None else joint
        if not isinstance(joint, Joint):
            raise TypeError(
                f"joint must be a rockjax.Joint, e.g. rj.Joint(n_sub=2); got {type(joint).__name__}."
            )
        if isinstance(block, Assembly):
            dt_bound = stable_dt_assembly(block, beta, joint=joint, mode=mode)
        else:
            dt_bound = stable_dt(block, beta, mode=mode, joint=joint)
        e_used = None
    else:
        if beta is not None:
            raise ValueError(
                f"beta (DEM damping) is not a Housner parameter; model={model!r} takes e. "
                f"Got beta={beta}."
            )
        if joint is not None:
            raise ValueError(
                f"joint (the DEM's contact joint) is not a Housner parameter; got joint={joint!r}. "
                "Drop it, or use model='dem'."
            )
        if e is not None:
            check_scalar("e", e, "[-]", "e.g. e=0.9, or e=None for the default.")
        e = None if e is None else float(e)
        # the simulator's default: Eq. (2) two-sided, Eq. (5) one-sided; e_H < 0 for a block
        # wider than tall (eta > 54.7 deg) is refused here, not run into failed runs
        e_run = e if e is not None else float(mode.default_e(block.eta))
        check_restitution(e_run, mode, default=e is None)
        e_used = mode.e_magnitude(e_run)  # what simulate_housner uses (|e| one-sided)
        # the step bound simulate_housner picks for a concrete block
        dt_bound = P_DT_TARGET / float(block.p)
    config = dict(
        model=model,
        mode=mode,
        beta=beta,
        e=e,
        joint=joint,
        law=law,
        wall_motion=wall_motion,
        support_motion=support_motion,
        storey=storey,
        dt_bound=dt_bound,
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
