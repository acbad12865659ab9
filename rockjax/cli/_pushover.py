"""``rockjax pushover``: the DEM pushover of a block or a stack (:func:`rockjax.pushover`) and
the three-branch law fitted to it (:func:`rockjax.fit_three_branch`); written as CSV
(:meth:`rockjax.Capacity.to_dataframe`), a figure and a JSON summary holding the law, which
``rockjax simulate --model three-branch --law FILE.json`` reads."""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from .. import __version__, jsonio, plot
from ..assembly import TOPS, Assembly
from ..modes import Mode
from ..pushover import MAX_D_OVER_B, Capacity, pushover
from ..relations import beta_dejong
from ..three_branch import fit_three_branch
from ._common import block_info, save
from ._options import (
    LAW_FIELDS,
    add_block_options,
    add_joint_options,
    add_mode_options,
    add_output_options,
    block_of,
    block_text,
    command_line,
    joint_of,
    joint_text,
    mode_of,
    outputs_of,
)


def add_pushover_parser(sub) -> None:
    p = sub.add_parser(
        "pushover",
        help="DEM pushover of a block or a stack and its three-branch fit; writes CSV, a figure "
        "and JSON",
        description=(
            "Pull a block (or a stack of --blocks equal blocks, --h in all) quasi-statically "
            "sideways with the DEM (rockjax.pushover: a displacement-controlled spring at the "
            "centroid) to --d-over-b, and fit the three-branch capacity law to the curve "
            "(rockjax.fit_three_branch). Prints the peak load multiplier and the law, and "
            "writes pushover.csv (the curve), pushover.png (with the law) and pushover.json "
            "(the law: rockjax simulate --model three-branch --law pushover.json) into --out."
        ),
        allow_abbrev=False,
    )
    add_block_options(p)
    p.add_argument(
        "--blocks",
        type=int,
        default=1,
        metavar="N",
        help="a stack of N equal blocks of height --h / N (default 1: one block)",
    )
    p.add_argument(
        "--top",
        choices=TOPS,
        default=None,
        help="a stack's top: free, or restrained by a floor (default: free)",
    )
    add_mode_options(p)
    p.add_argument(
        "--overburden",
        type=float,
        default=0.0,
        metavar="N_M",
        help="vertical load on the top face [N per m of wall] (default 0)",
    )
    p.add_argument(
        "--beta",
        type=float,
        default=None,
        metavar="S",
        help="DEM damping of the contact vibrations [s] (default: rj.beta_dejong(block))",
    )
    add_joint_options(p)
    p.add_argument(
        "--d-over-b",
        type=float,
        default=1.0,
        metavar="X",
        help=f"top displacement to pull to over b [-], at most {MAX_D_OVER_B:g} (default 1)",
    )
    p.add_argument(
        "--n-out", type=int, default=400, metavar="N", help="samples of the curve (default 400)"
    )
    p.add_argument(
        "--fix-lambda0",
        action="store_true",
        help="fit the three Deltas only, lambda_0 fixed at the rigid limit (as the paper does)",
    )
    add_output_options(p, "pushover")
    p.set_defaults(run=_pushover)


def _pushover(args: argparse.Namespace) -> int:
    t_start = time.perf_counter()
    files = outputs_of(args, "pushover")  # before any run
    mode = mode_of(args)
    body, what = _body(args, mode)
    joint = joint_of(args)
    if args.beta is not None and not (math.isfinite(args.beta) and args.beta >= 0):
        raise ValueError(
            f"--beta (DEM damping) must be >= 0, in s; got --beta {args.beta:g}. E.g. --beta "
            "0.002, or leave it out for beta_DeJong."
        )
    if not args.n_out >= 6:
        raise ValueError(
            f"--n-out (samples of the curve) must be an integer >= 6 (the three-branch fit "
            f"needs 6 points); got --n-out {args.n_out}."
        )
    if not (math.isfinite(args.d_over_b) and 0.0 < args.d_over_b <= MAX_D_OVER_B):
        raise ValueError(
            f"--d-over-b is the top displacement to reach over b (dimensionless), in (0, "
            f"{MAX_D_OVER_B:g}]; got --d-over-b {args.d_over_b:g}. E.g. --d-over-b 1 (where a "
            "rigid block's capacity is zero); not percent."
        )
    beta_text = "beta_DeJong" if args.beta is None else f"{args.beta:g} s"
    print(
        f"rockjax {__version__} pushover: {what}, {mode.name}, beta = {beta_text}, "
        f"{joint_text(joint)}; to d/b = {args.d_over_b:g} in {args.n_out} samples -> "
        f"{files.folder}/",
        flush=True,
    )
    kwargs = dict(beta=args.beta, d_over_b=args.d_over_b, n_out=args.n_out, joint=joint)
    if isinstance(body, Assembly):
        cap = pushover(body, **kwargs)
    else:
        cap = pushover(body, mode, args.overburden, **kwargs)
    lam0 = float(cap.lambda_rigid) if args.fix_lambda0 else None
    try:
        fit = fit_three_branch(cap, lambda_0=lam0)
        reason = None
    except ValueError as err:
        fit, reason = None, str(err)

    files.folder.mkdir(parents=True, exist_ok=True)
    cap.to_dataframe().to_csv(files.csv, float_format="%.12g")
    ax = plot.pushover(cap, fit)
    ax.set_title(f"{what}, {mode.name.replace('_', '-')}", fontsize="medium")
    save(ax, files.figure)
    peak = _peak(cap)
    beta = args.beta
    if beta is None and not isinstance(body, Assembly):
        beta = float(beta_dejong(body))  # rj.pushover's default for a block
    summary = {
        "rockjax_version": __version__,
        "command": command_line("pushover", args),
        "block": block_info(body.blocks[0] if isinstance(body, Assembly) else body),
        "n_blocks": args.blocks,
        "top": args.top or "free",
        "mode": mode.name,
        "gap_m": float(getattr(mode, "gap", 0.0)),
        "overburden_n_m": args.overburden,
        "beta_s": beta,  # None: a stack's default, its blocks' smallest beta_DeJong
        "joint": {"n_sub": joint.n_sub, "shear_release": joint.shear_release},
        "lambda_rigid": float(cap.lambda_rigid),
        **peak,
        "fitted": fit is not None,
        "law": None if fit is None else {k: float(getattr(fit.law, k)) for k in LAW_FIELDS},
        "lambda_p": None if fit is None else float(fit.law.lambda_p),
        "fit_rmse": None if fit is None else float(fit.rmse),
        "fit_max_error": None if fit is None else float(fit.max_error),
        "lambda_0_fixed": args.fix_lambda0,
        "reason": reason,
        "files": files.names,
    }
    jsonio.write_json(files.summary, summary)
    print(
        f"peak lambda    = {peak['lambda_max']:.4g} at d/b = {peak['d_over_b_at_max']:.4g} "
        f"(rigid limit {float(cap.lambda_rigid):.4g})"
    )
    if fit is None:
        print(f"three-branch   = not fitted ({reason})")
    else:
        law = fit.law
        print(
            f"three-branch   = lambda_0 {float(law.lambda_0):.4g}"
            f"{' (fixed)' if args.fix_lambda0 else ''}, Delta_1 {float(law.Delta_1):.4g}, "
            f"Delta_2 {float(law.Delta_2):.4g}, Delta_u {float(law.Delta_u):.4g} (fractions of "
            f"b); lambda_p {float(law.lambda_p):.4g}; rmse {float(fit.rmse):.2g}"
        )
    print(
        f"wrote {', '.join(files.names)} to {files.folder}/ in "
        f"{time.perf_counter() - t_start:.1f} s",
        flush=True,
    )
    return 0


def _body(args: argparse.Namespace, mode: Mode):
    """The block, or the stack of ``--blocks`` equal blocks, and its description."""
    if args.blocks < 1:
        raise ValueError(
            f"--blocks (blocks in the stack) must be an integer >= 1; got --blocks {args.blocks}."
        )
    if args.blocks == 1:
        if args.top is not None:
            raise ValueError(
                "--top is a stack's top restraint; give --blocks N (N >= 2), or drop --top."
            )
        block = block_of(args)
        return block, f"block {block_text(block)}"
    if mode.one_sided or args.gap is not None:
        raise ValueError(
            "--mode one_sided / --gap: a stack (--blocks >= 2) stands free on the ground; "
            "drop --mode and --gap (the facade pushover is of one block)."
        )
    if not (math.isfinite(args.overburden) and args.overburden >= 0):
        raise ValueError(
            f"--overburden must be >= 0, in N per m of wall; got --overburden {args.overburden:g}."
        )
    part = block_of(args, h=args.h / args.blocks)
    stack = Assembly.stack([part] * args.blocks, top=args.top or "free", overburden=args.overburden)
    return stack, (
        f"stack of {args.blocks} blocks {block_text(part)} ({args.top or 'free'} top"
        f"{f', overburden {args.overburden:g} N/m' if args.overburden else ''})"
    )


def _peak(cap: Capacity) -> dict:
    lam = np.asarray(cap.load_multiplier, dtype=float)
    k = int(np.argmax(lam))
    return {"lambda_max": float(lam[k]), "d_over_b_at_max": float(np.asarray(cap.d_over_b)[k])}
