"""The penalty sub-contact law: linear normal and shear springs, Mohr-Coulomb with zero tension
and zero cohesion, and stiffness-proportional (Rayleigh beta) dashpots.

Per sub-contact of tributary area ``A`` the springs are ``k_n = j_kn A`` and ``k_s = j_ks A``
(``j_kn = E/h``, ``j_ks = j_kn / (2 (1 + nu))``), and the dashpots ``c_n = beta k_n``,
``c_s = beta k_s`` (stiffness-proportional Rayleigh damping, Eq. 1 with alpha = 0). The shear
dashpot acts only while the contact sticks: a sliding contact's tangent shear stiffness is
zero, and it carries the Coulomb force ``tan(phi) N`` alone (:func:`coulomb`).

Damping conventions (``dashpot=``):

* ``"closed"`` (default): the dashpot acts on every closed (penetrated) sub-contact, even where
  the total normal force ``k_n delta + c_n delta_dot`` turns tensile while the corner separates.
  This pulling dashpot is where most of the energy of a rocking impact is lost, and it gives
  the paper's linear, steep ``e(beta)`` trend.
* ``"clipped"``: the total normal force is clipped at zero (no tension at all). Then the
  dashpot only pushes, the loss per impact saturates (``e`` near 0.965 for the 0.25 x 3 m
  block) and low targets of ``e`` cannot be reached at any ``beta``.

Contact onset (``onset=``):

* ``"sub_step"`` (default): the force of a step is the average of the contact law over the
  step window ``[t - dt/2, t + dt/2]`` with the penetration moving linearly at its current rate,
  so a contact that closes or opens inside the window contributes only for the part of the
  window it is closed (a time-of-impact correction). With ``a = |delta_dot| dt / 2``: fully
  closed for ``delta >= a``, open for ``delta <= -a``, and in between the closed fraction is
  ``f = (delta + a) / (2 a)`` and the mean penetration ``(delta + a)^2 / (4 a)``. The forces are
  then continuous in the state, so a response is continuous (and almost everywhere
  differentiable) in ``beta``, which calibration by gradient needs. A block at rest
  (``delta_dot = 0``) sees the plain law. The band shrinks with ``dt``: both conventions share
  the ``dt -> 0`` limit.
* ``"step"``: the plain law at the step's position, as in UDEC/3DEC: a dashpot switches on
  with its full force at the first penetrated step, so the energy lost per impact jumps as
  impact times cross step boundaries (``e(beta)`` is rough at the ~1e-4 level).

The integrated face law of :mod:`rockjax.dem` (``Joint(n_sub="exact")``, the default)
integrates :func:`normal_force` over each face, with ``k_n`` the stiffness per unit length of
face. :class:`Joint` collects these choices for :func:`rockjax.simulate_dem` and the fits.
"""

import equinox as eqx
import jax.numpy as jnp

DASHPOTS = ("closed", "clipped")
ONSETS = ("sub_step", "step")
SHEAR_RELEASES = ("uniform", "pressure", "none")
"""What the integrated face law's resultant shear spring keeps when the closed part of a face
moves (the points that open release their shear, as each sub-contact's spring does):
``"uniform"`` (default) assumes a uniform stress over the closed part and keeps the share of
the closed length that stays closed; ``"pressure"`` assumes the stress shaped like the previous
step's penetration (its Mohr-Coulomb cap, which vanishes at the contact line); ``"none"`` keeps
the spring whole. docs/verification.md ("Integrated face contact") compares them with 64
sub-contacts: ``"uniform"`` is the closest with damping (first-impact ``e`` within 5e-5)."""
FACE = "exact"
"""``Joint(n_sub=FACE)``: the contact law integrated over each face, the ``n_sub -> infinity``
limit of the sub-contacts (docs/theory.md, "Integrated face contact")."""


class Joint(eqx.Module):
    """How a face of the block meets its support in the DEM: the joint's discretisation and
    its damping and onset conventions (the block's ``E``, ``nu`` give its stiffness).

    ``Joint()`` is the converged joint: the law integrated over each face. ``Joint(n_sub=2)``
    is the paper's model (two corner sub-contacts, as DeJong's), a coarser discretisation of
    the same joint: its first-impact restitution of the 0.2 x 1.5 m parapet is 0.016 lower and
    a facade's first rebound about half (docs/verification.md, "Integrated face contact").

    Attributes:
        n_sub: ``"exact"`` (default: the law integrated in closed form over each face, the
            ``n_sub -> infinity`` limit) or an integer >= 2 of sub-contact points per face
            (trapezoidal tributary areas; 2 puts them at the corners).
        dashpot: ``"closed"`` (default) or ``"clipped"`` (see :mod:`rockjax.contact`).
        onset: ``"sub_step"`` (default) or ``"step"`` (see :mod:`rockjax.contact`).
        shear_release: The integrated face law's shear history rule, :data:`SHEAR_RELEASES`
            (default ``"uniform"``; the others are kept for the comparison of
            docs/verification.md).
    """

    n_sub: int | str = eqx.field(static=True, default=FACE)
    dashpot: str = eqx.field(static=True, default="closed")
    onset: str = eqx.field(static=True, default="sub_step")
    shear_release: str = eqx.field(static=True, default="uniform")

    def __check_init__(self):
        n = self.n_sub
        if n != FACE and (isinstance(n, bool) or not isinstance(n, int) or n < 2):
            raise ValueError(
                f"n_sub (sub-contacts per face) must be an integer >= 2 or {FACE!r} (the "
                f"integrated face law, the n_sub -> infinity limit); got n_sub={n!r}."
            )
        for name, value, choices in (
            ("dashpot", self.dashpot, DASHPOTS),
            ("onset", self.onset, ONSETS),
            ("shear_release", self.shear_release, SHEAR_RELEASES),
        ):
            if value not in choices:
                raise ValueError(
                    f"{name} must be one of {list(choices)}; got {name}={value!r} "
                    f"(rj.Joint({name}=...))."
                )

    @property
    def face(self) -> bool:
        """Whether this is the integrated face law."""
        return self.n_sub == FACE


def normal_force(delta, delta_dot, k_n, beta, dashpot: str, dt=None):
    """Normal force on the block [N] at sub-contacts with penetration ``delta`` [m] (> 0 closed).

    Args:
        delta: Penetration [m]; the contact is closed where ``delta > 0``.
        delta_dot: Penetration rate [m/s].
        k_n: Normal spring stiffness [N/m].
        beta: Stiffness-proportional damping coefficient [s], Eq. (1).
        dashpot: ``"closed"`` or ``"clipped"`` (see the module docstring).
        dt: Time step [s] for the ``"sub_step"`` onset (window average); ``None`` for ``"step"``.

    Returns:
        ``(f_total, f_elastic, closed_fraction)`` [N, N, -]; zero where the contact is open.
    """
    if dt is None:
        closed = delta > 0
        frac = jnp.where(closed, 1.0, 0.0)
        pen = jnp.where(closed, delta, 0.0)
    else:
        a = 0.5 * jnp.abs(delta_dot) * dt
        band = jnp.abs(delta) < a
        a_safe = jnp.where(band, a, 1.0)
        frac = jnp.where(band, (delta + a) / (2.0 * a_safe), jnp.where(delta > 0, 1.0, 0.0))
        pen = jnp.where(band, (delta + a) ** 2 / (4.0 * a_safe), jnp.maximum(delta, 0.0))
    f_el = k_n * pen
    f = f_el + frac * beta * k_n * delta_dot
    if dashpot == "clipped":
        f = jnp.maximum(f, 0.0)
    return f, f_el, frac


def coulomb(trial, limit):
    """The Mohr-Coulomb cap of a shear spring and whether the joint sticks.

    The joint's shear dashpot ``beta k_s`` is stiffness-proportional damping on the joint's
    incremental (tangent) shear stiffness: ``k_s`` while the spring is elastic, zero while the
    joint slides at its cap. So the dashpot acts only where the joint sticks, and the total
    shear force of a sliding joint is the Coulomb force ``tan(phi) N`` (docs/theory.md,
    "Friction on the whole joint").

    Args:
        trial: Elastic trial force of the shear spring [N].
        limit: Its Mohr-Coulomb cap ``tan(phi) N`` [N] (>= 0).

    Returns:
        ``(f_s, stick)``: the spring force clipped to ``[-limit, limit]`` [N], and 1.0 where
        the trial is within the cap (the joint sticks and its shear dashpot acts), 0.0 where
        it exceeds it (the joint slides) [-].
    """
    f_s = jnp.clip(trial, -limit, limit)
    return f_s, jnp.where(jnp.abs(trial) <= limit, 1.0, 0.0)


def shear_force(fs_old, slip_rate, dt, k_s, f_el, tan_phi, beta, frac=None):
    """Incremental elastic-plastic shear force [N] (Mohr-Coulomb, no cohesion, no tension).

    The elastic trial force ``fs_old - k_s * slip_rate * dt`` is capped at ``tan(phi) * f_el``
    (the elastic normal force; zero on an open contact, which also resets the spring). The
    dashpot ``beta k_s`` acts only while the contact sticks (:func:`coulomb`): a sliding
    contact carries the Coulomb force alone.

    Args:
        fs_old: Shear spring force at the previous step [N].
        slip_rate: Tangential velocity of the block's point relative to the support [m/s].
        dt: Time step [s].
        k_s: Shear spring stiffness [N/m].
        f_el: Elastic normal force [N] (>= 0).
        tan_phi: Friction coefficient ``tan(phi)`` [-].
        beta: Stiffness-proportional damping coefficient [s].
        frac: Closed fraction of the step from :func:`normal_force` (weights the dashpot);
            default 1 where ``f_el > 0``.

    Returns:
        ``(f_total, fs_new, weight)``: the shear force on the block including its dashpot and
        the new spring force to carry to the next step [N], and the weight of the shear
        dashpot ``frac * stick`` [-] (its dashpot is ``weight * beta * k_s``).
    """
    fs_new, stick = coulomb(fs_old - k_s * slip_rate * dt, tan_phi * f_el)
    if frac is None:
        frac = jnp.where(f_el > 0, 1.0, 0.0)
    weight = frac * stick
    f = fs_new - weight * beta * k_s * slip_rate
    return f, fs_new, weight


# ------------------------------------------------------- the face law's closed part (geometry)
# The integrated face law (docs/theory.md, "Integrated face contact") works on a penetration
# that is affine along a face; these helpers find where it is closed and cut the face there.
# Every face of rockjax.dem (a block's base, a bed or head joint, a return wall) uses them.


def crossing(lo, hi, d_lo, d_hi):
    """Where the affine field with end values ``d_lo``, ``d_hi`` crosses zero on [lo, hi]
    (``lo`` when it does not)."""
    cross = d_lo * d_hi < 0.0
    den = jnp.where(cross, d_lo - d_hi, 1.0)
    return lo + (hi - lo) * jnp.where(cross, d_lo / den, 0.0)


def closed_interval(lo, hi, d_lo, d_hi):
    """The interval of [lo, hi] where the affine field is > 0 (empty: ``ca == cb``)."""
    z = crossing(lo, hi, d_lo, d_hi)
    ca = jnp.where(d_lo > 0.0, lo, z)
    cb = jnp.where(d_hi > 0.0, hi, z)
    return ca, jnp.maximum(cb, ca)


def insert_cut(cuts, z):
    """``cuts`` (sorted, ends fixed) with the point ``z`` (in [lo, hi]) inserted in order."""
    out = []
    for x in cuts[1:-1]:  # one compare-exchange pass: carry the larger value on
        out.append(jnp.minimum(x, z))
        z = jnp.maximum(x, z)
    return [cuts[0], *out, z, cuts[-1]]


def face_integrands(wfn, wf_el, wn, wf, slip, arm_n, arm_s):
    """What a face law sums over its points, in this order: the normal force ``w f``, its
    elastic part ``w f_el`` and moment ``w f arm_n``; the normal dashpot's weights ``wn (1,
    arm_n, arm_n^2)``; the shear dashpot's ``wf (1, arm_s, arm_s^2)``; and the slip's
    ``wf slip (1, arm_s)``. ``w`` is the point's weight, ``wf`` its weight times the closed
    fraction, ``wn`` the same where the normal dashpot acts (only where the total force is
    compressive with a clipped dashpot). ``arm_n``, ``arm_s`` are the lever arms, or the face
    coordinate (:mod:`rockjax.dem`, whose arms are affine in it)."""
    return [
        wfn,
        wf_el,
        wfn * arm_n,
        wn,
        wn * arm_n,
        wn * arm_n * arm_n,
        wf,
        wf * arm_s,
        wf * arm_s * arm_s,
        wf * slip,
        wf * slip * arm_s,
    ]
