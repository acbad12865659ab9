"""The penalty sub-contact law: linear normal and shear springs, Mohr-Coulomb with zero tension
and zero cohesion, and stiffness-proportional (Rayleigh beta) dashpots.

Per sub-contact of tributary area ``A`` the springs are ``k_n = j_kn A`` and ``k_s = j_ks A``
(``j_kn = E/h``, ``j_ks = j_kn / (2 (1 + nu))``), and the dashpots ``c_n = beta k_n``,
``c_s = beta k_s`` (stiffness-proportional Rayleigh damping, Eq. 1 with alpha = 0).

Damping conventions (``dashpot=``):

* ``"closed"`` (default): the dashpot acts on every closed (penetrated) sub-contact, even where
  the total normal force ``k_n delta + c_n delta_dot`` turns tensile while the corner separates.
  This pulling dashpot is where most of the energy of a rocking impact is lost, and it gives
  the paper's linear, steep ``e(beta)`` trend.
* ``"clipped"``: the total normal force is clipped at zero (no tension at all). Then the
  dashpot only pushes, the loss per impact saturates (``e`` near 0.965 for the 0.25 x 3 m
  block) and low targets of ``e`` cannot be reached at any ``beta``.
"""

import jax.numpy as jnp

DASHPOTS = ("closed", "clipped")


def normal_force(delta, delta_dot, k_n, beta, dashpot: str):
    """Normal force on the block [N] at sub-contacts with penetration ``delta`` [m] (> 0 closed).

    Args:
        delta: Penetration [m]; the contact is closed where ``delta > 0``.
        delta_dot: Penetration rate [m/s].
        k_n: Normal spring stiffness [N/m].
        beta: Stiffness-proportional damping coefficient [s], Eq. (1).
        dashpot: ``"closed"`` or ``"clipped"`` (see the module docstring).

    Returns:
        ``(f_total, f_elastic)`` [N]; zero where the contact is open.
    """
    closed = delta > 0
    f_el = jnp.where(closed, k_n * delta, 0.0)
    f = f_el + jnp.where(closed, beta * k_n * delta_dot, 0.0)
    if dashpot == "clipped":
        f = jnp.maximum(f, 0.0)
    return f, f_el


def shear_force(fs_old, slip_rate, dt, k_s, f_el, tan_phi, beta):
    """Incremental elastic-plastic shear force [N] (Mohr-Coulomb, no cohesion, no tension).

    The elastic trial force ``fs_old - k_s * slip_rate * dt`` is capped at ``tan(phi) * f_el``
    (the elastic normal force; zero on an open contact, which also resets the spring).

    Args:
        fs_old: Shear spring force at the previous step [N].
        slip_rate: Tangential velocity of the block's point relative to the support [m/s].
        dt: Time step [s].
        k_s: Shear spring stiffness [N/m].
        f_el: Elastic normal force [N] (>= 0).
        tan_phi: Friction coefficient ``tan(phi)`` [-].
        beta: Stiffness-proportional damping coefficient [s].

    Returns:
        ``(f_total, fs_new)``: the shear force on the block including its dashpot, and the new
        spring force to carry to the next step [N].
    """
    limit = tan_phi * f_el
    fs_new = jnp.clip(fs_old - k_s * slip_rate * dt, -limit, limit)
    f = fs_new - jnp.where(f_el > 0, beta * k_s * slip_rate, 0.0)
    return f, fs_new
