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

from ._checks import concrete

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
