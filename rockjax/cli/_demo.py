"""``rockjax demo``, the main job: the paper's examples (Galvez et al., Sect. 2) run in six steps,
each a function here, then written as figures, CSV, NetCDF and ``results.json``."""

from __future__ import annotations

import argparse
import datetime
import math
import os
import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import jax
import numpy as np

from .. import __version__, jsonio
from ..block import Block
from ..calibration import Calibration, fit_beta
from ..constants import G
from ..contact import Joint
from ..dem import simulate_dem, stable_dt
from ..housner import simulate_housner
from ..ida import ida
from ..models import DEM, Housner
from ..motion import GroundMotion
from ..relations import beta_dejong, beta_isr, e_housner, e_isr, free_rocking_period
from ..response import STATUS_MESSAGES, Response
from ._common import block_info, check_outputs, fmt_e
from ._demo_files import nanmean_rows, write_calibration_and_ida, write_outputs, write_sweep
from ._demo_inputs import (
    BETA_MAX_RATIO,
    DEMO_FILES,
    DT_OUT,
    FACADE_B,
    FACADE_DT_OUT,
    FACADE_DURATION,
    FACADE_GAP,
    FACADE_H,
    N_BETA,
    N_BETA_QUICK,
    N_BOUNCES,
    PARAPET_B,
    PARAPET_DURATION,
    PARAPET_H,
    RELEASE,
    RICKER_PERIOD,
    RICKER_PGA,
)


def add_demo_parser(sub) -> None:
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


@dataclass(frozen=True)
class _Setup:
    """What the steps of the demo share: the output folder, the two blocks, the parapet's
    closed forms and the grid of its runs (one DEM step for all: one compilation)."""

    out: Path
    quick: bool
    parapet: Block
    facade: Block
    eta: float  # [rad]
    e_h: float  # Eq. 2 [-]
    b_dj: float  # beta_DeJong [s]
    betas: np.ndarray  # the e(beta) sweep [s], beta_DeJong included
    dt_dem: float  # the DEM step [s] of every parapet run: the most damped run's stable step
    theta0: float  # release rotation [rad]
    duration: float  # [s] of the parapet runs

    def dem_free(self, beta: float, dashpot: str = "closed") -> Response:
        """The parapet's DEM free rocking from ``theta0`` with damping ``beta`` [s]."""
        return simulate_dem(
            self.parapet,
            beta=beta,
            theta0=self.theta0,
            duration=self.duration,
            save_dt=DT_OUT,
            dt=self.dt_dem,
            joint=Joint(dashpot=dashpot),
        )


def _demo(args: argparse.Namespace) -> int:
    t_start = time.perf_counter()
    setup = _prepare(args)
    results = _start(args, setup)
    wall: dict[str, float] = {}
    free_a, runs_a, info_a = _parapet_free_rocking(setup, results, wall)
    free_b, runs_b, info_b = _facade_free_rocking(setup, results, wall)
    gm, pulse, runs_c, info_c = _ricker_pulse(setup, results, wall)
    sweep = _e_beta_sweep(setup, results, wall)
    fit = _calibration(setup, results, wall)
    ds_h, ds_d = _ida_pulses(setup, fit, results, wall)

    # outputs ------------------------------------------------------------------------------
    out, parapet = setup.out, setup.parapet
    t_io = time.perf_counter()
    files = write_outputs(
        out, parapet, setup.facade, gm, free_a, runs_a, free_b, runs_b, pulse, runs_c
    )
    files += write_sweep(out, setup.betas, setup.b_dj, setup.e_h, sweep)
    files += write_calibration_and_ida(out, fit, ds_h, ds_d)
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


def _prepare(args: argparse.Namespace) -> _Setup:
    """The inputs checked (and the output files, before any run), the output folder made, and
    the parapet's closed forms and run grid."""
    n_beta = args.n_beta if args.n_beta is not None else (N_BETA_QUICK if args.quick else N_BETA)
    if n_beta < 2:
        raise ValueError(f"--n-beta must be an integer >= 2; got {n_beta}.")
    parapet = Block(b=args.b, h=args.h)  # raises ValueError on bad geometry
    facade = Block(b=FACADE_B, h=FACADE_H)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} exists and is not a folder; give a folder path.")
    check_outputs("--out", [out / name for name in DEMO_FILES])  # before any run
    out.mkdir(parents=True, exist_ok=True)

    eta = float(parapet.eta)
    b_dj = float(beta_dejong(parapet))
    betas = np.union1d(b_dj * np.linspace(0.0, BETA_MAX_RATIO, n_beta), [b_dj])
    theta0 = RELEASE * eta
    # long enough for bounce 3 (1.5 periods of undamped rocking) of any --b/--h, with margin
    period = float(free_rocking_period(parapet.p, parapet.eta, theta0))
    return _Setup(
        out=out,
        quick=bool(args.quick),
        parapet=parapet,
        facade=facade,
        eta=eta,
        e_h=float(e_housner(parapet)),
        b_dj=b_dj,
        betas=betas,
        # the step of the most damped run, for every parapet DEM run: one compilation
        dt_dem=stable_dt(parapet, float(betas[-1])),
        theta0=theta0,
        duration=max(PARAPET_DURATION, DT_OUT * math.ceil(2.0 * period / DT_OUT)),
    )


def _start(args: argparse.Namespace, setup: _Setup) -> dict:
    """The first lines printed, and ``results.json``'s description of the run."""
    mode_txt = "quick" if args.quick else "full"
    print(f"rockjax {__version__} demo ({mode_txt}) -> {setup.out}/", flush=True)
    print(
        f"parapet {args.b:g} x {args.h:g} m: eta = {setup.eta:.4f} rad, e_H = {setup.e_h:.4f} "
        f"(Eq. 2), beta_DeJong = {setup.b_dj:.4g} s; DEM step {setup.dt_dem:.3g} s",
        flush=True,
    )
    facade = setup.facade
    return {
        "rockjax_version": __version__,
        "versions": _versions(),
        "command": "rockjax " + " ".join(_argv_of(args)),
        "quick": bool(args.quick),
        "parapet": block_info(setup.parapet) | {"e_H": setup.e_h, "beta_dejong_s": setup.b_dj},
        "facade": block_info(facade)
        | {"e_1sr": abs(float(e_isr(facade))), "beta_1sr_s": float(beta_isr(facade))},
        "note": "wall_s of the first run of each model includes its JIT compilation.",
    }


def _parapet_free_rocking(setup: _Setup, results: dict, wall: dict):
    """Step 1: the parapet's free rocking, DEM at ``beta = 0`` and ``beta_DeJong``, Housner
    with ``e_H``."""
    print(f"[1/6] parapet free rocking from {RELEASE:g} eta ({setup.duration:g} s)", flush=True)
    b_dj, e_h = setup.b_dj, setup.e_h
    runs = {
        "dem_beta0": (
            "DEM, beta = 0",
            lambda: setup.dem_free(0.0),
            {"model": "dem", "beta_s": 0.0},
        ),
        "dem_beta_dejong": (
            f"DEM, beta = beta_DeJong = {b_dj:.3g} s",
            lambda: setup.dem_free(b_dj),
            {"model": "dem", "beta_s": b_dj},
        ),
        "housner_e_H": (
            f"Housner, e = e_H = {e_h:.3f}",
            lambda: simulate_housner(
                setup.parapet, e=e_h, theta0=setup.theta0, duration=setup.duration, dt=DT_OUT
            ),
            {"model": "housner", "e": e_h},
        ),
    }
    responses, info = _run_all(runs, wall, "parapet_free")
    results["parapet_free_rocking"] = {
        "theta0_over_eta": RELEASE,
        "duration_s": setup.duration,
        "runs": info,
    }
    _print_e_table(info, runs)
    return responses, runs, info


def _facade_free_rocking(setup: _Setup, results: dict, wall: dict):
    """Step 2: the facade's one-sided free rocking, DEM with ``beta_1SR`` (Eq. 7) and Housner
    with ``|e_1SR|`` (Eq. 5)."""
    facade = setup.facade
    eta_f = float(facade.eta)
    e_1sr = abs(float(e_isr(facade)))
    beta_f = float(beta_isr(facade))
    print(
        f"[2/6] facade {FACADE_B:g} x {FACADE_H:g} m one-sided free rocking from {RELEASE:g} eta "
        f"(gap {FACADE_GAP * 1e3:g} mm)",
        flush=True,
    )
    runs = {
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
    responses, info = _run_all(runs, wall, "facade_free")
    results["facade_free_rocking"] = {
        "theta0_over_eta": RELEASE,
        "duration_s": FACADE_DURATION,
        "mode": "one_sided",
        "runs": info,
    }
    _print_e_table(info, runs)
    return responses, runs, info


def _ricker_pulse(setup: _Setup, results: dict, wall: dict):
    """Step 3: a Ricker pulse on the parapet, DEM at ``beta_DeJong`` and Housner with ``e_H``."""
    parapet, b_dj, e_h = setup.parapet, setup.b_dj, setup.e_h
    gm = GroundMotion.ricker(
        pga=RICKER_PGA,
        period=RICKER_PERIOD,
        dt=DT_OUT,
        duration=setup.duration,
        name=f"Ricker pulse, pga {RICKER_PGA / G:.2f} g, T = {RICKER_PERIOD:g} s",
    )
    print(
        f"[3/6] Ricker pulse on the parapet: pga = {RICKER_PGA:g} m/s^2 "
        f"({RICKER_PGA / G:.2f} g), T = {RICKER_PERIOD:g} s",
        flush=True,
    )
    runs = {
        "dem_beta_dejong": (
            "DEM, beta = beta_DeJong",
            lambda: simulate_dem(parapet, gm, beta=b_dj, dt=setup.dt_dem),
            {"model": "dem", "beta_s": b_dj},
        ),
        "housner_e_H": (
            "Housner, e = e_H",
            lambda: simulate_housner(parapet, gm, e=e_h),
            {"model": "housner", "e": e_h},
        ),
    }
    responses, info = _run_all(runs, wall, "ricker")
    results["parapet_ricker"] = {
        "pga_m_s2": RICKER_PGA,
        "period_s": RICKER_PERIOD,
        "duration_s": setup.duration,
        "runs": info,
    }
    for key, resp in responses.items():
        print(
            f"      {runs[key][0]:<40s} max |theta|/eta = {float(resp.theta_max) / setup.eta:.3f}"
            f"{'  OVERTURNED' if bool(resp.overturned) else ''}   ({_fmt_s(info[key]['wall_s'])})",
            flush=True,
        )
    return gm, responses, runs, info


def _e_beta_sweep(setup: _Setup, results: dict, wall: dict) -> dict[str, np.ndarray]:
    """Step 4: the DEM's ``e_exp`` of bounces 1-3 over the sweep of ``beta`` (Eq. 3), by
    dashpot convention; returns them, one ``(beta, bounce)`` array per dashpot."""
    betas, b_dj = setup.betas, setup.b_dj
    dashpots = ("closed",) if setup.quick else ("closed", "clipped")
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
            resp = setup.dem_free(float(beta), dashpot)
            e = resp.e_exp(N_BOUNCES)
            rows.append(e)
            print(
                f"      [{k:>2d}/{n_total}] {dashpot:<7s} beta = {beta:.4g} s "
                f"({beta / b_dj:.2f} beta_DJ): e_exp = {fmt_e(e)}   "
                f"{_fmt_s(time.perf_counter() - t0):>8s}",
                flush=True,
            )
        sweep[dashpot] = np.asarray(rows)
    wall["e_beta_sweep"] = time.perf_counter() - t0
    results["e_beta_sweep"] = {
        "beta_s": betas,
        "beta_over_beta_dejong": betas / b_dj,
        "theta0_over_eta": RELEASE,
        "dt_s": setup.dt_dem,
        "e_H": setup.e_h,
        "e_exp": {d: v for d, v in sweep.items()},
        "e_exp_mean": {d: nanmean_rows(v) for d, v in sweep.items()},
    }
    return sweep


def _calibration(setup: _Setup, results: dict, wall: dict) -> Calibration:
    """Step 5: ``beta`` calibrated to ``e_H`` by gradient descent (:func:`rockjax.fit_beta`)."""
    e_h, b_dj = setup.e_h, setup.b_dj
    print(
        f"[5/6] calibrate beta to e_H = {e_h:.4f} by gradient descent (rj.fit_beta, L-BFGS)",
        flush=True,
    )
    t0 = time.perf_counter()
    fit = fit_beta(setup.parapet, e=e_h, theta0=setup.theta0)
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
    return fit


def _ida_pulses(setup: _Setup, fit: Calibration, results: dict, wall: dict):
    """Step 6: an IDA of the parapet under analytic pulses, Housner with ``e_H`` and the DEM
    with the calibrated ``beta``; returns the two Datasets."""
    records = _demo_pulses(setup.quick)
    scales = np.linspace(0.1, 2.0, 8 if setup.quick else 20)
    print(
        f"[6/6] IDA of the parapet under {len(records)} pulses x {scales.size} scales, Housner "
        f"(e_H) and DEM (beta = {fit.beta:.3g} s, the calibrated one)",
        flush=True,
    )
    t0 = time.perf_counter()
    parapet = setup.parapet
    ds_h = ida(parapet, records, scales, model=Housner(e=setup.e_h), tail=2.0, progress=False)
    ds_d = ida(parapet, records, scales, model=DEM(beta=fit.beta), tail=2.0, progress=False)
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
    return ds_h, ds_d


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
            f"      {runs[key][0]:<44s} {fmt_e(run['e_exp'])}   ({_fmt_s(run['wall_s'])})",
            flush=True,
        )


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
