"""The public entry point of the IDA, :func:`ida`: plan, run, assemble."""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import jax
from jaxtyping import ArrayLike, Float

from .._lazy import lazy_module
from .._types import ScalarLike
from ..assembly import Assembly
from ..batching import host_threads
from ..block import Block
from ..building import ShearBuilding
from ..models import Model, as_model
from ..modes import Mode, as_mode
from ..motion import GroundMotion
from ._config import DEFAULT_SCALES, gap_unused
from ._dataset import to_dataset
from ._plan import make_plan, placement_on
from ._run import run_plan

xr = lazy_module("xarray")  # loaded on first use (rockjax/_lazy.py)


def ida(
    block: Block | Assembly,
    records: Sequence[GroundMotion],
    scales: Float[ArrayLike, " scale"] | Sequence[float] = DEFAULT_SCALES,
    *,
    model: Model | str = "dem",
    mode: Mode | str = "two_sided",
    im: str = "pga",
    tail: ScalarLike = 2.0,
    t_end: ScalarLike | None = None,
    chunk_size: int | None = None,
    progress: bool | None = None,
    devices: Sequence[jax.Device] | None = None,
    wall_motion: ShearBuilding | None = None,
    support_motion: ShearBuilding | None = None,
    storey: int | None = None,
    **deprecated,
) -> xr.Dataset:
    """Incremental dynamic analysis of one block: every record at every scale factor.

    Args:
        block: The block (scalar geometry and material), or an :class:`rockjax.Assembly` (a
            wall of several blocks; ``model=rj.DEM(...)``; ``mode=rj.Facade(gap=...)`` and
            ``wall_motion`` put its blocks' back faces on return walls, as in
            :func:`rockjax.simulate_assembly`). For an assembly ``max_d_over_b`` is the peak
            horizontal displacement of the top block's top centre over the bottom block's
            ``b`` (at the record samples; for a row, :meth:`rockjax.Assembly.row`, the +x end
            block's over block 0's), ``max_theta_over_eta`` the largest over the blocks,
            ``collapse`` the assembly's collapse rule (:func:`rockjax.simulate_assembly`).
        records: Ground motions, with distinct names. They may differ in length (zero-padded to
            the longest, plus ``tail``) and in ``dt`` (each runs on its own).
        scales: Scale factors [-] applied to each record, strictly increasing, finite, >= 0.
        model: The model with its options (:func:`rockjax.as_model`):
            ``rj.DEM(beta=..., joint=...)`` (:func:`rockjax.simulate_dem`; ``beta`` [s],
            Eq. (1), required; the DEM step is the largest divisor of the record step not
            above ``rj.stable_dt(block, beta, mode=mode)``, as in a single run),
            ``rj.Housner(e=...)`` (:func:`rockjax.simulate_housner`; ``e`` [-] defaults to
            ``e_H``, Eq. (2), two-sided, ``|e_1sr|``, Eq. (5), one-sided) or
            ``rj.ThreeBranch(law)`` (``simulate_housner`` with a three-branch law, e.g.
            ``rj.fit_three_branch(rj.pushover(block)).law``). Its name (``"dem"``,
            ``"housner"``, ``"three_branch"``) is the Dataset's ``model`` attribute, and
            ``"housner"`` is accepted for ``rj.Housner()``.
        mode: :class:`rockjax.Parapet` (``"two_sided"``) or :class:`rockjax.Facade`
            (``"one_sided"``; :func:`rockjax.as_mode`); a facade's gap [m] is the DEM's
            (``rj.Facade(gap=0.001)``; the Housner models refuse one). The Dataset's ``mode``
            attribute is its name.
        im: Intensity measure of the Dataset's ``im`` variable: ``"pga"`` [m/s^2], ``"pgv"``
            [m/s] or ``"sa(T)"``, e.g. ``"sa(0.5)"``, the 5 %-damped pseudo-spectral
            acceleration at T = 0.5 s [m/s^2] (:func:`rockjax.spectra.parse_im`).
        tail: Free vibration appended after the longest record [s].
        t_end: Length of every run [s]; default the longest record + ``tail``. Give it to make
            a subset of a record set run exactly as in a call on the whole set (a campaign's
            parts, :mod:`rockjax.campaign`); it must not cut a record short.
        chunk_size: Runs per compiled batch (split over ``devices``); default 64 per device
            (``rockjax.ida.CHUNK_PER_DEVICE``, the fastest measured). It bounds the memory
            (about ``chunk_size * n_time * 8`` bytes per saved series), not the results.
        progress: A progress bar over the runs (tqdm, on stderr), advanced per chunk: None
            (default) shows it when stderr is a terminal, True always (e.g. in a notebook or a
            log), False never.
        devices: Devices to split each chunk over (its runs split evenly, the records
            replicated; ``jax.shard_map``: each device runs its share as a batch of its own,
            host CPU devices each on a core); default every local device. With one device the
            chunks run as they are, and by default, on a host CPU, as many at once as the
            process may use cores (``rockjax.ida.host_threads``; named devices run one chunk
            at a time, as a campaign's single-core workers want). The chunk size is rounded up
            to a multiple of the device count. Results do not depend on it beyond round-off,
            nor on the threads at all (tests/test_ida.py).
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
        **deprecated: The former keywords ``beta``, ``e``, ``joint``, ``law`` (the model's
            options: give them in the model object) and ``gap`` (the facade's: give it in
            ``rj.Facade(gap=...)``) still work, with a ``DeprecationWarning`` naming the new
            form; the results are the same to the bit.

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
    model, mode = _convert(block, model, mode, deprecated)
    threads = 1
    if devices is None:
        devices = jax.local_devices()
        if len(devices) == 1 and devices[0].platform == "cpu":
            threads = host_threads()
    devices = list(devices)
    if not devices:
        raise ValueError("devices must name at least one device, e.g. jax.local_devices().")
    plan = make_plan(
        block,
        records,
        scales,
        model=model,
        mode=mode,
        tail=tail,
        t_end=t_end,
        chunk_size=chunk_size,
        n_devices=len(devices),
        im=im,
        wall_motion=wall_motion,
        support_motion=support_motion,
        storey=storey,
    )
    grids = run_plan(plan, placement_on(devices, threads), progress)
    return to_dataset(plan, grids)


DEPRECATED = ("beta", "e", "joint", "law", "gap")
"""The keywords :func:`ida` took before its model and mode objects carried them."""


def _convert(block, model, mode, deprecated: dict):
    """The model and mode objects of :func:`ida`'s arguments, converted once (the former
    keywords warned about and folded in)."""
    unknown = sorted(set(deprecated) - set(DEPRECATED))
    if unknown:
        raise TypeError(f"ida() got an unexpected keyword argument {unknown[0]!r}")
    if deprecated:
        given = ", ".join(f"{k}=" for k in deprecated)
        warnings.warn(
            f"rj.ida({given}...) is deprecated: give the model's options in its object, "
            "model=rj.DEM(beta=..., joint=...), rj.Housner(e=...) or rj.ThreeBranch(law, e=...), "
            "and a facade's gap in its mode, mode=rj.Facade(gap=...). The results are the same.",
            DeprecationWarning,
            stacklevel=3,
        )
    gap = deprecated.pop("gap", None)
    model = as_model(model, **deprecated)
    return model, as_mode(mode, gap, unused=gap_unused(block, model))
