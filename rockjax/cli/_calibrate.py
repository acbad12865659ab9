"""``rockjax calibrate``: the DEM damping ``beta`` of one block fitted to a restitution or to a
facade's measured bounces (:func:`rockjax.fit_beta`), written as a figure and JSON."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from .. import __version__, jsonio, plot
from ..block import Block
from ..contact import Joint
from ..modes import Facade, Parapet, as_mode
from ..relations import beta_dejong, e_housner, e_isr
from ._common import block_info, check_outputs, fmt_e, save
from ._demo_inputs import RELEASE

CALIBRATE_FILES = ("calibration.png", "calibration.json")  # `rockjax calibrate`'s, into --out


def add_calibrate_parser(sub) -> None:
    from ..calibration import BOUNCE_FRACTIONS, E_TOL, LOSSES, METHODS, MODES, TARGETS

    fractions = "/".join(f"{100 * f:g}" for f in BOUNCE_FRACTIONS)
    p = sub.add_parser(
        "calibrate",
        help="fit the DEM damping beta to a restitution e; writes a figure and JSON",
        description=(
            "Fit the DEM's stiffness-proportional damping beta [s] of one block so that its "
            "free rocking matches Housner's with restitution e (rockjax.fit_beta; bounce "
            "log-energy loss, L-BFGS by default). Facades (--mode one_sided) are calibrated "
            f"by default to their measured bounces (--target bounces): the DEM's e_exp of "
            f"bounces 1-3 is fitted to {fractions} % of |e_1SR|. "
            "Prints beta and the DEM's effective e; writes calibration.png (both time histories "
            "and the loss history) and calibration.json into --out. Exit status 1 when the fit "
            f"does not converge (--target e: |e_effective - e| <= {E_TOL:g}; bounces: the best "
            "match, the minimum of the loss; whether each e_exp is in its measured band is "
            "printed and written as target_met), with the reason; 2 on invalid input or an "
            "unreachable target."
        ),
        allow_abbrev=False,
    )
    p.add_argument("--b", type=float, required=True, metavar="M", help="block thickness [m]")
    p.add_argument("--h", type=float, required=True, metavar="M", help="block height [m]")
    p.add_argument(
        "--e",
        type=float,
        default=None,
        metavar="E",
        help="target Housner restitution [-], --target e only (default: e_H, Eq. 2; "
        "|e_1SR|, Eq. 5, with --mode one_sided --target e)",
    )
    p.add_argument(
        "--mode",
        choices=MODES,
        default=None,
        help="two_sided: parapet; one_sided: facade (default: two_sided; one_sided with "
        "--target bounces)",
    )
    p.add_argument(
        "--target",
        choices=TARGETS,
        default=None,
        help="e: match Housner with --e; bounces: facade bounce ratios (default: e two-sided, "
        "bounces one-sided)",
    )
    p.add_argument(
        "--theta0",
        type=float,
        default=RELEASE,
        metavar="FRAC",
        help=f"release rotation as a fraction of eta, in [0.05, 1) (default {RELEASE:g})",
    )
    p.add_argument(
        "--E", type=float, default=None, metavar="PA", help="Young's modulus [Pa] (default 1.8e9)"
    )
    p.add_argument(
        "--rho", type=float, default=None, metavar="KG_M3", help="density [kg/m^3] (default 1800)"
    )
    p.add_argument(
        "--beta-max",
        type=float,
        default=None,
        metavar="S",
        help="upper end of the beta search [s] (default: 2 beta_DeJong; 16 beta_Hcrit one-sided)",
    )
    p.add_argument(
        "--method",
        choices=METHODS,
        default="lbfgs",
        help="lbfgs (gradient), grid (256 points) or root (false position) (default: lbfgs)",
    )
    p.add_argument(
        "--n-sub",
        default="exact",
        metavar="N",
        help="the DEM joint: 'exact' (the contact law integrated over the face, the converged "
        "joint) or sub-contacts per face, an integer >= 2 (2: the paper's corner contacts) "
        "(default: exact)",
    )
    p.add_argument(
        "--loss",
        choices=LOSSES,
        default="peaks",
        help="peaks: the bounce log-energy loss; history: the paper's weighted-mean time-history "
        "error against Housner with --e, from the peaks optimum (--target e, --method lbfgs; "
        "default: peaks)",
    )
    p.add_argument(
        "--out",
        default="calibration_out",
        metavar="DIR",
        help="output folder (default: calibration_out)",
    )
    p.set_defaults(run=_calibrate)


def _calibrate(args: argparse.Namespace) -> int:
    from ..calibration import BOUNCE_BANDS, BOUNCE_FRACTIONS, fit_beta

    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} exists and is not a folder; give a folder path.")
    check_outputs("--out", [out / name for name in CALIBRATE_FILES])  # before the fit
    if args.mode is not None:
        mode = as_mode(args.mode)
    else:  # the mode whose default target is --target's
        mode = Facade() if args.target == Facade.default_target else Parapet()
    target = args.target or ("e" if args.loss == "history" else mode.default_target)
    if target == "bounces":
        if not mode.one_sided:
            raise ValueError(
                "--target bounces is the facade calibration; it needs --mode one_sided "
                "(or use --target e for a parapet)."
            )
        if args.e is not None and args.target is None:
            raise ValueError(
                "--mode one_sided calibrates to the facade bounce targets by default and takes "
                f"no --e; drop --e {args.e:g}, or add --target e to match Housner's one-sided "
                "rocking with it."
            )
        if args.e is not None:
            raise ValueError(
                f"--target bounces takes no --e (its targets are fractions of |e_1SR|); "
                f"got --e {args.e:g}."
            )
    if not (math.isfinite(args.theta0) and 0.05 <= args.theta0 < 1.0):
        raise ValueError(
            f"--theta0 is the release rotation as a fraction of eta and must lie in [0.05, 1); "
            f"got --theta0 {args.theta0:g}."
        )
    if args.e is not None and not (math.isfinite(args.e) and 0.0 < args.e <= 1.0):
        raise ValueError(
            f"--e (restitution, dimensionless) must lie in (0, 1]; got --e {args.e:g}."
        )
    material = {k: v for k, v in (("E", args.E), ("rho", args.rho)) if v is not None}
    block = Block(b=args.b, h=args.h, **material)  # raises ValueError on bad input
    joint = _joint_of(args.n_sub)
    eta = float(block.eta)
    e_h = float(e_housner(block))
    e_1sr = abs(float(e_isr(block)))
    b_dj = float(beta_dejong(block))
    e = None
    if target == "e":
        e = args.e if args.e is not None else mode.e_magnitude(float(mode.default_e(block)))
        if args.e is None and not e > 0.0:
            # Eq. 2 (or 5) leaves its range for squat blocks: e_H < 0 is no restitution
            which = "|e_1SR| (Eq. 5)" if mode.one_sided else "e_H (Eq. 2)"
            raise ValueError(
                f"the default target {which} = {e:.3g} is not a restitution coefficient for "
                f"this squat block ({args.b:g} x {args.h:g} m, h/b = {args.h / args.b:.3g}): the "
                "closed form holds for slender blocks. Give a measured value with --e, e.g. "
                "--e 0.9."
            )
    if e is not None:
        default = " (default: |e_1SR|, Eq. 5)" if mode.one_sided else " (default: e_H, Eq. 2)"
        goal = f"e = {e:.4f}" + (default if args.e is None else "")
    else:
        values = " / ".join(f"{f * e_1sr:.4f}" for f in BOUNCE_FRACTIONS)
        percents = "/".join(f"{100 * f:g}" for f in BOUNCE_FRACTIONS)
        goal = f"bounces 1-3: e_exp = {values} ({percents} % of |e_1SR| = {e_1sr:.4f})"
    print(
        f"rockjax {__version__} calibrate: block {args.b:g} x {args.h:g} m ({mode.name}), eta = "
        f"{eta:.4f} rad, beta_DeJong = {b_dj:.4g} s; release {args.theta0:g} eta; "
        f"method {args.method} -> {out}/",
        flush=True,
    )
    print(f"target: {goal}", flush=True)
    fit = fit_beta(
        block,
        e,
        target=target,
        mode=mode,
        theta0=args.theta0 * eta,
        beta_max=args.beta_max,
        method=args.method,
        loss=args.loss,
        joint=joint,
    )
    e_exp_fit = np.asarray(fit.e_exp, float)
    print(f"beta         = {fit.beta:.6g} s  ({fit.beta / b_dj:.4f} beta_DeJong)", flush=True)
    print(f"e_effective  = {fit.e_effective:.5f}  (DEM, least squares on bounce energies)")
    print(f"e_exp 1-3    = {fmt_e(e_exp_fit)}  (DEM, Eq. 6)")
    if fit.e_range is not None:
        print(
            f"reachable e  = {fit.e_range[0]:.4f} (beta_max = {fit.beta_max:.4g} s) to "
            f"{fit.e_range[1]:.4f} (beta = 0)"
        )
    else:
        print(f"searched     = beta in [0, {fit.beta_max:.4g}] s")
    extra = "" if fit.history_error is None else f", history error {fit.history_error:.4g}"
    if fit.loss_kind == "history":
        extra = f" (history error; from the peaks optimum beta = {fit.beta_start:.6g} s)"
    print(f"loss         = {fit.loss:.3g}{extra}")
    print(
        f"iterations   = {fit.n_iterations} ({'converged' if fit.converged else 'NOT converged'}), "
        f"simulations = {fit.n_simulations}, {fit.seconds:.1f} s (first call includes compilation)",
        flush=True,
    )
    if target == "bounces":
        pct = " / ".join(f"{100 * v / e_1sr:.1f}" for v in e_exp_fit)
        bands = " / ".join(f"{100 * lo:g}-{100 * hi:g}" for lo, hi in BOUNCE_BANDS)
        print(f"e_exp/|e_1SR| = {pct} % (measured bands {bands} %)")
        met = "yes" if fit.target_met else f"no, the best match: {fit.target_missed}"
        print(f"target met   = {met}", flush=True)

    out.mkdir(parents=True, exist_ok=True)
    axes = plot.calibration(fit)
    axes[0].set_title(
        f"{args.b:g} x {args.h:g} m {mode.name.replace('_', '-')} block, release "
        f"{args.theta0:g} eta: beta = {fit.beta:.4g} s"
    )
    png = save(axes[0], out / "calibration.png")
    result = {
        "rockjax_version": __version__,
        "command": "rockjax " + " ".join(_calibrate_argv(args)),
        "block": block_info(block) | {"e_H": e_h, "e_1sr": e_1sr, "beta_dejong_s": b_dj},
        "mode": mode.name,
        "target": target,
        "theta0_over_eta": args.theta0,
        "e_target": fit.e,
        "bounce_targets": None if target == "e" else [f * e_1sr for f in BOUNCE_FRACTIONS],
        "beta_s": fit.beta,
        "beta_over_beta_dejong": fit.beta / b_dj,
        "e_effective": fit.e_effective,
        "e_exp": e_exp_fit,
        "e_range": None if fit.e_range is None else list(fit.e_range),
        "beta_max_s": fit.beta_max,
        "loss": fit.loss,
        "history_error": fit.history_error,
        "history": {k: np.asarray(v) for k, v in fit.history.items()},
        "n_simulations": fit.n_simulations,
        "n_iterations": fit.n_iterations,
        "converged": fit.converged,
        "reason": fit.reason,
        "target_met": fit.target_met,
        "target_missed": fit.target_missed,
        "joint_n_sub": joint.n_sub,
        "loss_kind": fit.loss_kind,
        "beta_start_s": fit.beta_start,
        "method": fit.method,
        "seconds": fit.seconds,
        "dem_status": int(fit.dem.status),
        "files": [png, "calibration.json"],
    }
    jsonio.write_json(out / "calibration.json", result)
    print(f"wrote {png} and calibration.json to {out}/", flush=True)
    if not fit.converged:
        print(f"not converged: {fit.reason}", file=sys.stderr)
        return 1
    return 0


def _joint_of(n_sub: str) -> Joint:
    """The DEM joint of ``--n-sub``: ``"exact"`` or an integer >= 2 (ValueError otherwise)."""
    if n_sub == "exact":
        return Joint()
    try:
        n = int(n_sub)
    except ValueError:
        n = 0
    if n < 2 or str(n) != n_sub.strip():
        raise ValueError(
            f"--n-sub is the DEM joint: 'exact' or sub-contacts per face, an integer >= 2; got "
            f"--n-sub {n_sub}. E.g. --n-sub 2 (the paper's corner contacts)."
        )
    return Joint(n_sub=n)


def _calibrate_argv(args: argparse.Namespace) -> list[str]:
    parts = ["calibrate", "--b", f"{args.b:g}", "--h", f"{args.h:g}"]
    for flag, value in (("--e", args.e), ("--E", args.E), ("--rho", args.rho)):
        if value is not None:
            parts += [flag, f"{value:g}"]
    if args.mode is not None:
        parts += ["--mode", args.mode]
    if args.target is not None:
        parts += ["--target", args.target]
    parts += ["--theta0", f"{args.theta0:g}"]
    if args.beta_max is not None:
        parts += ["--beta-max", f"{args.beta_max:g}"]
    if args.n_sub != "exact":
        parts += ["--n-sub", str(args.n_sub)]
    if args.loss != "peaks":
        parts += ["--loss", args.loss]
    return parts + ["--method", args.method, "--out", str(args.out)]
