"""The calibration problems: what a loss evaluation needs, built and checked from the user's
input, and the statistics of the DEM (or Housner) runs at a parameter value.

* :class:`CalibrationProblem` (built by :func:`problem`): ``beta`` of the DEM against a target
  ``e`` (Housner's free rocking) or the facade bounce targets; :func:`stats` gives the loss, the
  signed gap, the DEM's own ``log e`` and the peak loss at a ``beta``.
* :class:`EProblem`: the Housner ``e`` that matches a DEM run (:func:`rockjax.fit_e`);
  loss :func:`housner_loss`.
* :class:`HistoryProblem` (built by :func:`history_problem`): ``beta`` and the width ``b`` from a
  measured history (:func:`rockjax.fit_history`); loss :func:`history_loss`.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import metrics
from .._checks import (
    check_choice,
    check_positive,
    check_scalar,
)
from ..block import Block
from ..compilation import persistent_jit, strong_scalars
from ..contact import Joint
from ..dem import simulate_dem, stable_dt
from ..housner import simulate_housner
from ..modes import MODE_NAMES, Mode, as_mode
from ..relations import beta_dejong, beta_hcrit, e_isr, free_rocking_period
from ..response import STATUS_OK, Response, e_exp
from ._result import BOUNCE_FRACTIONS, MIN_ENERGY_RATIO, hysteresis

MODES = MODE_NAMES
SAVE_DT = 0.002
"""Output step of the calibration runs [s] (the peaks are refined between samples)."""

FACADE_BETA_MAX_HCRIT = 16.0
"""Default ``beta_max`` of a facade (``mode="one_sided"``) in units of ``beta_Hcrit`` (the
paper's lower bound from ``omega_Hcrit``): on the converged joint the best fits lie at
0.6-5 ``beta_Hcrit`` for h/b 3-16 and slender walls need more (0.3 x 7.2 m is not bracketed
by 8; calibrate/REPORT.md), still far below ``beta_DeJong``."""


class CalibrationProblem(eqx.Module):
    """Everything a ``beta`` loss evaluation needs (:func:`problem` builds it); arrays traced,
    the rest static (one compile per bucket of durations, :func:`run_duration`).

    Attributes:
        block: The block (concrete floats).
        theta0: Release rotations [rad], shape ``(n_release,)``.
        ref: Housner reference peaks, leading axis ``n_release`` (dummies for ``"bounces"``).
        targets: ``[e]`` (``kind="e"``) or the three bounce targets ``e_exp,1-3`` [-].
        scale: ``|d(log e)/d(beta)|`` [1/s], for ``u = scale * beta`` (1 until
            :func:`rockjax.fit_beta` measures it).
        beta_cap: ``1.25 beta_max`` [s].
        mode: :class:`rockjax.Parapet` or :class:`rockjax.Facade` (its gap [m] traced; the
            fields below are static).
        kind: ``"e"`` or ``"bounces"``.
        n_bounces: Bounces compared.
        duration: Length of each free-rocking run [s].
        dt: DEM time step [s].
        joint: The DEM's :class:`rockjax.Joint`.
        hysteresis: Impact threshold of the peak finders, a fraction of ``eta`` [-].
        ref_theta: ``target="e"``: Housner's reference histories, one per release, saved every
            :data:`SAVE_DT` as the DEM's [rad] (None for ``"bounces"``).
        ref_t_last: ``target="e"``: the time of each reference's last compared bounce [s],
            the end of the window of :func:`history_stat`.
    """

    block: Block
    theta0: jax.Array  # (n_release,)
    ref: metrics.Peaks  # Housner reference peaks, leading axis n_release (or dummies)
    targets: jax.Array  # bounce targets (target="bounces") or e (target="e")
    scale: jax.Array  # S: d(log e)/d(beta) magnitude [1/s], for u = S beta
    beta_cap: jax.Array
    mode: Mode  # a facade's gap traced: one compile for every gap
    kind: str = eqx.field(static=True)  # "e" or "bounces"
    n_bounces: int = eqx.field(static=True)
    duration: float = eqx.field(static=True)
    dt: jax.Array
    joint: Joint = eqx.field(static=True)
    hysteresis: float = eqx.field(static=True)
    ref_theta: jax.Array | None = None  # Housner's histories (n_release, T) [rad], kind "e"
    ref_t_last: jax.Array | None = None  # their last compared bounce's time (n_release,) [s]


def dem_run(problem: CalibrationProblem, beta, theta0=None) -> Response:
    """The problem's DEM free-rocking run at ``beta`` [s] from ``theta0`` [rad] (default the
    first release), saved every :data:`SAVE_DT`; a failed run is reported in ``status``."""
    return simulate_dem(
        problem.block,
        beta=beta,
        mode=problem.mode,
        theta0=problem.theta0[0] if theta0 is None else theta0,
        duration=problem.duration,
        dt=problem.dt,
        joint=problem.joint,
        save_dt=SAVE_DT,
        throw=False,
    )


def dem_peaks(problem: CalibrationProblem, beta):
    """``(peaks, status)`` of the DEM runs at ``beta`` [s], one per release (vmapped)."""

    def one(theta0):
        r = dem_run(problem, beta, theta0)
        pk = metrics.peaks(
            r.t, r.theta, problem.block.eta, problem.n_bounces, problem.mode, problem.hysteresis
        )
        return pk, r.status

    return jax.vmap(one)(problem.theta0)


def bounce_log_e(problem: CalibrationProblem, pk: metrics.Peaks):
    """``log e_exp`` (Eq. 6) of bounces 1-3, per release, from the loss's peaks [-]."""
    n = jnp.arange(1, 4)[None, :]
    e_n = e_exp(pk.amplitude[:, 1:4], pk.amplitude[:, :1], problem.block.eta, n)
    return jnp.log(e_n)


def stats(problem: CalibrationProblem, beta):
    """``(loss, signed gap, the DEM's own log e, peak loss)`` at ``beta`` [s]; NaN if a run failed.

    ``target="e"``: the gap is :func:`rockjax.metrics.log_e_gap` (the least-squares
    ``log e_DEM - log e`` over the compared bounces, averaged over the releases) and the loss is
    its square, zero exactly where the DEM's restitution equals the target. The full
    bounce-by-bounce mismatch :func:`rockjax.metrics.peak_loss` is returned beside it: what is
    left of it at the optimum is the DEM's amplitude dependence of ``e``, which no single
    ``beta`` removes. ``target="bounces"``: the loss is the mean square of the three
    ``log e_exp,n - log target_n`` and the gap their mean.
    """
    # One compiled function, traced once per problem: the scan (vmapped), the L-BFGS
    # derivative (jvp) and its line search reuse its jaxpr instead of tracing the DEM run and
    # the peak finder again (about a second each).
    return _stats(problem, jnp.asarray(beta, float))


@persistent_jit
def _stats(problem: CalibrationProblem, beta):
    pk, status = dem_peaks(problem, beta)
    if problem.kind == "e":
        gap = jnp.mean(jax.vmap(metrics.log_e_gap)(pk, problem.ref))
        shape = jnp.mean(jax.vmap(metrics.peak_loss)(pk, problem.ref))
        loss = gap * gap
    else:
        d = bounce_log_e(problem, pk) - jnp.log(problem.targets)[None, :]
        loss = jnp.mean(d * d)
        gap = jnp.mean(d)
        shape = loss
    own = jnp.mean(jax.vmap(metrics.log_e_fit)(pk))  # the DEM's own log e, target-free
    bad = jnp.any(status != STATUS_OK)
    return tuple(jnp.where(bad, jnp.nan, x) for x in (loss, gap, own, shape))


def window_error(dem: Response, ref_theta, t_last):
    """The paper's weighted-mean history error (:func:`rockjax.metrics.history_error`) of a DEM
    run against a reference history, weights 1 up to ``t_last`` [s] (the reference's last
    compared bounce) and 0 after [-]."""
    return metrics.history_error(dem.theta, ref_theta, (dem.t <= t_last).astype(float))


def history_stat(problem: CalibrationProblem, beta):
    """The history error of the DEM at ``beta`` [s] against Housner's reference, averaged over
    the releases (:func:`window_error`) [-]; NaN if a run failed. ``target="e"`` only: the
    loss of ``fit_beta(..., loss="history")``."""
    if problem.ref_theta is None:
        raise ValueError("the history error needs a Housner reference: target='e'.")
    return _history_stat(problem, jnp.asarray(beta, float))


@persistent_jit
def _history_stat(problem: CalibrationProblem, beta):
    def one(theta0, ref_theta, t_last):
        r = dem_run(problem, beta, theta0)
        return window_error(r, ref_theta, t_last), r.status

    err, status = jax.vmap(one)(problem.theta0, problem.ref_theta, problem.ref_t_last)
    return jnp.where(jnp.any(status != STATUS_OK), jnp.nan, jnp.mean(err))


@persistent_jit
def history_stat_batch(problem: CalibrationProblem, betas):
    """:func:`history_stat` at each of ``betas`` [s] (one compiled, vmapped batch)."""
    return jax.vmap(lambda b: history_stat(problem, b))(betas)


@persistent_jit
def stats_batch(problem: CalibrationProblem, betas):
    """:func:`stats` at each of ``betas`` [s] (one compiled, vmapped batch)."""
    return jax.vmap(lambda b: stats(problem, b))(betas)


def last_compared_time(resp: Response, problem: CalibrationProblem) -> float:
    """Time [s] of the last bounce of ``resp`` that keeps :data:`MIN_ENERGY_RATIO` of its
    release energy (the end of the window of the history error)."""
    pk = metrics.peaks(
        resp.t, resp.theta, resp.eta, problem.n_bounces, problem.mode, problem.hysteresis
    )
    return last_compared_peak_time(pk)


def last_compared_peak_time(pk: metrics.Peaks) -> float:
    """:func:`last_compared_time` from the peaks of one run (NumPy, on the host) [s]."""
    log_energy = np.asarray(pk.log_energy)
    keep = np.asarray(pk.valid) & (log_energy - log_energy[0] >= math.log(MIN_ENERGY_RATIO))
    return float(np.asarray(pk.t)[keep].max())


def housner_reference(problem: CalibrationProblem, e: float | None = None) -> list[Response]:
    """Housner's free rocking, one response per release, with the problem's target ``e`` (or
    ``e`` [-]; required for ``target="bounces"``, which has no Housner target), saved every
    :data:`SAVE_DT` over the problem's duration."""
    if e is None:
        if problem.kind != "e":
            raise ValueError("target='bounces' has no Housner target e; pass e.")
        e = float(problem.targets[0])
    th = np.asarray(problem.theta0)
    return housner_peaks(
        problem.block, float(e), th, problem.mode, problem.n_bounces, problem.duration
    )[1]


# --------------------------------------------------------------------------- set-up


def release(block: Block, theta0) -> np.ndarray:
    """The release rotations [rad] (default ``0.5 eta``) as ``|theta0|``, checked:
    ``0.05 eta <= |theta0| < eta``; ValueError with the fix otherwise."""
    eta = float(block.eta)
    th = np.atleast_1d(np.asarray(0.5 * eta if theta0 is None else theta0, float))
    if th.ndim != 1 or th.size == 0 or not np.all(np.isfinite(th)):
        raise ValueError(
            f"theta0 must be a release rotation [rad] or a 1-D list of them; got {theta0}."
        )
    if np.any(np.abs(th) >= eta) or np.any(np.abs(th) < 0.05 * eta):
        raise ValueError(
            f"theta0={th} rad: each release must satisfy 0.05 eta <= |theta0| < eta "
            f"(eta = {eta:.4g} rad); e.g. theta0=0.5*block.eta."
        )
    return np.abs(th)


def concrete_block(block: Block) -> Block:
    """``block`` with Python floats (ValueError for traced values: a fit is not traced)."""
    try:
        return jax.tree.map(lambda x: float(np.asarray(x)), block)
    except TypeError:  # a tracer (TracerArrayConversionError, ConcretizationTypeError)
        raise ValueError(
            "fit_beta/fit_e need a concrete Block (Python floats), not traced values."
        ) from None


DEM_PERIOD_MARGIN = 1.6
"""How much longer than Housner's a DEM free-rocking half-cycle may be [-]. On the converged
joint the pivot is a triangle of contact inside the corner, so the DEM rocks slower than
Housner's rigid block (0.375 x 6.44 m at beta = 0: 8 bounces in 17.3 s against 13.3 s, a
ratio of 1.3; docs/theory.md, "Statics and the rocking period")."""


DURATION_GROWTH = 1.5
"""Ratio between consecutive run durations of the fits [-]: every block whose free-rocking run
falls in one of these buckets shares the fit's compiled programs (a loop over geometries
compiles once per bucket), at the cost of runs at most this much longer than needed."""


def run_duration(block: Block, theta0: np.ndarray, n_bounces: int) -> float:
    """Duration [s] long enough for impact ``n_bounces + 1`` of the DEM at the largest release:
    Housner's time for it times :data:`DEM_PERIOD_MARGIN`, rounded up to a bucket of
    :data:`DURATION_GROWTH` (from 1 s, in whole half-seconds) so that similar blocks share a
    compilation."""
    t_full = float(free_rocking_period(block.p, block.eta, float(np.max(theta0))))
    need = DEM_PERIOD_MARGIN * (n_bounces + 2) * 0.5 * t_full
    k = max(0, math.ceil(math.log(need) / math.log(DURATION_GROWTH) - 1e-9))
    return math.ceil(2.0 * DURATION_GROWTH**k) / 2.0  # whole half-seconds


def default_beta_max(block: Block, mode: Mode) -> float:
    """``2 beta_DeJong`` for parapets; ``FACADE_BETA_MAX_HCRIT beta_Hcrit`` for facades [s]."""
    if mode.one_sided:
        return FACADE_BETA_MAX_HCRIT * float(beta_hcrit(block))
    return 2.0 * float(beta_dejong(block))


def default_target(mode: Mode | str) -> str:
    """The calibration target of a mode: ``"e"`` two-sided, ``"bounces"`` one-sided.

    A facade's one-sided Housner rocking with ``e = |e_ISR|`` keeps about 20 % of its energy per
    impact, so at most two bounces inform an ``e`` fit, and the measured facade bounces are not
    Housner's (their ``e_exp`` rises from ~68 % to ~100 % of ``|e_ISR|``,
    :data:`rockjax.calibration.BOUNCE_FRACTIONS`): the bounce targets are what a facade is
    calibrated to (the mode's ``default_target``, :mod:`rockjax.modes`).
    """
    return as_mode(mode).default_target


def check_e_target(e, mode: Mode) -> float:
    """The target restitution ``e`` [-] of a ``target="e"`` fit as a float, checked: one finite
    number with ``0 < e <= 1`` (one-sided: ``0 < |e| <= 1``, its magnitude is used)."""
    check_scalar("e", e, "[-]", "e.g. e=rj.e_housner(block) (Eq. 2) or a measured e.")
    e_val = float(np.asarray(e, dtype=float))
    mag = mode.e_magnitude(e_val)
    if 0.0 < mag <= 1.0:
        return e_val
    which = "0 < |e| <= 1" if mode.one_sided else "0 < e <= 1"
    fix = "Pass a measured restitution, e.g. e=0.9."
    if np.isfinite(e_val) and e_val <= 0.0 and not mode.one_sided:
        fix = (
            "Housner's e_H = 1 - 1.5 sin^2(eta) (Eq. 2) is <= 0 for a block with eta >= 54.7 "
            "deg (b/h >= 1.41), which does not rock by Housner's impact rule: pass a measured "
            "restitution in (0, 1] for it, e.g. e=0.9."
        )
    raise ValueError(
        f"e (target restitution, dimensionless) must satisfy {which} for mode={mode.name!r}; "
        f"got e={e_val:.4g}. {fix}"
    )


def check_n_bounces(n_bounces, default_hint: str = "") -> int:
    """``n_bounces`` (impacts compared) as an int >= 1, else ValueError."""
    if isinstance(n_bounces, bool) or not (
        isinstance(n_bounces, (int, np.integer)) and n_bounces >= 1
    ):
        raise ValueError(
            f"n_bounces (impacts compared) must be an int >= 1; got {n_bounces!r}.{default_hint}"
        )
    return int(n_bounces)


def housner_peaks(block, e, theta0, mode: Mode, n_bounces, duration):
    """``(peaks stacked over releases, responses)`` of Housner's free rocking with ``e`` from
    each of ``theta0`` [rad], saved every :data:`SAVE_DT` over ``duration`` [s] (a facade
    flush on its walls: Housner's has no gap)."""
    rigid = mode.without_gap()
    resps = [
        simulate_housner(block, e=e, mode=rigid, theta0=th, duration=duration, dt=SAVE_DT)
        for th in theta0
    ]
    ts, thetas = [r.t for r in resps], [r.theta for r in resps]
    eta = np.float64(block.eta)  # an array: one program for every block
    return _stacked_peaks(ts, thetas, eta, n_bounces, mode, hysteresis(mode)), resps


@persistent_jit
def _stacked_peaks(ts, thetas, eta, n_bounces, mode, hyst):
    # One compiled program (eager, the peak finder would compile each of its small operations
    # in every new process); the same numbers as eager, bit for bit.
    pks = [metrics.peaks(t, th, eta, n_bounces, mode, hyst) for t, th in zip(ts, thetas)]
    return jax.tree.map(lambda *x: jnp.stack(x), *pks)


TARGETS = ("e", "bounces")
"""The calibration targets: Housner's rocking with a restitution ``e``, or the facade bounce
targets (:data:`rockjax.calibration.BOUNCE_FRACTIONS`)."""


def check_target(target, e, mode: Mode) -> str:
    """The target of a calibration, resolved and checked once, at the public entry point
    (:func:`rockjax.fit_beta`, :func:`problem`): ``target`` (None: the mode's
    ``default_target``) one of :data:`TARGETS`, with the ``e`` and the ``mode`` it takes
    (``"e"``: a given ``e``; ``"bounces"``: a facade, no ``e``).

    Raises:
        ValueError: an unknown target or one that does not fit ``e`` and ``mode``, naming the
            fix.
    """
    defaulted = target is None
    if defaulted:
        target = mode.default_target
    check_choice("target", target, TARGETS)
    if target == "bounces":
        if not mode.one_sided:
            raise ValueError(
                "target='bounces' is the facade calibration (measured e_exp of bounces 1-3 as "
                "fractions of e_ISR); use mode='one_sided', or target='e' for a parapet."
            )
        if e is not None:
            if defaulted:
                raise ValueError(
                    "mode='one_sided' calibrates to the facade bounce targets by default "
                    "(target='bounces', which takes no e); drop e, or pass target='e' to match "
                    "Housner's one-sided rocking with this e instead."
                )
            raise ValueError("target='bounces' takes no e (its targets are fractions of e_ISR).")
    elif e is None:
        raise ValueError(
            "fit_beta needs the target restitution e (e.g. e=rj.e_housner(block), Eq. 2), or "
            "target='bounces' for a facade."
        )
    return target


def build_problem(
    block,
    e=None,
    *,
    target: str,
    mode: Mode,
    theta0=None,
    n_bounces=None,
    beta_max=None,
    joint=None,
) -> tuple[CalibrationProblem, list[Response]]:
    """:func:`problem` and the Housner reference responses it was built from (one per release;
    empty for ``target="bounces"``). ``mode`` is the object and ``target`` the one
    :func:`check_target` returned (checked once by the caller, with ``e``)."""
    joint = Joint() if joint is None else joint
    if not isinstance(joint, Joint):
        raise TypeError(
            f"joint must be a rockjax.Joint, e.g. rj.Joint(n_sub=2); got {type(joint).__name__}."
        )
    one_sided = mode.one_sided
    block = concrete_block(block)
    th = release(block, theta0)
    if n_bounces is None:
        n_bounces = 3 if (one_sided or target == "bounces") else 8
    else:
        n_bounces = check_n_bounces(
            n_bounces, " Leave it None for the default (8 two-sided, 3 one-sided)."
        )
    if target == "bounces":
        n_bounces = max(int(n_bounces), 3)
    if beta_max is None:
        beta_max = default_beta_max(block, mode)
    check_positive(
        "beta_max",
        beta_max,
        "s",
        "Leave beta_max=None for the default (2 beta_DeJong; 16 beta_Hcrit one-sided).",
        scalar=True,
    )
    beta_cap = 1.25 * float(beta_max)
    duration = run_duration(block, th, n_bounces)
    dt = stable_dt(block, beta_cap, mode=mode, joint=joint)
    resps = []
    ref_theta = ref_t_last = None
    if target == "e":
        e_val = check_e_target(e, mode)
        # Housner's bounce k keeps e^(2k) of the release energy (impact map x flight energy
        # conservation): refuse an uninformative e before running anything, then check the runs
        if e_val**2 < MIN_ENERGY_RATIO:
            _check_informative(None, e_val, th, mode, n_bounces)
        ref, resps = housner_peaks(block, e_val, th, mode, n_bounces, duration)
        _check_informative(ref, e_val, th, mode, n_bounces)
        targets = jax.device_put(np.asarray([abs(e_val)]))
        ref_theta = jax.device_put(np.stack([np.asarray(r.theta) for r in resps]))
        ref_t_last = jax.device_put(
            np.asarray(
                [
                    last_compared_peak_time(jax.tree.map(lambda x, i=i: np.asarray(x)[i], ref))
                    for i in range(th.size)
                ]
            )
        )
    else:
        zeros = jax.device_put(np.zeros((th.size, n_bounces + 1)))
        ref = metrics.Peaks(
            t=zeros,
            amplitude=zeros,
            log_energy=zeros,
            valid=jax.device_put(np.zeros((th.size, n_bounces + 1), bool)),
            n_impacts=jax.device_put(np.zeros(th.size, np.int32)),
        )
        targets = jax.device_put(np.asarray(BOUNCE_FRACTIONS) * abs(float(e_isr(block))))
    out = CalibrationProblem(
        # the geometry and the step as arrays, traced: one compile for every block of a bucket
        block=strong_scalars(block),
        # device_put, not jnp.asarray: that would compile a copy of each array in each process
        theta0=jax.device_put(th),
        ref=ref,
        targets=targets,
        dt=jax.device_put(np.float64(dt)),
        scale=jnp.asarray(1.0, float),
        beta_cap=jnp.asarray(beta_cap),
        # a facade's gap as an array: traced, as one compile serves every gap
        mode=mode
        if not one_sided
        else eqx.tree_at(lambda m: m.gap, mode, jax.device_put(np.float64(mode.gap))),
        kind=target,
        n_bounces=int(n_bounces),
        duration=duration,
        joint=joint,
        hysteresis=hysteresis(mode),
        ref_theta=ref_theta,
        ref_t_last=ref_t_last,
    )
    return out, resps


def problem(
    block: Block,
    e=None,
    *,
    target: str | None = None,
    mode: Mode | str = "two_sided",
    theta0=None,
    n_bounces: int | None = None,
    beta_max: float | None = None,
    joint: Joint | None = None,
    gap: float | None = None,
) -> CalibrationProblem:
    """The calibration problem of :func:`rockjax.fit_beta`, checked and set up.

    Evaluate it with :func:`stats` / :func:`stats_batch` (loss, signed gap, the DEM's own
    ``log e``, peak loss at a ``beta``), :func:`dem_run` (the DEM run at a ``beta``) and
    :func:`housner_reference` (the Housner runs its reference peaks ``.ref`` come from).

    Its arguments ``block, e, target, mode, theta0, n_bounces, beta_max, joint, gap`` are those
    of :func:`rockjax.fit_beta` (same defaults, same checks).

    Returns:
        A :class:`CalibrationProblem` (its ``scale`` is 1: ``fit_beta`` sets it from its scan).

    Raises:
        ValueError: as :func:`rockjax.fit_beta` before its scan (bad input, a target with no
            informative bounce).
    """
    mode = as_mode(mode, gap)
    return build_problem(
        block,
        e,
        target=check_target(target, e, mode),
        mode=mode,
        theta0=theta0,
        n_bounces=n_bounces,
        beta_max=beta_max,
        joint=joint,
    )[0]


def _check_informative(ref: metrics.Peaks | None, e, th, mode, n_bounces):
    """Refuse a target ``e`` whose Housner reference has no bounce that keeps
    :data:`MIN_ENERGY_RATIO` of its release energy: the loss would be identically zero."""
    if ref is not None:
        lu = np.asarray(ref.log_energy)
        use = np.asarray(ref.valid) & (lu - lu[:, :1] >= math.log(MIN_ENERGY_RATIO))
        if np.all(use[:, 1:].sum(axis=1) > 0):
            return
    fix = (
        "use target='bounces' (the facade default)"
        if mode.one_sided
        else "raise e, or calibrate to a measured e"
    )
    raise ValueError(
        f"target e={e:.4g} gives no informative bounce: Housner's free rocking with it from "
        f"theta0={np.round(th, 5).tolist()} rad keeps less than {100 * MIN_ENERGY_RATIO:g} % "
        f"of the release energy at each of its first {n_bounces} impacts (bounce k keeps e^(2k), "
        f"so e >= {math.sqrt(MIN_ENERGY_RATIO):.3f} is needed), and the calibration loss would "
        f"be identically zero. {fix[0].upper() + fix[1:]}."
    )


def _range_message(problem, g0, g1, beta_max, e_range, edge=False):
    if problem.kind == "e":
        e = float(problem.targets[0])
        lo, hi = e_range
        if problem.joint.dashpot == "clipped":
            fix = "; the 'clipped' dashpot saturates: use rj.Joint(dashpot='closed') for lower e"
        elif edge:
            fix = ""
        else:
            fix = ", or widen beta_max for lower e"
        if problem.mode.one_sided:
            fix += "; or use target='bounces' (the facade default)"
        where = (
            " (beyond it the DEM keeps no bounce with "
            f"{100 * MIN_ENERGY_RATIO:g} % of its release energy)"
            if edge
            else ""
        )
        return (
            f"target e={e:.4g} is not reachable by this DEM block: over beta in "
            f"[0, {beta_max:.4g}] s{where} its restitution spans e = {lo:.4f} (beta = "
            f"{beta_max:.4g} s) to {hi:.4f} (beta = 0; {problem.joint}). Pick e in that "
            f"range{fix}."
        )
    return (
        f"the facade bounce targets {np.round(np.asarray(problem.targets), 4).tolist()} are not "
        f"bracketed over beta in [0, {beta_max:.4g}] s (mean log-gap {g0:+.3g} at beta = 0, "
        f"{g1:+.3g} at beta_max); widen beta_max."
    )


def check_range(problem, scan, own_s, beta_max):
    """The reachable ``(e(beta_max), e(0))`` of a ``target="e"`` fit (None for bounces), or a
    ValueError where the DEM keeps no informative bounce at an end (the range is undefined).

    Args:
        problem: The problem. scan: ``beta`` values of the scan [s], from 0 to ``beta_max``.
        own_s: The DEM's own ``log e`` at each (:func:`stats`). beta_max: [s].
    """
    e_lo, e_hi = math.exp(float(own_s[-1])), math.exp(float(own_s[0]))
    one_sided = problem.mode.one_sided
    lost = (
        f"keeps no bounce with {100 * MIN_ENERGY_RATIO:g} % of its release energy within "
        f"{problem.n_bounces} impacts"
    )
    if not np.isfinite(e_hi):
        raise ValueError(
            f"this DEM block {lost} even at beta = 0 (or a run failed): nothing to calibrate. "
            "Check the block (E, rho), the release theta0 and n_bounces"
            + (", or the gap." if one_sided else ".")
        )
    if problem.kind != "e":
        return None
    if not np.isfinite(e_lo):
        ok = [float(b) for b, o in zip(scan, own_s) if np.isfinite(o)]
        where = (
            f" (the scan saw bounces up to beta = {max(ok):.4g} s; the step is sized for "
            "beta_max, so aim a little lower)"
            if len(ok) > 1
            else ""
        )
        raise ValueError(
            f"the reachable range of e is undefined at beta_max={beta_max:.4g} s: the DEM block "
            f"{lost} there (its restitution is below {math.sqrt(MIN_ENERGY_RATIO):.3f}). Lower "
            f"beta_max{where}"
            + (", or use target='bounces' (the facade default)." if one_sided else ".")
        )
    return (e_lo, e_hi)


def check_reachable(problem, g0, g1, beta_max, e_range, edge=False):
    """ValueError (with the reachable range and the fix) unless the signed gap changes sign
    between ``beta = 0`` (``g0 >= 0``) and ``beta_max`` (``g1 <= 0``); ``edge``: ``beta_max``
    is where the DEM's last informative bounce vanishes (the message says so)."""
    if not (np.isfinite(g0) and np.isfinite(g1)):
        raise ValueError(
            "a DEM calibration run failed (non-finite or unstable); check the block and beta_max."
        )
    if not (g0 >= 0.0 >= g1):
        raise ValueError(_range_message(problem, g0, g1, beta_max, e_range, edge))


# --------------------------------------------------------------------------- fit_e


class EProblem(eqx.Module):
    """:func:`rockjax.fit_e`: the DEM peaks (fixed) and what the Housner runs need."""

    block: Block
    theta0: jax.Array
    dem: metrics.Peaks
    mode: Mode  # as Housner's rigid block takes it (no gap)
    n_bounces: int = eqx.field(static=True)
    duration: float = eqx.field(static=True)
    hysteresis: float = eqx.field(static=True)


def housner_loss(v, problem: EProblem):
    """Peak loss of Housner's free rocking with ``e = sigmoid(v)`` against the DEM's peaks [-]
    (forward-mode derivatives through the solve, ``diffrax.ForwardMode``)."""
    import diffrax

    e = jax.nn.sigmoid(v)

    def one(theta0, ref):
        r = simulate_housner(
            problem.block,
            e=e,
            mode=problem.mode,
            theta0=theta0,
            duration=problem.duration,
            dt=SAVE_DT,
            adjoint=diffrax.ForwardMode(),
        )
        pk = metrics.peaks(
            r.t, r.theta, problem.block.eta, problem.n_bounces, problem.mode, problem.hysteresis
        )
        return metrics.peak_loss(pk, ref)

    return jnp.mean(jax.vmap(one)(problem.theta0, problem.dem))


# --------------------------------------------------------------------------- fit_history


class HistoryProblem(eqx.Module):
    """:func:`rockjax.fit_history`: the measured peaks and the DEM set-up (``b`` and ``beta``
    are the unknowns); :func:`history_problem` builds it."""

    block: Block
    theta0: jax.Array
    measured: metrics.Peaks
    beta_ref: jax.Array
    t_scale: jax.Array
    mode: Mode
    n_bounces: int = eqx.field(static=True)
    duration: float = eqx.field(static=True)
    save_dt: float = eqx.field(static=True)
    dt: float = eqx.field(static=True)
    hysteresis: float = eqx.field(static=True)


def history_params(problem: HistoryProblem, u):
    """``(beta [s], b [m])`` of the scaled unknowns ``u``: ``beta0 exp(u0)``, ``b exp(u1)``."""
    return problem.beta_ref * jnp.exp(u[0]), problem.block.b * jnp.exp(u[1])


def history_loss(u, problem: HistoryProblem):
    """Amplitude plus timing loss of the DEM at :func:`history_params` against the measured
    peaks [-]; NaN if the run failed."""
    beta, b = history_params(problem, u)
    blk = eqx.tree_at(lambda k: k.b, problem.block, b)
    r = simulate_dem(
        blk,
        beta=beta,
        mode=problem.mode,
        theta0=problem.theta0,
        duration=problem.duration,
        dt=problem.dt,
        save_dt=problem.save_dt,
        throw=False,
    )
    pk = metrics.peaks(r.t, r.theta, blk.eta, problem.n_bounces, problem.mode, problem.hysteresis)
    ref = problem.measured
    loss = metrics.amplitude_loss(pk, ref, MIN_ENERGY_RATIO) + metrics.timing_loss(
        pk, ref, problem.t_scale, MIN_ENERGY_RATIO
    )
    return jnp.where(r.status == STATUS_OK, loss, jnp.nan)


def history_problem(
    block: Block,
    measured: Response,
    beta0: float | None = None,
    mode: Mode | str = "two_sided",
    n_bounces: int = 8,
) -> HistoryProblem:
    """Checks and set-up of :func:`rockjax.fit_history` (also used to map its loss on a grid).

    Args: as :func:`rockjax.fit_history`.

    Raises:
        ValueError: a non-uniform or non-finite ``measured`` history, one with fewer than two
            impacts or no informative bounce, ``n_bounces < 1``, ``beta0 <= 0``.
    """
    mode = as_mode(mode)
    check_n_bounces(n_bounces)
    block = concrete_block(block)
    if not isinstance(measured, Response):
        raise ValueError(
            "measured must be a rockjax.Response (the fit reads measured.t [s] and "
            f"measured.theta [rad] of the free rocking); got {type(measured).__name__}. Pass "
            "the Response of a run (rj.simulate_dem) or of a test record."
        )
    t = np.asarray(measured.t, float)
    th = np.asarray(measured.theta, float)
    if t.ndim != 1 or t.size < 3 or not np.all(np.isfinite(th)):
        raise ValueError("measured must be a Response with finite, uniformly sampled theta(t).")
    save_dt = float(t[1] - t[0])
    if not np.allclose(np.diff(t), save_dt, rtol=1e-6, atol=1e-12):
        raise ValueError("measured.t must be uniform; resample the record first.")
    theta0 = float(th[0])
    eta = float(block.eta)
    release(block, theta0)
    hyst = hysteresis(mode)
    ref = metrics.peaks(t, th, eta, n_bounces, mode, hyst)
    if int(ref.n_impacts) < 2:
        raise ValueError("the measured history has fewer than two impacts; record longer.")
    w, _ = metrics.bounce_weights(ref, MIN_ENERGY_RATIO)
    if not float(jnp.sum(w)) > 0:
        raise ValueError(
            f"the measured history keeps no bounce with {100 * MIN_ENERGY_RATIO:g} % of its "
            "release energy: the loss would be identically zero; release from a larger theta0."
        )
    beta0 = 0.3 * float(beta_dejong(block)) if beta0 is None else float(beta0)
    if not beta0 > 0:
        raise ValueError(f"beta0 must be > 0 s (the fit works on log beta); got {beta0}.")
    wide = eqx.tree_at(lambda k: k.b, block, 1.5 * block.b)
    dt = 0.8 * min(stable_dt(block, 20 * beta0, mode=mode), stable_dt(wide, 20 * beta0, mode=mode))
    t_scale = float(ref.t[1])  # the first bounce's peak time: about one impact interval
    # The DEM runs two such intervals past the last compared measured peak, whatever the
    # record's length: a trial whose bounces come later than the measured ones (a narrower b,
    # less damping) must still show them, or the loss jumps by the bounce it missed (the
    # record's end used to cut them off, and L-BFGS stopped at that cliff).
    t_last = float(np.max(np.where(np.asarray(w) > 0, np.asarray(ref.t), 0.0)))
    return HistoryProblem(
        block=block,
        theta0=jnp.asarray(theta0),
        measured=ref,
        beta_ref=jnp.asarray(beta0),
        t_scale=jnp.asarray(t_scale),
        mode=mode,
        n_bounces=n_bounces,
        duration=t_last + 2.0 * t_scale,
        save_dt=save_dt,
        dt=float(dt),
        hysteresis=hyst,
    )
