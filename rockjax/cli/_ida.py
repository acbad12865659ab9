"""``rockjax ida``: an incremental dynamic analysis of one block under record sets or ``.AT2``
files, written as NetCDF with its CSV table, figures and fragility summary."""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from pathlib import Path

import numpy as np

from .. import __version__, jsonio, plot
from ..block import Block
from ..constants import G
from ..models import DEM, as_model
from ..modes import MODE_NAMES, as_mode
from ..relations import beta_dejong
from ..response import STATUS_MESSAGES
from ._common import check_outputs, save
from ._demo_inputs import PARAPET_B, PARAPET_H

FIGURE_FORMATS = ("png", "pdf", "svg")  # matplotlib writes each without extra packages


def add_ida_parser(sub) -> None:
    from ..records import FEMA_P695_SETS

    p = sub.add_parser(
        "ida",
        help="incremental dynamic analysis of one block under record sets; writes NetCDF, CSV, "
        "figures and a fragility summary",
        description=(
            "Run one block under every record at every scale factor (rockjax.ida) and write the "
            "(record x scale) Dataset to NetCDF, with the IDA table (CSV), the IDA and fragility "
            "figures and the fragility summary (JSON) next to it. Records: the FEMA P695 sets "
            "(both horizontal components of each record; needs `pip install rockjax[records]`) "
            "and/or PEER .AT2 files (or folders of them)."
        ),
        allow_abbrev=False,
    )
    p.add_argument("--b", type=float, default=PARAPET_B, metavar="M", help="block thickness [m]")
    p.add_argument("--h", type=float, default=PARAPET_H, metavar="M", help="block height [m]")
    p.add_argument(
        "--records",
        nargs="+",
        required=True,
        metavar="SET|PATH",
        help=f"record sets ({', '.join(FEMA_P695_SETS)}), .AT2 files or folders of .AT2 files",
    )
    p.add_argument(
        "--normalized",
        action="store_true",
        help="FEMA P695 sets: use the normalized records (recorded x normalization factor)",
    )
    p.add_argument("--model", choices=("dem", "housner"), default="dem", help="(default: dem)")
    p.add_argument(
        "--mode",
        choices=MODE_NAMES,
        default="two_sided",
        help="two_sided: parapet; one_sided: facade (default: two_sided)",
    )
    p.add_argument(
        "--beta",
        type=float,
        default=None,
        metavar="S",
        help="DEM stiffness-proportional damping [s] (default: rj.beta_dejong(block))",
    )
    p.add_argument(
        "--e",
        type=float,
        default=None,
        metavar="E",
        help="Housner restitution coefficient (default: e_H two-sided, |e_1SR| one-sided)",
    )
    p.add_argument(
        "--scales",
        default="0.05:2.0:40",
        metavar="START:STOP:N|S1,S2,...",
        help="scale factors: N evenly spaced from START to STOP, or a list (default 0.05:2.0:40)",
    )
    p.add_argument("--gap", type=float, default=0.0, metavar="M", help="DEM one-sided gap [m]")
    p.add_argument(
        "--tail", type=float, default=2.0, metavar="S", help="free vibration after records [s]"
    )
    p.add_argument(
        "--chunk-size",
        type=int,
        default=None,
        metavar="N",
        help="runs per compiled batch (default 64 per device)",
    )
    p.add_argument(
        "--im",
        default="pga",
        metavar="IM",
        help="intensity measure of the IDA and its fragility: pga, pgv or sa(T), e.g. sa(0.5) "
        "(default: pga)",
    )
    p.add_argument(
        "--figure-format",
        choices=FIGURE_FORMATS,
        default="png",
        help="format of the IDA and fragility figures: png (raster) or pdf/svg (vector) "
        "(default: png)",
    )
    p.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar on stderr (default: only when stderr is a terminal)",
    )
    p.add_argument(
        "--out",
        required=True,
        metavar="FILE.nc",
        help="NetCDF file to write (.nc is added to a name without a suffix); the CSV table, "
        "figures and fragility summary go next to it (FILE.csv, FILE_curves.png, "
        "FILE_fragility.png, FILE_fragility.json)",
    )
    p.set_defaults(run=_ida)


def _parse_scales(text: str) -> np.ndarray:
    example = "e.g. --scales 0.05:2.0:40 (40 values from 0.05 to 2.0) or --scales 0.5,1,1.5"
    if ":" not in text and "," in text and any(not v.strip() for v in text.split(",")):
        raise ValueError(
            f"--scales {text!r} has an empty item (two commas in a row, or one at an end); give "
            f"one number between each pair of commas, {example}."
        )
    try:
        if ":" in text:
            start, stop, num = text.split(":")
            n = int(num)
            if n < 1:
                raise ValueError
            scales = np.linspace(float(start), float(stop), n)
        else:
            scales = np.array([float(v) for v in text.split(",") if v.strip()])
    except ValueError:
        raise ValueError(f"--scales {text!r} cannot be read; {example}.") from None
    if scales.size == 0:
        raise ValueError(f"--scales {text!r} gives no scale factors; {example}.")
    return scales


def _ida_outputs(out: Path, figure_format: str) -> dict[str, Path]:
    """The files ``rockjax ida`` writes, by kind: the NetCDF ``out`` and, next to it, the CSV
    table, the two figures and the fragility summary (named after ``out``'s stem)."""
    stem = out.with_suffix("") if out.suffix.lower() in (".nc", ".nc4") else out
    return {
        "netcdf": out,
        "csv": stem.with_name(f"{stem.name}.csv"),
        "curves": stem.with_name(f"{stem.name}_curves.{figure_format}"),
        "fragility": stem.with_name(f"{stem.name}_fragility.{figure_format}"),
        "summary": stem.with_name(f"{stem.name}_fragility.json"),
    }


def _write_ida_csv(path: Path, ds) -> None:
    """The IDA table, one row per run: record, scale, the IM (in its units, and in g for an
    acceleration), PGA in g where the IM is another, the peaks, overturned and status."""
    dims = ("record", "scale")
    im = str(ds.attrs.get("im", "pga"))
    im_units = str(ds["im"].attrs.get("units", ""))
    columns = {"scale [-]": None, f"{im} [{im_units or '-'}]": ds["im"]}
    if "im_g" in ds:
        columns[f"{im} [g]"] = ds["im_g"]
    if im != "pga":
        columns["pga [g]"] = ds["pga_scaled"] / G
    columns["max_theta_over_eta [-]"] = ds["max_theta_over_eta"]
    columns["max_d_over_b [-]"] = ds["max_d_over_b"]
    grids = {k: None if v is None else np.asarray(v.transpose(*dims)) for k, v in columns.items()}
    collapse = np.asarray(ds["collapse"].transpose(*dims), bool)
    status = np.asarray(ds["status"].transpose(*dims))
    scales = np.asarray(ds["scale"], float)
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["record", *columns, "overturned", "status"])
        for i, record in enumerate(np.asarray(ds["record"])):
            for j, scale in enumerate(scales):
                values = [scale if g is None else g[i, j] for g in grids.values()]
                w.writerow(
                    [str(record), *(f"{float(v):.10g}" for v in values)]
                    + ["true" if collapse[i, j] else "false", int(status[i, j])]
                )


def _ida_figures_and_summary(ds, files: dict[str, Path], title: str) -> list[str]:
    """The IDA curves, the fragility figure and the fragility summary file; returns the lines
    to print (the fit, or why it cannot be made)."""
    from ..fragility import fragility

    ax = plot.ida(ds)
    ax.set_title(title, fontsize="medium")
    save(ax, files["curves"])
    summary = {"ida": files["netcdf"].name, "command": ds.attrs.get("command", "")}
    try:
        frag = fragility(ds)
    except ValueError as err:
        files.pop("fragility")
        jsonio.write_json(files["summary"], {"fitted": False, "reason": str(err), **summary})
        return [f"fragility: not fitted ({err})"]
    jsonio.write_json(files["summary"], {"fitted": True, **frag.summary(), **summary})
    ax = plot.fragility(frag, ds=ds)
    ax.set_title(title, fontsize="medium")
    save(ax, files["fragility"])
    return [f"fragility: {frag!r}"]


def _ida(args: argparse.Namespace) -> int:
    from ..ida import collapse_intervals, ida
    from ..records import load as load_records

    t_start = time.perf_counter()
    if args.chunk_size is not None and args.chunk_size < 1:
        raise ValueError(f"--chunk-size must be an integer >= 1; got {args.chunk_size}.")
    out = Path(args.out)
    if out.is_dir():
        raise ValueError(f"--out {out} is a folder; give a file path such as {out / 'ida.nc'}.")
    if out.suffix.lower() in (".csv", ".json", *(f".{fmt}" for fmt in FIGURE_FORMATS)):
        raise ValueError(
            f"--out {out} names the NetCDF file, and the {out.suffix} file is one of those "
            f"written next to it; give a path ending in .nc, e.g. {out.with_suffix('.nc')}."
        )
    if out.suffix == "":  # `--out results`: the NetCDF file is results.nc (said in the summary)
        out = out.with_name(f"{out.name}.nc")
        if out.is_dir():
            raise ValueError(f"--out {out} is a folder; give a file path such as {out / 'ida.nc'}.")
    elif out.suffix.lower() not in (".nc", ".nc4"):
        raise ValueError(
            f"--out {out} must name a NetCDF file, ending in .nc; got the suffix {out.suffix!r}. "
            f"Give e.g. --out {out.with_name(out.name + '.nc')}."
        )
    files = _ida_outputs(out, args.figure_format)
    # before any run: a bad path loses no work (the figure is written only when the fit exists)
    check_outputs("--out", list(files.values()))
    scales = _parse_scales(args.scales)
    block = Block(b=args.b, h=args.h)  # raises ValueError on bad geometry
    # --mode --gap: the mode object, converted once (a gap for a parapet refused here)
    mode = as_mode(args.mode, args.gap)
    # checked here in the flags' words (rj.as_model checks them too) before the records load
    if args.model == "housner" and args.beta is not None:
        raise ValueError(
            f"--beta (DEM damping) is not a Housner parameter; --model housner takes --e. "
            f"Got --beta {args.beta:g}."
        )
    if args.model == "dem" and args.e is not None:
        raise ValueError(
            f"--e (restitution) is a Housner parameter; --model dem takes --beta [s]. "
            f"Got --e {args.e:g}."
        )
    if args.e is not None and not (math.isfinite(args.e) and 0.0 < args.e <= 1.0):
        raise ValueError(
            f"--e (restitution, dimensionless) must lie in (0, 1]; got --e {args.e:g}. E.g. "
            "--e 0.9, or leave it out for the paper's default."
        )
    # the model object, converted once: the DEM's beta defaults to DeJong's
    beta = args.beta
    if args.model == DEM.name and beta is None:
        beta = float(beta_dejong(block))
    model = as_model(args.model, beta=beta, e=args.e)
    if model.rigid and model.e is None:
        e_default = float(mode.default_e(block))
        if not 0.0 < mode.e_magnitude(e_default) <= 1.0:
            which = "e_1SR (Eq. 5)" if mode.one_sided else "e_H (Eq. 2)"
            raise ValueError(
                f"the default restitution {which} = {e_default:.3g} is not a restitution "
                f"coefficient for this block ({args.b:g} x {args.h:g} m, h/b = "
                f"{args.h / args.b:.3g}): the closed form holds for slender blocks. Give a "
                "measured value with --e, e.g. --e 0.9."
            )
    try:
        motions = load_records(args.records, normalized=args.normalized)
    except ValueError as err:
        raise ValueError(f"--records {err}") from None
    n_runs = len(motions) * scales.size
    uncalibrated = args.beta is None
    if not model.rigid:
        param = f"beta = {model.beta:.4g} s" + (
            " = beta_DeJong, an uncalibrated default: calibrate it with rockjax calibrate"
            if uncalibrated
            else ""
        )
        short = f"beta = {model.beta:.3g} s" + (
            " (beta_DeJong, uncalibrated)" if uncalibrated else ""
        )
    elif model.e is None:
        e_default = mode.default_e(block)
        eq = "|Eq. 5|" if mode.one_sided else "Eq. 2"
        param = short = f"e = {abs(float(e_default)):.4g} ({eq}, the default)"
    else:
        param = short = f"e = {model.e:g}"
    print(
        f"rockjax {__version__} ida: block {args.b:g} x {args.h:g} m, {model.name} "
        f"{mode.name} ({param}); {len(motions)} records x {scales.size} scales "
        f"({scales[0]:g} to {scales[-1]:g}) = {n_runs} runs -> {out}",
        flush=True,
    )
    title = f"{model.name} {mode.name.replace('_', '-')}, block {args.b:g} x {args.h:g} m, {short}"
    ds = ida(
        block,
        motions,
        scales,
        model=model,
        mode=mode,
        tail=args.tail,
        chunk_size=args.chunk_size,
        progress=args.progress,
        im=args.im,
    )
    ds.attrs["command"] = "rockjax ida " + " ".join(_ida_argv(args))
    if out.parent != Path(""):
        out.parent.mkdir(parents=True, exist_ok=True)
    ds.to_netcdf(out, engine="h5netcdf")
    _write_ida_csv(files["csv"], ds)
    fragility_lines = _ida_figures_and_summary(ds, files, title)

    collapse = np.asarray(ds["collapse"], bool)
    failed = int(np.sum(np.asarray(ds["status"]) != 0))
    lowest = np.asarray(collapse_intervals(ds).lowest, float)
    n_col = int(np.sum(np.isfinite(lowest)))
    print(
        f"runs: {n_runs}, collapsed: {int(collapse.sum())}, failed (status != 0): {failed}",
        flush=True,
    )
    if n_col:
        # records that never collapsed count as above the largest scale in the median
        median = float(np.median(np.where(np.isfinite(lowest), lowest, np.inf)))
        median_txt = f"{median:.4g}" if math.isfinite(median) else f"> {scales[-1]:g}"
        print(
            f"lowest collapse scale per record: min {np.nanmin(lowest):.4g}, median "
            f"{median_txt} ({n_col}/{lowest.size} records collapsed at some scale)",
            flush=True,
        )
    else:
        print(f"no record collapsed the block up to scale {scales[-1]:g}", flush=True)
    for line in fragility_lines:
        print(line, flush=True)
    names = ", ".join(str(path) for path in files.values())
    print(f"wrote {names} in {time.perf_counter() - t_start:.1f} s", flush=True)
    if failed == n_runs:
        codes = sorted({int(c) for c in np.unique(np.asarray(ds["status"]))})
        why = "; ".join(f"status {c}: {STATUS_MESSAGES.get(c, '?')}" for c in codes)
        print(
            f"error: all {n_runs} runs failed ({why}); the files hold no result. See the "
            f"'status' variable of {out}.",
            file=sys.stderr,
        )
        return 1
    if failed:
        print(f"warning: {failed} runs failed; see the 'status' variable", file=sys.stderr)
    return 0


def _ida_argv(args: argparse.Namespace) -> list[str]:
    parts = ["--b", f"{args.b:g}", "--h", f"{args.h:g}", "--records", *args.records]
    parts += ["--model", args.model, "--mode", args.mode, "--scales", args.scales]
    for flag, value in (("--beta", args.beta), ("--e", args.e)):
        if value is not None:
            parts += [flag, f"{value:g}"]
    if args.normalized:
        parts.append("--normalized")
    parts += ["--gap", f"{args.gap:g}", "--tail", f"{args.tail:g}", "--im", args.im]
    parts += ["--figure-format", args.figure_format]
    if args.chunk_size is not None:
        parts += ["--chunk-size", str(args.chunk_size)]
    return parts + ["--out", str(args.out)]
