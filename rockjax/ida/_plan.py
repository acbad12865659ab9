"""The IDA's plan: records grouped by time step, the runs in padded chunks, and where
they run (devices)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from .._checks import (
    check_nonnegative,
    check_positive,
    check_scales,
)
from .._lazy import lazy_module
from ..block import Block
from ..motion import GroundMotion
from ..spectra import IntensityMeasure, intensity, parse_im
from ._config import run_config

xr = lazy_module("xarray")  # loaded on first use (rockjax/_lazy.py)


CHUNK_PER_DEVICE = 64
"""Default runs per compiled batch on each device, the fastest measured: the far-field IDA of
the 0.2 x 1.5 m block (880 runs, one device) took 7.9 s warm in chunks of 256, 5.2 s in chunks
of 128 and 5.1 s in chunks of 64 as a parapet, and 103, 76 and 74 ms a run as a facade, when
facades still ran as a ``vmap`` batch (they now run one after another on CPU, where a chunk's
size only sets how many runs one compiled call takes; docs/benchmarks.md, "IDA: chunk size
and devices")."""


class Chunk(NamedTuple):
    """One compiled batch: runs ``k * size ... (k + 1) * size - 1`` of a ``dt`` group (its
    runs flattened record-major over the scales; indices past ``n_runs`` are padding)."""

    group: Group
    k: int
    size: int
    n_runs: int


class Plan(NamedTuple):
    """Everything :func:`ida` runs and labels, checked: the block, the run parameters, the
    records grouped by ``dt`` and the chunks."""

    block: Block
    config: dict
    e_used: float | None
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


def make_plan(
    block,
    records,
    scales,
    *,
    model,
    mode,
    tail,
    t_end,
    chunk_size,
    n_devices,
    im,
    wall_motion=None,
    support_motion=None,
    storey=None,
) -> Plan:
    """Check the inputs of :func:`ida` and cut its runs into chunks (no run yet); ``model``
    and ``mode`` are the objects."""
    block, config, e_used = run_config(
        block,
        model=model,
        mode=mode,
        wall_motion=wall_motion,
        support_motion=support_motion,
        storey=storey,
    )
    im_spec = parse_im(im)
    scales = check_scales(scales)
    if chunk_size is None:
        chunk_size = CHUNK_PER_DEVICE * n_devices
    if isinstance(chunk_size, bool) or not (isinstance(chunk_size, int) and chunk_size >= 1):
        raise ValueError(
            f"chunk_size must be an int >= 1; got chunk_size={chunk_size!r}. Leave it None "
            f"for the default ({CHUNK_PER_DEVICE} runs per device)."
        )
    check_nonnegative("tail", tail, "s", "tail is the free vibration after the records, e.g. 2.0.")
    tail = float(tail)
    groups, pga, t_end = group_records(records, tail, t_end)
    pgv = np.array([float(r.pgv) for r in records])
    im_record = np.array([float(intensity(r, im_spec.name)) for r in records])
    # Both simulators split each record step into ceil(dt_rec / dt_bound) equal steps.
    dt_step = np.zeros(len(records))
    chunks = []
    for g in groups:
        n_runs = g.index.size * scales.size
        size = min(chunk_size, n_runs)
        size = -(-size // n_devices) * n_devices  # a multiple of the device count
        chunks += [Chunk(g, k, size, n_runs) for k in range(math.ceil(n_runs / size))]
        dt_step[g.index] = g.dt / max(1, math.ceil(g.dt / config["dt_bound"] - 1e-9))
    return Plan(
        block,
        config,
        e_used,
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


class Placement(NamedTuple):
    """Puts a chunk's per-run arrays split over the devices and the records on every one;
    ``mesh``: the devices' mesh (axis ``"run"``), None for one device; ``threads``: how many
    chunks run at once (:func:`rockjax.batching.host_threads`)."""

    split: object
    replicated: object
    mesh: jax.sharding.Mesh | None = None
    threads: int = 1


def placement_on(devices, threads: int = 1) -> Placement:
    """The placement on ``devices``; on a single device, ``threads`` chunks at once."""
    if len(devices) == 1:
        return Placement(split=lambda x: x, replicated=lambda x: x, threads=threads)
    mesh = jax.sharding.Mesh(
        np.asarray(devices), ("run",), axis_types=(jax.sharding.AxisType.Auto,)
    )
    runs = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec("run"))
    every = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec())
    return Placement(
        split=lambda x: jax.device_put(x, runs),
        replicated=lambda x: None if x is None else jax.device_put(x, every),
        mesh=mesh,
    )


def run_order(plan: Plan, g: Group) -> tuple[np.ndarray, np.ndarray]:
    """The runs of group ``g`` in the order they are cut into chunks: ``(record within the
    group, scale index)`` of each, by the scaled record's PGV (``scale * pgv``), lowest first.

    A ``vmap`` chunk steps until its last run ends, and a run that has collapsed takes one step
    a sample; so runs that collapse early are cheap only among others that do. Record by
    record, every chunk held some of a record's low scales, which stand to the end. By PGV, the
    far-field IDA of the 0.2 x 1.5 m parapet (880 runs, warm, 2 threads) took 2.32-2.33 s
    instead of 2.71-2.73 s (2.46-2.50 s by scale alone; its last chunk padded with its last
    run, not the group's first), with the same results to the bit
    (docs/benchmarks.md, "IDA: the order of the runs"). Runs made one after another (Housner,
    DEM facades) cost the same in any order."""
    local, j = np.divmod(np.arange(g.index.size * plan.scales.size), plan.scales.size)
    order = np.argsort(plan.pgv[g.index][local] * plan.scales[j], kind="stable")
    return local[order], j[order]


class Group(NamedTuple):
    """Records sharing one ``dt``: their indices in the input and their padded arrays."""

    index: np.ndarray
    dt: float
    ag: jax.Array
    ag_v: jax.Array | None


def group_records(records, tail: float, t_end: float | None = None):
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
            Group(idx, float(d), jnp.asarray(ag), None if ag_v is None else jnp.asarray(ag_v))
        )
    pga = np.array([float(r.pga) for r in records])
    return groups, pga, float(t_end)
