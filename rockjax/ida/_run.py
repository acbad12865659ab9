"""Running an IDA's chunks: the batched DEM and Housner runs, the buildings' histories
solved once per record."""

from __future__ import annotations

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np

from .. import _progress
from .._lazy import lazy_module
from ..assembly import Assembly
from ..batching import in_threads
from ..compilation import persistent_jit, strong_scalars
from ..housner import batch_runs
from ..models import map_numbers
from ..motion import GroundMotion
from ..response import STATUS_OK
from ..supports import storey_supports, wall_top_motion
from ._plan import Placement, Plan, run_order

xr = lazy_module("xarray")  # loaded on first use (rockjax/_lazy.py)


def run_plan(plan: Plan, place: Placement, progress: bool | None) -> dict[str, np.ndarray]:
    """Run the plan's chunks; the EDPs on the (record, scale) grid."""
    n_rec, n_scale = len(plan.records), plan.scales.size
    grids = {
        "max_d_over_b": np.full((n_rec, n_scale), np.nan),
        "max_theta_over_eta": np.full((n_rec, n_scale), np.nan),
        "collapse": np.zeros((n_rec, n_scale), bool),
        "status": np.zeros((n_rec, n_scale), np.int32),
    }
    bar = _progress.bar(progress, total=n_rec * n_scale, desc="rockjax.ida", unit="run")
    # the block, beta, e and a facade's gap as data (arrays), not static Python numbers: one
    # program for every value (rockjax.compilation.strong_scalars)
    model = map_numbers(plan.config["model"], strong_scalars)
    mode = strong_scalars(plan.config["mode"])
    block = strong_scalars(plan.block)
    walls: dict[float, tuple] = {}
    supports: dict[float, tuple] = {}
    orders: dict[float, tuple] = {}  # per group: its runs in chunk order (run_order)

    def prepare(g, k, size, n_runs_g):
        """A chunk's inputs, placed: ``(chunk, options, local, j, real)``, :func:`run_chunk`'s
        arguments and the chunk's records (local to its group), scales and real runs."""
        flat = np.arange(k * size, (k + 1) * size)
        real = flat < n_runs_g
        # padding: repeats of the group's last run in chunk order (its strongest, which
        # collapses first of all), dropped
        flat = np.where(real, flat, n_runs_g - 1)
        local, j = orders[g.dt][0][flat], orders[g.dt][1][flat]
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
                walls[g.dt] = wall_histories(plan.config["wall_motion"], g.ag, g.dt, height)
            wall = tuple(place.replicated(w) for w in walls[g.dt])
        support = None
        if plan.config["support_motion"] is not None:
            # the same for a wall of several blocks: its base floor's acceleration and the
            # storey's drift at scale 1, once per record
            # (and the return walls' motion relative to the base floor, when they move with
            # the building: the same solve)
            moving = plan.config["wall_motion"] is not None
            if g.dt not in supports:
                supports[g.dt] = support_histories(
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
        dt_bound = g.dt / steps if model.rigid else np.asarray(g.dt / steps)
        chunk = (block, ag, ag_v, rec_k, scale_k, wall, support)
        options = dict(model=model, mode=mode, dt_rec=g.dt, dt_bound=dt_bound, mesh=place.mesh)
        return chunk, options, local, j, real

    # the chunks run in place.threads threads at once (rockjax.batching.in_threads; on a host
    # CPU rockjax.ida.host_threads, each on a core; one thread: the caller's); a chunk that
    # compiles runs alone (the others would compile its program again), and the bar says so.
    # A thread takes the next chunk as soon as it is free: the chunks' costs differ (runs
    # ordered by PGV, run_order)
    where = []  # per chunk: its group's records, and its records (local), scales, real runs

    def tasks():
        for n, (g, k, size, n_runs_g) in enumerate(plan.chunks):
            first = g.dt not in orders  # the group's first chunk
            if first:
                orders[g.dt] = run_order(plan, g)
            chunk, options, local, j, real = prepare(g, k, size, n_runs_g)
            alone = first and run_chunk.will_compile(*chunk, **options)
            bar.set_postfix_str(
                f"chunk {n + 1}/{len(plan.chunks)}, dt = {g.dt:g} s"
                + (", compiling" if alone else "")
            )
            where.append((g.index, local, j, real))
            yield functools.partial(outputs, chunk, options), alone

    for n, out in in_threads(tasks(), place.threads):
        index, local, j, real = where[n]
        if "t_heel" in out and "t_heel" not in grids:  # (Housner with a moving wall)
            grids["t_heel"] = np.full((n_rec, n_scale), np.nan)
        for key in grids:
            grids[key][index[local[real]], j[real]] = np.asarray(out[key])[real]
        bar.update(int(real.sum()))
    bar.close()
    return grids


def outputs(chunk: tuple, options: dict) -> dict[str, np.ndarray]:
    """A chunk's EDPs (:func:`run_chunk`), on the host."""
    return jax.device_get(run_chunk(*chunk, **options))


@persistent_jit
def wall_histories(building, ag, dt: float, height):
    """``(u_top, v_top)`` of the return wall at ``height`` for every record of a group at scale
    1, shape (record, time) (:func:`rockjax.wall_top_motion`)."""

    def one(a):
        return wall_top_motion(building, GroundMotion(ag=a, dt=dt), height)

    return jax.vmap(one)(ag)


@persistent_jit
def support_histories(building, ag, dt: float, storey: int, restrained: bool, wall_height=None):
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
def run_chunk(
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
    dt_rec,
    dt_bound,
    mesh=None,
):
    """EDPs of one chunk of runs (:func:`chunk_runs`), compiled; ``mesh``: the devices the
    runs are split over (``shard_map``: each device runs its share as a batch of its own, on
    its own core), or None."""
    options = dict(model=model, mode=mode, dt_rec=dt_rec, dt_bound=dt_bound)
    args = (block, ag, ag_v, rec_idx, scale, wall, support)
    if mesh is None:
        return chunk_runs(*args, **options)
    spec, every = jax.sharding.PartitionSpec("run"), jax.sharding.PartitionSpec()
    # (the scan's initial carries are not marked as varying over the devices: unchecked)
    return jax.shard_map(
        functools.partial(chunk_runs, **options),
        mesh=mesh,
        in_specs=(every, every, every, spec, spec, every, every),
        out_specs=spec,
        check_vma=False,
    )(*args)


def chunk_runs(
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
    dt_rec,
    dt_bound,
):
    """EDPs of one chunk of runs: ``ag[rec_idx[k]] * scale[k]`` for each k (batched) with the
    ``model`` object; ``wall``: None, or the return wall's ``(u_top, v_top)`` per record at
    scale 1, scaled likewise; ``support``: None, or an assembly's base acceleration (and top
    restraint's ``(u, v)``) per record at scale 1 (:func:`support_histories`), scaled
    likewise (un-jitted: :func:`run_chunk` compiles it)."""

    def one(i, s):
        motion = GroundMotion(ag=s * ag[i], dt=dt_rec, ag_v=None if ag_v is None else s * ag_v[i])
        kw = {} if wall is None else {"wall_motion": (s * wall[0][i], s * wall[1][i])}
        if isinstance(block, Assembly):
            if support is not None:
                motion = GroundMotion(ag=s * support[0][i], dt=dt_rec, ag_v=motion.ag_v)
                if len(support) == 3:
                    kw["support_motion"] = (s * support[1][i], s * support[2][i])
            r = model.simulate(block, motion, mode=mode, dt=dt_bound, throw=False, **kw)
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
        r = model.simulate(block, motion, mode=mode, dt=dt_bound, throw=False, **kw)
        # the DEM's running maximum over every step; a rigid block's from its peak rotation
        d_max = block.top_displacement(r.theta_max) if model.rigid else r.extras["d_max"]
        ok = r.status == STATUS_OK
        heel = {} if "t_heel" not in r.extras else {"t_heel": r.extras["t_heel"]}
        return {
            "max_d_over_b": jnp.where(ok, d_max / block.b, jnp.nan),
            "max_theta_over_eta": jnp.where(ok, r.theta_max / r.eta, jnp.nan),
            "collapse": r.overturned & ok,
            "status": r.status.astype(jnp.int32),
        } | heel

    if model.rigid or (mode.one_sided and not isinstance(block, Assembly)):
        # on CPU one run after another (much faster): Housner's passes, and a DEM facade's
        # samples in open or closed steps (rockjax.dem.run, n_open), are taken per run
        return batch_runs(one, rec_idx, scale)
    return jax.vmap(one)(rec_idx, scale)
