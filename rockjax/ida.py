"""Incremental dynamic analysis (IDA): one block under records x scale factors, batched.

Every (record, scale) pair is one run of :func:`rockjax.simulate_dem` or
:func:`rockjax.simulate_housner` (``model="three_branch"``: with a three-branch law) with
``throw=False``. A facade in a building (``wall_motion=`` a :class:`rockjax.ShearBuilding`)
has its return walls driven by the building's response to each scaled record; a wall of
several blocks in a building (an :class:`rockjax.Assembly` with ``support_motion=`` a building
and ``storey=``) stands on its floor and is held by the floor above. The building is linear:
its response is solved once per record and scaled with the record in every run. The pairs are
flattened and run in chunks of ``chunk_size``: one compiled batch per chunk from a Python
loop, which bounds the memory and lets a progress bar advance between chunks (DEM runs are
vmapped; Housner runs go through :func:`rockjax.housner.batch_runs`, one after another on
CPU). The last chunk is padded (with
zero-scale runs of the first record, dropped afterwards) to the same shape, so the batch
compiles once.

Records. Every run lasts ``t_end`` = the longest record plus a free-vibration ``tail`` [s]
(records are zero-padded), so the block can finish its last excursion (or overturn) after the
strongest record ends. Each record runs on its own ``dt``: records are grouped by ``dt`` and
each group is batched separately (one compilation per group), so a set that mixes steps (the
FEMA near-field set has 0.0024 to 0.02 s) does not run every record on the finest one. Each
run sees ``scale * ag`` (and ``scale * ag_v``, if any record of its group has a vertical
component; the others get zeros).

Engineering demand parameters, per run:

* ``max_d_over_b``: peak ``|d|/b`` of the top centre relative to the base. DEM: the running
  maximum over every step, ``extras["d_max"] / b``. Housner: from the peak rotation with the
  rigid-block formula ``|d| = b/2 (1 - cos theta_max) + h sin theta_max``, which is the same
  as ``max|Response.d|`` over the run because ``|d|`` grows with ``|theta|`` on
  ``[0, pi/2]``, but also includes the peaks between samples (``theta_max`` is the maximum
  of each solver step's dense output).
* ``max_theta_over_eta``: ``theta_max / eta``.
* ``collapse``: overturned (``|theta| > eta`` moving outward; the state is frozen from then
  on, so the two EDPs above are then the values where the run stopped, just past ``eta``).
* ``status``: 0 if the run is valid, else a code of ``rockjax.response.STATUS_MESSAGES``; a
  failed run has NaN EDPs and ``collapse = False`` and does not stop the batch.
* ``t_heel`` (Housner with ``wall_motion`` only): ``extras["t_heel"]`` of the run [s], the
  first time the rigid block, its return wall receded behind its base, would rock on its heel
  (``inf``: never); the run is the rigid block's up to that time only (docs/three_branch.md,
  "Moving return walls").
* ``pga_scaled``: ``scale * pga`` [m/s^2], with ``pga`` the peak of the record as run.
* ``im``: the intensity measure of the run, ``scale * IM(record)``, for ``im="pga"``
  (default; equal to ``pga_scaled``), ``"pgv"`` [m/s] or ``"sa(T)"`` (5 %-damped
  pseudo-spectral acceleration at ``T`` seconds, :mod:`rockjax.spectra`) [m/s^2]; all three
  are proportional to the record's amplitude. ``im_g`` is the same in g where the IM is an
  acceleration. Per record, ``pgv`` [m/s] and ``im_record`` (the IM at scale 1) are
  coordinates, so :func:`rockjax.fragility` can fit against PGA, PGV or the IDA's IM.
"""

from __future__ import annotations

import datetime
import math
from collections.abc import Sequence
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike, Float

from . import _progress
from ._checks import (
    GAP_HINT,
    GAP_NEEDS_ONE_SIDED,
    HOUSNER_GAP_UNUSED,
    check_choice,
    check_gap,
    check_nonnegative,
    check_positive,
    check_scalar,
    check_scales,
)
from ._lazy import lazy_module
from ._types import ScalarLike
from .assembly import ASSEMBLY_GAP_UNUSED, Assembly
from .block import Block
from .building import ShearBuilding
from .compilation import persistent_jit, strong_scalars
from .constants import G
from .contact import Joint
from .dem import simulate_assembly, simulate_dem, stable_dt, stable_dt_assembly
from .housner import P_DT_TARGET, batch_runs, check_restitution, simulate_housner
from .modes import MODE_NAMES, Mode, as_mode
from .motion import GroundMotion
from .response import STATUS_OK
from .spectra import IntensityMeasure, intensity, parse_im
from .supports import check_storey, check_walls_in_building, storey_supports, wall_top_motion
from .three_branch import ThreeBranchFit, ThreeBranchLaw

xr = lazy_module("xarray")  # loaded on first use (rockjax/_lazy.py)

MODELS = ("dem", "housner", "three_branch")
MODES = MODE_NAMES

DEFAULT_SCALES = np.linspace(0.05, 2.0, 40)
DEFAULT_SCALES.flags.writeable = False


def ida(
    block: Block | Assembly,
    records: Sequence[GroundMotion],
    scales: Float[ArrayLike, " scale"] | Sequence[float] = DEFAULT_SCALES,
    *,
    model: str = "dem",
    mode: Mode | str = "two_sided",
    beta: ScalarLike | None = None,
    e: ScalarLike | None = None,
    gap: ScalarLike | None = None,
    tail: ScalarLike = 2.0,
    t_end: ScalarLike | None = None,
    chunk_size: int = 256,
    progress: bool | None = None,
    devices: Sequence[jax.Device] | None = None,
    im: str = "pga",
    joint: Joint | None = None,
    law: ThreeBranchLaw | ThreeBranchFit | None = None,
    wall_motion: ShearBuilding | None = None,
    support_motion: ShearBuilding | None = None,
    storey: int | None = None,
) -> xr.Dataset:
    """Incremental dynamic analysis of one block: every record at every scale factor.

    Args:
        block: The block (scalar geometry and material), or an :class:`rockjax.Assembly` (a
            wall of several blocks; ``model="dem"``; ``mode="one_sided"``, ``gap`` and
            ``wall_motion`` put its blocks' back faces on return walls, as in
            :func:`rockjax.simulate_assembly`). For an assembly ``max_d_over_b`` is the peak
            horizontal displacement of the top block's top centre over the bottom block's
            ``b`` (at the record samples; for a row, :meth:`rockjax.Assembly.row`, the +x end
            block's over block 0's), ``max_theta_over_eta`` the largest over the blocks,
            ``collapse`` the assembly's collapse rule (:func:`rockjax.simulate_assembly`).
        records: Ground motions, with distinct names. They may differ in length (zero-padded to
            the longest, plus ``tail``) and in ``dt`` (each runs on its own).
        scales: Scale factors [-] applied to each record, strictly increasing, finite, >= 0.
        model: ``"dem"`` (:func:`rockjax.simulate_dem`), ``"housner"``
            (:func:`rockjax.simulate_housner`) or ``"three_branch"`` (``simulate_housner`` with
            ``law``).
        mode: :class:`rockjax.Parapet` (``"two_sided"``) or :class:`rockjax.Facade`
            (``"one_sided"``; :func:`rockjax.as_mode`). The Dataset's ``mode`` attribute is its
            name.
        beta: DEM only, required: stiffness-proportional Rayleigh coefficient [s], Eq. (1). The
            DEM step is the largest divisor of the record step not above
            ``rj.stable_dt(block, beta, mode=mode)``, as in a single run.
        e: Housner only: coefficient of restitution [-]; default as in
            :func:`rockjax.simulate_housner` (``e_H``, Eq. (2), two-sided; ``|e_1sr|``, Eq. (5),
            one-sided).
        gap: DEM one-sided only, with ``mode="one_sided"``: facade-to-return-wall gap [m];
            default None (0, or the Facade's own).
        tail: Free vibration appended after the longest record [s].
        t_end: Length of every run [s]; default the longest record + ``tail``. Give it to make
            a subset of a record set run exactly as in a call on the whole set (a campaign's
            parts, :mod:`rockjax.campaign`); it must not cut a record short.
        chunk_size: Runs per compiled batch; bounds the memory (about
            ``chunk_size * n_time * 8`` bytes per saved series), not the results.
        progress: A progress bar over the runs (tqdm, on stderr), advanced per chunk: None
            (default) shows it when stderr is a terminal, True always (e.g. in a notebook or a
            log), False never.
        devices: Devices to shard each chunk over (its runs split evenly, the records
            replicated; ``jax.sharding``); default every local device. With one device the
            chunks run as they are. The chunk size is rounded up to a multiple of the device
            count. Results do not depend on it (tests/test_ida.py).
        im: Intensity measure of the Dataset's ``im`` variable: ``"pga"`` [m/s^2], ``"pgv"``
            [m/s] or ``"sa(T)"``, e.g. ``"sa(0.5)"``, the 5 %-damped pseudo-spectral
            acceleration at T = 0.5 s [m/s^2] (:func:`rockjax.spectra.parse_im`).
        joint: DEM only: the contact joint (:class:`rockjax.Joint`); default ``rj.Joint()``,
            the converged joint; ``rj.Joint(n_sub=2)`` is the paper's corner contacts. Named
            in ``attrs["joint"]``.
        law: ``model="three_branch"`` only, required: the three-branch moment-rotation law
            (:class:`rockjax.ThreeBranchLaw`, e.g. ``rj.fit_three_branch(rj.pushover(block)).law``).
        wall_motion: One-sided only: a :class:`rockjax.ShearBuilding` whose response to each
            scaled record moves the facade's return walls (``wall_motion=`` of the
            simulators; taken at the block's height, or an assembly's whole height); its
            periods are in ``attrs["building_periods"]``. With ``support_motion`` (a facade
            in storey ``storey``), the same building: the walls move with that storey, its
            drift interpolated linearly in height, solved with the supports once per record.
        support_motion: An :class:`rockjax.Assembly` only: the :class:`rockjax.ShearBuilding`
            whose storey ``storey`` the wall spans (:func:`rockjax.simulate_assembly`): its
            base on floor ``storey - 1`` (0 the ground), its top restraint held by floor
            ``storey``. The scales, ``pga`` and ``im`` stay those of the ground record. Its
            periods are in ``attrs["building_periods"]``, the storey in ``attrs["storey"]``.
        storey: With ``support_motion``: the storey (1-based) the wall stands in, 1 to
            ``n_storeys`` for a restrained top, up to ``n_storeys + 1`` (the roof) for a free
            one; default 1.

    Returns:
        An ``xarray.Dataset`` with dims ``("record", "scale")`` and variables
        ``max_d_over_b``, ``max_theta_over_eta``, ``collapse`` (bool), ``status`` (int) and
        ``pga_scaled`` [m/s^2], ``im`` [m/s^2 or m/s] and, for an acceleration IM, ``im_g``
        [g] (see the module docstring for their definitions; ``attrs["im"]`` names the IM).
        Coordinates: ``record`` (names), ``scale``, and per record ``pga`` [m/s^2] (of the
        record as run), ``pgv`` [m/s], ``im_record`` (the IM at scale 1),
        ``dt`` [s] and ``duration`` [s] (as given), ``name``, and ``meta_<key>`` for every
        metadata key of any record ("" where a record lacks it). ``attrs`` hold the run
        parameters (model, mode, beta or e, the block, gap, tail, the run length ``t_end``,
        the rockjax version and the UTC creation time); the coordinate ``dt_step`` holds each
        record's solver step [s]. ``ds.to_netcdf(path)`` writes it (via h5netcdf).

    Raises:
        ValueError: on invalid input, with the value, its unit and the fix.
    """
    devices = list(jax.local_devices() if devices is None else devices)
    if not devices:
        raise ValueError("devices must name at least one device, e.g. jax.local_devices().")
    plan = _plan(
        block,
        records,
        scales,
        model=model,
        mode=mode,
        beta=beta,
        e=e,
        gap=gap,
        tail=tail,
        t_end=t_end,
        chunk_size=chunk_size,
        n_devices=len(devices),
        im=im,
        joint=joint,
        law=law,
        wall_motion=wall_motion,
        support_motion=support_motion,
        storey=storey,
    )
    grids = _run(plan, _placement(devices), progress)
    return _assemble(plan, grids)


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
        block = _scalar_block(block)
    storey = _check_support(block, support_motion, storey)
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


def _check_support(block, support_motion, storey) -> int:
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


class CollapseIntervals(NamedTuple):
    """Result of :func:`collapse_intervals`.

    Attributes:
        intervals: Record name -> list of ``(lo, hi)`` scale factors: the lowest and highest
            sampled scale of each contiguous run of collapsed scales, in increasing order.
        lowest: Lowest collapsed scale factor per record [-] (NaN where none collapsed), an
            ``xarray.DataArray`` over ``record``.
    """

    intervals: dict[str, list[tuple[float, float]]]
    lowest: xr.DataArray


def collapse_intervals(ds: xr.Dataset) -> CollapseIntervals:
    """Contiguous intervals of collapsing scale factors per record, from an :func:`ida` Dataset.

    IDA curves of rocking blocks are not monotonic: a record that overturns a block at one
    scale may leave it standing at a larger one ("resurrection"), so there can be several
    intervals. An interval ``(lo, hi)`` spans sampled scales: every sampled scale from ``lo`` to
    ``hi`` collapsed, and the sampled scales next to it (if any) did not. Runs with a nonzero
    ``status`` are left out (their neighbours decide), so a failed run neither splits nor
    creates an interval.

    Args:
        ds: A Dataset with dims ``("record", "scale")`` and variables ``collapse`` and
            ``status``, as :func:`ida` returns.

    Returns:
        A :class:`CollapseIntervals` ``(intervals, lowest)``.

    Raises:
        ValueError: if ``ds`` lacks the ``collapse`` or ``status`` variables.
    """
    for var in ("collapse", "status"):
        if var not in ds:
            raise ValueError(
                f"ds has no {var!r} variable; pass the Dataset that rj.ida returns "
                f"(it has {sorted(ds.data_vars)})."
            )
    ds = ds.sortby("scale")
    scales = np.asarray(ds["scale"], float)
    collapse = np.asarray(ds["collapse"].transpose("record", "scale"), bool)
    ok = np.asarray(ds["status"].transpose("record", "scale")) == STATUS_OK
    names = [str(r) for r in np.asarray(ds["record"])]
    intervals: dict[str, list[tuple[float, float]]] = {}
    lowest = np.full(len(names), np.nan)
    for i, name in enumerate(names):
        s, c = scales[ok[i]], collapse[i][ok[i]]
        edges = np.diff(np.concatenate([[0], c.astype(np.int8), [0]]))
        starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
        intervals[name] = [(float(s[a]), float(s[b])) for a, b in zip(starts, stops)]
        if starts.size:
            lowest[i] = s[starts[0]]
    da = xr.DataArray(lowest, coords={"record": ds["record"]}, dims=("record",))
    da.attrs["long_name"] = "lowest collapse scale factor"
    return CollapseIntervals(intervals=intervals, lowest=da)


# ----------------------------------------------------------------------------- plan, run, assemble


class _Chunk(NamedTuple):
    """One compiled batch: runs ``k * size ... (k + 1) * size - 1`` of a ``dt`` group (its
    runs flattened record-major over the scales; indices past ``n_runs`` are padding)."""

    group: _Group
    k: int
    size: int
    n_runs: int


class _Plan(NamedTuple):
    """Everything :func:`ida` runs and labels, checked: the block, the run parameters, the
    records grouped by ``dt`` and the chunks."""

    block: Block
    config: dict
    e_used: float | None
    e_given: bool
    scales: np.ndarray
    records: Sequence[GroundMotion]
    groups: list
    chunks: list
    pga: np.ndarray  # per record, as run [m/s^2]
    pgv: np.ndarray  # per record [m/s]
    im: IntensityMeasure
    im_record: np.ndarray  # the IM per record at scale 1 [im.units]
    dt_step: np.ndarray  # solver step per record [s]
    tail: float
    t_end: float


def _plan(
    block,
    records,
    scales,
    *,
    model,
    mode,
    beta,
    e,
    gap,
    tail,
    t_end,
    chunk_size,
    n_devices,
    im,
    joint=None,
    law=None,
    wall_motion=None,
    support_motion=None,
    storey=None,
) -> _Plan:
    """Check the inputs of :func:`ida` and cut its runs into chunks (no run yet)."""
    block, config, e_used = run_config(
        block,
        model=model,
        mode=mode,
        beta=beta,
        e=e,
        gap=gap,
        joint=joint,
        law=law,
        wall_motion=wall_motion,
        support_motion=support_motion,
        storey=storey,
    )
    im_spec = parse_im(im)
    scales = check_scales(scales)
    if not (isinstance(chunk_size, int) and chunk_size >= 1):
        raise ValueError(f"chunk_size must be an int >= 1; got chunk_size={chunk_size!r}. Use 256.")
    check_nonnegative("tail", tail, "s", "tail is the free vibration after the records, e.g. 2.0.")
    tail = float(tail)
    groups, pga, t_end = _group_records(records, tail, t_end)
    pgv = np.array([float(r.pgv) for r in records])
    im_record = np.array([float(intensity(r, im_spec.name)) for r in records])
    # Both simulators split each record step into ceil(dt_rec / dt_bound) equal steps.
    dt_step = np.zeros(len(records))
    chunks = []
    for g in groups:
        n_runs = g.index.size * scales.size
        size = min(chunk_size, n_runs)
        size = -(-size // n_devices) * n_devices  # a multiple of the device count
        chunks += [_Chunk(g, k, size, n_runs) for k in range(math.ceil(n_runs / size))]
        dt_step[g.index] = g.dt / max(1, math.ceil(g.dt / config["dt_bound"] - 1e-9))
    return _Plan(
        block,
        config,
        e_used,
        e is not None,
        scales,
        records,
        groups,
        chunks,
        pga,
        pgv,
        im_spec,
        im_record,
        dt_step,
        tail,
        t_end,
    )


def _run(plan: _Plan, place: _Placement, progress: bool | None) -> dict[str, np.ndarray]:
    """Run the plan's chunks; the EDPs on the (record, scale) grid."""
    n_rec, n_scale = len(plan.records), plan.scales.size
    grids = {
        "max_d_over_b": np.full((n_rec, n_scale), np.nan),
        "max_theta_over_eta": np.full((n_rec, n_scale), np.nan),
        "collapse": np.zeros((n_rec, n_scale), bool),
        "status": np.zeros((n_rec, n_scale), np.int32),
    }
    bar = _progress.bar(progress, total=n_rec * n_scale, desc="rockjax.ida", unit="run")
    seen: set[float] = set()
    building = {"wall_motion", "support_motion", "storey"}
    config = {k: v for k, v in plan.config.items() if k not in building}
    # the block, beta, e and a facade's gap as data (arrays), not static Python numbers: one
    # program for every value (rockjax.compilation.strong_scalars)
    config |= strong_scalars({k: config[k] for k in ("beta", "e", "mode")})
    block = strong_scalars(plan.block)
    walls: dict[float, tuple] = {}
    supports: dict[float, tuple] = {}
    for n, (g, k, size, n_runs_g) in enumerate(plan.chunks):
        # the first chunk of a dt group compiles: say so while it runs
        first = g.dt not in seen
        seen.add(g.dt)
        bar.set_postfix_str(
            f"chunk {n + 1}/{len(plan.chunks)}, dt = {g.dt:g} s" + (", compiling" if first else "")
        )
        flat = np.arange(k * size, (k + 1) * size)
        real = flat < n_runs_g
        flat = np.where(real, flat, 0)  # padding: repeats of the group's first run, dropped
        local, j = np.divmod(flat, n_scale)
        ag, ag_v = place.replicated(g.ag), place.replicated(g.ag_v)
        rec_k, scale_k = place.split(local.astype(np.int32)), place.split(plan.scales[j])
        wall = None
        in_building = plan.config["support_motion"] is not None
        if plan.config["wall_motion"] is not None and not in_building:
            # the building is linear: its wall motion under a scaled record is the scaled
            # wall motion, so it is solved once per record, not in every run
            if g.dt not in walls:
                # taken at the facade's height: the block's, or the stack's
                height = plan.block.height if isinstance(plan.block, Assembly) else plan.block.h
                walls[g.dt] = _wall_histories(plan.config["wall_motion"], g.ag, g.dt, height)
            wall = tuple(place.replicated(w) for w in walls[g.dt])
        support = None
        if plan.config["support_motion"] is not None:
            # the same for a wall of several blocks: its base floor's acceleration and the
            # storey's drift at scale 1, once per record
            # (and the return walls' motion relative to the base floor, when they move with
            # the building: the same solve)
            moving = plan.config["wall_motion"] is not None
            if g.dt not in supports:
                supports[g.dt] = _support_histories(
                    plan.config["support_motion"],
                    g.ag,
                    g.dt,
                    plan.config["storey"],
                    plan.block.top == "restrained",
                    plan.block.height if moving else None,
                )
            support = tuple(place.replicated(a) for a in supports[g.dt])
            if moving:
                support, wall = support[:-2], support[-2:]
        # the step: data for the DEM (its number of steps a sample is then data too); for
        # Housner the record step over its number of substeps (static: equal for every
        # block that takes as many)
        steps = max(1, math.ceil(g.dt / plan.config["dt_bound"] - 1e-9))
        dt_bound = np.asarray(g.dt / steps) if config["model"] == "dem" else g.dt / steps
        chunk = (block, ag, ag_v, rec_k, scale_k, wall, support)
        out = _run_chunk(*chunk, dt_rec=g.dt, **(config | {"dt_bound": dt_bound}))
        out = jax.device_get(out)
        if "t_heel" in out and "t_heel" not in grids:  # (Housner with a moving wall)
            grids["t_heel"] = np.full((n_rec, n_scale), np.nan)
        for key in grids:
            grids[key][g.index[local[real]], j[real]] = np.asarray(out[key])[real]
        bar.set_postfix_str(f"chunk {n + 1}/{len(plan.chunks)}, dt = {g.dt:g} s", refresh=False)
        bar.update(int(real.sum()))
    bar.close()
    return grids


def _assemble(plan: _Plan, grids: dict[str, np.ndarray]) -> xr.Dataset:
    """The labelled Dataset of :func:`ida` from the plan and the EDP grids."""
    records, block, config = plan.records, plan.block, plan.config
    with np.errstate(over="ignore"):  # a huge scale may overflow to inf, as it does in the run
        pga_scaled = plan.pga[:, None] * plan.scales[None, :]
        im_scaled = plan.im_record[:, None] * plan.scales[None, :]
    im = plan.im
    dims = ("record", "scale")
    data_vars = {
        "max_d_over_b": (dims, grids["max_d_over_b"], _attrs("peak |d|/b, top centre", "1")),
        "max_theta_over_eta": (dims, grids["max_theta_over_eta"], _attrs("theta_max/eta", "1")),
        "collapse": (dims, grids["collapse"], {"long_name": "overturned"}),
        "status": (dims, grids["status"], {"long_name": "0 ok, else STATUS_MESSAGES code"}),
        "pga_scaled": (dims, pga_scaled, _attrs("scaled peak ground acceleration", "m/s^2")),
        "im": (dims, im_scaled, _attrs(f"{im.name}: scaled {im.long_name}", im.units)),
    }
    if "t_heel" in grids:
        data_vars["t_heel"] = (
            dims,
            grids["t_heel"],
            _attrs("first time the rigid block would rock on its heel (inf: never)", "s"),
        )
    if im.is_acceleration:
        data_vars["im_g"] = (dims, im_scaled / G, _attrs(f"{im.name}: scaled, in g", "g"))
    names = [r.name for r in records]
    coords = {
        "record": names,
        "scale": ("scale", plan.scales, {"units": "1"}),
        "name": ("record", names),
        "pga": (
            "record",
            plan.pga,
            _attrs("peak ground acceleration of the record as run", "m/s^2"),
        ),
        "pgv": ("record", plan.pgv, _attrs("peak ground velocity of the record", "m/s")),
        "im_record": (
            "record",
            plan.im_record,
            _attrs(f"{im.name}: {im.long_name} of the record (scale 1)", im.units),
        ),
        "dt": ("record", np.array([r.dt for r in records], float), _attrs("record step", "s")),
        "dt_step": ("record", plan.dt_step, _attrs("solver step of the record's runs", "s")),
        "duration": (
            "record",
            np.array([r.duration for r in records], float),
            _attrs("record duration", "s"),
        ),
    }
    keys = sorted({key for r in records for key, _ in r.meta})
    for key in keys:
        coords[f"meta_{key}"] = ("record", [r.metadata.get(key, "") for r in records])
    from . import __version__  # at call time: the package sets it after importing this module

    attrs = {
        "model": config["model"],
        "mode": config["mode"].name,
        "im": im.name,
        **_block_attrs(block),
        "gap": float(config["mode"].gap),
        "tail": plan.tail,
        "t_end": plan.t_end,
        "rockjax_version": __version__,
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
    }
    if config["model"] == "dem":
        attrs["beta"] = config["beta"]
        attrs["joint"] = repr(config["joint"])
    else:
        attrs["e"] = plan.e_used
        attrs["e_source"] = "given" if plan.e_given else "default (Eq. 2 or Eq. 5)"
    if config["law"] is not None:
        law = config["law"]
        for field in ("lambda_0", "Delta_1", "Delta_2", "Delta_u"):
            if hasattr(law, field):
                attrs[f"law_{field}"] = float(getattr(law, field))
    if config["wall_motion"] is not None:
        attrs["building_periods"] = np.asarray(config["wall_motion"].periods, float)
    if config["support_motion"] is not None:
        attrs["building_periods"] = np.asarray(config["support_motion"].periods, float)
        attrs["storey"] = config["storey"]
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)


# ----------------------------------------------------------------------------- helpers


def _block_attrs(block) -> dict:
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


def _attrs(long_name: str, units: str) -> dict:
    return {"long_name": long_name, "units": units}


def _scalar_block(block: Block) -> Block:
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


class _Placement(NamedTuple):
    """Puts a chunk's per-run arrays split over the devices and the records on every one."""

    split: object
    replicated: object


def _placement(devices) -> _Placement:
    if len(devices) == 1:
        return _Placement(split=lambda x: x, replicated=lambda x: x)
    mesh = jax.sharding.Mesh(np.asarray(devices), ("run",))
    runs = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec("run"))
    every = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec())
    return _Placement(
        split=lambda x: jax.device_put(x, runs),
        replicated=lambda x: None if x is None else jax.device_put(x, every),
    )


class _Group(NamedTuple):
    """Records sharing one ``dt``: their indices in the input and their padded arrays."""

    index: np.ndarray
    dt: float
    ag: jax.Array
    ag_v: jax.Array | None


def _group_records(records, tail: float, t_end: float | None = None):
    """Records grouped by ``dt``, each zero-padded to ``t_end`` (default: the longest record +
    ``tail``).

    Returns ``(groups, pga per record [m/s^2], t_end [s])``.
    """
    if isinstance(records, GroundMotion) or not isinstance(records, Sequence) or not records:
        raise ValueError(
            "records must be a non-empty sequence of rockjax.GroundMotion, e.g. [gm1, gm2]; "
            f"got {type(records)}."
        )
    for r in records:
        if not isinstance(r, GroundMotion):
            raise ValueError(f"records must hold rockjax.GroundMotion; got {type(r)}.")
    names = [r.name for r in records]
    if len(set(names)) != len(names):
        dup = sorted({n for n in names if names.count(n) > 1})
        raise ValueError(
            f"record names must be distinct (they label the Dataset); {dup} repeat. Rename "
            "with GroundMotion(ag=r.ag, dt=r.dt, name='...', ag_v=r.ag_v, meta=r.meta)."
        )
    for r in records:
        check_positive("dt", r.dt, "s")
    longest = max(r.duration for r in records)
    if t_end is None:
        t_end = longest + tail
    else:
        t_end = float(t_end)
        if not (math.isfinite(t_end) and t_end >= longest - 1e-9):
            raise ValueError(
                f"t_end = {t_end} s would cut the longest record ({longest:g} s) short; give "
                "t_end >= the longest record's duration, or leave it None (longest + tail)."
            )
    steps: list[float] = []
    for r in records:
        if not any(math.isclose(r.dt, d, rel_tol=1e-9) for d in steps):
            steps.append(r.dt)
    groups = []
    for d in steps:
        idx = np.array([i for i, r in enumerate(records) if math.isclose(r.dt, d, rel_tol=1e-9)])
        n_time = int(math.floor(t_end / d + 1e-9)) + 1
        ag = np.zeros((idx.size, n_time))
        with_v = any(records[i].ag_v is not None for i in idx)
        ag_v = np.zeros_like(ag) if with_v else None
        for row, i in enumerate(idx):
            r = records[i]
            n = min(r.n, n_time)
            ag[row, :n] = np.asarray(r.ag, dtype=float)[:n]
            if with_v and r.ag_v is not None:
                ag_v[row, :n] = np.asarray(r.ag_v, dtype=float)[:n]
        groups.append(
            _Group(idx, float(d), jnp.asarray(ag), None if ag_v is None else jnp.asarray(ag_v))
        )
    pga = np.array([float(r.pga) for r in records])
    return groups, pga, float(t_end)


@persistent_jit
def _wall_histories(building, ag, dt: float, height):
    """``(u_top, v_top)`` of the return wall at ``height`` for every record of a group at scale
    1, shape (record, time) (:func:`rockjax.wall_top_motion`)."""

    def one(a):
        return wall_top_motion(building, GroundMotion(ag=a, dt=dt), height)

    return jax.vmap(one)(ag)


@persistent_jit
def _support_histories(building, ag, dt: float, storey: int, restrained: bool, wall_height=None):
    """The supports of a wall in storey ``storey`` for every record of a group at scale 1,
    each (record, time): the base floor's absolute acceleration [m/s^2] and, for a restrained
    top, the storey's drift [m] and its rate [m/s] (floor ``storey`` less floor ``storey - 1``,
    :meth:`rockjax.ShearBuilding.response`), as :func:`rockjax.simulate_assembly` computes them
    in a single run; with ``wall_height`` [m], last, the return walls' ``(u_top, v_top)``
    relative to the base floor at that height (:func:`rockjax.supports.storey_supports`)."""

    def one(a):
        base, top, *walls = storey_supports(
            building, a, dt, storey, restrained, wall_height=wall_height
        )
        out = (base,) if top is None else (base, *top)
        return out + (tuple(walls[0]) if walls else ())

    return jax.vmap(one)(ag)


@persistent_jit
def _run_chunk(
    block,
    ag,
    ag_v,
    rec_idx,
    scale,
    wall,
    support,
    *,
    model,
    mode,
    beta,
    e,
    joint,
    law,
    dt_rec,
    dt_bound,
):
    """EDPs of one chunk of runs: ``ag[rec_idx[k]] * scale[k]`` for each k (batched); ``wall``:
    None, or the return wall's ``(u_top, v_top)`` per record at scale 1, scaled likewise;
    ``support``: None, or an assembly's base acceleration (and top restraint's ``(u, v)``) per
    record at scale 1 (:func:`_support_histories`), scaled likewise."""

    common = dict(beta=beta, mode=mode, dt=dt_bound, joint=joint, throw=False)

    def one(i, s):
        motion = GroundMotion(ag=s * ag[i], dt=dt_rec, ag_v=None if ag_v is None else s * ag_v[i])
        wall_motion = None if wall is None else (s * wall[0][i], s * wall[1][i])
        if isinstance(block, Assembly):
            kw = {}
            if support is not None:
                motion = GroundMotion(ag=s * support[0][i], dt=dt_rec, ag_v=motion.ag_v)
                if len(support) == 3:
                    kw["support_motion"] = (s * support[1][i], s * support[2][i])
            if wall_motion is not None:
                kw["wall_motion"] = wall_motion
            r = simulate_assembly(block, motion, **common, **kw)
            top = block.blocks[-1]
            # (r.x is already relative to the block's rest position)
            d = r.x[:, -1] + 0.5 * top.h * jnp.sin(r.theta[:, -1])
            ok = r.status == STATUS_OK
            return {
                "max_d_over_b": jnp.where(ok, jnp.max(jnp.abs(d)) / block.blocks[0].b, jnp.nan),
                "max_theta_over_eta": jnp.where(ok, jnp.max(r.theta_max / r.eta), jnp.nan),
                "collapse": r.overturned & ok,
                "status": r.status.astype(jnp.int32),
            }
        if model == "dem":
            r = simulate_dem(
                block,
                motion,
                **common,
                **({} if wall_motion is None else {"wall_motion": wall_motion}),
            )
            d_max = r.extras["d_max"]
        else:
            extra = {} if law is None else {"law": law}
            if wall_motion is not None:
                extra["wall_motion"] = wall_motion
            r = simulate_housner(block, motion, e=e, mode=mode, dt=dt_bound, throw=False, **extra)
            d_max = block.top_displacement(r.theta_max)
        ok = r.status == STATUS_OK
        heel = {} if "t_heel" not in r.extras else {"t_heel": r.extras["t_heel"]}
        return {
            "max_d_over_b": jnp.where(ok, d_max / block.b, jnp.nan),
            "max_theta_over_eta": jnp.where(ok, r.theta_max / r.eta, jnp.nan),
            "collapse": r.overturned & ok,
            "status": r.status.astype(jnp.int32),
        } | heel

    if model == "dem" or isinstance(block, Assembly):
        return jax.vmap(one)(rec_idx, scale)
    return batch_runs(one, rec_idx, scale)  # on CPU one run after another (much faster)
