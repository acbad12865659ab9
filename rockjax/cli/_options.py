"""The options that ``rockjax simulate``, ``spectrum`` and ``pushover`` share, each group with
its parser arguments and the function that turns them into rockjax objects: the block, the
record or pulse (units always explicit), the mode, the DEM joint, the host building, the
output folder and its figure format, and lists of numbers (``START:STOP:N`` or ``A,B,C``).

Every bad value raises ``ValueError`` naming the option, its value, its unit and the fix;
:func:`rockjax.cli.main` prints it as one ``error: ...`` line (exit status 2)."""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..block import Block
from ..building import ShearBuilding
from ..constants import G
from ..contact import SHEAR_RELEASES, Joint
from ..modes import MODE_NAMES, Mode, as_mode
from ..motion import GroundMotion
from ..pulses import SHAPES, pulse
from ..records import CSV_UNITS, read_at2, read_csv
from ..spectra import DEFAULT_DAMPING
from ._common import check_outputs
from ._demo_inputs import PARAPET_B, PARAPET_H
from ._ida import FIGURE_FORMATS

PULSE_DT = 0.005  # [s], the sampling step of a --pulse (the demo's records')
STOREY_HEIGHT = 3.0  # [m], the default storey height of a --storeys building
JOINT_CHOICES = "face, corners or an integer N >= 2"
LAW_FIELDS = ("lambda_0", "Delta_1", "Delta_2", "Delta_u")  # a three-branch law's numbers


# ----------------------------------------------------------------------------- the block


def add_block_options(p: argparse.ArgumentParser) -> None:
    """``--b``, ``--h`` (the paper's parapet by default), ``--rho``, ``--E``."""
    p.add_argument(
        "--b",
        type=float,
        default=PARAPET_B,
        metavar="M",
        help=f"thickness [m] (default {PARAPET_B})",
    )
    p.add_argument(
        "--h", type=float, default=PARAPET_H, metavar="M", help=f"height [m] (default {PARAPET_H})"
    )
    p.add_argument(
        "--rho", type=float, default=None, metavar="KG_M3", help="density [kg/m^3] (default 1800)"
    )
    p.add_argument(
        "--E", type=float, default=None, metavar="PA", help="Young's modulus [Pa] (default 1.8e9)"
    )


def block_of(args: argparse.Namespace, h: float | None = None) -> Block:
    """The block of ``--b``, ``--h`` (or ``h`` [m], a part of the wall), ``--rho``, ``--E``."""
    material = {k: v for k, v in (("rho", args.rho), ("E", args.E)) if v is not None}
    try:
        return Block(b=args.b, h=args.h if h is None else h, **material)
    except ValueError as err:
        raise ValueError(
            f"--b {args.b:g} --h {args.h:g} (metres; --rho kg/m^3, --E Pa): {err}"
        ) from None


def block_text(block: Block) -> str:
    return f"{float(block.b):g} x {float(block.h):g} m"


# ----------------------------------------------------------------------------- the motion


def add_motion_options(p: argparse.ArgumentParser, *, free: bool = False) -> None:
    """A record file (``--record``, with ``--units`` where the file does not state them) or an
    analytic pulse (``--pulse``); with ``free``, neither is a free release (``--duration``)."""
    group = p.add_mutually_exclusive_group(required=not free)
    group.add_argument(
        "--record",
        metavar="FILE",
        help="a PEER .AT2 file, or a CSV/text file of time and acceleration (its units from "
        "its header, e.g. 'acc [m/s2]', or from --units)",
    )
    group.add_argument(
        "--pulse",
        choices=SHAPES,
        help="an analytic pulse: MH (Ricker wavelet), AR (antisymmetric Ricker), SC (one sine "
        "cycle), with --pga-g and --pulse-period",
    )
    p.add_argument(
        "--units",
        choices=tuple(CSV_UNITS),
        default=None,
        help="units of a CSV record's acceleration, where its header does not state them",
    )
    p.add_argument(
        "--column",
        default=None,
        metavar="INDEX|NAME",
        help="the acceleration column of a CSV record with several (0-based index or name)",
    )
    p.add_argument(
        "--scale", type=float, default=1.0, metavar="X", help="scale factor of the record [-]"
    )
    p.add_argument("--pga-g", type=float, default=None, metavar="G", help="peak of the --pulse [g]")
    p.add_argument(
        "--pulse-period", type=float, default=None, metavar="S", help="period of the --pulse [s]"
    )


def motion_of(args: argparse.Namespace) -> GroundMotion | None:
    """The record or pulse of the options, scaled by ``--scale``; None for a free release."""
    pulse_only = (("--pga-g", args.pga_g), ("--pulse-period", args.pulse_period))
    record_only = (("--units", args.units), ("--column", args.column))
    if args.pulse is None:
        for flag, value in pulse_only:
            if value is not None:
                raise ValueError(f"{flag} belongs to --pulse; give --pulse MH|AR|SC, or drop it.")
    if args.record is None:
        for flag, value in record_only:
            if value is not None:
                raise ValueError(
                    f"{flag} belongs to a CSV --record; give --record FILE, or drop it."
                )
    if not (math.isfinite(args.scale) and args.scale > 0):
        raise ValueError(
            f"--scale (the record's scale factor, dimensionless) must be positive; got --scale "
            f"{args.scale:g}. E.g. --scale 1.5."
        )
    if args.record is not None:
        motion = _read_record(args)
    elif args.pulse is not None:
        motion = _pulse(args)
    else:
        return None
    return motion if args.scale == 1.0 else motion.scaled(args.scale)


def _read_record(args: argparse.Namespace) -> GroundMotion:
    path = Path(args.record)
    if not path.is_file():
        raise ValueError(f"--record {path}: no such file; give a .AT2 or CSV record file.")
    try:
        if path.suffix.upper() == ".AT2":
            if args.units is not None or args.column is not None:
                raise ValueError(
                    f"{path}: a PEER .AT2 file states its units and holds one column; drop "
                    "--units and --column."
                )
            return read_at2(path)
        column = args.column
        if column is not None and column.lstrip("-").isdigit():
            column = int(column)
        return read_csv(path, units=args.units, column=column)
    except ValueError as err:
        text = str(err)
        if "units=" in text:  # the reader's fix, in the command's words
            text += f" On the command line: --units {' or --units '.join(CSV_UNITS)}."
        if "column=" in text:
            text += " On the command line: --column INDEX|NAME."
        raise ValueError(f"--record {text}") from None


def _pulse(args: argparse.Namespace) -> GroundMotion:
    for flag, value, unit, example in (
        ("--pga-g", args.pga_g, "g", "--pga-g 0.4"),
        ("--pulse-period", args.pulse_period, "s", "--pulse-period 0.5"),
    ):
        if value is None:
            raise ValueError(f"--pulse {args.pulse} needs {flag} (in {unit}), e.g. {example}.")
        if not (math.isfinite(value) and value > 0):
            raise ValueError(
                f"{flag} must be positive, in {unit}; got {flag} {value:g}. E.g. {example}."
            )
    name = f"{args.pulse} pulse, {args.pga_g:g} g, T = {args.pulse_period:g} s"
    return pulse(args.pulse, args.pga_g * G, args.pulse_period, dt=PULSE_DT, name=name)


def motion_text(motion: GroundMotion) -> str:
    return (
        f"{motion.name} (pga {float(motion.pga_g):.3g} g, dt {motion.dt:g} s, "
        f"{motion.duration:.4g} s)"
    )


# ----------------------------------------------------------------------------- mode and joint


def add_mode_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--mode",
        choices=MODE_NAMES,
        default="two_sided",
        help="two_sided: parapet; one_sided: facade on its return walls (default: two_sided)",
    )
    p.add_argument(
        "--gap",
        type=float,
        default=None,
        metavar="M",
        help="DEM, one_sided: gap between the facade and its return walls [m] (default 0)",
    )


def mode_of(args: argparse.Namespace) -> Mode:
    try:
        return as_mode(args.mode, args.gap)
    except ValueError as err:
        gap = "" if args.gap is None else f" --gap {args.gap:g} (metres)"
        raise ValueError(f"--mode {args.mode}{gap}: {err}") from None


def add_joint_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--joint",
        default=None,
        metavar="KIND",
        help="the DEM joint: face (the contact law integrated over each face, the converged "
        "joint), corners (two point contacts at the corners, the paper's 3DEC model) or N "
        "point contacts per face, an integer >= 2 (default: face)",
    )
    p.add_argument(
        "--shear-release",
        choices=SHEAR_RELEASES,
        default=None,
        help="the face joint's shear history rule (default: uniform)",
    )


def joint_of(args: argparse.Namespace) -> Joint:
    """The DEM joint of ``--joint`` and ``--shear-release``."""
    kind = "face" if args.joint is None else args.joint.strip()
    if kind in ("face", "exact"):
        n_sub = "exact"
    elif kind == "corners":
        n_sub = 2
    elif kind.isdigit() and int(kind) >= 2:
        n_sub = int(kind)
    else:
        raise ValueError(
            f"--joint is the DEM joint: {JOINT_CHOICES} (point contacts per face); got --joint "
            f"{args.joint}. E.g. --joint corners (the paper's model) or --joint face."
        )
    if args.shear_release is not None and n_sub != "exact":
        raise ValueError(
            f"--shear-release is the integrated face joint's rule; --joint {args.joint} is point "
            "contacts, each with its own shear spring. Drop --shear-release, or use --joint face."
        )
    return Joint(n_sub=n_sub, shear_release=args.shear_release or "uniform")


def joint_text(joint: Joint) -> str:
    if joint.face:
        return f"face joint ({joint.shear_release} shear release)"
    return "corner contacts" if joint.n_sub == 2 else f"{joint.n_sub} point contacts per face"


# ----------------------------------------------------------------------------- the building


def add_building_options(p: argparse.ArgumentParser, *, storey: bool = True) -> None:
    p.add_argument(
        "--storeys",
        type=int,
        default=None,
        metavar="N",
        help="a host building: a uniform linear shear building of N storeys (with "
        "--building-period)",
    )
    p.add_argument(
        "--building-period",
        type=float,
        default=None,
        metavar="S",
        help="the building's fundamental period [s] (about 0.1 s per storey for URM)",
    )
    p.add_argument(
        "--building-damping",
        type=float,
        default=None,
        metavar="ZETA",
        help=f"the building's damping ratio [-] in every mode (default {DEFAULT_DAMPING:g})",
    )
    p.add_argument(
        "--storey-height",
        type=float,
        default=None,
        metavar="M",
        help=f"the building's storey height [m] (default {STOREY_HEIGHT:g})",
    )
    if storey:
        p.add_argument(
            "--storey",
            type=int,
            default=None,
            metavar="S",
            help="the storey the block stands in, on floor S-1 (1: the ground); a parapet "
            "(two_sided) stands on the roof by default (S = N+1), a facade (one_sided) in "
            "storey 1, its return walls moving with the storey",
        )


def building_of(args: argparse.Namespace) -> ShearBuilding | None:
    """The host building of ``--storeys`` and ``--building-period`` (None without them)."""
    extra = (
        ("--building-period", args.building_period),
        ("--building-damping", args.building_damping),
        ("--storey-height", args.storey_height),
        ("--storey", getattr(args, "storey", None)),
    )
    if args.storeys is None:
        for flag, value in extra:
            if value is not None:
                raise ValueError(
                    f"{flag} describes the host building; give --storeys N and "
                    "--building-period S too, or drop it."
                )
        return None
    if args.storeys < 1:
        raise ValueError(
            f"--storeys (the building's storeys) must be an integer >= 1; got --storeys "
            f"{args.storeys}."
        )
    if args.building_period is None:
        raise ValueError(
            "--storeys needs --building-period, the fundamental period in s, e.g. "
            f"--building-period {0.1 * args.storeys:g} (about 0.1 s per storey for URM)."
        )
    damping = DEFAULT_DAMPING if args.building_damping is None else args.building_damping
    height = STOREY_HEIGHT if args.storey_height is None else args.storey_height
    for flag, value, unit in (
        ("--building-period", args.building_period, "s"),
        ("--storey-height", height, "m"),
    ):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{flag} must be positive, in {unit}; got {flag} {value:g}.")
    if not (math.isfinite(damping) and 0.0 <= damping < 1.0):
        raise ValueError(
            f"--building-damping is a damping ratio (dimensionless) in [0, 1); got "
            f"--building-damping {damping:g}. E.g. --building-damping 0.05 for 5 %."
        )
    try:
        return ShearBuilding.uniform(args.storeys, height, args.building_period, damping)
    except ValueError as err:
        raise ValueError(f"--storeys / --building-period / --storey-height: {err}") from None


def building_text(bldg: ShearBuilding) -> str:
    periods = np.asarray(bldg.periods)
    return (
        f"{bldg.n_storeys}-storey shear building, T1 = {float(periods[0]):.3g} s, "
        f"{100 * float(bldg.damping):g} % damping"
    )


# ----------------------------------------------------------------------------- outputs


@dataclass(frozen=True)
class Outputs:
    """The files a command writes into its ``--out`` folder: the CSV table, the figure and the
    JSON summary, named after the command."""

    folder: Path
    csv: Path
    figure: Path
    summary: Path

    @property
    def names(self) -> list[str]:
        return [self.csv.name, self.figure.name, self.summary.name]


def add_output_options(p: argparse.ArgumentParser, command: str) -> None:
    p.add_argument(
        "--out",
        default=f"{command}_out",
        metavar="DIR",
        help=f"output folder (default: {command}_out)",
    )
    p.add_argument(
        "--figure-format",
        choices=FIGURE_FORMATS,
        default="png",
        help="format of the figure: png (raster) or pdf/svg (vector) (default: png)",
    )


def outputs_of(args: argparse.Namespace, command: str) -> Outputs:
    """The output files, checked before any run (a bad path loses no work)."""
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} exists and is not a folder; give a folder path.")
    files = Outputs(
        folder=out,
        csv=out / f"{command}.csv",
        figure=out / f"{command}.{args.figure_format}",
        summary=out / f"{command}.json",
    )
    check_outputs("--out", [files.csv, files.figure, files.summary])
    return files


# ----------------------------------------------------------------------------- numbers


def parse_values(flag: str, text: str, unit: str, example: str) -> np.ndarray:
    """``START:STOP:N`` (N evenly spaced values, ends included) or ``A,B,C`` as a float array,
    finite, >= 0 and increasing."""
    try:
        if ":" in text:
            start, stop, num = text.split(":")
            if int(num) < 2:
                raise ValueError
            values = np.linspace(float(start), float(stop), int(num))
        else:
            values = np.array([float(v) for v in text.split(",")])
    except ValueError:
        raise ValueError(
            f"{flag} {text!r} cannot be read; give START:STOP:N (N >= 2 values) or a list "
            f"A,B,C, in {unit}: {example}."
        ) from None
    if not (np.all(np.isfinite(values)) and np.all(values >= 0) and np.all(np.diff(values) > 0)):
        raise ValueError(f"{flag} {text!r} must give increasing values >= 0, in {unit}: {example}.")
    return values


def command_line(command: str, args: argparse.Namespace) -> str:
    """The command as run, every option spelled out (defaults included), for the summaries."""
    parts = ["rockjax", command]
    for key, value in vars(args).items():
        if key in ("run", "command") or value is None or value is False:
            continue
        flag = "--" + key.replace("_", "-")
        parts += (
            [flag]
            if value is True
            else [flag, f"{value:g}" if isinstance(value, float) else str(value)]
        )
    return " ".join(parts)
