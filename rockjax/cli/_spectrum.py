"""``rockjax spectrum``: the elastic response spectrum of a record or a pulse
(:func:`rockjax.response_spectrum`), and in a host building the floor spectra
(:func:`rockjax.floor_spectra`) beside the ground's; written as CSV
(:meth:`rockjax.spectra.Spectrum.to_dataframe`), a figure and a JSON summary."""

from __future__ import annotations

import argparse
import math
import time

import jax.numpy as jnp
import numpy as np

from .. import __version__, jsonio, plot
from ..building import floor_spectra
from ..constants import G
from ..spectra import DEFAULT_DAMPING, Spectrum, response_spectrum
from ._common import save
from ._options import (
    add_building_options,
    add_motion_options,
    add_output_options,
    building_of,
    building_text,
    command_line,
    motion_of,
    motion_text,
    outputs_of,
    parse_values,
)

PERIODS = "0:3:151"  # [s]: T = 0 (the PGA) to 3 s every 0.02 s, the range that rocks walls


def add_spectrum_parser(sub) -> None:
    p = sub.add_parser(
        "spectrum",
        help="elastic response spectrum of a record or a pulse (and floor spectra in a "
        "building); writes CSV, a figure and JSON",
        description=(
            "The pseudo-acceleration, displacement and pseudo-velocity response spectra of a "
            "record (--record) or an analytic pulse (--pulse): peaks of linear oscillators of "
            "damping --damping, by the exact piecewise-linear recurrence (rockjax.spectra). "
            "With a host building (--storeys, --building-period) the spectra of its floors too "
            "(rockjax.floor_spectra). Prints the PGA and the peak Sa, and writes spectrum.csv "
            "(one row per period), spectrum.png and spectrum.json into --out."
        ),
        allow_abbrev=False,
    )
    add_motion_options(p)
    p.add_argument(
        "--periods",
        default=PERIODS,
        metavar="START:STOP:N|T1,T2,...",
        help=f"oscillator periods [s], >= 0 (0 gives the PGA): N evenly spaced from START to "
        f"STOP, or a list (default {PERIODS})",
    )
    p.add_argument(
        "--damping",
        type=float,
        default=DEFAULT_DAMPING,
        metavar="ZETA",
        help=f"damping ratio of the oscillators [-] (default {DEFAULT_DAMPING:g})",
    )
    add_building_options(p, storey=False)
    add_output_options(p, "spectrum")
    p.set_defaults(run=_spectrum)


def _spectrum(args: argparse.Namespace) -> int:
    t_start = time.perf_counter()
    files = outputs_of(args, "spectrum")  # before any run
    periods = parse_values(
        "--periods", args.periods, "s", f"e.g. --periods {PERIODS} or --periods 0,0.2,0.5,1"
    )
    if not (math.isfinite(args.damping) and 0.0 <= args.damping < 1.0):
        raise ValueError(
            f"--damping is a damping ratio (dimensionless) in [0, 1); got --damping "
            f"{args.damping:g}. E.g. --damping 0.05 for 5 %."
        )
    motion = motion_of(args)
    building = building_of(args)
    where = "" if building is None else f" in a {building_text(building)}"
    print(
        f"rockjax {__version__} spectrum: {motion_text(motion)}{where}; {periods.size} periods "
        f"from {periods[0]:g} to {periods[-1]:g} s, {100 * args.damping:g} % damping -> "
        f"{files.folder}/",
        flush=True,
    )
    spec = response_spectrum(motion, periods, args.damping)
    labels = ["ground"]
    if building is not None:
        floors = floor_spectra(building, motion, periods, args.damping)
        spec = Spectrum(
            periods=spec.periods,
            damping=spec.damping,
            sd=jnp.concatenate([spec.sd[None], floors.sd]),
            sa=jnp.concatenate([spec.sa[None], floors.sa]),
        )
        labels += [f"floor {k + 1}" for k in range(building.n_storeys)]
    files.folder.mkdir(parents=True, exist_ok=True)
    df = spec.to_dataframe(labels if building is not None else None)
    df.to_csv(files.csv, float_format="%.12g")
    ax = plot.spectrum(spec, labels=labels if building is not None else None)
    ax.set_title(f"{motion.name}{where}", fontsize="medium")
    save(ax, files.figure)

    sa = np.atleast_2d(np.asarray(spec.sa, dtype=float))
    peaks = []
    for label, row in zip(labels, sa, strict=True):
        k = int(np.argmax(row))
        peaks.append(
            {
                "motion": label,
                "pga_g": float(row[0]) / G if periods[0] == 0 else None,
                "sa_max_g": float(row[k]) / G,
                "t_at_sa_max_s": float(periods[k]),
            }
        )
        pga = "" if periods[0] != 0 else f"PGA {float(row[0]) / G:.4g} g, "
        print(f"{label:<9s} {pga}peak Sa = {float(row[k]) / G:.4g} g at T = {periods[k]:.4g} s")
    summary = {
        "rockjax_version": __version__,
        "command": command_line("spectrum", args),
        "motion": {
            "name": motion.name,
            "pga_g": float(motion.pga_g),
            "dt_s": motion.dt,
            "duration_s": motion.duration,
        },
        "damping": args.damping,
        "periods_s": periods,
        "building": None
        if building is None
        else {
            "n_storeys": building.n_storeys,
            "periods_s": np.asarray(building.periods),
            "damping": float(building.damping),
        },
        "peaks": peaks,
        "files": files.names,
    }
    jsonio.write_json(files.summary, summary)
    print(
        f"wrote {', '.join(files.names)} to {files.folder}/ in "
        f"{time.perf_counter() - t_start:.1f} s",
        flush=True,
    )
    return 0
