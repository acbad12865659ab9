"""The ``rockjax`` command line.

``rockjax demo [--out DIR] [--quick]`` runs the main job on built-in examples from the paper
(Galvez et al., Sect. 2): free rocking of a parapet with DEM and Housner, a one-sided facade,
a Ricker pulse, the DEM ``e(beta)`` sweep behind Eq. (3), a calibration of ``beta`` to ``e_H``
by gradient descent, and a small IDA under analytic pulses with both models. It writes figures
(PNG), time histories (CSV), IDA Datasets (NetCDF) and ``results.json`` into ``DIR`` and prints
a summary.

``rockjax ida --records nearfield|farfield|...|FILE.AT2... --out ida.nc`` runs an incremental
dynamic analysis (:func:`rockjax.ida`) of one block under FEMA P695 record sets
(:func:`rockjax.records.fema_p695`) or PEER ``.AT2`` files, writes the Dataset to NetCDF and,
next to it, the IDA table as CSV (``ida.csv``: one row per run), the IDA curves and the
fitted collapse fragility as figures (``ida_curves.png``, ``ida_fragility.png``; PDF or SVG with
``--figure-format``) and the fragility summary (``ida_fragility.json``: median in the IM's
units and in g, dispersion, bootstrap intervals; or why it cannot be fitted), and prints a
summary.

``rockjax calibrate --b 0.25 --h 3 [--e 0.975]`` fits the DEM damping ``beta`` of one block so
that its free rocking matches Housner's with restitution ``e`` (:func:`rockjax.fit_beta`; default
``e = e_H``, Eq. 2), or, with ``--mode one_sided`` (target ``bounces`` by default), a facade's
measured bounce ratios. It prints ``beta``, the DEM's effective ``e`` and the reachable range,
and writes ``calibration.png`` (DEM at the fitted ``beta`` vs Housner, and the loss history) and
``calibration.json``; a fit that does not meet its target within the stated tolerance is
reported with the reason on stderr and exit status 1 (the files are still written).

Errors in the input, and an output file that cannot be written (every file a command writes is
checked before its first run), are reported as one ``error: ...`` line on stderr with exit
status 2. An IDA whose runs all fail writes its files and exits with status 1 and one
``error: ...`` line naming the runs' status.
"""

from __future__ import annotations

import argparse
import csv
import datetime
import math
import os
import platform
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

import jax
import numpy as np

from . import __version__, jsonio, plot
from .block import Block
from .calibration import fit_beta
from .compilation import enable_cache
from .constants import G
from .contact import Joint
from .dem import simulate_dem, stable_dt
from .housner import simulate_housner
from .ida import ida
from .motion import GroundMotion
from .relations import beta_dejong, beta_isr, e_housner, e_isr, free_rocking_period
from .response import STATUS_MESSAGES, Response

# ----------------------------------------------------------------------------- demo inputs
PARAPET_B, PARAPET_H = 0.25, 3.0  # [m], the paper's reference parapet
FACADE_B, FACADE_H = 0.2, 1.5  # [m]
FACADE_GAP = 0.001  # facade-to-return-wall gap [m]
RELEASE = 0.5  # release rotation theta0 / eta [-] of every free-rocking run
RICKER_PGA, RICKER_PERIOD = 4.0, 0.5  # [m/s^2], [s]: rocks the parapet hard, without overturning
N_BOUNCES = 3  # bounces evaluated with Eq. (6), as the paper does
BETA_MAX_RATIO = 1.5  # the sweep spans 0 .. 1.5 beta_DeJong
N_BETA, N_BETA_QUICK = 7, 4  # 0, 0.25, ..., 1.5 beta_DeJong; 0, 0.5, 1, 1.5 beta_DeJong

# Every parapet run (free, pulse, sweep) shares the output step, the duration and the DEM step,
# so each model compiles once for all of them: compilation, not stepping, is what costs time.
DT_OUT = 0.005  # output step [s] of the parapet runs (and the Ricker record's step)
PARAPET_DURATION = 8.0  # [s], at least: 3 bounces at e = 1 (free-rocking period 2.4 s)
FACADE_DT_OUT = 0.002  # [s]: facade bounces are short
FACADE_DURATION = 1.5  # [s]: the facade is at rest after about 1 s
FIGURE_FORMATS = ("png", "pdf", "svg")  # matplotlib writes each without extra packages
DEMO_FILES = (
    "parapet_free_rocking.png",
    "parapet_peaks.png",
    "facade_free_rocking.png",
    "parapet_ricker.png",
    "parapet_free_rocking.csv",
    "facade_free_rocking.csv",
    "parapet_ricker.csv",
    "e_beta.png",
    "e_beta.csv",
    "calibration.png",
    "ida_pulses_housner.nc",
    "ida_pulses_housner.png",
    "ida_pulses_dem.nc",
    "ida_pulses_dem.png",
    "results.json",
)  # what `rockjax demo` writes into --out, each checked before the first run
CALIBRATE_FILES = ("calibration.png", "calibration.json")  # `rockjax calibrate`'s, into --out


def main(argv: Sequence[str | os.PathLike] | None = None) -> int:
    """Entry point of the ``rockjax`` command.

    Args:
        argv: Command-line arguments without the program name; default ``sys.argv[1:]``.

    Returns:
        The exit status: 0 on success, 1 when a calibration misses its target or every run of
        an IDA failed (the reason on stderr; the files are still written), 2 on invalid input
        or a file that cannot be read or written (after printing ``error: ...``), 130 when
        interrupted, 1 when the reader of the output goes away (a broken pipe).
    """
    parser = _parser()
    args = parser.parse_args(None if argv is None else [os.fspath(a) for a in argv])
    if argv is None:  # run as the command (not called from Python): reuse compiled programs
        enable_cache()
    try:
        return args.run(args)
    except ValueError as err:
        message = " ".join(str(err).split("\n"))
        print(f"error: {message}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader (e.g. `| head`) went away: stop quietly, as Unix tools do
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except OSError as err:  # after BrokenPipeError, one of them: a path the checks before the runs could not foresee (disk full)
        where = f": {err.filename}" if err.filename else ""
        print(f"error: {err.strerror or err}{where}", file=sys.stderr)
        return 2


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rockjax",
        description="Differentiable rocking of URM parapets and facades (DEM and Housner), on JAX.",
        allow_abbrev=False,
    )
    parser.add_argument("--version", action="version", version=f"rockjax {__version__}")
    sub = parser.add_subparsers(title="commands", dest="command", required=True)
    demo = sub.add_parser(
        "demo",
        help="run the main job on built-in examples and write figures, CSV and results.json",
        description=(
            "Free rocking of a parapet (DEM at beta=0 and beta_DeJong, Housner with e_H), a "
            "one-sided facade (DEM vs Housner), a Ricker pulse on the parapet, and the DEM "
            "e(beta) sweep of the paper's Eq. (3)."
        ),
        allow_abbrev=False,
    )
    demo.add_argument("--out", default="out", metavar="DIR", help="output folder (default: out)")
    demo.add_argument(
        "--quick",
        action="store_true",
        help=(
            f"a {N_BETA_QUICK}-point e(beta) sweep, closed dashpot only "
            f"(default: {N_BETA} points, closed and clipped)"
        ),
    )
    demo.add_argument(
        "--b",
        type=float,
        default=PARAPET_B,
        metavar="M",
        help=f"parapet thickness [m] (default {PARAPET_B})",
    )
    demo.add_argument(
        "--h",
        type=float,
        default=PARAPET_H,
        metavar="M",
        help=f"parapet height [m] (default {PARAPET_H})",
    )
    demo.add_argument(
        "--n-beta",
        type=int,
        default=None,
        metavar="N",
        help=f"points of the e(beta) sweep, >= 2 (default {N_BETA}, quick {N_BETA_QUICK})",
    )
    demo.set_defaults(run=_demo)
    _add_ida_parser(sub)
    _add_calibrate_parser(sub)
    return parser


# ----------------------------------------------------------------------------- demo


def _demo(args: argparse.Namespace) -> int:
    t_start = time.perf_counter()
    n_beta = args.n_beta if args.n_beta is not None else (N_BETA_QUICK if args.quick else N_BETA)
    if n_beta < 2:
        raise ValueError(f"--n-beta must be an integer >= 2; got {n_beta}.")
    parapet = Block(b=args.b, h=args.h)  # raises ValueError on bad geometry
    facade = Block(b=FACADE_B, h=FACADE_H)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} exists and is not a folder; give a folder path.")
    _check_outputs("--out", [out / name for name in DEMO_FILES])  # before any run
    out.mkdir(parents=True, exist_ok=True)

    eta = float(parapet.eta)
    e_h = float(e_housner(parapet))
    b_dj = float(beta_dejong(parapet))
    betas = np.union1d(b_dj * np.linspace(0.0, BETA_MAX_RATIO, n_beta), [b_dj])
    # the step of the most damped run, for every parapet DEM run: one compilation
    dt_dem = stable_dt(parapet, float(betas[-1]))
    theta0 = RELEASE * eta
    # long enough for bounce 3 (1.5 periods of undamped rocking) of any --b/--h, with margin
    period = float(free_rocking_period(parapet.p, parapet.eta, theta0))
    duration = max(PARAPET_DURATION, DT_OUT * math.ceil(2.0 * period / DT_OUT))
    mode_txt = "quick" if args.quick else "full"
    print(f"rockjax {__version__} demo ({mode_txt}) -> {out}/", flush=True)
    print(
        f"parapet {args.b:g} x {args.h:g} m: eta = {eta:.4f} rad, e_H = {e_h:.4f} (Eq. 2), "
        f"beta_DeJong = {b_dj:.4g} s; DEM step {dt_dem:.3g} s",
        flush=True,
    )
    results: dict = {
        "rockjax_version": __version__,
        "versions": _versions(),
        "command": "rockjax " + " ".join(_argv_of(args)),
        "quick": bool(args.quick),
        "parapet": _block_info(parapet) | {"e_H": e_h, "beta_dejong_s": b_dj},
        "facade": _block_info(facade)
        | {"e_1sr": abs(float(e_isr(facade))), "beta_1sr_s": float(beta_isr(facade))},
        "note": "wall_s of the first run of each model includes its JIT compilation.",
    }
    wall: dict[str, float] = {}

    # (a) parapet free rocking -----------------------------------------------------------
    print(f"[1/6] parapet free rocking from {RELEASE:g} eta ({duration:g} s)", flush=True)

    def dem_free(beta, dashpot="closed"):
        return simulate_dem(
            parapet,
            beta=beta,
            theta0=theta0,
            duration=duration,
            save_dt=DT_OUT,
            dt=dt_dem,
            joint=Joint(dashpot=dashpot),
        )

    runs_a = {
        "dem_beta0": ("DEM, beta = 0", lambda: dem_free(0.0), {"model": "dem", "beta_s": 0.0}),
        "dem_beta_dejong": (
            f"DEM, beta = beta_DeJong = {b_dj:.3g} s",
            lambda: dem_free(b_dj),
            {"model": "dem", "beta_s": b_dj},
        ),
        "housner_e_H": (
            f"Housner, e = e_H = {e_h:.3f}",
            lambda: simulate_housner(parapet, e=e_h, theta0=theta0, duration=duration, dt=DT_OUT),
            {"model": "housner", "e": e_h},
        ),
    }
    free_a, info_a = _run_all(runs_a, wall, "parapet_free")
    results["parapet_free_rocking"] = {
        "theta0_over_eta": RELEASE,
        "duration_s": duration,
        "runs": info_a,
    }
    _print_e_table(info_a, runs_a)

    # (b) facade free rocking ------------------------------------------------------------
    eta_f = float(facade.eta)
    e_1sr = abs(float(e_isr(facade)))
    beta_f = float(beta_isr(facade))
    print(
        f"[2/6] facade {FACADE_B:g} x {FACADE_H:g} m one-sided free rocking from {RELEASE:g} eta "
        f"(gap {FACADE_GAP * 1e3:g} mm)",
        flush=True,
    )
    runs_b = {
        "dem_beta_1sr": (
            f"DEM, beta = beta_1SR = {beta_f:.3g} s (Eq. 7)",
            lambda: simulate_dem(
                facade,
                beta=beta_f,
                mode="one_sided",
                gap=FACADE_GAP,
                theta0=RELEASE * eta_f,
                duration=FACADE_DURATION,
                save_dt=FACADE_DT_OUT,
            ),
            {"model": "dem", "beta_s": beta_f, "gap_m": FACADE_GAP},
        ),
        "housner_e_1sr": (
            f"Housner, e = |e_1SR| = {e_1sr:.3f} (Eq. 5)",
            lambda: simulate_housner(
                facade,
                e=e_1sr,
                mode="one_sided",
                theta0=RELEASE * eta_f,
                duration=FACADE_DURATION,
                dt=FACADE_DT_OUT,
            ),
            {"model": "housner", "e": e_1sr},
        ),
    }
    free_b, info_b = _run_all(runs_b, wall, "facade_free")
    results["facade_free_rocking"] = {
        "theta0_over_eta": RELEASE,
        "duration_s": FACADE_DURATION,
        "mode": "one_sided",
        "runs": info_b,
    }
    _print_e_table(info_b, runs_b)

    # (c) Ricker pulse on the parapet ------------------------------------------------------
    gm = GroundMotion.ricker(
        pga=RICKER_PGA,
        period=RICKER_PERIOD,
        dt=DT_OUT,
        duration=duration,
        name=f"Ricker pulse, pga {RICKER_PGA / G:.2f} g, T = {RICKER_PERIOD:g} s",
    )
    print(
        f"[3/6] Ricker pulse on the parapet: pga = {RICKER_PGA:g} m/s^2 "
        f"({RICKER_PGA / G:.2f} g), T = {RICKER_PERIOD:g} s",
        flush=True,
    )
    runs_c = {
        "dem_beta_dejong": (
            "DEM, beta = beta_DeJong",
            lambda: simulate_dem(parapet, gm, beta=b_dj, dt=dt_dem),
            {"model": "dem", "beta_s": b_dj},
        ),
        "housner_e_H": (
            "Housner, e = e_H",
            lambda: simulate_housner(parapet, gm, e=e_h),
            {"model": "housner", "e": e_h},
        ),
    }
    pulse, info_c = _run_all(runs_c, wall, "ricker")
    results["parapet_ricker"] = {
        "pga_m_s2": RICKER_PGA,
        "period_s": RICKER_PERIOD,
        "duration_s": duration,
        "runs": info_c,
    }
    for key, resp in pulse.items():
        print(
            f"      {runs_c[key][0]:<40s} max |theta|/eta = {float(resp.theta_max) / eta:.3f}"
            f"{'  OVERTURNED' if bool(resp.overturned) else ''}   ({_fmt_s(info_c[key]['wall_s'])})",
            flush=True,
        )

    # (d) e(beta) sweep --------------------------------------------------------------------
    dashpots = ("closed",) if args.quick else ("closed", "clipped")
    print(
        f"[4/6] DEM e(beta) sweep: {betas.size} values of beta in [0, {BETA_MAX_RATIO:g} "
        f"beta_DeJong], dashpot {' and '.join(dashpots)}",
        flush=True,
    )
    sweep: dict[str, np.ndarray] = {}
    t0 = time.perf_counter()
    n_total = betas.size * len(dashpots)
    k = 0
    for dashpot in dashpots:
        rows = []
        for beta in betas:
            k += 1
            resp = dem_free(float(beta), dashpot)
            e = resp.e_exp(N_BOUNCES)
            rows.append(e)
            print(
                f"      [{k:>2d}/{n_total}] {dashpot:<7s} beta = {beta:.4g} s "
                f"({beta / b_dj:.2f} beta_DJ): e_exp = {_fmt_e(e)}   "
                f"{_fmt_s(time.perf_counter() - t0):>8s}",
                flush=True,
            )
        sweep[dashpot] = np.asarray(rows)
    wall["e_beta_sweep"] = time.perf_counter() - t0
    results["e_beta_sweep"] = {
        "beta_s": betas,
        "beta_over_beta_dejong": betas / b_dj,
        "theta0_over_eta": RELEASE,
        "dt_s": dt_dem,
        "e_H": e_h,
        "e_exp": {d: v for d, v in sweep.items()},
        "e_exp_mean": {d: _nanmean_rows(v) for d, v in sweep.items()},
    }

    # (e) beta calibration by gradient descent ---------------------------------------------
    print(
        f"[5/6] calibrate beta to e_H = {e_h:.4f} by gradient descent (rj.fit_beta, L-BFGS)",
        flush=True,
    )
    t0 = time.perf_counter()
    fit = fit_beta(parapet, e=e_h, theta0=theta0)
    wall["calibration"] = time.perf_counter() - t0
    print(
        f"      beta = {fit.beta:.4g} s ({fit.beta / b_dj:.3f} beta_DeJong), DEM e = "
        f"{fit.e_effective:.4f}, {fit.n_iterations} iterations, {fit.n_simulations} DEM runs, "
        f"{_fmt_s(wall['calibration'])} (with compilation)",
        flush=True,
    )
    results["calibration"] = {
        "target_e": e_h,
        "beta_s": fit.beta,
        "beta_over_beta_dejong": fit.beta / b_dj,
        "e_effective": fit.e_effective,
        "e_range": fit.e_range,
        "loss": fit.loss,
        "history_error": fit.history_error,
        "n_iterations": fit.n_iterations,
        "n_simulations": fit.n_simulations,
        "converged": fit.converged,
        "wall_s": wall["calibration"],
    }

    # (f) IDA under analytic pulses ---------------------------------------------------------
    records = _demo_pulses(args.quick)
    scales = np.linspace(0.1, 2.0, 8 if args.quick else 20)
    print(
        f"[6/6] IDA of the parapet under {len(records)} pulses x {scales.size} scales, Housner "
        f"(e_H) and DEM (beta = {fit.beta:.3g} s, the calibrated one)",
        flush=True,
    )
    t0 = time.perf_counter()
    ds_h = ida(parapet, records, scales, model="housner", e=e_h, tail=2.0, progress=False)
    ds_d = ida(parapet, records, scales, model="dem", beta=fit.beta, tail=2.0, progress=False)
    wall["ida"] = time.perf_counter() - t0
    results["ida"] = {
        "records": [r.name for r in records],
        "scales": scales,
        "pga_m_s2": [float(r.pga) for r in records],
        "housner_collapse_fraction": float(ds_h["collapse"].mean()),
        "dem_collapse_fraction": float(ds_d["collapse"].mean()),
        "wall_s": wall["ida"],
    }
    print(
        f"      collapsed runs: Housner {int(ds_h['collapse'].sum())}, DEM "
        f"{int(ds_d['collapse'].sum())} of {ds_h['collapse'].size}   "
        f"({_fmt_s(wall['ida'])})",
        flush=True,
    )

    # outputs ------------------------------------------------------------------------------
    t_io = time.perf_counter()
    files = _write_outputs(out, parapet, facade, gm, free_a, runs_a, free_b, runs_b, pulse, runs_c)
    files += _write_sweep(out, betas, b_dj, e_h, sweep)
    files += _write_calibration_and_ida(out, fit, ds_h, ds_d)
    wall["figures_and_files"] = time.perf_counter() - t_io
    wall["total"] = time.perf_counter() - t_start
    results["wall_s"] = wall
    results["files"] = sorted([*files, "results.json"])
    jsonio.write_json(out / "results.json", results)

    bad = [
        f"{section}/{key}: {STATUS_MESSAGES.get(run['status'], run['status'])}"
        for section, info in (("parapet", info_a), ("facade", info_b), ("ricker", info_c))
        for key, run in info.items()
        if run["status"] != 0
    ]
    print(f"wrote {len(results['files'])} files to {out}/ in {wall['total']:.1f} s", flush=True)
    for line in bad:
        print(f"warning: {line}", file=sys.stderr)
    return 0


def _demo_pulses(quick: bool) -> list[GroundMotion]:
    """The demo's embedded records: symmetric and antisymmetric Ricker and one-sine pulses of
    0.5 g at two periods (one in quick mode), 8 s long at 0.005 s."""
    periods = (0.5,) if quick else (0.5, 1.0)
    out = []
    for T in periods:
        kw = dict(dt=DT_OUT, duration=8.0)
        out.append(GroundMotion.ricker(0.5 * G, T, t0=1.5 * T, name=f"MH_T{T:g}s", **kw))
        out.append(
            GroundMotion.ricker_antisymmetric(0.5 * G, T, t0=1.5 * T, name=f"AR_T{T:g}s", **kw)
        )
        out.append(GroundMotion.sine_cycle(0.5 * G, T, t0=0.5, name=f"SC_T{T:g}s", **kw))
    return out


def _write_calibration_and_ida(out: Path, fit, ds_h, ds_d) -> list[str]:
    files = []
    axes = plot.calibration(fit)
    files.append(_save(axes[0], out / "calibration.png"))
    for name, ds in (("housner", ds_h), ("dem", ds_d)):
        path = out / f"ida_pulses_{name}.nc"
        ds.to_netcdf(path)
        files.append(path.name)
        ax = plot.ida(ds)
        ax.set_title(f"IDA under pulses, {name.upper() if name == 'dem' else 'Housner'}")
        files.append(_save(ax, out / f"ida_pulses_{name}.png"))
    return files


def _fmt_s(seconds: float) -> str:
    """A wall time, in ms below one second (compiled runs take a few ms)."""
    return f"{seconds * 1e3:.1f} ms" if seconds < 1.0 else f"{seconds:.1f} s"


def _run_all(runs, wall, prefix):
    """Run each ``{key: (label, thunk, inputs)}``; return the responses and their summaries."""
    responses: dict[str, Response] = {}
    info: dict[str, dict] = {}
    for key, (label, thunk, inputs) in runs.items():
        t0 = time.perf_counter()
        resp = jax.block_until_ready(thunk())
        elapsed = time.perf_counter() - t0
        wall[f"{prefix}/{key}"] = elapsed
        responses[key] = resp
        info[key] = inputs | {
            "label": label,
            "e_exp": resp.e_exp(N_BOUNCES),
            "theta_max_over_eta": float(resp.theta_max) / float(resp.eta),
            "overturned": bool(resp.overturned),
            "status": int(resp.status),
            "wall_s": elapsed,
        }
    return responses, info


def _print_e_table(info, runs):
    print(f"      e_exp (Eq. 6) of bounces 1-{N_BOUNCES}:", flush=True)
    for key, run in info.items():
        print(
            f"      {runs[key][0]:<44s} {_fmt_e(run['e_exp'])}   ({_fmt_s(run['wall_s'])})",
            flush=True,
        )


def _fmt_e(e) -> str:
    return " ".join("  -  " if not np.isfinite(v) else f"{v:.3f}" for v in np.asarray(e))


def _nanmean_rows(e: np.ndarray) -> np.ndarray:
    counts = np.sum(np.isfinite(e), axis=1)
    sums = np.nansum(e, axis=1)
    return np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)


def _write_outputs(out, parapet, facade, gm, free_a, runs_a, free_b, runs_b, pulse, runs_c):
    files = []
    labels_a = {runs_a[k][0]: r for k, r in free_a.items()}
    ax = plot.time_history(
        labels_a, title=f"Parapet {parapet.b:g} x {parapet.h:g} m, free rocking from 0.5 eta"
    )
    files.append(_save(ax, out / "parapet_free_rocking.png"))
    ax = plot.peaks_decay(
        labels_a,
        n_bounces=6,
        e_reference={f"e_H = {float(e_housner(parapet)):.3f}": float(e_housner(parapet))},
        title=f"Parapet {parapet.b:g} x {parapet.h:g} m: peak decay",
    )
    files.append(_save(ax, out / "parapet_peaks.png"))
    ax = plot.time_history(
        {runs_b[k][0]: r for k, r in free_b.items()},
        title=(
            f"Facade {facade.b:g} x {facade.h:g} m, one-sided free rocking "
            f"(gap {FACADE_GAP * 1e3:g} mm)"
        ),
    )
    files.append(_save(ax, out / "facade_free_rocking.png"))

    import matplotlib.pyplot as plt  # loaded by the plots above, which chose the backend

    fig, (ax_g, ax_t) = plt.subplots(
        2, 1, figsize=(7.0, 5.5), sharex=True, height_ratios=[1, 2], layout="constrained"
    )
    plot.ground_motion(gm, ax=ax_g, title=f"Parapet {parapet.b:g} x {parapet.h:g} m, Ricker pulse")
    ax_g.set_xlabel("")
    plot.time_history({runs_c[k][0]: r for k, r in pulse.items()}, ax=ax_t)
    files.append(_save(ax_t, out / "parapet_ricker.png"))

    files.append(_write_csv_series(out / "parapet_free_rocking.csv", free_a))
    files.append(_write_csv_series(out / "facade_free_rocking.csv", free_b))
    files.append(_write_csv_series(out / "parapet_ricker.csv", pulse, ag=np.asarray(gm.ag)))
    return files


def _write_sweep(out, betas, b_dj, e_h, sweep):
    series = {f"DEM, dashpot={d}": v for d, v in sweep.items()}
    ax = plot.e_beta(
        betas, series, e_h=e_h, beta_dejong=b_dj, title="DEM free rocking: e(beta), Eq. (3)"
    )
    png = _save(ax, out / "e_beta.png")
    path = out / "e_beta.csv"
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        head = ["dashpot", "beta_s", "beta_over_beta_dejong"]
        w.writerow(head + [f"e_exp_{n}" for n in range(1, N_BOUNCES + 1)] + ["e_exp_mean"])
        for dashpot, e in sweep.items():
            mean = _nanmean_rows(e)
            for beta, row, m in zip(betas, e, mean):
                w.writerow(
                    [dashpot, f"{beta:.6g}", f"{beta / b_dj:.4f}", *map(_csv_num, row)]
                    + [_csv_num(m)]
                )
    return [png, path.name]


def _write_csv_series(path: Path, responses: dict[str, Response], ag=None) -> str:
    """One CSV of ``t`` [s] and ``theta`` [rad] per response (all on the same time grid)."""
    keys = list(responses)
    t = np.asarray(responses[keys[0]].t)
    cols = [t]
    head = ["t_s"]
    if ag is not None:
        cols.append(np.pad(ag, (0, max(0, t.size - ag.size)))[: t.size])
        head.append("ag_m_s2")
    for key in keys:
        theta = np.asarray(responses[key].theta)
        if theta.shape != t.shape:
            raise ValueError(
                f"{key}: time grid differs from {keys[0]} ({theta.shape} vs {t.shape})."
            )
        cols.append(theta)
        head.append(f"theta_{key}_rad")
    np.savetxt(
        path, np.column_stack(cols), delimiter=",", header=",".join(head), comments="", fmt="%.9g"
    )
    return path.name


def _save(ax, path: Path) -> str:
    ax.figure.savefig(path, dpi=130)
    plot.close(ax)
    return path.name


def _csv_num(x) -> str:
    return "" if not np.isfinite(x) else f"{x:.6f}"


def _block_info(block: Block) -> dict:
    return {
        "b_m": float(block.b),
        "h_m": float(block.h),
        "rho_kg_m3": float(block.rho),
        "E_pa": float(block.E),
        "nu": float(block.nu),
        "eta_rad": float(block.eta),
        "p_rad_s": float(block.p),
    }


def _argv_of(args: argparse.Namespace) -> list[str]:
    parts = ["demo", "--out", str(args.out), "--b", f"{args.b:g}", "--h", f"{args.h:g}"]
    if args.quick:
        parts.append("--quick")
    if args.n_beta is not None:
        parts += ["--n-beta", str(args.n_beta)]
    return parts


def _versions() -> dict:
    import jaxlib
    import matplotlib

    return {
        "rockjax": __version__,
        "jax": jax.__version__,
        "jaxlib": jaxlib.__version__,
        "numpy": np.__version__,
        "matplotlib": matplotlib.__version__,
        "python": platform.python_version(),
        "platform": platform.platform(),
        "jax_backend": jax.default_backend(),
        "cpu_count": os.cpu_count(),
        "xla_flags": os.environ.get("XLA_FLAGS", ""),
        "date_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
    }


# ----------------------------------------------------------------------------- ida


def _add_ida_parser(sub) -> None:
    from .records import FEMA_P695_SETS

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
        choices=("two_sided", "one_sided"),
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
        "--chunk-size", type=int, default=256, metavar="N", help="runs per compiled batch"
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


def _check_writable(flag: str, folder: Path) -> None:
    """Fail now, not after the computation, if ``folder`` (created later if missing) cannot be
    written: its nearest existing ancestor must be a folder that takes a new file (probed with
    a temporary file, removed at once; nothing is left behind)."""
    existing = folder.absolute()
    while not existing.exists():
        existing = existing.parent
    why = None
    if not existing.is_dir():
        why = f"{existing} is a file, not a folder"
    else:
        try:
            with tempfile.NamedTemporaryFile(dir=existing, prefix=".rockjax-probe-"):
                pass
        except OSError as err:
            why = err.strerror or str(err)
    if why is not None:
        raise ValueError(
            f"{flag}: cannot write into {folder} ({why}); give a path in a folder you can write to."
        )


def _check_outputs(flag: str, paths: Sequence[Path]) -> None:
    """Fail now, not after the computation, if any file the command will write cannot be
    written: each folder as :func:`_check_writable`, and each file must not be a folder nor an
    existing file that cannot be overwritten."""
    for folder in dict.fromkeys(path.parent for path in paths):
        _check_writable(flag, folder)
    for path in paths:
        if path.is_dir():
            raise ValueError(
                f"{flag}: {path} is a folder, where the command writes a file; move or rename it, "
                f"or give another {flag}."
            )
        if path.exists() and not os.access(path, os.W_OK):
            raise ValueError(
                f"{flag}: {path} exists and cannot be overwritten (no write permission); make it "
                f"writable, or give another {flag}."
            )


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
    from .fragility import fragility

    ax = plot.ida(ds)
    ax.set_title(title, fontsize="medium")
    _save(ax, files["curves"])
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
    _save(ax, files["fragility"])
    return [f"fragility: {frag!r}"]


def _ida(args: argparse.Namespace) -> int:
    from .ida import collapse_intervals, ida
    from .records import load as load_records

    t_start = time.perf_counter()
    if args.chunk_size < 1:
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
    _check_outputs("--out", list(files.values()))
    scales = _parse_scales(args.scales)
    block = Block(b=args.b, h=args.h)  # raises ValueError on bad geometry
    # checked here too (rj.ida checks them all) so the error comes before the records load
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
    if args.model == "housner" and args.e is None:
        e_default = float(e_isr(block) if args.mode == "one_sided" else e_housner(block))
        if not 0.0 < (abs(e_default) if args.mode == "one_sided" else e_default) <= 1.0:
            which = "e_H (Eq. 2)" if args.mode == "two_sided" else "e_1SR (Eq. 5)"
            raise ValueError(
                f"the default restitution {which} = {e_default:.3g} is not a restitution "
                f"coefficient for this block ({args.b:g} x {args.h:g} m, h/b = "
                f"{args.h / args.b:.3g}): the closed form holds for slender blocks. Give a "
                "measured value with --e, e.g. --e 0.9."
            )
    beta = args.beta
    if args.model == "dem" and beta is None:
        beta = float(beta_dejong(block))
    try:
        motions = load_records(args.records, normalized=args.normalized)
    except ValueError as err:
        raise ValueError(f"--records {err}") from None
    n_runs = len(motions) * scales.size
    if args.model == "dem":
        param = f"beta = {beta:.4g} s" + (
            " = beta_DeJong, an uncalibrated default: calibrate it with rockjax calibrate"
            if args.beta is None
            else ""
        )
    elif args.e is None:
        e_default = e_isr(block) if args.mode == "one_sided" else e_housner(block)
        eq = "|Eq. 5|" if args.mode == "one_sided" else "Eq. 2"
        param = f"e = {abs(float(e_default)):.4g} ({eq}, the default)"
    else:
        param = f"e = {args.e:g}"
    print(
        f"rockjax {__version__} ida: block {args.b:g} x {args.h:g} m, {args.model} "
        f"{args.mode} ({param}); {len(motions)} records x {scales.size} scales "
        f"({scales[0]:g} to {scales[-1]:g}) = {n_runs} runs -> {out}",
        flush=True,
    )
    if args.model == "dem":
        short = f"beta = {beta:.3g} s" + (
            " (beta_DeJong, uncalibrated)" if args.beta is None else ""
        )
    else:
        short = param
    title = f"{args.model} {args.mode.replace('_', '-')}, block {args.b:g} x {args.h:g} m, {short}"
    ds = ida(
        block,
        motions,
        scales,
        model=args.model,
        mode=args.mode,
        beta=beta,
        e=args.e,
        gap=args.gap,
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
    return parts + ["--chunk-size", str(args.chunk_size), "--out", str(args.out)]


# ----------------------------------------------------------------------------- calibrate


def _add_calibrate_parser(sub) -> None:
    from .calibration import BOUNCE_FRACTIONS, E_TOL, METHODS, MODES

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
        choices=("e", "bounces"),
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
        choices=("peaks", "history"),
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
    from .calibration import BOUNCE_BANDS, BOUNCE_FRACTIONS, default_target, fit_beta

    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} exists and is not a folder; give a folder path.")
    _check_outputs("--out", [out / name for name in CALIBRATE_FILES])  # before the fit
    mode = args.mode or ("one_sided" if args.target == "bounces" else "two_sided")
    target = args.target or ("e" if args.loss == "history" else default_target(mode))
    if target == "bounces":
        if mode != "one_sided":
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
        e = args.e if args.e is not None else (e_h if mode == "two_sided" else e_1sr)
        if args.e is None and not e > 0.0:
            # Eq. 2 (or 5) leaves its range for squat blocks: e_H < 0 is no restitution
            which = "e_H (Eq. 2)" if mode == "two_sided" else "|e_1SR| (Eq. 5)"
            raise ValueError(
                f"the default target {which} = {e:.3g} is not a restitution coefficient for "
                f"this squat block ({args.b:g} x {args.h:g} m, h/b = {args.h / args.b:.3g}): the "
                "closed form holds for slender blocks. Give a measured value with --e, e.g. "
                "--e 0.9."
            )
    if e is not None:
        default = {"two_sided": " (default: e_H, Eq. 2)", "one_sided": " (default: |e_1SR|, Eq. 5)"}
        goal = f"e = {e:.4f}" + (default[mode] if args.e is None else "")
    else:
        values = " / ".join(f"{f * e_1sr:.4f}" for f in BOUNCE_FRACTIONS)
        percents = "/".join(f"{100 * f:g}" for f in BOUNCE_FRACTIONS)
        goal = f"bounces 1-3: e_exp = {values} ({percents} % of |e_1SR| = {e_1sr:.4f})"
    print(
        f"rockjax {__version__} calibrate: block {args.b:g} x {args.h:g} m ({mode}), eta = "
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
    print(f"e_exp 1-3    = {_fmt_e(e_exp_fit)}  (DEM, Eq. 6)")
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
        f"{args.b:g} x {args.h:g} m {mode.replace('_', '-')} block, release "
        f"{args.theta0:g} eta: beta = {fit.beta:.4g} s"
    )
    png = _save(axes[0], out / "calibration.png")
    result = {
        "rockjax_version": __version__,
        "command": "rockjax " + " ".join(_calibrate_argv(args)),
        "block": _block_info(block) | {"e_H": e_h, "e_1sr": e_1sr, "beta_dejong_s": b_dj},
        "mode": mode,
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


if __name__ == "__main__":
    sys.exit(main())
