"""Supports that move: every accepted form of ``wall_motion``, ``support_motion`` and
``storey`` turned into one :class:`SupportHistory` before any simulator sees it.

A wall (a block, or an assembly of blocks) stands on a base, may be held at its top by a
restraint, and a facade leans on return walls. Each of these may move:

- the **base**: the ground (``motion``), or floor ``storey - 1`` of a
  :class:`rockjax.ShearBuilding` (``support_motion=bldg``): its absolute acceleration;
- the **top restraint** (an assembly with ``top="restrained"``): floor ``storey`` of the
  building, or a pair ``(u, v)`` of arrays, relative to the base;
- the **return walls** (``mode="one_sided"``, ``wall_motion=``): a pair ``(u_top, v_top)``
  of arrays, a ``ShearBuilding``, the wall's absolute acceleration as a ``GroundMotion``, or
  ``(height, GroundMotion)`` pairs (:func:`rockjax.wall_top_motion`), taken at the wall's
  height ``H`` relative to the base.

:func:`resolve_supports` turns them into arrays at the run's samples; the DEM (a block and an
assembly), Housner (:func:`wall_history`) and :func:`rockjax.ida` consume only that. A new
kind of support motion is added here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._checks import check_below, check_scalar, check_series_pair, concrete, is_array_pair
from ._types import ScalarLike, TimeSeries
from ._walls import check_wall_rotation
from .assembly import Assembly
from .building import MAX_HEIGHT, MM_FIX, ShearBuilding
from .compilation import bucket_length, is_traced
from .motion import GroundMotion


class SupportHistory(eqx.Module):
    """The supports of a run at its samples.

    Attributes:
        ag: The base's absolute horizontal acceleration [m/s^2] (the ground's, or the base
            floor's in a building).
        top: ``(u, v)``: the top restraint's displacement [m] and velocity [m/s] relative to
            the base, or None (it moves with the base, or there is none).
        wall: ``(u_top, v_top)``: the return walls' displacement [m] and velocity [m/s]
            relative to the base at the wall's height, or None (fixed, or none).
    """

    ag: jax.Array | np.ndarray
    top: tuple | None = None
    wall: tuple | None = None


def resolve_supports(
    assembly: Assembly,
    motion: GroundMotion | None,
    ag,
    dt_out: float,
    *,
    wall_motion=None,
    support_motion=None,
    storey: int | None = None,
) -> SupportHistory:
    """The :class:`SupportHistory` of a wall (an assembly; a block is the assembly of one)
    under ``motion``, whose run samples the ground acceleration ``ag`` [m/s^2] (the record,
    padded or cut to the run's duration) every ``dt_out`` [s].

    Args:
        assembly: The wall.
        motion: The ground motion (None: free motion, a zero record).
        ag: The run's ground acceleration [m/s^2].
        dt_out: The run's sample step [s].
        wall_motion: The return walls' motion (see the module docstring), or None (fixed).
        support_motion: A :class:`rockjax.ShearBuilding` (its floors carry the wall), a pair
            ``(u, v)`` of arrays (the top restraint's motion relative to the base), or None
            (the ground).
        storey: With a building: the storey (1-based) the wall stands in (default 1).

    Raises:
        ValueError: for a combination that does not define the supports' motion, naming the
            argument and the fix.
    """
    storey_ = 1 if storey is None else storey
    # walls that move with the building the facade stands in: solved with its supports
    with_building = check_walls_in_building(wall_motion, support_motion, storey_)
    wall = None
    if wall_motion is not None and not with_building:  # fixed walls: no wall arrays
        n_record = None if motion is None else np.shape(motion.ag)[0]
        wall = wall_arrays(wall_motion, motion, assembly.height, ag, dt_out, n_record)
    wall_height = assembly.height if with_building else None
    ag, top, *walls = in_building(support_motion, storey, assembly, motion, ag, dt_out, wall_height)
    if with_building:
        wall = walls[0]
    return SupportHistory(ag=ag, top=top, wall=wall)


def wall_history(wall_motion, motion: GroundMotion, height, n_record: int):
    """``(u_top, v_top)`` [m, m/s] of a moving wall at the record's ``n_record`` samples,
    from any accepted ``wall_motion`` (a pair of arrays is checked and returned); a
    building's solve, compiled per record length, runs on the record padded to its bucket
    (its last sample repeated; the solve is causal, so the record's own samples are
    unchanged) and is cut on the host: one compilation per bucket."""
    if is_series_pair(wall_motion):
        u, v = wall_motion
    else:
        a_rec = concrete(motion.ag)
        if (
            isinstance(wall_motion, ShearBuilding)
            and a_rec is not None
            and not is_traced(wall_motion)
        ):
            n_rec = a_rec.shape[0]
            n_bucket = bucket_length(n_rec)
            padded = GroundMotion(
                ag=np.pad(a_rec, (0, n_bucket - n_rec), mode="edge"), dt=motion.dt
            )
            u, v = wall_top_motion(wall_motion, padded, height)
            u, v = np.asarray(u)[:n_rec], np.asarray(v)[:n_rec]
        else:
            u, v = wall_top_motion(wall_motion, motion, height)
    check_series_pair(
        "wall_motion",
        ("u_top [m]", "v_top [m/s]"),
        (u, v),
        n_record,
        "Sample the wall at the record's dt.",
    )
    check_wall_rotation(u, height)
    return u, v


def is_series_pair(x) -> bool:
    """Whether ``x`` is a pair of histories (1-D arrays or lists of numbers), as ``(u_top,
    v_top)`` are given, as opposed to a model object or ``(height, GroundMotion)`` pairs."""
    if not (isinstance(x, tuple | list) and len(x) == 2):
        return False
    for w in x:
        if isinstance(w, jax.Array | np.ndarray):
            if w.ndim != 1:
                return False
            continue
        if not isinstance(w, list | tuple):
            return False
        try:
            if np.asarray(w, dtype=float).ndim != 1:
                return False
        except (TypeError, ValueError):
            return False
    return True


def wall_arrays(wall_motion, motion, height, ag, dt_out, n_record):
    """``(u_top, v_top)`` [m, m/s] of a moving wall at the run's samples (those of ``ag``):
    :func:`wall_history` at the record's ``n_record`` samples (None: free motion, ``ag``'s),
    and past the record's end (a longer duration) the wall holds its last position; a
    shorter duration truncates it. NumPy arrays for concrete histories, jnp when traced."""
    n = ag.shape[0]
    n_rec = n if n_record is None else n_record
    gm = motion if motion is not None else GroundMotion.zeros(n * dt_out, dt_out)
    u, v = wall_history(wall_motion, gm, height, n_rec)
    traced = concrete(ag) is None or concrete(u) is None or concrete(v) is None
    xp = jnp if traced else np
    u, v = xp.asarray(u, float), xp.asarray(v, float)
    if n != n_rec:  # a longer duration: the wall holds its last position; shorter: truncated
        pad = max(0, n - n_rec)
        u = xp.pad(u, (0, pad), mode="edge")[:n]
        v = xp.pad(v, (0, pad))[:n]
    return u, v


def in_building(building, storey, assembly: Assembly, motion, ag, dt_out, wall_height=None):
    """The base floor's absolute acceleration [m/s^2] and the top restraint's motion
    relative to it (``(u [m], v [m/s])`` or ``None``), from the building's exact response
    to the (padded) ground acceleration ``ag``; with ``wall_height`` [m] (a building), also
    the return walls' ``(u_top, v_top)`` relative to the base floor at that height
    (:func:`storey_supports`)."""
    if building is None:
        if storey not in (None, 1):
            raise ValueError(
                f"storey={storey!r} needs support_motion=<rockjax.ShearBuilding> (the floors "
                "that carry the wall); leave storey=1 for a wall on the ground."
            )
        return ag, None
    if is_array_pair(building):
        return ag, restraint_arrays(building, storey, assembly, ag)
    if not isinstance(building, ShearBuilding):
        raise ValueError(
            f"support_motion must be a rockjax.ShearBuilding (the floors carrying the wall) or "
            f"a pair (u, v) of arrays, the top restraint's motion relative to the base [m, "
            f"m/s]; got {type(building).__name__}. Build one with rj.ShearBuilding.uniform(...)."
        )
    if motion is None:
        raise ValueError(
            "support_motion needs motion=<rockjax.GroundMotion>, the ground motion under the "
            "building (its floors move only under a record)."
        )
    storey = check_storey(building, 1 if storey is None else storey, assembly.top)
    restrained = assembly.top == "restrained"
    return storey_supports(building, ag, dt_out, storey, restrained, wall_height=wall_height)


def check_walls_in_building(wall_motion, support_motion, storey) -> bool:
    """Whether the return walls move with the building the wall stands in
    (``wall_motion=bldg, support_motion=bldg``: their motion is the storey's drift,
    :func:`storey_supports`); raises ValueError, naming the argument and the fix, for the
    combinations that do not define the walls' motion relative to the base floor. Without
    ``support_motion`` (or ``wall_motion``): False, nothing checked."""
    if wall_motion is None or support_motion is None:
        return False
    if is_array_pair(wall_motion):
        return False  # (u_top, v_top) relative to the base floor, as given
    if not isinstance(wall_motion, ShearBuilding):
        raise ValueError(
            "wall_motion with support_motion (a wall standing in a building) must be the "
            "same rockjax.ShearBuilding as support_motion (the walls move with the storey), or "
            "a pair (u_top, v_top) of arrays relative to the base floor [m, m/s]; got "
            f"{type(wall_motion).__name__}. Accelerations are relative to the ground, not to "
            "the base floor: pass wall_motion=support_motion or the pair."
        )
    if not isinstance(support_motion, ShearBuilding):
        raise ValueError(
            "wall_motion=<ShearBuilding> needs support_motion=<the same ShearBuilding>: with "
            "support_motion=(u, v), motion is the base floor's acceleration and the building "
            "cannot be solved from it. Pass wall_motion=(u_top, v_top), the walls' motion "
            "relative to the base floor at the facade's height [m, m/s]."
        )
    if not _same_building(wall_motion, support_motion):
        raise ValueError(
            "wall_motion and support_motion must be the same rockjax.ShearBuilding (the "
            "return walls move with the storey the facade stands in); got two different "
            "buildings. Pass wall_motion=support_motion, or wall_motion=(u_top, v_top) "
            "relative to the base floor."
        )
    if storey == support_motion.n_storeys + 1:
        raise ValueError(
            f"wall_motion=<ShearBuilding> moves the return walls with the storey the facade "
            f"stands in; on the roof (storey={storey}) no storey is above it. Drop wall_motion "
            "(walls fixed to the roof), or give wall_motion=(u_top, v_top) relative to it."
        )
    return True


def _same_building(a: ShearBuilding, b: ShearBuilding) -> bool:
    if a is b:
        return True
    try:
        return bool(eqx.tree_equal(a, b))
    except (jax.errors.ConcretizationTypeError, jax.errors.TracerBoolConversionError):
        return False  # traced buildings: only the same object is known to be the same


def check_storey(building: ShearBuilding, storey, top: str) -> int:
    """``storey`` checked for a wall with a ``top`` ("free" or "restrained") in ``building``:
    an integer, 1 to ``n_storeys`` for a restrained top (it needs the floor above), up to
    ``n_storeys + 1`` (the roof) for a free one. Raises ValueError with the fix."""
    n = building.n_storeys
    top_max = n if top == "restrained" else n + 1
    if not (isinstance(storey, int) and not isinstance(storey, bool) and 1 <= storey <= top_max):
        raise ValueError(
            f"storey (1-based storey the wall stands in) must be an integer in 1..{top_max} "
            f"for this {n}-storey building and a {top} top; got storey={storey!r}. "
            f"Storey i stands on floor i - 1 (0 the ground); a restrained top needs floor i."
        )
    return storey


def storey_supports(
    building: ShearBuilding, ag, dt, storey: int, restrained: bool, *, wall_height=None
):
    """What a wall in storey ``storey`` of ``building`` stands on and is held by, under the
    ground acceleration ``ag`` [m/s^2] at step ``dt`` [s]: the base floor's absolute
    acceleration [m/s^2] (``ag`` itself for storey 1) and, for a restrained top, the top
    floor's displacement [m] and velocity [m/s] relative to the base floor (else None), from
    the building's exact response (:meth:`rockjax.ShearBuilding.response`).

    With ``wall_height`` [m] (a facade's height ``H``), a third value: the return walls'
    ``(u_top, v_top)`` [m, m/s] relative to the base floor at ``H`` above it. A shear
    building's storey deforms linearly between its floors, so the walls' displacement is the
    floors' interpolated linearly in height, ``(u_i - u_{i-1}) H / h_i`` within storey ``i``
    of height ``h_i`` (above floor ``i``, the next storey's; above the roof, the roof's), and
    their velocity likewise."""
    resp = building.response(GroundMotion(ag=ag, dt=dt))
    base = storey - 1
    ag_base = ag if base == 0 else resp.acceleration[base - 1]
    top = None
    if restrained:
        u, v = resp.displacement[storey - 1], resp.velocity[storey - 1]
        if base > 0:
            u, v = u - resp.displacement[base - 1], v - resp.velocity[base - 1]
        top = (u, v)
    if wall_height is None:
        return ag_base, top
    nodes = jnp.concatenate([jnp.zeros(1), jnp.cumsum(building.storey_heights)])
    z = nodes[base] + jnp.asarray(wall_height, float)
    # the weights of the floors (the ground first) in the piecewise-linear profile at z
    weights = jax.vmap(lambda f: jnp.interp(z, nodes, f))(jnp.eye(nodes.shape[0]))
    weights = weights.at[base].add(-1.0)  # relative to the base floor
    u_w, v_w = weights[1:] @ resp.displacement, weights[1:] @ resp.velocity
    return ag_base, top, (u_w, v_w)


def restraint_arrays(pair, storey, assembly: Assembly, ag):
    """The top restraint's ``(u [m], v [m/s])`` relative to the base, given as arrays at the
    run's samples (``support_motion=(u, v)``), checked."""
    if storey not in (1, None):  # None: rj.simulate_dem's default
        raise ValueError(
            f"storey={storey!r} applies to support_motion=<rockjax.ShearBuilding>; with "
            "support_motion=(u, v) (the restraint's motion relative to the base) the base is "
            "motion itself: leave storey=1."
        )
    if assembly.top != "restrained":
        raise ValueError(
            "support_motion=(u, v) moves the top restraint and needs an Assembly with "
            "top='restrained'; got top='free'. Drop support_motion for a free top (the base "
            "is motion)."
        )
    check_series_pair(
        "support_motion",
        ("u [m]", "v [m/s]"),
        pair,
        ag.shape[0],
        "Sample it at motion's dt over the run's duration (pad the record first).",
    )
    check_wall_rotation(pair[0], assembly.height, "support_motion", ("u", "v"))
    return tuple(jnp.asarray(a, float) for a in pair)


# ----------------------------------------------------------------------------- return walls


def wall_top_motion(
    wall_motion: ShearBuilding | GroundMotion | Sequence[tuple[float, GroundMotion]],
    motion: GroundMotion,
    height: ScalarLike,
) -> tuple[TimeSeries, TimeSeries]:
    """Displacement and velocity of a return wall at ``height`` relative to the base.

    The contract of the moving return walls (docs/building.md): the wall's contact line with
    the facade is straight, ``u_w(y, t) = u_top(t) y / h``, and this function gives ``u_top``
    (and its rate) at the facade height ``h = height``, positive toward +x (toward the
    facade, pushing it outward).

    Args:
        wall_motion: One of
            - a :class:`ShearBuilding`: its floor displacements relative to the ground under
              ``motion``, linear in height between the ground (0) and the floors; above the
              roof, the roof's;
            - a :class:`rockjax.GroundMotion` (same ``dt`` and length as ``motion``): the
              wall's absolute acceleration at ``height`` [m/s^2];
            - a sequence of ``(height_i [m], GroundMotion_i)`` pairs: absolute accelerations at
              those heights; the relative motion is linear in height between 0 at the base
              and those heights, and constant above the highest.
        motion: The ground motion at the facade's base.
        height: Height above the base [m] at which the wall's motion is wanted (the facade
            height).

    Returns:
        ``(u, v)``: displacement [m] and velocity [m/s] relative to the base, shape
        ``(time,)`` of ``motion.ag``, at the samples ``k motion.dt``. Accelerations are
        integrated exactly for their linear interpolant, from rest.

    Raises:
        ValueError: on a negative height, records of another step or length than
            ``motion``, or a ``wall_motion`` of another kind.
    """
    if not isinstance(motion, GroundMotion):
        raise ValueError(f"motion must be a rockjax.GroundMotion; got {type(motion).__name__}.")
    check_scalar("height", height, "m", "Give the facade height, e.g. height=3.0.")
    if (c := concrete(height)) is not None and not (np.isfinite(c) and c >= 0):
        raise ValueError(
            f"height must be a finite height >= 0 in m above the base; got height={height}."
        )
    check_below("height", concrete(height), MAX_HEIGHT, "m", MM_FIX.format("height"))
    motion.check_finite()
    if isinstance(wall_motion, ShearBuilding):
        return _wall_in_building(
            wall_motion,
            jnp.asarray(motion.ag, dtype=jnp.float64),
            motion.dt,
            jnp.asarray(height, dtype=jnp.float64).reshape(()),
        )
    # Concrete records are integrated in NumPy: eager JAX would compile every operation anew
    # for each record length (the simulators call this once per record).
    ag = _values(motion.ag)
    if isinstance(wall_motion, GroundMotion):
        _check_same_axis("wall_motion", wall_motion, motion)
        u, v = _integrate_relative(_values(wall_motion.ag) - ag, motion.dt)
        return jnp.asarray(u), jnp.asarray(v)
    pairs = _check_pairs(wall_motion, motion)
    rel = [_integrate_relative(_values(g.ag) - ag, motion.dt) for _, g in pairs]
    w = _height_weights([zi for zi, _ in pairs], height)
    u = sum(wi * r[0] for wi, r in zip(w, rel, strict=True))
    v = sum(wi * r[1] for wi, r in zip(w, rel, strict=True))
    return jnp.asarray(u), jnp.asarray(v)


@eqx.filter_jit
def _wall_in_building(building: ShearBuilding, ag, dt: float, height):
    """Floor displacements and velocities relative to the ground, interpolated at ``height``."""
    resp = building.response(GroundMotion(ag=ag, dt=dt))
    u, v = resp.displacement, resp.velocity
    nodes = jnp.concatenate([jnp.zeros(1), jnp.cumsum(building.storey_heights)])
    w = jax.vmap(lambda f: jnp.interp(height, nodes, f))(jnp.eye(nodes.shape[0]))[1:]
    return w @ u, w @ v


def _check_same_axis(label: str, record: GroundMotion, motion: GroundMotion) -> None:
    if not math.isclose(record.dt, motion.dt, rel_tol=1e-9) or record.n != motion.n:
        raise ValueError(
            f"{label} must share the ground motion's step and length: got dt={record.dt} s and "
            f"{record.n} samples against dt={motion.dt} s and {motion.n} samples. Resample or "
            "trim the wall record to the ground record's time axis."
        )
    record.check_finite()


def _check_pairs(wall_motion, motion: GroundMotion) -> list:
    fix = (
        "wall_motion must be a rockjax.ShearBuilding, a rockjax.GroundMotion (the wall's "
        "absolute acceleration) or a sequence of (height [m], GroundMotion) pairs, e.g. "
        "[(3.0, floor1), (6.0, floor2)]"
    )
    if isinstance(wall_motion, str | bytes) or not isinstance(wall_motion, Sequence):
        raise ValueError(f"{fix}; got {type(wall_motion).__name__}.")
    pairs = list(wall_motion)
    if not pairs or not all(
        isinstance(p, Sequence) and len(p) == 2 and isinstance(p[1], GroundMotion) for p in pairs
    ):
        raise ValueError(f"{fix}; got {wall_motion!r:.200}.")
    heights = []
    for i, (zi, record) in enumerate(pairs):
        check_scalar(f"wall_motion[{i}] height", zi, "m", "e.g. (3.0, floor1).")
        _check_same_axis(f"wall_motion[{i}]", record, motion)
        heights.append(concrete(zi))
        check_below(
            f"wall_motion[{i}] height", heights[-1], MAX_HEIGHT, "m", MM_FIX.format("height")
        )
    if all(z is not None for z in heights):
        z = np.array([float(v) for v in heights])
        if not np.all(np.isfinite(z)) or np.any(z <= 0) or np.any(np.diff(z) <= 0):
            raise ValueError(
                f"the heights of wall_motion must be positive and increasing, in m above the "
                f"base; got {z.tolist()}. Sort the (height, GroundMotion) pairs from the "
                "lowest up; the base itself (height 0) moves with the ground and is implied."
            )
    return pairs


def _xp(*arrays):
    """NumPy when every array is concrete NumPy, else jax.numpy."""
    return np if all(isinstance(a, np.ndarray) for a in arrays) else jnp


def _values(x):
    """A concrete series as a float64 NumPy array; a traced one as a float64 JAX array."""
    c = concrete(x)
    return jnp.asarray(x, dtype=jnp.float64) if c is None else c


def _height_weights(z, height) -> list:
    """Weights ``w_i`` with ``sum_i w_i f_i = f(height)`` for ``f`` linear between 0 at the
    base and the values ``f_i`` at the increasing heights ``z_i`` [m], and ``f`` at the
    highest above it. Python floats for concrete heights, JAX scalars for traced ones."""
    zc = [concrete(zi) for zi in z]
    hc = concrete(height)
    if hc is not None and all(zi is not None for zi in zc):
        nodes = np.concatenate([[0.0], [float(zi) for zi in zc]])
        return [float(np.interp(float(hc), nodes, row)) for row in np.eye(nodes.size)[1:]]
    nodes = jnp.concatenate(
        [jnp.zeros(1), jnp.stack([jnp.asarray(zi, dtype=jnp.float64).reshape(()) for zi in z])]
    )
    h = jnp.asarray(height, dtype=jnp.float64).reshape(())
    return list(jax.vmap(lambda f: jnp.interp(h, nodes, f))(jnp.eye(nodes.shape[0]))[1:])


def _integrate_relative(a, dt: float):
    """Displacement and velocity from rest of the acceleration ``a`` [m/s^2], linear between
    its samples: ``v_{k+1} = v_k + dt (a_k + a_{k+1}) / 2``,
    ``u_{k+1} = u_k + dt v_k + dt^2 (2 a_k + a_{k+1}) / 6`` (exact for that interpolant)."""
    xp = _xp(a)
    dv = 0.5 * dt * (a[:-1] + a[1:])
    v = xp.concatenate([xp.zeros(1), xp.cumsum(dv)])
    du = dt * v[:-1] + dt * dt * (2.0 * a[:-1] + a[1:]) / 6.0
    u = xp.concatenate([xp.zeros(1), xp.cumsum(du)])
    return u, v
