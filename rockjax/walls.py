"""Moving return walls: the one home of their geometry and of their histories.

A facade's return wall moves with the building it belongs to. It is modelled as a rigid body
that turns, relative to the base, to ``theta_w = u_top / H`` (``u_top`` the wall's
displacement at the facade's height ``H``, toward the facade), about the facade's toe (the
front corner of its base) for ``theta_w > 0`` and about its heel for ``theta_w < 0``: the
position of a facade that rocks with its wall, so that a facade riding on the wall at
``theta = theta_w`` lies flush on it (docs/pushover.md, "Moving return walls"). A face of the
wall that stands at ``x = x_face`` at rest then lies on the line ``x = x0 + slope y`` with
``slope = tan(theta_w)`` and ``x0 = x_face - d (1 / cos(theta_w) - 1)``, ``d`` the distance
from the face to the pivot at rest; its material rises at ``theta_w' (x_pivot - x)``.

Used by :func:`rockjax.simulate_dem` (a block's back face) and
:func:`rockjax.simulate_assembly` (the back faces of a stack, one rigid wall about block 0's
toe).
"""

import jax.numpy as jnp
import numpy as np

from ._checks import check_series_pair, concrete, is_array_pair
from .compilation import is_traced
from .motion import GroundMotion

MAX_WALL_ROTATION = 0.3
"""Largest wall rotation ``|u_top| / H`` accepted [rad]: :func:`wall_line` is accurate to 1e-7
only up to 0.3 rad, and no standing building drifts more than a few percent; above it the
displacements are taken for millimetres typed for metres (5 for 5 mm at 3 m is 1.7 rad)."""


def wall_pivot(theta_w, toe, heel):
    """What belongs to the wall's pivot: ``toe`` for ``theta_w > 0`` [rad], ``heel`` otherwise
    (a position [m], or a face's distance from the pivot [m])."""
    return jnp.where(theta_w > 0.0, toe, heel)


def wall_line(x_face, d, theta_w, rate):
    """The contact line ``x = x0 + slope y`` of a wall face turned rigidly by ``theta_w``, and
    its rates: ``(x0, slope, x0', slope')`` [m, -, m/s, 1/s].

    .. math:: x_0 = x_f - d\\,(\\sec\\theta_w - 1), \\quad \\mathrm{slope} = \\tan\\theta_w

    (``x_f - d theta_w^2 / 2 + theta_w y`` to second order).

    Args:
        x_face: The face's position at rest, a vertical line ``x = x_face`` [m].
        d: The pivot's distance in front of the face at rest, ``x_pivot - x_face`` [m], on
            the base ``y = 0`` (:func:`wall_pivot`).
        theta_w: The wall's rotation [rad], ``u_top / H``; positive turns its top toward +x.
        rate: Its rate ``theta_w'`` [rad/s], ``v_top / H``.

    ``tan`` and ``sec - 1`` are evaluated by their Taylor series with their exact derivatives
    (so the rates are the derivatives of the line used and an energy balance closes; no
    transcendental function in a time-stepping loop): truncation below 1e-7 of either for
    ``|theta_w| <= 0.3`` rad, exactly 0 at ``theta_w = 0``.
    """
    s2 = theta_w * theta_w
    slope = theta_w * (1.0 + s2 * (1 / 3 + s2 * (2 / 15 + s2 * (17 / 315 + s2 * 62 / 2835))))
    slope_d = 1.0 + s2 * (1.0 + s2 * (2 / 3 + s2 * (17 / 45 + s2 * 62 / 315)))
    sec_m1 = s2 * (1 / 2 + s2 * (5 / 24 + s2 * (61 / 720 + s2 * 277 / 8064)))
    sec_m1_d = theta_w * (1.0 + s2 * (5 / 6 + s2 * (61 / 120 + s2 * 277 / 1008)))
    return x_face - d * sec_m1, slope, -d * sec_m1_d * rate, slope_d * rate


def wall_rise(x_pivot, rate, x):
    """Vertical velocity [m/s] of the wall's material at ``x`` [m]: it turns rigidly at
    ``rate`` [rad/s] about ``(x_pivot, 0)`` (:func:`wall_pivot`), so it rises at
    ``rate (x_pivot - x)``. A facade riding on the wall turns about the same corner at the same
    rate: no slip along the wall."""
    return rate * (x_pivot - x)


def check_wall_rotation(u_top, height, arg: str = "wall_motion", names=("u_top", "v_top")):
    """Refuse a concrete displacement history ``u_top`` [m] of a wall (or of a top restraint)
    relative to the base whose rotation ``|u_top| / height`` exceeds
    :data:`MAX_WALL_ROTATION` (a unit slip: millimetres for metres).

    Args:
        u_top: The displacement history [m].
        height: The height it is taken at [m].
        arg: The argument it came in, for the message.
        names: The names of the displacement and velocity series, for the message.
    """
    u, h = concrete(u_top), concrete(height)
    if u is None or h is None or u.size == 0:
        return
    peak = float(np.max(np.abs(u)))
    rot = peak / float(h)
    if rot > MAX_WALL_ROTATION:
        raise ValueError(
            f"{arg}: {names[0]} [m] reaches {peak:.4g} m at the height {float(h):.4g} m, a "
            f"rotation |{names[0]}| / H = {rot:.3g} rad above {MAX_WALL_ROTATION:g} rad (the "
            "moving wall's model holds below it; buildings drift a few percent). rockjax works "
            f"in metres: did you give millimetres? Divide {names[0]} and {names[1]} by 1000."
        )


def wall_arrays(wall_motion, motion, height, ag, dt_out, n_record):
    """``(u_top, v_top)`` [m, m/s] of a moving wall at the run's samples.

    Args:
        wall_motion: A pair ``(u_top, v_top)`` of arrays with one value per record sample, or
            what :func:`rockjax.wall_top_motion` accepts (a ``ShearBuilding``, the wall's
            absolute acceleration as a ``GroundMotion``, ``(height, GroundMotion)`` pairs).
        motion: The ground motion (None: free motion, a zero record).
        height: The height at which ``u_top`` is taken [m] (the facade's height).
        ag: The run's ground acceleration [m/s^2] (its samples: the record, padded or cut to
            the run's duration).
        dt_out: The run's sample step [s].
        n_record: The record's number of samples (None: free motion, ``ag``'s).

    Past the record's end (a longer duration) the wall holds its last position; a shorter
    duration truncates it. NumPy arrays for concrete histories, jnp when traced.

    Raises:
        ValueError: a history without one finite value per record sample.
    """
    n = ag.shape[0]
    xp = np if concrete(ag) is not None else jnp
    n_rec = n if n_record is None else n_record
    if is_array_pair(wall_motion):
        u, v = wall_motion
    else:
        # lazily: building imports dem, which imports this module
        from .building import ShearBuilding, wall_top_motion
        from .dem import padded_length

        gm = motion if motion is not None else GroundMotion.zeros(n * dt_out, dt_out)
        a_rec = concrete(gm.ag)
        if (
            isinstance(wall_motion, ShearBuilding)
            and a_rec is not None
            and not is_traced(wall_motion)
        ):
            # the building's solve, compiled per record length, runs on the record padded to
            # its bucket (its last sample repeated; the solve is causal, so the first n_rec
            # samples are the same), then cut on the host: one compilation per bucket
            n_bucket = padded_length(n_rec)
            gm = GroundMotion(ag=np.pad(a_rec, (0, n_bucket - n_rec), mode="edge"), dt=gm.dt)
            u, v = wall_top_motion(wall_motion, gm, height)
            u, v = np.asarray(u)[:n_rec], np.asarray(v)[:n_rec]
        else:
            u, v = wall_top_motion(wall_motion, gm, height)
    check_series_pair(
        "wall_motion",
        ("u_top [m]", "v_top [m/s]"),
        (u, v),
        n_rec,
        "Sample the wall at the record's dt.",
    )
    check_wall_rotation(u, height)
    xp = np if concrete(u) is not None and concrete(v) is not None and xp is np else jnp
    u, v = xp.asarray(u, float), xp.asarray(v, float)
    if n != n_rec:  # a longer duration: the wall holds its last position; shorter: truncated
        pad = max(0, n - n_rec)
        u = xp.pad(u, (0, pad), mode="edge")[:n]
        v = xp.pad(v, (0, pad))[:n]
    return u, v
