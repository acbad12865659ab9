"""The public entry point of the IDA, :func:`ida`: plan, run, assemble."""

from __future__ import annotations

from collections.abc import Sequence

import jax
from jaxtyping import ArrayLike, Float

from .._lazy import lazy_module
from .._types import ScalarLike
from ..assembly import Assembly
from ..block import Block
from ..building import ShearBuilding
from ..contact import Joint
from ..modes import Mode
from ..motion import GroundMotion
from ..three_branch import ThreeBranchFit, ThreeBranchLaw
from ._config import DEFAULT_SCALES
from ._dataset import to_dataset
from ._plan import make_plan, placement_on
from ._run import run_plan

xr = lazy_module("xarray")  # loaded on first use (rockjax/_lazy.py)


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
    plan = make_plan(
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
    grids = run_plan(plan, placement_on(devices), progress)
    return to_dataset(plan, grids)
