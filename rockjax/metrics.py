"""Differentiable comparisons of two rocking responses (the losses of :mod:`rockjax.calibration`).

Two kinds of measure:

* **Peaks** (phase-insensitive, smooth in the parameters): the history is cut into half-cycles
  at its impacts, and each half-cycle's peak ``|theta_k|`` (refined by a parabola through the
  three samples around the largest) is turned into the rocking energy
  ``U_k = cos(eta - |theta_k|) - cos(eta)`` (over ``m g R``, :func:`rockjax.relations.rocking_energy`).
  For Housner's model released from rest, ``U_k = e^(2k) U_0`` exactly, so
  ``log U_k - log U_0`` is linear in the bounce number ``k`` with slope ``2 log e``: comparing
  ``log U_k`` of two responses bounce by bounce compares their energy loss per impact whatever
  their phase.
* **History** (the paper's): the weighted-mean error of ``theta(t)`` sample by sample. It is what
  the paper minimised by trial, but it is rough in the parameters (a shifted impact shifts all
  later samples) and flat once the phase is lost, so it serves to report, not to steer.

Everything here is pure ``jax.numpy`` (``jit``/``vmap``/``grad``-able); the half-cycle cut is
integer (no derivative flows through it), the peak values and times carry the derivatives.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Bool, Float, Int

from .modes import Mode, as_mode
from .relations import rocking_energy
from .response import HYSTERESIS as HYSTERESIS  # the bounce thresholds, shared with the
from .response import MODES as MODES  # NumPy finder rockjax.response.bounce_peaks
from .response import RELATIVE_BOUNCE as RELATIVE_BOUNCE


class Peaks(eqx.Module):
    """Half-cycle peaks of a response: index 0 is the release, ``k >= 1`` the peak after impact k.

    Attributes:
        t: Peak times [s], shape ``(n + 1,)``.
        amplitude: Peak ``|theta_k|`` [rad].
        log_energy: ``log U_k`` with ``U_k = cos(eta - |theta_k|) - cos(eta)`` [-].
        valid: True where the half-cycle was completed (a later impact exists) within the run.
        n_impacts: Number of impacts counted in the whole run (int).
    """

    t: Float[Array, "*batch n"]
    amplitude: Float[Array, "*batch n"]
    log_energy: Float[Array, "*batch n"]
    valid: Bool[Array, "*batch n"]
    n_impacts: Int[Array, "*batch"]


def half_cycles(
    theta: Float[ArrayLike, " T"],
    eta,
    mode: Mode | str = "two_sided",
    hysteresis: float = HYSTERESIS,
) -> Int[Array, " T"]:
    """Index of the half-cycle each sample belongs to (0 before the first impact) [-].

    Impacts are detected with hysteresis (:data:`HYSTERESIS`): two-sided, ``theta`` changing
    side; one-sided, ``theta`` returning to the wall (a sample within the threshold, or a
    V-shaped minimum whose chord reaches the wall within one sample: an instantaneous impact
    between samples). No derivative flows through the result.
    """
    mode = as_mode(mode)
    theta = jax.lax.stop_gradient(jnp.asarray(theta, float))
    eps = hysteresis * jax.lax.stop_gradient(jnp.asarray(eta, float))

    if not mode.one_sided:
        side0 = jnp.where(theta[0] < 0, -1.0, 1.0)

        def step(carry, th):
            side, k = carry
            flip = side * th < -eps
            side = jnp.where(flip, -side, side)
            k = k + flip.astype(k.dtype)
            return (side, k), k

        _, seg = jax.lax.scan(step, (side0, jnp.zeros((), jnp.int32)), theta)
    else:
        # one-sided: an impact is a sample below the threshold, or a V-shaped minimum from
        # which one of its two chords reaches the wall within one sample,
        # y_i <= max(y_{i-1} - y_i, y_{i+1} - y_i): Housner's impact is instantaneous, so a
        # sample rarely falls within eps of the wall; the sample nearest an impact at distance
        # a < h from it has y_i ~ v a and the chord on the far side of the impact ~ v h. A
        # smooth minimum of height m and curvature c passes only if m < c h^2 / 2 (a
        # near-touch). A rebound counts once theta has risen above twice the threshold and
        # above RELATIVE_BOUNCE of the previous peak (micro-chatter on the wall is no bounce).
        d_prev = theta[:-2] - theta[1:-1]
        d_next = theta[2:] - theta[1:-1]
        v = (d_prev > 0) & (d_next > 0) & (theta[1:-1] <= jnp.maximum(d_prev, d_next))
        vee = jnp.concatenate([jnp.zeros(1, bool), v, jnp.zeros(1, bool)])

        def step(carry, x):
            th, at_wall = x
            armed, k, cur, prev = carry
            hit = armed & ((th < eps) | at_wall)
            prev = jnp.where(hit, cur, prev)
            cur = jnp.where(hit, 0.0, jnp.maximum(cur, th))
            rise = th > jnp.maximum(2.0 * eps, RELATIVE_BOUNCE * prev)
            armed = jnp.where(hit, False, armed | rise)
            k = k + hit.astype(k.dtype)
            return (armed, k, cur, prev), k

        zero = jnp.zeros((), float)
        init = (jnp.asarray(True), jnp.zeros((), jnp.int32), zero, jnp.abs(theta[0]))
        _, seg = jax.lax.scan(step, init, (theta, vee))
    return seg


def peaks(
    t: Float[ArrayLike, " T"],
    theta: Float[ArrayLike, " T"],
    eta,
    n: int,
    mode: Mode | str = "two_sided",
    hysteresis: float = HYSTERESIS,
) -> Peaks:
    """The release and the first ``n`` half-cycle peaks of ``|theta(t)|``, differentiably.

    One-sided, the peaks are those of ``max(theta, 0)``: the rebounds away from the wall.

    Args:
        t: Sample times [s], uniform.
        theta: Rotation [rad]; the first sample is the release (from rest).
        eta: Slenderness angle [rad].
        n: Number of bounces (static).
        mode: :class:`rockjax.Parapet` / ``"two_sided"`` or :class:`rockjax.Facade` /
            ``"one_sided"`` (:func:`rockjax.as_mode`).
        hysteresis: Impact detection threshold as a fraction of ``eta`` (:data:`HYSTERESIS`).

    Returns:
        :class:`Peaks` with ``n + 1`` entries. A peak that the run did not reach has
        ``valid=False`` and amplitude ``hysteresis * eta`` (an upper bound: the block rocked
        less than that, or the run ended first).
    """
    mode = as_mode(mode)
    t = jnp.asarray(t, float)
    theta = jnp.asarray(theta, float)
    eta = jnp.asarray(eta, float)
    y = mode.amplitude(theta)  # one-sided the rebounds: theta < 0 is the wall's penetration
    seg = half_cycles(theta, eta, mode, hysteresis)
    m = n + 1
    idx = jnp.arange(y.shape[0])
    # largest sample of each half-cycle (first occurrence), then a parabola through its
    # neighbours: the refined peak moves continuously as the true peak slides between samples
    ymax = jax.ops.segment_max(jax.lax.stop_gradient(y), seg, num_segments=m)
    big = y.shape[0]
    at_max = jnp.where(jax.lax.stop_gradient(y) == ymax[jnp.clip(seg, 0, m - 1)], idx, big)
    i = jax.ops.segment_min(jnp.where(seg < m, at_max, big), seg, num_segments=m)
    exists = i < big
    i = jnp.clip(i, 1, y.shape[0] - 2)
    y0, y1, y2 = y[i - 1], y[i], y[i + 1]
    curv = y0 - 2.0 * y1 + y2
    safe = jnp.where(curv < 0, curv, -1.0)
    s = jnp.where(curv < 0, jnp.clip(0.5 * (y0 - y2) / safe, -1.0, 1.0), 0.0)
    h = t[1] - t[0]
    amp = y1 - 0.25 * (y0 - y2) * s
    tk = t[i] + s * h
    # the release is the first sample, exactly
    amp = amp.at[0].set(y[0])
    tk = tk.at[0].set(t[0])
    n_imp = seg[-1]
    valid = exists & (jnp.arange(m) < n_imp)
    valid = valid.at[0].set(True)
    floor = hysteresis * eta
    amp = jnp.where(valid, jnp.maximum(amp, floor), floor)
    log_u = jnp.log(rocking_energy(amp, eta))
    return Peaks(t=tk, amplitude=amp, log_energy=log_u, valid=valid, n_impacts=n_imp)


def bounce_weights(ref: Peaks, min_energy_ratio: float = 0.02):
    """``(w, k)``: weight 1 on the bounces ``k >= 1`` of ``ref`` that are valid and keep at least
    ``min_energy_ratio`` of its release energy, else 0; and the bounce numbers ``k`` (floats).
    The weights of every loss here."""
    k = jnp.arange(ref.log_energy.shape[0], dtype=float)
    use = ref.valid & (ref.log_energy - ref.log_energy[0] >= jnp.log(min_energy_ratio))
    return jnp.where(use & (k > 0), 1.0, 0.0), k


def log_e_gap(sim: Peaks, ref: Peaks, min_energy_ratio: float = 0.02):
    """Signed least-squares gap ``log e_sim - log e_ref`` from the bounce energies [-].

    ``sum_k w_k 2k (log U_k^sim - log U_k^ref) / sum_k w_k (2k)^2`` over the bounces ``k >= 1``
    where the reference is valid and keeps at least ``min_energy_ratio`` of its release energy
    (``w_k = 1``, else 0). Both responses must start from the same release. Positive when
    ``sim`` loses less energy per impact than ``ref``. Monotone in the damping of ``sim``: the
    statistic the root-find baseline solves.
    """
    w, k = bounce_weights(ref, min_energy_ratio)
    d = (sim.log_energy - sim.log_energy[0]) - (ref.log_energy - ref.log_energy[0])
    return jnp.sum(w * 2 * k * d) / jnp.maximum(jnp.sum(w * 4 * k * k), 1.0)


def peak_loss(sim: Peaks, ref: Peaks, min_energy_ratio: float = 0.02):
    """Phase-insensitive loss: weighted mean square gap of the bounce log-energies [-].

    ``sum_k w_k (dlogU_k)^2 / sum_k w_k (2k)^2`` with ``dlogU_k`` the gap of
    ``log U_k - log U_0`` between ``sim`` and ``ref`` and the weights of :func:`log_e_gap`. If
    ``sim`` has a constant restitution ``e_s`` and ``ref`` has ``e``, the loss is exactly
    ``(log e_s - log e)^2``: its square root reads as the relative error in ``e``.
    """
    w, k = bounce_weights(ref, min_energy_ratio)
    d = (sim.log_energy - sim.log_energy[0]) - (ref.log_energy - ref.log_energy[0])
    return jnp.sum(w * d * d) / jnp.maximum(jnp.sum(w * 4 * k * k), 1.0)


def amplitude_loss(sim: Peaks, ref: Peaks, min_energy_ratio: float = 0.02):
    """Mean square gap of the bounce ``log |theta_k|`` [-] (weights of :func:`log_e_gap`; the
    two responses may differ in ``eta``, e.g. when the block's width is fitted)."""
    w, _ = bounce_weights(ref, min_energy_ratio)
    d = jnp.log(sim.amplitude) - jnp.log(ref.amplitude)
    return jnp.sum(w * d * d) / jnp.maximum(jnp.sum(w), 1.0)


def timing_loss(sim: Peaks, ref: Peaks, scale, min_energy_ratio: float = 0.02):
    """Mean square gap of the bounce peak times over ``scale**2`` [-] (phase, smoothly)."""
    w, _ = bounce_weights(ref, min_energy_ratio)
    d = (sim.t - ref.t) / scale
    return jnp.sum(w * d * d) / jnp.maximum(jnp.sum(w), 1.0)


def log_e_fit(pk: Peaks, min_energy_ratio: float = 0.02):
    """Least-squares ``log e`` of one response from its own bounces: slope of
    ``log U_k - log U_0`` against ``2k`` through the origin [-], over the valid bounces that keep
    at least ``min_energy_ratio`` of the release energy; NaN if there is none."""
    w, k = bounce_weights(pk, min_energy_ratio)
    d = pk.log_energy - pk.log_energy[0]
    den = jnp.sum(w * 4 * k * k)
    return jnp.where(den > 0, jnp.sum(w * 2 * k * d) / jnp.maximum(den, 1.0), jnp.nan)


def history_error(
    theta: Float[ArrayLike, " T"],
    theta_ref: Float[ArrayLike, " T"],
    weights: Float[ArrayLike, " T"] | None = None,
):
    """The paper's weighted-mean time-history error, as a normalised weighted RMS [-].

    ``sqrt( sum_i w_i (theta_i - theta_ref_i)^2 / sum_i w_i theta_ref_i^2 )``. ``weights``
    defaults to 1 on every sample (pass a window, e.g. 1 up to the last compared bounce and 0
    after, to restrict it). 0 for identical histories, ~1.4 for uncorrelated ones of equal size.
    """
    theta = jnp.asarray(theta, float)
    theta_ref = jnp.asarray(theta_ref, float)
    w = jnp.ones_like(theta_ref) if weights is None else jnp.asarray(weights, float)
    if theta.shape != theta_ref.shape or w.shape != theta_ref.shape:
        raise ValueError(
            f"theta, theta_ref and weights must have one value per sample, the same shape; got "
            f"theta {theta.shape}, theta_ref {theta_ref.shape}, weights {w.shape}. Sample both "
            "histories on the same times, e.g. theta = np.interp(t_ref, t, theta)."
        )
    num = jnp.sum(w * (theta - theta_ref) ** 2)
    den = jnp.maximum(jnp.sum(w * theta_ref**2), 1e-300)
    return jnp.sqrt(num / den + 1e-300)
