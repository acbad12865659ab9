"""What a DEM run returns: :class:`AssemblyResponse` (per-block series) and, for a single
block, the :class:`rockjax.Response` every model returns."""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax
import numpy as np
from jaxtyping import Array, Bool, Float, Int

from .._checks import concrete
from ..compilation import cut_to
from ..response import STATUS_MESSAGES, Response, one_run_times


class AssemblyResponse(eqx.Module):
    """A simulated history of an assembly, sampled at ``t``; the last axis of the per-block
    series is the block (bottom to top; from -x to +x in a row).

    Attributes:
        t: Sample times [s].
        theta: Rotation of each block [rad] (positive clockwise: the top toward +x).
        theta_dot: Angular velocity of each block [rad/s].
        x: Horizontal displacement of each centroid from its rest position [m].
        y: Height of each centroid above the ground surface [m].
        d: Horizontal displacement of each block's top face centre from its rest position
            [m], ``x + (h/2) sin(theta)``.
        overturned: True once the assembly collapsed (a block or a sub-stack past its unstable
            point, or a block off its support); the state is frozen from then on.
        status: 0 if the run is valid, else a code in ``rockjax.response.STATUS_MESSAGES``.
        theta_max: Largest ``|theta|`` of each block over the run, between samples too [rad].
        eta: Slenderness ``atan(b/h)`` of each block [rad].
        d_max: Largest ``|d|`` of each block over the run, between samples too [m].
        energy: Total mechanical energy [J] (kinetic + gravity + overburden + contact springs),
            or None when not requested.
        dt: The time step used [s] (a one-block facade's: while its return wall is in reach).
        work_wall: With a moving return wall (``wall_motion``) and ``save=("energy",)``: the
            work done on the blocks by the wall since ``t = 0`` [J], so that
            ``energy - work_wall`` is conserved without damping, slip or ground motion;
            zeros for a fixed wall; else None.
        normal_forces: With ``save=("forces",)``: the normal force of each interface [N]
            (``time x interface``; in a stack interface 0 the ground joint, ``k`` the bed
            joint between blocks ``k - 1`` and ``k``; in a row the order of
            :attr:`rockjax.Assembly.interfaces`), the resultant over the face of springs and
            dashpots, positive in compression, along the lower body's normal (the ground's:
            vertical); else None.
        shear_forces: With ``"forces"``: the shear force of each interface [N] (springs and
            dashpots), along the lower body's tangent (the ground's: +x), on the upper block;
            else None.
        restraint_force: With ``"forces"`` and a restrained top: the top restraint's
            horizontal force on the top block [N] (positive toward +x); else None.
        wall_forces: With ``"forces"`` on return walls (``mode="one_sided"``): the normal
            force of each block's back face on its wall [N] (``time x block``, positive in
            compression; a moving wall's horizontal component); else None.
        dt_open: A one-block facade's step while its return wall is out of reach [s]
            (:func:`rockjax.dem.run`, ``n_open``; docs/theory.md, "Time stepping"); None where
            every step is ``dt``.

    The forces are those of the step taken at each sample (the state at the sample, the
    dashpots at the lagged half-step velocity, as ``extras["normal_forces"]`` of
    a single block's :class:`rockjax.Response`); the centred dashpots that move the blocks differ from
    them by ``dt/2`` times the dashpot matrix times the accelerations (nothing at rest or at
    ``beta = 0``).
    """

    t: Float[Array, " time"]
    theta: Float[Array, "time block"]
    theta_dot: Float[Array, "time block"]
    x: Float[Array, "time block"]
    y: Float[Array, "time block"]
    d: Float[Array, "time block"]
    overturned: Bool[Array, ""]
    status: Int[Array, ""]
    theta_max: Float[Array, " block"]
    eta: Float[Array, " block"]
    d_max: Float[Array, " block"]
    energy: Float[Array, " time"] | None
    dt: Float[Array, ""]
    work_wall: Float[Array, " time"] | None = None
    normal_forces: Float[Array, "time interface"] | None = None
    shear_forces: Float[Array, "time interface"] | None = None
    restraint_force: Float[Array, " time"] | None = None
    wall_forces: Float[Array, "time block"] | None = None
    dt_open: Float[Array, ""] | None = None

    def to_dataframe(self):
        """The history as a ``pandas.DataFrame``, one row per sample (one run only).

        The index is ``"t [s]"``; per block ``k`` (0 the bottom one; in a row, the -x end)
        the columns ``"theta_<k> [rad]"``, ``"theta_dot_<k> [rad/s]"``, ``"x_<k> [m]"``,
        ``"y_<k> [m]"``, ``"d_<k> [m]"`` and ``"theta_<k>/eta_<k> [-]"``; then, where saved,
        ``"energy [J]"``, ``"work_wall [J]"``, per interface ``i`` ``"normal_force_<i> [N]"``
        and ``"shear_force_<i> [N]"``, ``"restraint_force [N]"`` and per block
        ``"wall_force_<k> [N]"``. ``df.attrs`` holds the run's scalars: ``overturned``,
        ``status``, ``status_message``, ``dt [s]``, ``n_blocks`` and, per block,
        ``theta_max_<k> [rad]``, ``eta_<k> [rad]`` and ``d_max_<k> [m]``. Write it with
        ``df.to_csv(path)``.

        Returns:
            The ``pandas.DataFrame``.

        Raises:
            ValueError: for a batch of runs (from ``vmap``; index one run first,
                e.g. ``jax.tree.map(lambda x: x[i], resp)``) or inside ``jit``.
        """
        import pandas as pd

        t = one_run_times(self)
        theta, eta = concrete(self.theta), concrete(self.eta)
        n = theta.shape[-1]
        per_block = {
            "theta_{k} [rad]": theta,
            "theta_dot_{k} [rad/s]": self.theta_dot,
            "x_{k} [m]": self.x,
            "y_{k} [m]": self.y,
            "d_{k} [m]": self.d,
            "theta_{k}/eta_{k} [-]": theta / eta,
        }
        columns = {
            name.format(k=k): concrete(v)[:, k] for name, v in per_block.items() for k in range(n)
        }
        for name, value in (("energy [J]", self.energy), ("work_wall [J]", self.work_wall)):
            if value is not None:
                columns[name] = concrete(value)
        for name, value in (
            ("normal_force_{k} [N]", self.normal_forces),
            ("shear_force_{k} [N]", self.shear_forces),
            ("wall_force_{k} [N]", self.wall_forces),
        ):
            if value is not None:
                v = concrete(value)
                columns |= {name.format(k=k): v[:, k] for k in range(v.shape[-1])}
        if self.restraint_force is not None:
            columns["restraint_force [N]"] = concrete(self.restraint_force)
        df = pd.DataFrame(columns, index=pd.Index(t, name="t [s]"))
        status = int(np.asarray(self.status))
        df.attrs.update(
            overturned=bool(np.asarray(self.overturned)),
            status=status,
            status_message=STATUS_MESSAGES.get(status, "unknown status"),
            n_blocks=n,
            **{"dt [s]": float(concrete(self.dt))},
        )
        for name, value in (
            ("theta_max_{k} [rad]", self.theta_max),
            ("eta_{k} [rad]", self.eta),
            ("d_max_{k} [m]", self.d_max),
        ):
            v = concrete(value)
            df.attrs |= {name.format(k=k): float(v[k]) for k in range(n)}
        return df


# ----------------------------------------------------------------------------- parameters


def block_response(r: AssemblyResponse, b) -> Response:
    """The :class:`rockjax.Response` of a single block (``b`` its width [m]) from the run of
    the assembly of one it is: the same arrays, block axis dropped; ``extras`` holds ``x``,
    ``y`` (centroid [m]), ``d_max`` [m], ``dt`` [s], a facade's ``dt_open`` [s] and, as
    requested, ``normal_forces``, ``shear_forces`` (the base joint's, [N]), ``wall_forces``
    and ``work_wall``."""

    def block(x):
        # the block axis dropped; on the host for a concrete run (an eager slice of a device
        # array would compile once per record length)
        if isinstance(x, jax.core.Tracer):
            return x[..., 0]
        return jax.device_put(np.asarray(x)[..., 0])

    extras = {"x": block(r.x), "y": block(r.y), "d_max": block(r.d_max), "dt": r.dt}
    for key in ("normal_forces", "shear_forces", "wall_forces"):
        value = getattr(r, key)
        if value is not None:
            extras[key] = block(value)
    if r.work_wall is not None:
        extras["work_wall"] = r.work_wall
    if r.dt_open is not None:
        extras["dt_open"] = r.dt_open
    return Response(
        t=r.t,
        theta=block(r.theta),
        theta_dot=block(r.theta_dot),
        d=block(r.d),
        overturned=r.overturned,
        status=r.status,
        theta_max=block(r.theta_max),
        eta=block(r.eta),
        b=b,
        energy=r.energy,
        extras=extras,
    )


def cut(r: AssemblyResponse, n: int) -> AssemblyResponse:
    """A padded run's series cut to the true ``n`` samples, on the host (an eager slice of a
    device array would compile once per length)."""
    if r.t.shape[0] == n:
        return r

    names = ("t", "theta", "theta_dot", "x", "y", "d", "energy", "work_wall")
    names += ("normal_forces", "shear_forces", "restraint_force", "wall_forces")
    return dataclasses.replace(r, **cut_to({k: getattr(r, k) for k in names}, n))


def cut_block(r: Response, n: int) -> Response:
    """:func:`cut` of a single block's :class:`rockjax.Response`."""
    if r.t.shape[0] == n:
        return r

    keys = ("x", "y", "normal_forces", "shear_forces", "wall_forces", "work_wall")
    names = ("t", "theta", "theta_dot", "d", "energy")
    series = {k: getattr(r, k) for k in names}
    extras = {k: r.extras[k] for k in keys if k in r.extras}
    series, extras = cut_to((series, extras), n)
    return dataclasses.replace(r, extras={**r.extras, **extras}, **series)
