"""Parapets (two-sided rocking, the paper's Figs 1-3): e(beta), linear fits, the h/b power law.

For each geometry the DEM free-rocking restitution ``e`` (least squares over up to 8 bounces,
:func:`rockjax.calibration.e_effective`) is computed on a grid ``beta = 0 ... 1.5 beta_DeJong``;
lines ``e = e0 - x beta`` are fitted with ``e0`` free and with ``e0 = e_H`` (Eq. 3); the slopes
``x`` are fitted as ``x = y (h/b)^k`` (Eq. 4, paper: ``k = -0.37``) per ``b`` and pooled.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import NullFormatter

import rockjax as rj

from ._common import Progress, linear_fit, power_fit, save_fig, write_csv, write_json

PAPER_K = -0.37
RHO0, E0 = 1800.0, 1.8e9
"""Reference density [kg/m^3] and Young's modulus [Pa] (the paper's)."""

FULL = {
    "b": (0.1, 0.2, 0.3, 0.4),
    "ratios": (4, 6, 8, 12, 16, 24),
    "n_beta": 9,
    "E": (0.9e9, 1.8e9, 3.6e9),
    "rho": (1800.0, 2400.0),
}
QUICK = {"b": (0.2,), "ratios": (4, 8), "n_beta": 5, "E": (1.8e9, 3.6e9), "rho": (1800.0,)}
MATERIAL_GEOMETRY = (0.4, 4.0)
"""``(b, h)`` [m] of the paper's Fig. 3 block."""


def e_curve(
    b: float, h: float, betas, E: float = E0, rho: float = RHO0, n_sub="exact"
) -> list[dict]:
    """DEM restitution at each ``beta`` [s] for a ``b x h`` [m] parapet; one row per ``beta``."""
    blk = rj.Block(b=b, h=h, rho=rho, E=E)
    joint = rj.Joint(n_sub=n_sub)
    out = rj.calibration.e_effective(blk, np.asarray(betas), mode="two_sided", joint=joint)
    bd = float(rj.beta_dejong(blk))
    return [
        {
            "b_m": b,
            "h_m": h,
            "h_over_b": h / b,
            "E_Pa": E,
            "rho_kg_m3": rho,
            "beta_s": float(beta),
            "beta_over_dejong": float(beta) / bd,
            "e": float(e),
            "e_exp1": float(e3[0]),
            "e_exp2": float(e3[1]),
            "e_exp3": float(e3[2]),
            "ok": bool(ok),
        }
        for beta, e, e3, ok in zip(out["beta"], out["e"], out["e_exp"], out["ok"], strict=True)
    ]


def geometry_fit(rows: list[dict]) -> dict:
    """Line fits of one geometry's ``e(beta)``: free intercept and intercept ``e_H`` (Eq. 3)."""
    r0 = rows[0]
    blk = rj.Block(b=r0["b_m"], h=r0["h_m"], rho=r0["rho_kg_m3"], E=r0["E_Pa"])
    e_h = float(rj.e_housner(blk))
    beta = [r["beta_s"] for r in rows]
    e = [r["e"] for r in rows]
    free, fixed = linear_fit(beta, e), linear_fit(beta, e, intercept=e_h)
    return {
        "b_m": r0["b_m"],
        "h_m": r0["h_m"],
        "h_over_b": r0["h_over_b"],
        "E_Pa": r0["E_Pa"],
        "rho_kg_m3": r0["rho_kg_m3"],
        "beta_dejong_s": float(rj.beta_dejong(blk)),
        "e_H": e_h,
        "e_at_beta0": e[0],
        "e0_free": free["a"],
        "x_free_per_s": free["slope"],
        "r2_free": free["r2"],
        "x_eq3_per_s": fixed["slope"],
        "r2_eq3": fixed["r2"],
    }


def power_laws(fits: list[dict], key: str) -> dict:
    """``x = y (h/b)^k`` of slope column ``key`` per ``b`` and pooled, and ``y`` at ``k = -0.37``."""
    out = {}
    for b in sorted({f["b_m"] for f in fits}):
        sel = [f for f in fits if f["b_m"] == b]
        r = np.array([f["h_over_b"] for f in sel])
        x = np.array([f[key] for f in sel])
        fit = power_fit(r, x) if len(sel) > 1 else {"c": np.nan, "k": np.nan, "r2": np.nan}
        y_paper = float(np.exp(np.mean(np.log(x / r**PAPER_K))))
        out[f"b={b:g}"] = {**fit, "y_at_paper_k": y_paper}
    r = np.array([f["h_over_b"] for f in fits])
    x = np.array([f[key] for f in fits])
    out["pooled"] = power_fit(r, x)
    bs = sorted({f["b_m"] for f in fits})
    if len(bs) > 1:
        y = [out[f"b={b:g}"]["y_at_paper_k"] for b in bs]
        out["y_vs_b_at_paper_k"] = power_fit(bs, y)
    return out


def material_effect(rows: list[dict], fits: list[dict]) -> list[dict]:
    """Shift of ``e(beta)`` against the reference ``E0, RHO0`` on the common ``beta`` grid."""
    ref = [r for r in rows if r["E_Pa"] == E0 and r["rho_kg_m3"] == RHO0]
    ref_fit = next(f for f in fits if f["E_Pa"] == E0 and f["rho_kg_m3"] == RHO0)
    e_ref = np.array([r["e"] for r in ref])
    out = []
    for f in fits:
        e = np.array(
            [r["e"] for r in rows if (r["E_Pa"], r["rho_kg_m3"]) == (f["E_Pa"], f["rho_kg_m3"])]
        )
        out.append(
            {
                "E_Pa": f["E_Pa"],
                "rho_kg_m3": f["rho_kg_m3"],
                "max_abs_delta_e": float(np.nanmax(np.abs(e - e_ref))),
                "x_free_per_s": f["x_free_per_s"],
                "slope_change_pct": 100.0 * (f["x_free_per_s"] / ref_fit["x_free_per_s"] - 1.0),
                "beta_dejong_s": f["beta_dejong_s"],
            }
        )
    return out


def _geometry_study(cfg: dict, progress: Progress) -> tuple[list[dict], list[dict]]:
    rows, fits = [], []
    for b in cfg["b"]:
        for r in cfg["ratios"]:
            h = b * r
            bd = float(rj.beta_dejong(rj.Block(b=b, h=h, rho=RHO0, E=E0)))
            rs = e_curve(b, h, np.linspace(0.0, 1.5 * bd, cfg["n_beta"]), n_sub=cfg["n_sub"])
            rows += rs
            fits.append(geometry_fit(rs))
            progress.step(f"b={b:g} m h/b={r:g}")
    return rows, fits


def _material_study(cfg: dict, progress: Progress) -> tuple[list[dict], list[dict]]:
    b, h = MATERIAL_GEOMETRY
    bd = float(rj.beta_dejong(rj.Block(b=b, h=h, rho=RHO0, E=E0)))
    betas = np.linspace(0.0, 1.5 * bd, cfg["n_beta"])
    rows, fits = [], []
    for E in cfg["E"]:
        for rho in cfg["rho"]:
            rs = e_curve(b, h, betas, E=E, rho=rho, n_sub=cfg["n_sub"])
            rows += rs
            fits.append(geometry_fit(rs))
            progress.step(f"b={b:g} m h={h:g} m E={E / 1e9:g} GPa rho={rho:g}")
    return rows, fits


def _plot_e_beta(rows, fits, path: Path) -> None:
    bs = sorted({r["b_m"] for r in rows})
    fig, axes = plt.subplots(1, len(bs), figsize=(3.6 * len(bs), 3.4), squeeze=False)
    for ax, b in zip(axes[0], bs, strict=True):
        for f in (f for f in fits if f["b_m"] == b):
            sel = [r for r in rows if r["b_m"] == b and r["h_m"] == f["h_m"]]
            beta = np.array([r["beta_s"] for r in sel])
            (ln,) = ax.plot(beta, [r["e"] for r in sel], "o", ms=3, label=f"h/b={f['h_over_b']:g}")
            ax.plot(beta, f["e0_free"] - f["x_free_per_s"] * beta, "-", c=ln.get_color(), lw=0.8)
        ax.set(title=f"b = {b:g} m", xlabel="beta [s]", ylabel="e (DEM) [-]")
        ax.legend(fontsize=6)
    save_fig(fig, path)


def _plot_power(fits, laws, path: Path) -> None:
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(8, 3.4))
    rr = np.geomspace(3, 30, 50)
    for b in sorted({f["b_m"] for f in fits}):
        sel = [f for f in fits if f["b_m"] == b]
        (ln,) = a1.loglog(
            [f["h_over_b"] for f in sel], [f["x_eq3_per_s"] for f in sel], "o", label=f"b={b:g} m"
        )
        law = laws[f"b={b:g}"]
        if np.isfinite(law["k"]):
            a1.loglog(rr, law["c"] * rr ** law["k"], "-", c=ln.get_color(), lw=0.8)
    a1.xaxis.set_minor_formatter(NullFormatter())
    a1.set(
        xlabel="h/b [-]",
        ylabel="x (Eq. 3, e0 = e_H) [1/s]",
        title=f"pooled k = {laws['pooled']['k']:.3f} (paper -0.37)",
    )
    a1.legend(fontsize=7)
    b = [float(k[2:]) for k in laws if k.startswith("b=")]
    a2.plot(b, [laws[f"b={v:g}"]["y_at_paper_k"] for v in b], "o-", label="y at k = -0.37")
    a2.plot(b, [laws[f"b={v:g}"]["c"] for v in b], "s--", label="y at own k per b")
    a2.set(xlabel="b [m]", ylabel="y [1/s]", title="y vs b (Fig. 2B)")
    a2.legend(fontsize=7)
    save_fig(fig, path)


def _plot_material(rows, path: Path) -> None:
    fig, ax = plt.subplots(figsize=(4.5, 3.4))
    for E, rho in sorted({(r["E_Pa"], r["rho_kg_m3"]) for r in rows}):
        sel = [r for r in rows if (r["E_Pa"], r["rho_kg_m3"]) == (E, rho)]
        ax.plot(
            [r["beta_s"] for r in sel],
            [r["e"] for r in sel],
            "o-",
            ms=3,
            label=f"E={E / 1e9:g} GPa, rho={rho:g}",
        )
    ax.set(xlabel="beta [s]", ylabel="e (DEM) [-]", title="b = 0.4 m, h = 4 m (Fig. 3)")
    ax.legend(fontsize=7)
    save_fig(fig, path)


def run(out: Path, quick: bool = False, n_sub="exact") -> dict:
    """Run the parapet study with the DEM joint ``rj.Joint(n_sub=n_sub)``; write CSV/JSON/PNG
    under ``out``; return the JSON payload."""
    cfg = {**(QUICK if quick else FULL), "n_sub": n_sub}
    n = len(cfg["b"]) * len(cfg["ratios"]) + len(cfg["E"]) * len(cfg["rho"])
    progress = Progress("parapets", n)
    rows, fits = _geometry_study(cfg, progress)
    m_rows, m_fits = _material_study(cfg, progress)
    laws = {"eq3": power_laws(fits, "x_eq3_per_s"), "free": power_laws(fits, "x_free_per_s")}
    material = material_effect(m_rows, m_fits)
    note = "e: DEM least-squares restitution over up to 8 bounces, release 0.5 eta; SI units"
    write_csv(out / "parapets_e_beta.csv", rows + m_rows, note)
    write_csv(out / "parapets_fits.csv", fits + m_fits, "x: slope of e = e0 - x beta [1/s]")
    write_csv(out / "parapets_material.csv", material, "reference E = 1.8 GPa, rho = 1800 kg/m^3")
    _plot_e_beta(rows, fits, out / "parapets_e_beta.png")
    _plot_power(fits, laws["eq3"], out / "parapets_power_law.png")
    _plot_material(m_rows, out / "parapets_material.png")
    payload = {
        "config": cfg,
        "paper_k": PAPER_K,
        "fits": fits,
        "power_laws": laws,
        "material": material,
    }
    write_json(out / "parapets.json", payload, progress.elapsed)
    return payload
