"""The figures and CSV files of ``rockjax demo``."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from .. import plot
from ..relations import e_housner
from ..response import Response
from ._common import save
from ._demo_inputs import FACADE_GAP, N_BOUNCES


def write_outputs(out, parapet, facade, gm, free_a, runs_a, free_b, runs_b, pulse, runs_c):
    files = []
    labels_a = {runs_a[k][0]: r for k, r in free_a.items()}
    ax = plot.time_history(
        labels_a, title=f"Parapet {parapet.b:g} x {parapet.h:g} m, free rocking from 0.5 eta"
    )
    files.append(save(ax, out / "parapet_free_rocking.png"))
    ax = plot.peaks_decay(
        labels_a,
        n_bounces=6,
        e_reference={f"e_H = {float(e_housner(parapet)):.3f}": float(e_housner(parapet))},
        title=f"Parapet {parapet.b:g} x {parapet.h:g} m: peak decay",
    )
    files.append(save(ax, out / "parapet_peaks.png"))
    ax = plot.time_history(
        {runs_b[k][0]: r for k, r in free_b.items()},
        title=(
            f"Facade {facade.b:g} x {facade.h:g} m, one-sided free rocking "
            f"(gap {FACADE_GAP * 1e3:g} mm)"
        ),
    )
    files.append(save(ax, out / "facade_free_rocking.png"))

    import matplotlib.pyplot as plt  # loaded by the plots above, which chose the backend

    fig, (ax_g, ax_t) = plt.subplots(
        2, 1, figsize=(7.0, 5.5), sharex=True, height_ratios=[1, 2], layout="constrained"
    )
    plot.ground_motion(gm, ax=ax_g, title=f"Parapet {parapet.b:g} x {parapet.h:g} m, Ricker pulse")
    ax_g.set_xlabel("")
    plot.time_history({runs_c[k][0]: r for k, r in pulse.items()}, ax=ax_t)
    files.append(save(ax_t, out / "parapet_ricker.png"))

    files.append(_write_csv_series(out / "parapet_free_rocking.csv", free_a))
    files.append(_write_csv_series(out / "facade_free_rocking.csv", free_b))
    files.append(_write_csv_series(out / "parapet_ricker.csv", pulse, ag=np.asarray(gm.ag)))
    return files


def write_sweep(out, betas, b_dj, e_h, sweep):
    series = {f"DEM, dashpot={d}": v for d, v in sweep.items()}
    ax = plot.e_beta(
        betas, series, e_h=e_h, beta_dejong=b_dj, title="DEM free rocking: e(beta), Eq. (3)"
    )
    png = save(ax, out / "e_beta.png")
    path = out / "e_beta.csv"
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        head = ["dashpot", "beta_s", "beta_over_beta_dejong"]
        w.writerow(head + [f"e_exp_{n}" for n in range(1, N_BOUNCES + 1)] + ["e_exp_mean"])
        for dashpot, e in sweep.items():
            mean = nanmean_rows(e)
            for beta, row, m in zip(betas, e, mean):
                w.writerow(
                    [dashpot, f"{beta:.6g}", f"{beta / b_dj:.4f}", *map(_csv_num, row)]
                    + [_csv_num(m)]
                )
    return [png, path.name]


def write_calibration_and_ida(out: Path, fit, ds_h, ds_d) -> list[str]:
    files = []
    axes = plot.calibration(fit)
    files.append(save(axes[0], out / "calibration.png"))
    for name, ds in (("housner", ds_h), ("dem", ds_d)):
        path = out / f"ida_pulses_{name}.nc"
        ds.to_netcdf(path)
        files.append(path.name)
        ax = plot.ida(ds)
        ax.set_title(f"IDA under pulses, {name.upper() if name == 'dem' else 'Housner'}")
        files.append(save(ax, out / f"ida_pulses_{name}.png"))
    return files


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


def nanmean_rows(e: np.ndarray) -> np.ndarray:
    counts = np.sum(np.isfinite(e), axis=1)
    sums = np.nansum(e, axis=1)
    return np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)


def _csv_num(x) -> str:
    return "" if not np.isfinite(x) else f"{x:.6f}"
