"""Facades (one-sided rocking, the paper's Figs 5-7): e_exp of bounces 1-3 vs beta, fitted beta.

Per geometry: a scan of ``e_exp`` (Eq. 6) of bounces 1-3 over ``beta = SCAN x beta_Hcrit``;
:func:`rockjax.fit_beta` (``target="bounces"``: 68/80/100 % of ``|e_ISR|``, Eq. 5; ``method="root"``, the
Illinois root of the mean signed log-gap, to keep the campaign short) searched up
to the largest scanned ``beta`` that still has a first bounce; the fit compared with Eq. 7
(:func:`rockjax.beta_isr`) as a ratio. Then, at the fitted ``beta`` of a few geometries, the
return-wall gap: ``e_gap / e_0`` of bounce 1 and of the mean of bounces 1-3 (Fig. 7).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import rockjax as rj

from ._common import Progress, save_fig, write_csv, write_json

RHO = 1800.0
"""Density [kg/m^3]."""
MIN_BOUNCE = 0.05
"""A first bounce counts as present when its ``e_exp`` is at least this [-] (below it the
peak finder picks up residual contact vibration, not a rebound)."""
GAPS_M = (0.0, 0.0003, 0.001, 0.003, 0.004, 0.006)
"""Return-wall gaps [m] (the paper's 0, 0.3, 1, 3, 4, 6 mm)."""

FULL = {
    "ratios": (3, 8, 16, 24),
    "b": (0.11, 0.30),
    "E": (1.8e9, 4.05e9),
    "scan": (0.0, 0.5, 1.0, 2.0, 4.0, 8.0),
    "method": "root",
    "max_iter": 40,  # three squat (h/b 3) fits stopped unconverged at 12
    "gap_geometries": tuple((0.11, r, 1.8e9) for r in (3, 8, 16, 24)),
    "gaps": GAPS_M,
}
QUICK = {
    "ratios": (8,),
    "b": (0.11,),
    "E": (1.8e9,),
    "scan": (0.0, 1.0, 2.0, 4.0),
    "method": "root",
    "max_iter": 12,
    "gap_geometries": ((0.11, 8, 1.8e9),),
    "gaps": (0.0, 0.003),
}


def _block(b: float, ratio: float, E: float) -> rj.Block:
    return rj.Block(b=b, h=b * ratio, rho=RHO, E=E)


def scan(blk: rj.Block, factors, joint: rj.Joint) -> list[dict]:
    """``e_exp`` of bounces 1-3 at ``beta = factors x beta_Hcrit`` [s]; one row per ``beta``
    (NaN where a bounce is absent, as :func:`rockjax.calibration.e_effective` reports it)."""
    bh = float(rj.beta_hcrit(blk))
    out = rj.calibration.e_effective(blk, bh * np.asarray(factors), mode="one_sided", joint=joint)
    return [
        {
            "beta_s": float(beta),
            "beta_over_hcrit": float(beta) / bh,
            "e_exp1": float(e3[0]),
            "e_exp2": float(e3[1]),
            "e_exp3": float(e3[2]),
            "ok": bool(ok),
        }
        for beta, e3, ok in zip(out["beta"], out["e_exp"], out["ok"], strict=True)
    ]


def beta_max_candidates(rows: list[dict]) -> list[float]:
    """Search ends [s]: the largest scanned ``beta`` with a first bounce, then the next one."""
    has = [r["ok"] and np.isfinite(r["e_exp1"]) and r["e_exp1"] >= MIN_BOUNCE for r in rows]
    last = max((i for i, h in enumerate(has) if h), default=0)
    return [rows[i]["beta_s"] for i in range(max(last, 1), min(last + 2, len(rows)))]


def fit(blk: rj.Block, rows: list[dict], cfg: dict) -> dict:
    """Fit ``beta`` to the bounce targets; try each search end until one brackets them."""
    e_isr = abs(float(rj.e_isr(blk)))
    beta_eq7 = float(rj.beta_isr(blk))
    msg = ""
    for bmax in beta_max_candidates(rows):
        try:
            f = rj.fit_beta(
                blk,
                target="bounces",
                mode="one_sided",
                beta_max=bmax,
                method=cfg["method"],
                max_iter=cfg["max_iter"],
                joint=rj.Joint(n_sub=cfg["n_sub"]),
            )
        except ValueError as err:
            msg = str(err).replace("\n", " ")
            continue
        e3 = np.asarray(f.e_exp, float)
        pct = 100.0 * e3 / e_isr
        return {
            "beta_fit_s": f.beta,
            "beta_max_s": bmax,
            "beta_eq7_s": beta_eq7,
            "fit_over_eq7": f.beta / beta_eq7,
            "fit_over_hcrit": f.beta / float(rj.beta_hcrit(blk)),
            "e_exp1": float(e3[0]),
            "e_exp2": float(e3[1]),
            "e_exp3": float(e3[2]),
            "pct_isr1": float(pct[0]),
            "pct_isr2": float(pct[1]),
            "pct_isr3": float(pct[2]),
            "loss": f.loss,
            "n_simulations": f.n_simulations,
            "converged": bool(f.converged),
            "error": "" if f.converged else f"not converged: {f.reason}",
        }
    nan = float("nan")
    keys = ("beta_fit_s", "fit_over_eq7", "fit_over_hcrit", "e_exp1", "e_exp2", "e_exp3")
    keys += ("pct_isr1", "pct_isr2", "pct_isr3", "loss")
    return {
        **dict.fromkeys(keys, nan),
        "beta_max_s": nan,
        "beta_eq7_s": beta_eq7,
        "n_simulations": 0,
        "converged": False,
        "error": msg,
    }


def gap_ratios(blk: rj.Block, beta: float, gaps, beta_max: float, joint: rj.Joint) -> list[dict]:
    """``e_gap / e_0`` at ``beta`` [s] for each gap [m]: of bounce 1 and of the mean of 1-3
    (NaN where a bounce is absent); ``beta_max`` [s] is the fit's, so the DEM step is the fit's."""
    res = []
    for g in gaps:
        out = rj.calibration.e_effective(
            blk, [beta], mode="one_sided", gap=g, beta_max=beta_max, joint=joint
        )
        res.append(np.asarray(out["e_exp"][0], float))
    e0 = res[0]
    return [
        {
            "gap_m": float(g),
            "e_exp1": float(e[0]),
            "e_exp2": float(e[1]),
            "e_exp3": float(e[2]),
            "ratio_bounce1": float(e[0] / e0[0]),
            "ratio_mean123": float(np.mean(e) / np.mean(e0)),
        }
        for g, e in zip(gaps, res, strict=True)
    ]


def _geometry_head(b: float, ratio: float, E: float) -> dict:
    blk = _block(b, ratio, E)
    return {
        "b_m": b,
        "h_m": b * ratio,
        "h_over_b": ratio,
        "E_Pa": E,
        "beta_hcrit_s": float(rj.beta_hcrit(blk)),
        "beta_dejong_s": float(rj.beta_dejong(blk)),
        "e_isr_abs": abs(float(rj.e_isr(blk))),
    }


def _write(out: Path, scans, fits, gaps, cfg, progress) -> None:
    note = "e_exp: Eq. 6 of bounces 1-3, one-sided DEM, friction 30 deg, release 0.5 eta; SI units"
    if scans:
        write_csv(out / "facades_scan.csv", scans, note)
    if fits:
        write_csv(out / "facades_fit.csv", fits, "targets 68/80/100 % of |e_ISR|; " + note)
    if gaps:
        write_csv(out / "facades_gap.csv", gaps, "at the fitted beta; " + note)
    payload = {"config": cfg, "fits": fits, "gaps": gaps}
    write_json(out / "facades.json", payload, progress.elapsed)


def _plot_scan(scans, fits, path: Path) -> None:
    fig, axes = plt.subplots(1, 3, figsize=(11, 3.4), sharey=True)
    for f in fits:
        sel = [
            s for s in scans if (s["b_m"], s["h_m"], s["E_Pa"]) == (f["b_m"], f["h_m"], f["E_Pa"])
        ]
        label = f"b={f['b_m']:g} h/b={f['h_over_b']:g} E={f['E_Pa'] / 1e9:g}"
        for k, ax in enumerate(axes, start=1):
            y = [s[f"e_exp{k}"] / f["e_isr_abs"] for s in sel]
            ax.plot([s["beta_over_hcrit"] for s in sel], y, "o-", ms=2, lw=0.7, label=label)
    for k, (ax, frac) in enumerate(zip(axes, (0.68, 0.80, 1.0), strict=True), start=1):
        ax.axhline(frac, c="k", ls="--", lw=0.8)
        ax.set(xlabel="beta / beta_Hcrit [-]", title=f"bounce {k} (absent bounces omitted)")
    axes[0].set_ylabel("e_exp / |e_ISR| [-]")
    axes[2].legend(fontsize=5)
    save_fig(fig, path)


def _plot_fit(fits, path: Path) -> None:
    fig, ax = plt.subplots(figsize=(4.6, 3.6))
    for b in sorted({f["b_m"] for f in fits}):
        for E in sorted({f["E_Pa"] for f in fits}):
            sel = [f for f in fits if (f["b_m"], f["E_Pa"]) == (b, E)]
            (dots,) = ax.semilogy(
                [f["h_over_b"] for f in sel if f["converged"]],
                [f["beta_fit_s"] for f in sel if f["converged"]],
                "o",
                label=f"fit b={b:g} E={E / 1e9:g} GPa",
            )
            ax.semilogy(  # a search that did not converge: where it stopped, hollow
                [f["h_over_b"] for f in sel if not f["converged"]],
                [f["beta_fit_s"] for f in sel if not f["converged"]],
                "o",
                mfc="none",
                c=dots.get_color(),
            )
            ax.semilogy(
                [f["h_over_b"] for f in sel],
                [f["beta_eq7_s"] for f in sel],
                "x--",
                lw=0.7,
                label=f"Eq. 7 b={b:g} E={E / 1e9:g} GPa",
            )
    ax.set(xlabel="h/b [-]", ylabel="beta [s]", title="facade beta: fitted vs Eq. 7 (Fig. 5B)")
    ax.legend(fontsize=5)
    save_fig(fig, path)


def _plot_gap(gaps, path: Path) -> None:
    fig, ax = plt.subplots(figsize=(4.6, 3.4))
    for geom in sorted({(g["b_m"], g["h_over_b"], g["E_Pa"]) for g in gaps}):
        sel = [g for g in gaps if (g["b_m"], g["h_over_b"], g["E_Pa"]) == geom]
        (ln,) = ax.plot(
            [1e3 * g["gap_m"] for g in sel],
            [g["ratio_bounce1"] for g in sel],
            "o-",
            label=f"h/b={geom[1]:g} bounce 1",
        )
        ax.plot(
            [1e3 * g["gap_m"] for g in sel],
            [g["ratio_mean123"] for g in sel],
            "s--",
            c=ln.get_color(),
            label=f"h/b={geom[1]:g} mean 1-3",
        )
    ax.set(xlabel="gap [mm]", ylabel="e_gap / e_0 [-]", title="return-wall gap (Fig. 7)")
    ax.legend(fontsize=6)
    save_fig(fig, path)


def run(out: Path, quick: bool = False, n_sub="exact") -> dict:
    """Run the facade study with the DEM joint ``rj.Joint(n_sub=n_sub)``; write CSV/JSON/PNG
    under ``out`` (after every geometry).

    The gap study runs right after the fit of each geometry in ``cfg["gap_geometries"]`` whose
    fit converged (``converged`` in the fit table; a search that did not is kept as where it
    stopped, marked).
    """
    cfg = {**(QUICK if quick else FULL), "n_sub": n_sub}
    joint = rj.Joint(n_sub=n_sub)
    geoms = [(b, r, E) for E in cfg["E"] for b in cfg["b"] for r in cfg["ratios"]]
    progress = Progress("facades", len(geoms))
    scans, fits, gaps = [], [], []
    for b, r, E in geoms:
        head = _geometry_head(b, r, E)
        rows = scan(_block(b, r, E), cfg["scan"], joint)
        scans += [{**head, **row} for row in rows]
        f = {**head, **fit(_block(b, r, E), rows, cfg)}
        fits.append(f)
        if (b, r, E) in cfg["gap_geometries"] and f["converged"]:
            pick = ("b_m", "h_m", "h_over_b", "E_Pa", "beta_fit_s")
            res = gap_ratios(_block(b, r, E), f["beta_fit_s"], cfg["gaps"], f["beta_max_s"], joint)
            gaps += [{**{k: f[k] for k in pick}, **g} for g in res]
        _write(out, scans, fits, gaps, cfg, progress)
        note = "" if f["converged"] else " (not converged)"
        progress.step(
            f"b={b:g} m h/b={r:g} E={E / 1e9:g} GPa beta_fit={f['beta_fit_s']:.3g} s{note}"
        )
    _plot_scan(scans, fits, out / "facades_scan.png")
    _plot_fit(fits, out / "facades_fit.png")
    if gaps:
        _plot_gap(gaps, out / "facades_gap.png")
    return {"fits": fits, "gaps": gaps}
