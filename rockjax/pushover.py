"""Quasi-static DEM pushover: the capacity curve of a block (paper Section 4, Fig. 9).

The block of :mod:`rockjax.dem` (the same joint, contact law and step, :func:`rockjax.dem.step`)
is pulled by a horizontal control spring attached to its centroid, whose far end moves at a
slow, constant rate (displacement control). A horizontal force on the centroid of a rigid body
is a uniform horizontal acceleration, so the control force ``F`` gives the load multiplier
``lambda = (F - m x_ddot) / (m g)`` (the horizontal acceleration in g that the supports
resist: the control force less the block's small inertia), and displacement control traces
the softening branch after the peak down to ``d/b ~ 1``. An overburden ``N`` [N per m of
length] acts vertically at the top centre. The pushover reuses the DEM step with its ``load``
hook in its own scan. Derivations, the loading-rate study and the paper's four walls:
docs/pushover.md.
"""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ._checks import (
    GAP_NEEDS_ONE_SIDED,
    check_kind,
    check_nonnegative,
    check_positive,
    concrete,
    warn_implausible,
)
from .assembly import Assembly, limit_analysis
from .block import Block
from .constants import G
from .contact import Joint
from .dem import dem_params, initial_state, stable_dt, step
from .modes import Mode, Parapet, as_mode
from .relations import beta_dejong

CONTROL_STIFFNESS = 50.0
"""Control spring stiffness in units of ``m g / h`` [-]. The rigid block's softening branch
has the stiffness ``-2 m g / h`` against the centroid's displacement, so 50 keeps the
controlled system stable (positive total stiffness) with a 25-fold margin, and the spring's
frequency ``sqrt(50 g / h)`` stays far below the contact modes the step resolves."""

CONTROL_DAMPING = 1.0
"""Damping ratio [-] of the control spring's dashpot (critical for the block's mass): it kills
the oscillation of the block on the control spring, which ``beta`` (on the contacts only)
does not reach. In steady pulling the block moves with the control point and the dashpot
carries no force."""

PULL_TIME = 80.0
"""Default duration of the pull in units of ``1 / p`` [-] (``p`` Housner's frequency
parameter): halving the rate moves the paper's walls' curves by < 0.13 % of ``lambda_0``
(docs/pushover.md, "Pushover")."""

RAMP_FRACTION = 0.25
"""Fraction of the pull over which the control point's velocity ramps smoothly from 0 to the
rate (a sudden start would shake the block)."""

MAX_D_OVER_B = 1.5
"""Largest ``d_over_b`` a pushover pulls to [-]: the rigid block's capacity is zero at
``d/b = 1`` and it overturns past it; 1.5 shows half a thickness of the negative branch, and a
larger value is taken for percent or millimetres (``d_over_b=100``)."""

SETTLE_FRACTION = 0.05
"""Fraction of the pull's duration added before it, over which the overburden is applied
(linearly) while the control point holds still."""


class Capacity(eqx.Module):
    """A pushover (capacity) curve.

    Attributes:
        load_multiplier: ``lambda`` [-], the horizontal acceleration in g: the supports'
            horizontal reaction over the block's weight ``m g`` (the control force less the
            block's inertia), per output sample.
        d_over_b: Horizontal displacement of the top centre relative to the base over ``b``
            [-].
        theta: Rotation [rad] (positive outward, about the +x toe).
        lambda_rigid: The rigid-block limit at ``theta = 0`` [-]: ``(b/h) (1 + N / W)``,
            ``W = rho g b h`` the weight per unit length, ``N`` the overburden.
        b: Block thickness [m].
        h: Block height [m].
        overburden: ``N`` [N/m] at the top centre.
        t: Time of each sample in the pull [s] (from the start of pulling).
        theta_blocks: For an :class:`rockjax.Assembly`, the rotation of each block [rad]
            (sample x block); ``None`` for one block.

    For an assembly, ``b`` is block 0's thickness, ``h`` the stack's height,
    ``lambda_rigid`` the rigid collapse multiplier of :func:`rockjax.limit_analysis` (the
    lowest mechanism of rocking and sliding, with the pull's friction angle; ``inf`` where
    none forms), ``theta`` the rotation of the block that rotated most by the end of the
    pull, and ``d_over_b`` the largest horizontal displacement of a block's
    top face centre over ``b`` (docs/pushover.md, "Assemblies");
    :meth:`rigid_load_multiplier` is the one-block curve and does not apply.
    """

    load_multiplier: Float[Array, " sample"]
    d_over_b: Float[Array, " sample"]
    theta: Float[Array, " sample"]
    lambda_rigid: Float[Array, ""]
    b: Float[Array, ""]
    h: Float[Array, ""]
    overburden: Float[Array, ""]
    t: Float[Array, " sample"]
    theta_blocks: Float[Array, "sample block"] | None = None

    def to_dataframe(self):
        """The curve as a ``pandas.DataFrame``, one row per sample of the pull.

        The index is ``"t [s]"`` (time from the start of pulling); the columns carry their
        units in their names: ``"d/b [-]"``, ``"d [m]"`` (``d_over_b * b``),
        ``"lambda [-]"`` (the load multiplier, ``a/g``), ``"theta [rad]"`` and, for an
        assembly, ``"theta_<k> [rad]"`` per block ``k`` (0 the bottom one). ``df.attrs``
        holds the curve's scalars: ``lambda_rigid [-]``, ``b [m]``, ``h [m]``,
        ``overburden [N/m]`` and ``n_blocks``. Write it with ``df.to_csv(path)``.

        Returns:
            The ``pandas.DataFrame``.

        Raises:
            ValueError: inside ``jit``/``vmap`` (the values must be concrete).
        """
        import pandas as pd

        t = concrete(self.t)
        if t is None or t.ndim != 1:
            raise ValueError(
                "Capacity.to_dataframe needs one concrete curve: call it outside jit/vmap on "
                f"the Capacity of one pushover (t has shape {np.shape(self.t)})."
            )
        b = float(concrete(self.b))
        columns = {
            "d/b [-]": self.d_over_b,
            "d [m]": concrete(self.d_over_b) * b,
            "lambda [-]": self.load_multiplier,
            "theta [rad]": self.theta,
        }
        n_blocks = 1
        if self.theta_blocks is not None:
            blocks = concrete(self.theta_blocks)
            n_blocks = blocks.shape[-1]
            columns |= {f"theta_{k} [rad]": blocks[:, k] for k in range(n_blocks)}
        df = pd.DataFrame(
            {name: np.asarray(v, dtype=float) for name, v in columns.items()},
            index=pd.Index(t, name="t [s]"),
        )
        df.attrs.update(
            {
                "lambda_rigid [-]": float(concrete(self.lambda_rigid)),
                "b [m]": b,
                "h [m]": float(concrete(self.h)),
                "overburden [N/m]": float(concrete(self.overburden)),
                "n_blocks": n_blocks,
            }
        )
        return df

    def rigid_load_multiplier(self, theta) -> Float[Array, "..."]:
        r"""The rigid block's ``lambda`` at rotation ``theta`` [rad] (virtual work about the toe):

        $$\lambda = \frac{W (b \cos\theta - h \sin\theta) + N (b \cos\theta - 2 h \sin\theta)}
        {W (h \cos\theta + b \sin\theta)}$$

        Args:
            theta: Rotation [rad].

        Returns:
            ``lambda`` [-].
        """
        b, h = self.b, self.h
        psi = self.lambda_rigid * h / b - 1.0  # N / W
        c, s = jnp.cos(theta), jnp.sin(theta)
        return (b * c - h * s + psi * (b * c - 2.0 * h * s)) / (h * c + b * s)


ASSEMBLY_STANDS = (
    "an Assembly stands on the ground with its own top support; leave mode='two_sided' and "
    "gap=0 (set the restraint's clearance with Assembly.stack(top=, gap=))."
)
"""Why :func:`pushover` refuses a facade mode or a gap for an assembly, and the fix."""


def pushover(
    block: Block | Assembly,
    mode: Mode | str = "two_sided",
    overburden=0.0,
    *,
    beta=None,
    d_over_b: float = 1.0,
    duration: float | None = None,
    n_out: int = 400,
    joint: Joint = Joint(),
    phi_deg=None,
    gap=None,
) -> Capacity:
    """Quasi-static monotonic DEM pushover of a block or an assembly, displacement-controlled.

    A control spring (stiffness ``CONTROL_STIFFNESS m g / h``, critically damped) pulls the
    centroid toward +x (outward for a facade) at a constant rate, after a smooth start; the
    load multiplier is its force less the block's inertia over the weight,
    ``lambda = (F - m x_ddot) / (m g)``, equivalent to a uniform horizontal acceleration
    ``lambda g`` on the rigid block. The overburden, if any, is applied first (linearly over
    ``SETTLE_FRACTION`` of the duration), vertical at the top centre. The rigid limit is
    ``lambda_0 = (b/h)(1 + N/W)``, ``W = rho g b h`` (docs/pushover.md). Not traceable: call
    it outside ``jit``/``vmap``.

    An :class:`rockjax.Assembly` is pushed by the same spring acting on the mass-weighted
    mean horizontal displacement of its centroids, its force shared by the blocks in
    proportion to their masses: a uniform horizontal body force, the load of
    :func:`rockjax.collapse_multiplier` (docs/pushover.md, "Assemblies"). Its overburden and
    top restraint are the assembly's own (``overburden`` and ``mode`` must stay at their
    defaults).

    Args:
        block: The block (``E`` sets the joint's stiffness, Section 2), or an
            :class:`rockjax.Assembly`.
        mode: :class:`rockjax.Parapet` (``"two_sided"``) or :class:`rockjax.Facade`
            (``"one_sided"``: its return wall at -x, its ``gap`` behind the back face; it is
            pulled away from the wall).
        overburden: Vertical load at the top centre ``N`` [N/m] (per metre of length).
        beta: Stiffness-proportional damping [s], Eq. (1), to damp the contact vibrations;
            default :func:`rockjax.beta_dejong` (critical damping at ``omega_crit``).
        d_over_b: Top displacement to pull to, over ``b`` [-] (the rigid block's ``lambda``
            reaches zero at ``d/b ~ 1``); for an assembly, about this far (the rigid
            mechanism's travel), ``b`` being block 0's; at most :data:`MAX_D_OVER_B`.
        duration: Time of the pull [s]; default ``PULL_TIME / p`` (times ``d_over_b`` past
            1). Longer is more quasi-static; a pull faster than ``PULL_TIME / p`` per unit of
            ``d_over_b`` (the rate checked) is run with a ``rockjax.PlausibilityWarning``.
        n_out: Number of output samples along the pull.
        joint: The contact joint (:class:`rockjax.Joint`); default the integrated face law.
        phi_deg: Friction angle [deg]; default 50 (parapets) or 30 (facades).
        gap: With ``mode="one_sided"``: the facade's gap [m]; default None (0, or the
            Facade's own).

    Returns:
        The :class:`Capacity` curve, ``n_out`` samples from the start of pulling.

    Raises:
        ValueError: on invalid input, naming the argument, its unit and the fix.
    """
    check_kind(
        "block",
        block,
        (Block, Assembly),
        "Build one with rj.Block(b=0.25, h=3.0) or rj.Assembly.stack([...]).",
    )
    check_positive(
        "d_over_b",
        d_over_b,
        "[-]",
        "The top displacement to reach over b, e.g. 1.0.",
        scalar=True,
    )
    if float(d_over_b) > MAX_D_OVER_B:
        raise ValueError(
            f"d_over_b={float(d_over_b):g} is above {MAX_D_OVER_B:g}: it is the top displacement "
            "to reach over b (dimensionless; the rigid block's capacity is zero at d/b = 1 and it "
            "overturns past it), not percent or millimetres. Use e.g. d_over_b=1.0 (the "
            "default), or divide by 100 if you gave percent."
        )
    if not (isinstance(n_out, int) and not isinstance(n_out, bool) and n_out >= 2):
        raise ValueError(f"n_out (output samples) must be an integer >= 2; got n_out={n_out!r}.")
    # the mode object, converted once (an assembly's top restraint has its own clearance)
    unused = ASSEMBLY_STANDS if isinstance(block, Assembly) else GAP_NEEDS_ONE_SIDED
    mode = as_mode(mode, gap, unused=unused)
    if isinstance(block, Assembly):
        if mode.one_sided:
            raise ValueError(f"mode={mode!r}: {ASSEMBLY_STANDS}")
        if overburden != 0.0:
            raise ValueError(
                f"overburden={overburden!r} N/m: an Assembly carries its own overburden; build "
                "it with Assembly.stack(..., overburden=<N/m>) and leave overburden=0."
            )
        return _pushover_assembly(
            block,
            beta,
            d_over_b,
            duration,
            n_out,
            joint,
            Parapet.phi_deg if phi_deg is None else phi_deg,
        )
    check_nonnegative(
        "overburden",
        overburden,
        "N/m",
        "The load per metre of wall length at the top.",
        scalar=True,
    )
    if beta is None:
        beta = float(beta_dejong(block))
    p = float(block.p)
    duration = _pull_duration(duration, d_over_b, p)
    params = dem_params(block, beta, mode=mode, joint=joint, phi_deg=phi_deg)
    dt = stable_dt(block, beta, mode=mode, joint=joint)
    b, h = float(block.b), float(block.h)
    m = float(block.m)
    weight = m * G
    p_top = float(overburden) * float(block.length)  # [N]
    # the centroid's travel for the top to reach d_over_b * b, rigid kinematics about the toe
    theta_end = _rigid_theta(d_over_b * b, b, h)
    x_end = 0.5 * b * (1.0 - math.cos(theta_end)) + 0.5 * h * math.sin(theta_end)
    interval = duration / (n_out - 1)  # [s] between output samples
    n_settle = math.ceil(SETTLE_FRACTION * (n_out - 1)) if p_top > 0 else 0
    t_settle = n_settle * interval
    t_ramp = RAMP_FRACTION * duration
    rate = x_end / (duration - 0.5 * t_ramp)  # the ramp loses half its length
    k_c = CONTROL_STIFFNESS * weight / h
    c_c = 2.0 * CONTROL_DAMPING * math.sqrt(k_c * m)
    n_in = max(1, math.ceil(interval / dt - 1e-9))
    dt = interval / n_in  # divides the output interval
    control = _Control(
        k=jnp.asarray(k_c),
        c=jnp.asarray(c_c),
        rate=jnp.asarray(rate),
        t_ramp=jnp.asarray(t_ramp),
        t_settle=jnp.asarray(t_settle),
        p_top=jnp.asarray(p_top),
    )
    state0 = initial_state(block, params)
    force, ax, theta, d = _pull(params, state0, control, jnp.asarray(dt), n_in, n_out + n_settle)
    # the supports' horizontal reaction: the control force less the block's inertia (which
    # is small but not nil where the block starts to rock)
    force = force - m * ax
    # drop the settling samples: the curve starts when pulling starts
    force, theta, d = force[n_settle:], theta[n_settle:], d[n_settle:]
    t = jnp.arange(n_out) * interval
    return Capacity(
        load_multiplier=force / weight,
        d_over_b=d / b,
        theta=theta,
        lambda_rigid=jnp.asarray((b / h) * (1.0 + p_top / weight)),
        b=jnp.asarray(b),
        h=jnp.asarray(h),
        overburden=jnp.asarray(float(overburden)),
        t=t,
    )


def _pull_duration(duration, d_over_b, p: float) -> float:
    """The pull's duration [s]: by default ``PULL_TIME / p`` per unit of ``d_over_b`` past 1
    (``PULL_TIME / p`` up to ``d/b = 1``), the rate checked to be quasi-static
    (docs/pushover.md, "Rate"); a given duration is checked, and a faster pull warned of."""
    slowest = PULL_TIME / p * max(1.0, float(d_over_b))
    if duration is None:
        return slowest
    check_positive("duration", duration, "s", f"e.g. duration={slowest:.3g}.", scalar=True)
    # the rate checked: d/b per second at most p / PULL_TIME (the default over d/b = 1)
    needed = PULL_TIME / p * float(d_over_b)
    if float(duration) < needed * (1.0 - 1e-9):
        warn_implausible(
            f"duration={float(duration):.4g} s pulls to d_over_b={float(d_over_b):g} faster than "
            f"the rate checked to be quasi-static (d/b per second <= p / {PULL_TIME:g} = "
            f"{p / PULL_TIME:.4g} 1/s, p = {p:.4g} rad/s): the curve may carry the block's "
            f"inertia. Give duration >= {needed:.4g} s, or leave duration=None."
        )
    return float(duration)


def _rigid_theta(d, b, h):
    """The rotation [rad] at which the rigid block's top centre has moved ``d`` [m]
    (``d = b/2 (1 - cos theta) + h sin theta``, increasing on [0, pi/2 - ...])."""
    lo, hi = 0.0, 0.5 * math.pi
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if 0.5 * b * (1.0 - math.cos(mid)) + h * math.sin(mid) < d:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


class _Control(eqx.Module):
    k: jax.Array  # control spring [N/m]
    c: jax.Array  # its dashpot [N s/m]
    rate: jax.Array  # control point velocity [m/s]
    t_ramp: jax.Array  # [s]
    t_settle: jax.Array  # [s]
    p_top: jax.Array  # overburden force [N]

    def target(self, t):
        """Control point displacement [m] and velocity [m/s] at time ``t`` [s]: at rest while
        settling, then a (1 - cos) velocity ramp over ``t_ramp`` to ``rate``."""
        tp = jnp.maximum(t - self.t_settle, 0.0)
        on = tp < self.t_ramp
        phase = jnp.pi * jnp.minimum(tp, self.t_ramp) / self.t_ramp
        u_ramp = self.rate * (0.5 * tp - 0.5 * self.t_ramp / jnp.pi * jnp.sin(phase))
        v_ramp = self.rate * 0.5 * (1.0 - jnp.cos(phase))
        u = jnp.where(on, u_ramp, self.rate * (tp - 0.5 * self.t_ramp))
        v = jnp.where(on, v_ramp, self.rate)
        return u, v

    def load(self, state, t, h):
        """``(Fx, Fy, M)`` on the centroid of the one block [N, N, N m] and the control force
        [N]."""
        u, v = self.target(t)
        f = self.k * (u - state.x[0]) + self.c * (v - state.vx[0])
        ramp = jnp.where(self.t_settle > 0, jnp.minimum(t / self.t_settle, 1.0), 1.0)
        p = self.p_top * ramp
        # vertical load at the top centre, body point (0, h/2): arm rx = (h/2) sin(theta)
        return [(f, -p, 0.5 * h * state.s[0] * p)], f


@eqx.filter_jit
def _pull(params, state0, control: _Control, dt, n_in: int, n_samples: int):
    """Scan the DEM step under the control load; the control force [N], theta [rad] and top
    displacement [m] every ``n_in`` steps (sample 0 at ``t = 0``)."""

    h = params.h[0]

    def inner(carry, _):
        st, k = carry
        load, _ = control.load(st, k * dt, h)
        st, *_ = step(params, st, 0.0, 0.0, dt, load=load, one_history=True)
        return (st, k + 1.0), None

    def outer(carry, _):
        st, k = carry
        load, f = control.load(st, k * dt, h)
        new, acc, *_ = step(params, st, 0.0, 0.0, dt, load=load, one_history=True)
        out = (f, acc[0][0], st.theta[0], st.x[0] + 0.5 * h * st.s[0])
        carry, _ = jax.lax.scan(inner, (new, k + 1.0), length=n_in - 1)
        return carry, out

    outer = jax.checkpoint(outer, prevent_cse=False)
    _, (f, ax, theta, d) = jax.lax.scan(outer, (state0, jnp.zeros(())), length=n_samples)
    f = eqx.error_if(f, ~jnp.all(jnp.isfinite(f)), "rockjax.pushover: non-finite state")
    return f, ax, theta, d


# ----------------------------------------------------------------------------- assemblies


def _mechanism(assembly: Assembly, phi_deg):
    """The rigid collapse mechanism under a uniform horizontal body force (small rotation,
    :func:`rockjax.limit_analysis`): its multiplier ``lambda`` [-] and the ratio of the
    control coordinate (the mass-weighted mean centroid displacement) to the largest
    displacement of a block's top face centre [-] (0.5 where no mechanism forms)."""
    la = limit_analysis(assembly, phi_deg)
    lam = float(la.load_multiplier)
    if not math.isfinite(lam):
        return lam, 0.5
    m = np.asarray([float(b.m) for b in assembly.blocks])
    # the velocities are scaled so that the largest top face centre moves at 1
    return lam, float(np.dot(m, np.asarray(la.velocity)[:, 0]) / m.sum())


def _pushover_assembly(assembly, beta, d_over_b, duration, n_out, joint, phi_deg):
    blocks = assembly.blocks
    n = len(blocks)
    if beta is None:
        beta = min(float(beta_dejong(b)) for b in blocks)
    b0 = float(blocks[0].b)
    height = float(assembly.height)
    # the slowest rocking frequency: a block, or the stack as one block
    mono = Block(b=b0, h=height, length=blocks[0].length)
    p = min([float(b.p) for b in blocks] + [float(mono.p)])
    duration = _pull_duration(duration, d_over_b, p)
    params = dem_params(assembly, beta, joint=joint, phi_deg=phi_deg)
    dt = stable_dt(assembly, beta, joint=joint)
    masses = [float(b.m) for b in blocks]
    total = sum(masses)
    weight = total * G
    lam_rigid, ratio = _mechanism(assembly, phi_deg)
    interval = duration / (n_out - 1)
    n_settle = math.ceil(SETTLE_FRACTION * (n_out - 1))
    t_settle = n_settle * interval
    t_ramp = RAMP_FRACTION * duration
    # stiff enough for the softest mechanism: one block alone on the control coordinate sees
    # k (m_k / M)^2, which must beat its own softening 2 m_k g / h_k (as for one block)
    k_c = (
        CONTROL_STIFFNESS
        * G
        * total
        * max(total / (masses[k] * float(blocks[k].h)) for k in range(n))
    )
    c_c = 2.0 * CONTROL_DAMPING * math.sqrt(k_c * total * total / min(masses))
    n_in = max(1, math.ceil(interval / dt - 1e-9))
    dt = interval / n_in
    # the control point's travel: the rigid mechanism's, to move its top d_over_b * b0, plus
    # the control spring's stretch at the rigid peak (a restrained wall's peak is high)
    lam_peak = lam_rigid if math.isfinite(lam_rigid) else 0.0
    x_end = d_over_b * b0 * ratio + lam_peak * weight / k_c
    rate = x_end / (duration - 0.5 * t_ramp)
    control = _Control(
        k=jnp.asarray(k_c),
        c=jnp.asarray(c_c),
        rate=jnp.asarray(rate),
        t_ramp=jnp.asarray(t_ramp),
        t_settle=jnp.asarray(t_settle),
        p_top=jnp.asarray(0.0),
    )
    share = jnp.asarray(masses) / total
    state0 = initial_state(assembly, params)
    force, inertia, theta, d = _pull_assembly(
        params, state0, control, share, jnp.asarray(dt), jnp.asarray(n_in), n_out + n_settle
    )
    force = force - inertia
    force, theta, d = force[n_settle:], theta[n_settle:], d[n_settle:]
    lead = int(jnp.argmax(jnp.abs(theta[-1])))
    return Capacity(
        load_multiplier=force / weight,
        d_over_b=jnp.max(d, axis=-1) / b0,
        theta=theta[:, lead],
        lambda_rigid=jnp.asarray(lam_rigid),
        b=jnp.asarray(b0),
        h=jnp.asarray(height),
        overburden=jnp.asarray(float(assembly.overburden)),
        t=jnp.arange(n_out) * interval,
        theta_blocks=theta,
    )


@eqx.filter_jit
def _pull_assembly(params, state0, control: _Control, share, dt, n_in, n_samples: int):
    """Scan the assembly step under the control load: the control force [N], the blocks'
    horizontal inertia ``sum m_k a_k`` [N], the rotations [rad] and the top face centres'
    horizontal displacements [m] every ``n_in`` steps (sample 0 at ``t = 0``)."""
    n = params.n
    masses = params.m

    def coordinate(st):
        x = jnp.stack(st.x) - params.x0
        vx = jnp.stack(st.vx)
        return jnp.sum(share * x), jnp.sum(share * vx)

    def load(st, t):
        u, v = control.target(t)
        xc, vc = coordinate(st)
        f = control.k * (u - xc) + control.c * (v - vc)
        return [(f * share[k], 0.0, 0.0) for k in range(n)], f

    def inner(_, carry):
        st, k = carry
        ld, _ = load(st, k * dt)
        st, *_ = step(params, st, 0.0, 0.0, dt, load=ld, one_history=True)
        return st, k + 1.0

    def outer(carry, _):
        st, k = carry
        ld, f = load(st, k * dt)
        new, acc, *_ = step(params, st, 0.0, 0.0, dt, load=ld, one_history=True)
        inertia = sum(masses[j] * acc[j][0] for j in range(n))
        top = jnp.stack([st.x[j] - params.x0[j] + 0.5 * params.h[j] * st.s[j] for j in range(n)])
        out = (f, inertia, jnp.stack(st.theta), top)
        # a traced trip count (a while loop): walls of one topology share one compilation
        carry = jax.lax.fori_loop(1, n_in, inner, (new, k + 1.0))
        return carry, out

    _, (f, inertia, theta, d) = jax.lax.scan(outer, (state0, jnp.zeros(())), length=n_samples)
    f = eqx.error_if(f, ~jnp.all(jnp.isfinite(f)), "rockjax.pushover: non-finite state")
    return f, inertia, theta, d
