"""``rockjax simulate``: one history of one block under a record, a pulse or a free release,
by the DEM, Housner or Housner with a three-branch law, on the ground or in a host building;
written as CSV (:meth:`rockjax.Response.to_dataframe`), a figure and a JSON summary."""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import __version__, jsonio, plot
from ..block import Block
from ..building import ShearBuilding
from ..contact import Joint
from ..dem import simulate_dem
from ..housner import simulate_housner
from ..modes import Mode
from ..motion import GroundMotion
from ..pushover import pushover
from ..relations import beta_dejong
from ..response import STATUS_MESSAGES, Response
from ..three_branch import ThreeBranchLaw, fit_three_branch
from ._common import block_info, save
from ._demo_inputs import DT_OUT
from ._options import (
    LAW_FIELDS,
    add_block_options,
    add_building_options,
    add_joint_options,
    add_mode_options,
    add_motion_options,
    add_output_options,
    block_of,
    block_text,
    building_of,
    building_text,
    command_line,
    joint_of,
    joint_text,
    mode_of,
    motion_of,
    motion_text,
    outputs_of,
)

MODEL_NAMES = {"dem": "DEM", "housner": "Housner", "three-branch": "Housner, three-branch law"}
MODELS = tuple(MODEL_NAMES)  # --model
TAIL = 2.0  # [s] of free rocking after a record, by default (as rockjax ida)


def add_simulate_parser(sub) -> None:
    p = sub.add_parser(
        "simulate",
        help="one history of one block under a record or a pulse; writes CSV, a figure and JSON",
        description=(
            "Run one block under a record (--record, a PEER .AT2 or CSV file) or an analytic "
            "pulse (--pulse), or released from --theta0 without ground motion, with the DEM "
            "(--beta), Housner (--e) or Housner with a three-branch law (--law), on the ground "
            "or in a host building (--storeys, --building-period, --storey). Prints the peak "
            "|theta|/eta and whether the block overturned, and writes simulate.csv (the history, "
            "one row per sample), simulate.png and simulate.json into --out. Exit status 1 when "
            "the run failed numerically (the files are still written), 2 on invalid input."
        ),
        allow_abbrev=False,
    )
    add_block_options(p)
    add_motion_options(p, free=True)
    add_mode_options(p)
    p.add_argument("--model", choices=MODELS, default="dem", help="(default: dem)")
    p.add_argument(
        "--beta",
        type=float,
        default=None,
        metavar="S",
        help="DEM stiffness-proportional damping [s] (default: rj.beta_dejong(block), "
        "uncalibrated: calibrate it with rockjax calibrate)",
    )
    p.add_argument(
        "--e",
        type=float,
        default=None,
        metavar="E",
        help="Housner and three-branch restitution [-] (default: e_H, Eq. 2, two-sided; "
        "|e_1SR|, Eq. 5, one-sided)",
    )
    p.add_argument(
        "--law",
        default=None,
        metavar="pushover|FILE.json|L0,D1,D2,DU",
        help="three-branch: the law fitted to the block's DEM pushover (pushover, the "
        "default), the pushover.json that rockjax pushover writes, or lambda_0, Delta_1, "
        "Delta_2, Delta_u (dimensionless; Deltas as fractions of b)",
    )
    add_joint_options(p)
    add_building_options(p)
    p.add_argument(
        "--theta0",
        type=float,
        default=0.0,
        metavar="FRAC",
        help="initial rotation as a fraction of eta, in (-1, 1) (default 0); with no record "
        "or pulse, a free release (give --duration)",
    )
    p.add_argument(
        "--duration",
        type=float,
        default=None,
        metavar="S",
        help=f"length of the run [s] (default: the record's + {TAIL:g} s of free rocking; "
        "the record is padded with zeros or cut to it)",
    )
    add_output_options(p, "simulate")
    p.set_defaults(run=_simulate)


@dataclass(frozen=True)
class Setup:
    """One run of ``rockjax simulate``, checked: the block, its mode and model with their
    parameters, and its supports (the ground motion, the base it stands on, its walls)."""

    block: Block
    mode: Mode
    model: str
    motion: GroundMotion | None  # the ground's, as given
    base: GroundMotion | None  # what the block stands on for the whole run: the ground, or a floor
    wall_motion: object  # a facade's moving return walls, or None
    building: ShearBuilding | None
    storey: int | None
    params: dict  # the model's: beta and joint (DEM), e and law (Housner)
    theta0: float  # [rad]
    duration: float | None  # [s] of a free release; None: the record's (padded to the run)


def _simulate(args: argparse.Namespace) -> int:
    t_start = time.perf_counter()
    files = outputs_of(args, "simulate")  # before any run
    setup = _setup(args)
    print(
        f"rockjax {__version__} simulate: block {block_text(setup.block)}, {setup.mode.name}, "
        f"{_model_text(setup)}; {_load_text(setup)} -> {files.folder}/",
        flush=True,
    )
    resp = _run(setup)
    files.folder.mkdir(parents=True, exist_ok=True)
    _write_csv(setup, resp, files.csv)
    _figure(setup, resp, files.figure)
    summary = _summary(setup, args, resp) | {"files": files.names}
    jsonio.write_json(files.summary, summary)
    ratio, step = summary["theta_max_over_eta"], summary["dt_step_s"]
    print(
        f"peak |theta|/eta = {ratio:.4f}  (theta_max = {summary['theta_max_rad']:.5g} rad, "
        f"eta = alpha = {float(resp.eta):.5g} rad)"
    )
    print(f"overturned       = {'YES' if summary['overturned'] else 'no'}")
    print(f"model            = {MODEL_NAMES[setup.model]}, time step {step:.3g} s")
    print(
        f"wrote {', '.join(files.names)} to {files.folder}/ in "
        f"{time.perf_counter() - t_start:.1f} s",
        flush=True,
    )
    if summary["status"] != 0:
        print(
            f"error: the run failed (status {summary['status']}: {summary['status_message']}); "
            "the files hold the history up to the failure.",
            file=sys.stderr,
        )
        return 1
    return 0


def _write_csv(setup: Setup, resp: Response, path: Path) -> None:
    """:meth:`rockjax.Response.to_dataframe`, with the base's absolute acceleration as run
    (``ag [m/s^2]``, zero after the record) in front."""
    df = resp.to_dataframe()
    ag = np.zeros(len(df))
    if setup.base is not None:
        n = min(len(df), setup.base.n)
        ag[:n] = np.asarray(setup.base.ag)[:n]
    df.insert(0, "ag [m/s^2]", ag)
    df.to_csv(path, float_format="%.12g")


def _summary(setup: Setup, args: argparse.Namespace, resp: Response) -> dict:
    """``simulate.json``: the inputs and the run's peak, collapse flag, status and step."""
    status = int(resp.status)
    return {
        "rockjax_version": __version__,
        "command": command_line("simulate", args),
        "block": block_info(setup.block),
        "mode": setup.mode.name,
        "gap_m": float(getattr(setup.mode, "gap", 0.0)),
        "model": setup.model,
        **_params_info(setup),
        "motion": None if setup.motion is None else _motion_info(setup.motion, args.scale),
        "building": _building_info(setup),
        "theta0_over_eta": args.theta0,
        "duration_s": float(np.asarray(resp.t)[-1]),
        "theta_max_rad": float(resp.theta_max),
        "theta_max_over_eta": float(resp.theta_max) / float(resp.eta),
        "overturned": bool(resp.overturned),
        "status": status,
        "status_message": STATUS_MESSAGES.get(status, "unknown status"),
        "dt_step_s": float(np.asarray(resp.extras.get("dt", math.nan))),
    }


# ----------------------------------------------------------------------------- checks


def _setup(args: argparse.Namespace) -> Setup:
    """The run of the options, every combination checked before any computation."""
    model = args.model
    block = block_of(args)
    mode = mode_of(args)
    _check_model_options(args, mode)
    if not (math.isfinite(args.theta0) and -1.0 < args.theta0 < 1.0):
        raise ValueError(
            f"--theta0 is the initial rotation as a fraction of eta (dimensionless) and must "
            f"lie in (-1, 1); got --theta0 {args.theta0:g}. E.g. --theta0 0.5."
        )
    if args.duration is not None and not (math.isfinite(args.duration) and args.duration > 0):
        raise ValueError(
            f"--duration (the run's length) must be positive, in s; got --duration "
            f"{args.duration:g}. E.g. --duration 10."
        )
    motion = motion_of(args)
    if motion is None and (args.theta0 == 0.0 or args.duration is None):
        raise ValueError(
            "give a ground motion: --record FILE or --pulse MH|AR|SC (with --pga-g and "
            "--pulse-period); or, for free rocking, --theta0 FRAC and --duration S."
        )
    building = building_of(args)
    duration, ground = args.duration, motion
    if motion is not None:
        # the run's record: the ground's, padded with zeros (or cut) to the run's length, so
        # that a building's floors and walls keep moving after the ground stops
        duration = motion.duration + TAIL if duration is None else duration
        n = int(round(duration / motion.dt)) + 1
        ag = np.zeros(n)
        ag[: min(n, motion.n)] = np.asarray(motion.ag)[:n]
        ground = GroundMotion(ag=ag, dt=motion.dt, name=motion.name, meta=motion.meta)
        duration = None  # the record's
    base, walls, storey = _placement(args, building, ground, mode)
    return Setup(
        block=block,
        mode=mode,
        model=model,
        motion=motion,
        base=base,
        wall_motion=walls,
        building=building,
        storey=storey,
        params=_params(args, block, mode),
        theta0=args.theta0 * float(block.eta),
        duration=duration,
    )


def _check_model_options(args: argparse.Namespace, mode: Mode) -> None:
    dem = args.model == "dem"
    if dem and args.e is not None:
        raise ValueError(
            f"--e (restitution) is a Housner parameter; --model dem takes --beta [s]. Got "
            f"--e {args.e:g}: drop it, or use --model housner."
        )
    if not dem and args.beta is not None:
        raise ValueError(
            f"--beta (DEM damping, in s) is not a Housner parameter; --model {args.model} "
            f"takes --e. Got --beta {args.beta:g}: drop it, or use --model dem."
        )
    if args.model != "three-branch" and args.law is not None:
        raise ValueError(
            f"--law is the three-branch model's capacity law; --model {args.model} has none. "
            "Use --model three-branch, or drop --law."
        )
    pushover_law = args.model == "three-branch" and args.law in (None, "pushover")
    if not dem and not pushover_law:
        for flag, value in (("--joint", args.joint), ("--shear-release", args.shear_release)):
            if value is not None:
                raise ValueError(
                    f"{flag} is the DEM's contact joint; --model {args.model} is a rigid block "
                    "on its corners. Drop it, or use --model dem."
                )
    if not dem and getattr(mode, "gap", 0.0) != 0.0:
        raise ValueError(
            f"--gap {args.gap:g} (metres): Housner's facade rests flush on its return walls; "
            "the gap is the DEM's (--model dem). Drop --gap."
        )
    if args.beta is not None and not (math.isfinite(args.beta) and args.beta >= 0):
        raise ValueError(
            f"--beta (DEM damping) must be >= 0, in s; got --beta {args.beta:g}. E.g. "
            "--beta 0.002, or leave it out for beta_DeJong."
        )
    if args.e is not None and not (math.isfinite(args.e) and 0.0 < args.e <= 1.0):
        raise ValueError(
            f"--e (restitution, dimensionless) must lie in (0, 1]; got --e {args.e:g}. E.g. "
            "--e 0.9, or leave it out for the paper's default."
        )


def _params(args: argparse.Namespace, block: Block, mode: Mode) -> dict:
    """The model's parameters: ``beta`` [s] and ``joint`` (DEM), ``e`` [-] (None: the
    simulator's default) and ``law`` (three-branch)."""
    if args.model == "dem":
        beta = float(beta_dejong(block)) if args.beta is None else args.beta
        return {"beta": beta, "beta_default": args.beta is None, "joint": joint_of(args)}
    params = {"e": args.e}
    if args.model == "three-branch":
        params |= _law(args, block, mode)
    return params


def _law(args: argparse.Namespace, block: Block, mode: Mode) -> dict:
    """``{"law": ThreeBranchLaw, "law_from": text}`` of ``--law``."""
    text = "pushover" if args.law is None else args.law.strip()
    if text == "pushover":
        joint = joint_of(args)
        fit = fit_three_branch(pushover(block, mode, joint=joint))
        return {
            "law": fit.law,
            "law_from": f"fitted to the block's DEM pushover ({joint_text(joint)})",
        }
    path = Path(text)
    if path.suffix.lower() == ".json":
        if not path.is_file():
            raise ValueError(
                f"--law {path}: no such file; give the pushover.json of rockjax pushover, "
                "'pushover', or four numbers L0,D1,D2,DU."
            )
        try:
            data = json.loads(path.read_text())
            values = data.get("law", data) if isinstance(data, dict) else None
            numbers = [float(values[k]) for k in LAW_FIELDS]
        except (ValueError, TypeError, KeyError):
            raise ValueError(
                f"--law {path}: not a three-branch law; the file must hold "
                f"{', '.join(LAW_FIELDS)} (at the top or under 'law', as rockjax pushover "
                "writes them)."
            ) from None
        source = f"from {path}"
    else:
        try:
            numbers = [float(v) for v in text.split(",")]
            if len(numbers) != 4:
                raise ValueError
        except ValueError:
            raise ValueError(
                f"--law {text!r} cannot be read; give 'pushover', a JSON file, or four numbers "
                "lambda_0,Delta_1,Delta_2,Delta_u (dimensionless; the Deltas as fractions of b), "
                "e.g. --law 0.133,0.005,0.14,0.97."
            ) from None
        source = "given"
    try:
        law = ThreeBranchLaw(**dict(zip(LAW_FIELDS, numbers, strict=True)))
    except ValueError as err:
        raise ValueError(f"--law: {err}") from None
    return {"law": law, "law_from": source}


def _placement(args, building, motion, mode):
    """``(base, wall_motion, storey)``: the motion the block stands on and its facade's moving
    return walls, in the host building (a parapet on floor ``storey - 1``, the roof by
    default; a facade in storey ``storey``, 1 by default, its walls moving with the storey's
    floors), or on the ground."""
    if building is None:
        return motion, None, None
    if motion is None:
        raise ValueError(
            "--storeys: a building moves under a ground motion; give --record or --pulse."
        )
    n = building.n_storeys
    top = n if mode.one_sided else n + 1
    storey = (1 if mode.one_sided else n + 1) if args.storey is None else args.storey
    if not 1 <= storey <= top:
        where = (
            "a facade stands in a storey, between two floors: 1 to N"
            if mode.one_sided
            else "a parapet stands on floor S-1: 1 (the ground) to N+1 (the roof)"
        )
        raise ValueError(
            f"--storey must lie in 1..{top} for --storeys {n} ({where}); got --storey {storey}."
        )
    if storey == 1 and not mode.one_sided:
        return motion, None, storey
    floors = building.floor_motions(motion)
    base = motion if storey == 1 else floors[storey - 2]
    if not mode.one_sided:
        return base, None, storey
    if storey == 1:  # the building's exact storey drift
        return base, building, storey
    height = float(np.asarray(building.storey_heights)[storey - 1])
    return base, [(height, floors[storey - 1])], storey


# ----------------------------------------------------------------------------- the run


def _run(setup: Setup) -> Response:
    free = setup.base is None  # the output step of a free release
    common = dict(
        mode=setup.mode, theta0=setup.theta0, duration=setup.duration, throw=False,
        wall_motion=setup.wall_motion,
    )  # fmt: skip
    if setup.model == "dem":
        p = setup.params
        return simulate_dem(
            setup.block, setup.base, beta=p["beta"], joint=p["joint"],
            save_dt=DT_OUT if free else None, **common,
        )  # fmt: skip
    return simulate_housner(
        setup.block, setup.base, e=setup.params["e"], law=setup.params.get("law"),
        dt=DT_OUT if free else None, **common,
    )  # fmt: skip


def _figure(setup: Setup, resp: Response, path: Path) -> None:
    title = f"{block_text(setup.block)} {setup.mode.name.replace('_', '-')} block, {setup.model}"
    label = MODEL_NAMES[setup.model]
    if setup.base is None:
        ax = plot.time_history({label: resp}, title=f"{title}, free rocking")
        save(ax, path)
        return
    plt = plot.pyplot()
    _, (ax_g, ax_t) = plt.subplots(
        2, 1, figsize=(7.0, 5.5), sharex=True, height_ratios=[1, 2], layout="constrained"
    )
    plot.ground_motion(setup.base, ax=ax_g, title=title)
    ax_g.set_xlabel("")
    plot.time_history({label: resp}, ax=ax_t)
    save(ax_t, path)


# ----------------------------------------------------------------------------- texts


def _model_text(setup: Setup) -> str:
    p = setup.params
    if setup.model == "dem":
        default = " = beta_DeJong, uncalibrated" if p["beta_default"] else ""
        return f"DEM (beta = {p['beta']:.4g} s{default}; {joint_text(p['joint'])})"
    if p["e"] is None:  # the simulator's default, named
        mode = setup.mode
        e_default = mode.e_magnitude(float(mode.default_e(setup.block)))
        e = f"e = {e_default:.4g}, " + ("|e_1SR| (Eq. 5)" if mode.one_sided else "e_H (Eq. 2)")
    else:
        e = f"e = {p['e']:g}"
    if setup.model == "housner":
        return f"Housner ({e})"
    law = p["law"]
    numbers = ", ".join(f"{k} = {float(getattr(law, k)):.4g}" for k in LAW_FIELDS)
    return f"three-branch ({e}; law {p['law_from']}: {numbers})"


def _load_text(setup: Setup) -> str:
    if setup.motion is None:
        return f"free rocking from {setup.theta0:.4g} rad for {setup.duration:g} s"
    text = motion_text(setup.motion)
    if setup.building is not None:
        floor = "the ground" if setup.storey == 1 else f"floor {setup.storey - 1}"
        text += f" in a {building_text(setup.building)}, storey {setup.storey} (base on {floor})"
    return text


def _params_info(setup: Setup) -> dict:
    p = setup.params
    if setup.model == "dem":
        joint: Joint = p["joint"]
        return {
            "beta_s": p["beta"],
            "beta_is_default": p["beta_default"],
            "joint": {"n_sub": joint.n_sub, "shear_release": joint.shear_release},
        }
    info = {"e": p["e"]}
    if "law" in p:
        info["law"] = {k: float(getattr(p["law"], k)) for k in LAW_FIELDS}
        info["law_from"] = p["law_from"]
    return info


def _motion_info(motion: GroundMotion, scale: float) -> dict:
    return {
        "name": motion.name,
        "scale": scale,
        "pga_m_s2": float(motion.pga),
        "pga_g": float(motion.pga_g),
        "dt_s": motion.dt,
        "duration_s": motion.duration,
    }


def _building_info(setup: Setup) -> dict | None:
    bldg = setup.building
    if bldg is None:
        return None
    return {
        "n_storeys": bldg.n_storeys,
        "periods_s": np.asarray(bldg.periods),
        "damping": float(bldg.damping),
        "storey_heights_m": np.asarray(bldg.storey_heights),
        "storey": setup.storey,
    }
