"""Pulse-like vs non-pulse records, parapets vs facades: the paper's IDA study on whole record sets.

The paper's four blocks (h x b = 1.50 x 0.170, 3.00 x 0.250, 6.44 x 0.375, 8.00 x 0.375 m), each
as a parapet (two-sided) and a facade (one-sided, no gap), with the DEM (beta calibrated here
by ``rj.fit_beta``: to Housner's e_H for parapets, to the experimental bounce ratios for
facades) and with Housner (e_H, Eq. 2; |e_1SR|, Eq. 5), under the FEMA P695 near-field set (28
records x 2 components: 14 pulse-like, 14 not) and far-field set (22 x 2). Every record is
normalised to PGA = 1 g, so a scale factor is the PGA in g; each record's capacity is the
lowest PGA at which the block overturns (later resurrections do not raise it).

Stages (each prints its wall time; all are written to ``summary.json``):

1. pulse identification of every record (``rj.identify_pulse``: MH / AR / SC, Fig. 8);
2. beta calibration of the DEM for each block and mode (cached in ``beta.json``);
3. the IDA campaign (``rj.campaign.run``, Dask; resumable: rerun the command after an
   interruption and only the missing parts run);
4. analysis: capacity per record, ratio of median capacities pulse / no-pulse and pulse /
   far-field with bootstrap intervals over records, facade / parapet capacity ratios by pulse
   shape; CSV tables and figures.

    python experiments/pulse_study.py [--out experiments/results/pulse_study]
        [--scheduler tcp://host:8786] [--workers 2] [--quick]

``--quick`` runs one block and 6 records per set on 16 scales (a smoke run, ~1 min).
The findings are written up in experiments/README.md.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import time

import numpy as np

import rockjax as rj
from rockjax.constants import G

GEOMETRIES = {  # label: (h, b) [m]
    "h1.50": (1.50, 0.170),
    "h3.00": (3.00, 0.250),
    "h6.44": (6.44, 0.375),
    "h8.00": (8.00, 0.375),
}
MODES = ("two_sided", "one_sided")
MODELS = ("dem", "housner")
SETS = ("nearfield", "farfield")
SUBSETS = ("NF pulse", "NF no-pulse", "FF")
SCALES = np.geomspace(0.02, 4.0, 48)  # PGA [g] of the normalised records; 11.9 % apart
N_BOOT = 2000
SEED = 0


def subset_of(meta_set: str) -> str:
    return {"nearfield_pulse": "NF pulse", "nearfield_no_pulse": "NF no-pulse"}.get(meta_set, "FF")


def load_records(quick: bool) -> dict[str, list[rj.GroundMotion]]:
    """The FEMA P695 sets, each record normalised to PGA = 1 g (metadata kept)."""
    sets = {}
    for name in SETS:
        recs = rj.records.fema_p695(name)
        if quick:  # 3 of each kind: pulse and no-pulse near-field, far-field
            if name == "nearfield":
                pulse = [r for r in recs if r.metadata["pulse"] == "yes"][:3]
                nopulse = [r for r in recs if r.metadata["pulse"] == "no"][:3]
                recs = pulse + nopulse
            else:
                recs = recs[:6]
        sets[name] = [r.scaled_to_pga(G) for r in recs]
    return sets


def identify(sets) -> list[dict]:
    rows = []
    for name, recs in sets.items():
        for r in recs:
            best, fits = rj.identify_pulse(r)
            rows.append(
                dict(
                    record=r.name,
                    set=r.metadata["set"],
                    subset=subset_of(r.metadata["set"]),
                    shape=best.shape,
                    period=best.period,
                    amplitude_g=best.amplitude / G,
                    r2=best.r2,
                    **{f"r2_{k}": v.r2 for k, v in fits.items()},
                )
            )
    return rows


def calibrate(blocks, path: pathlib.Path) -> dict[tuple[str, str], dict]:
    """beta per block and mode, from ``path`` if it holds the same blocks, else fitted."""
    cached = json.loads(path.read_text()) if path.exists() else {}
    out = {}
    for label, block in blocks.items():
        for mode in MODES:
            key = f"{label}/{mode}"
            spec = dict(h=float(block.h), b=float(block.b))
            if key in cached and cached[key]["block"] == spec:
                out[(label, mode)] = cached[key]
                continue
            t0 = time.perf_counter()
            if mode == "two_sided":
                fit = rj.fit_beta(block, e=float(rj.e_housner(block)), mode=mode)
                target = f"e_H = {float(rj.e_housner(block)):.4f} (Eq. 2)"
            else:
                fit = rj.fit_beta(block, target="bounces", mode=mode)
                target = "e_exp of bounces 1-3 at 68/80/100 % of |e_1SR| (Eq. 5)"
            out[(label, mode)] = dict(
                block=spec,
                beta=float(fit.beta),
                beta_dejong=float(rj.beta_dejong(block)),
                target=target,
                e_effective=float(fit.e_effective),
                loss=float(fit.loss),
                n_simulations=int(fit.n_simulations),
                seconds=time.perf_counter() - t0,
            )
            print(
                f"  beta {key}: {fit.beta:.4g} s ({target}; {out[(label, mode)]['seconds']:.1f} s)"
            )
            # written after every fit, so an interrupted run keeps the fits it made
            path.write_text(
                json.dumps({**cached, **{f"{k[0]}/{k[1]}": v for k, v in out.items()}}, indent=1)
            )
    path.write_text(json.dumps({f"{k[0]}/{k[1]}": v for k, v in out.items()}, indent=1))
    return out


def capacities(results, cases, shapes) -> list[dict]:
    """One row per (case, record): the lowest collapse PGA [g] (inf: none up to the top scale)."""
    shape_of = {row["record"]: row for row in shapes}
    rows = []
    for case in cases:
        ds = results[case.name]
        low = rj.collapse_intervals(ds).lowest
        n_int = {k: len(v) for k, v in rj.collapse_intervals(ds).intervals.items()}
        failed = (ds["status"] != 0).sum("scale")
        label = case.name.split("_")[0]
        for rec in ds["record"].values:
            rec = str(rec)
            cap = float(low.sel(record=rec))
            rows.append(
                dict(
                    geometry=label,
                    h=float(case.block.h),
                    b=float(case.block.b),
                    mode=case.mode,
                    model=case.model.name,
                    record=rec,
                    subset=shape_of[rec]["subset"],
                    shape=shape_of[rec]["shape"],
                    shape_r2=shape_of[rec]["r2"],
                    capacity_g=cap if np.isfinite(cap) else np.inf,
                    n_collapse_intervals=n_int[rec],
                    n_failed_runs=int(failed.sel(record=rec)),
                )
            )
    return rows


def _median(x: np.ndarray) -> float:
    """Median with censored values (inf = no collapse in range) ranked above all others."""
    return float(np.median(np.sort(x))) if x.size else np.nan


def ratio_table(rows, rng) -> list[dict]:
    """Median capacity per subset and the pulse / no-pulse and pulse / far-field ratios."""
    table = []
    keys = sorted({(r["geometry"], r["mode"], r["model"]) for r in rows})
    for geo, mode, model in keys:
        sel = [r for r in rows if (r["geometry"], r["mode"], r["model"]) == (geo, mode, model)]
        caps = {s: np.array([r["capacity_g"] for r in sel if r["subset"] == s]) for s in SUBSETS}
        med = {s: _median(c) for s, c in caps.items()}
        entry = dict(geometry=geo, mode=mode, model=model)
        for s in SUBSETS:
            entry[f"median_{s}"] = med[s]
            entry[f"censored_{s}"] = int(np.sum(~np.isfinite(caps[s])))
        static = float(np.tan(rj.Block(b=sel[0]["b"], h=sel[0]["h"]).eta))
        entry["static_g"] = static
        for other in ("NF no-pulse", "FF"):
            a, b = caps["NF pulse"], caps[other]
            if not (a.size and b.size):
                continue
            boot = []
            for _ in range(N_BOOT):
                ma = _median(rng.choice(a, a.size))
                mb = _median(rng.choice(b, b.size))
                boot.append(ma / mb if np.isfinite(mb) else 0.0)
            ratio = med["NF pulse"] / med[other] if np.isfinite(med[other]) else np.nan
            entry[f"ratio_pulse_over_{other}"] = ratio
            entry[f"ratio_ci90_{other}"] = [float(q) for q in np.quantile(boot, [0.05, 0.95])]
        table.append(entry)
    return table


def pair_table(rows) -> list[dict]:
    """The paper's comparison record by record: capacity of each pulse-like record over that of
    each non-pulse record (near-field no-pulse and far-field), per block, mode and model."""
    table = []
    keys = sorted({(r["geometry"], r["mode"], r["model"]) for r in rows})
    for key in keys:
        sel = [r for r in rows if (r["geometry"], r["mode"], r["model"]) == key]
        a = np.array([r["capacity_g"] for r in sel if r["subset"] == "NF pulse"])
        b = np.array([r["capacity_g"] for r in sel if r["subset"] != "NF pulse"])
        a, b = a[np.isfinite(a)], b[np.isfinite(b)]
        ratio = (a[:, None] / b[None, :]).ravel()
        q = np.quantile(ratio, [0.05, 0.25, 0.5, 0.75, 0.95])
        table.append(
            dict(
                geometry=key[0],
                mode=key[1],
                model=key[2],
                n_pairs=int(ratio.size),
                q05=q[0],
                q25=q[1],
                median=q[2],
                q75=q[3],
                q95=q[4],
                min=float(ratio.min()),
                frac_below_1=float(np.mean(ratio < 1.0)),
                frac_below_1_3=float(np.mean(ratio <= 1 / 3)),
                frac_in_1_12_to_1_3=float(np.mean((ratio >= 1 / 12) & (ratio <= 1 / 3))),
            )
        )
    return table


def model_table(rows) -> list[dict]:
    """DEM over Housner capacity, record by record, per block and mode."""
    table = []
    by = {}
    for r in rows:
        by.setdefault((r["geometry"], r["mode"], r["record"]), {})[r["model"]] = r["capacity_g"]
    step = SCALES[1] / SCALES[0]
    for geo in sorted({k[0] for k in by}):
        for mode in MODES:
            ratio = np.array(
                [
                    v["dem"] / v["housner"]
                    for k, v in by.items()
                    if k[:2] == (geo, mode) and len(v) == 2
                ]
            )
            ratio = ratio[np.isfinite(ratio)]
            if not ratio.size:
                continue
            table.append(
                dict(
                    geometry=geo,
                    mode=mode,
                    n_records=int(ratio.size),
                    median_dem_over_housner=float(np.median(ratio)),
                    q10=float(np.quantile(ratio, 0.1)),
                    q90=float(np.quantile(ratio, 0.9)),
                    frac_within_one_step=float(
                        np.mean(np.abs(np.log(ratio)) <= 1.01 * np.log(step))
                    ),
                )
            )
    return table


def shape_table(rows) -> list[dict]:
    """Facade / parapet capacity ratio per record, grouped by the record's pulse shape."""
    table = []
    pairs = {}
    for r in rows:
        pairs.setdefault((r["geometry"], r["model"], r["record"]), {})[r["mode"]] = r
    for model in MODELS:
        for subset_group in ("NF pulse", "all"):
            for shape in rj.pulses.SHAPES:
                ratios = []
                for (geo, mdl, rec), p in pairs.items():
                    if mdl != model or len(p) < 2:
                        continue
                    row = p["two_sided"]
                    if row["shape"] != shape:
                        continue
                    if subset_group != "all" and row["subset"] != subset_group:
                        continue
                    fac, par = p["one_sided"]["capacity_g"], row["capacity_g"]
                    if np.isfinite(fac) and np.isfinite(par):
                        ratios.append(fac / par)
                ratios = np.array(ratios)
                table.append(
                    dict(
                        model=model,
                        records=subset_group,
                        shape=shape,
                        n_pairs=int(ratios.size),
                        facade_weaker_fraction=float(np.mean(ratios < 1.0))
                        if ratios.size
                        else np.nan,
                        median_facade_over_parapet=float(np.median(ratios))
                        if ratios.size
                        else np.nan,
                        q10=float(np.quantile(ratios, 0.1)) if ratios.size else np.nan,
                        q90=float(np.quantile(ratios, 0.9)) if ratios.size else np.nan,
                    )
                )
    return table


def figures(out: pathlib.Path, rows, ratios, results, cases) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []
    geos = sorted({r["geometry"] for r in rows})
    colors = {"NF pulse": "tab:red", "NF no-pulse": "tab:blue", "FF": "tab:green"}

    # 1. capacity by subset: one panel per block, columns mode x model
    fig, axes = plt.subplots(1, len(geos), figsize=(4.2 * len(geos), 4.2), squeeze=False)
    combos = [(m, md) for m in MODES for md in MODELS]
    for ax, geo in zip(axes[0], geos):
        for j, (mode, model) in enumerate(combos):
            for k, s in enumerate(SUBSETS):
                c = np.array(
                    [
                        r["capacity_g"]
                        for r in rows
                        if (r["geometry"], r["mode"], r["model"], r["subset"])
                        == (geo, mode, model, s)
                    ]
                )
                x = j + (k - 1) * 0.25
                fin = c[np.isfinite(c)]
                jitter = np.random.default_rng(k + 10 * j).uniform(-0.06, 0.06, fin.size)
                ax.scatter(x + jitter, fin, s=6, color=colors[s], alpha=0.5, lw=0)
                if c.size:
                    ax.plot([x - 0.1, x + 0.1], [_median(c)] * 2, color="k", lw=2)
        h, b = GEOMETRIES[geo]
        ax.axhline(b / h, color="0.4", ls=":", lw=1)
        ax.set_yscale("log")
        ax.set_xticks(range(len(combos)))
        ax.set_xticklabels(
            [
                f"{'parapet' if m == 'two_sided' else 'facade'}\n{md.upper() if md == 'dem' else 'Housner'}"
                for m, md in combos
            ],
            fontsize=8,
        )
        ax.set_title(f"h x b = {h:.2f} x {b:.3f} m")
        ax.grid(True, which="both", axis="y", alpha=0.3)
    axes[0][0].set_ylabel("capacity: lowest collapse PGA [g]")
    for s in SUBSETS:
        axes[0][0].scatter([], [], color=colors[s], label=s)
    axes[0][0].plot([], [], color="k", lw=2, label="median")
    axes[0][0].plot([], [], color="0.4", ls=":", label="static b/h")
    axes[0][0].legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(out / "capacity_by_set.png", dpi=130)
    plt.close(fig)
    written.append("capacity_by_set.png")

    # 2. pulse / no-pulse ratios with bootstrap intervals, the paper's 1/12-1/3 band
    fig, ax = plt.subplots(figsize=(9, 4.2))
    labels = []
    for i, t in enumerate(ratios):
        for k, (other, mk) in enumerate((("NF no-pulse", "o"), ("FF", "s"))):
            if f"ratio_pulse_over_{other}" not in t:
                continue
            r, (lo, hi) = t[f"ratio_pulse_over_{other}"], t[f"ratio_ci90_{other}"]
            ax.errorbar(
                i + (k - 0.5) * 0.25,
                r,
                yerr=[[max(r - lo, 0)], [max(hi - r, 0)]],
                fmt=mk,
                color=colors[other],
                ms=5,
                label=f"pulse / {other}" if i == 0 else None,
            )
        labels.append(
            f"{t['geometry']}\n{'par' if t['mode'] == 'two_sided' else 'fac'} {t['model'][:3]}"
        )
    ax.axhspan(1 / 12, 1 / 3, color="0.85", label="paper: 1/12 - 1/3")
    ax.axhline(1.0, color="0.3", lw=0.8)
    ax.set_yscale("log")
    ax.set_xticks(range(len(labels)))
    ax.set_xticklabels(labels, fontsize=7)
    ax.set_ylabel("median capacity ratio [-]")
    ax.set_title("Pulse-like near-field records vs the others (90 % bootstrap over records)")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "pulse_ratio.png", dpi=130)
    plt.close(fig)
    written.append("pulse_ratio.png")

    # 3. facade vs parapet capacity pairs (Fig. 11 style), coloured by pulse shape
    shape_colors = {"MH": "tab:purple", "AR": "tab:orange", "SC": "tab:cyan"}
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.8))
    for ax, model in zip(axes, MODELS):
        pairs = {}
        for r in rows:
            if r["model"] == model:
                pairs.setdefault((r["geometry"], r["record"]), {})[r["mode"]] = r
        for shape, col in shape_colors.items():
            xs, ys, ps = [], [], []
            for p in pairs.values():
                if len(p) == 2 and p["two_sided"]["shape"] == shape:
                    xs.append(p["two_sided"]["capacity_g"])
                    ys.append(p["one_sided"]["capacity_g"])
                    ps.append(p["two_sided"]["subset"] == "NF pulse")
            xs, ys, ps = np.array(xs), np.array(ys), np.array(ps, bool)
            ok = np.isfinite(xs) & np.isfinite(ys)
            ax.scatter(
                xs[ok & ps], ys[ok & ps], s=18, color=col, marker="o", label=f"{shape}, NF pulse"
            )
            ax.scatter(
                xs[ok & ~ps],
                ys[ok & ~ps],
                s=8,
                color=col,
                marker=".",
                alpha=0.5,
                label=f"{shape}, others",
            )
        lim = [SCALES[0], SCALES[-1]]
        ax.plot(lim, lim, color="k", lw=0.8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("parapet capacity [g]")
        ax.set_ylabel("facade capacity [g]")
        ax.set_title(
            f"{'DEM' if model == 'dem' else 'Housner'}: below the diagonal = facade weaker"
        )
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(out / "facade_vs_parapet.png", dpi=130)
    plt.close(fig)
    written.append("facade_vs_parapet.png")

    # 4. IDA curves (Fig. 10 style) of the 3 m block, near-field, both modes and models
    geo = "h3.00" if "h3.00" in geos else geos[0]
    sel = [c for c in cases if c.name.startswith(geo + "_") and c.records == "nearfield"]
    fig, axes = plt.subplots(2, 2, figsize=(10, 8), sharex=True, sharey=True)
    for ax, c in zip(axes.ravel(), sel):
        ds = results[c.name]
        pulse = ds["meta_set"] == "nearfield_pulse"
        rj.plot.ida(ds.sel(record=ds["record"][pulse]), ax=ax)
        ax.set_title(f"{c.mode} {c.model.name}: NF pulse records", fontsize=9)
        if ax.get_legend() is not None:
            ax.get_legend().remove()
    axes[0, 0].set_yscale("log")  # shared: the capacities span 0.04-1 g
    axes[0, 0].set_ylim(
        0.9 * float(cases_scales(results, sel)[0]), 1.1 * float(cases_scales(results, sel)[-1])
    )
    fig.tight_layout()
    fig.savefig(out / f"ida_{geo}_nf_pulse.png", dpi=130)
    plt.close(fig)
    written.append(f"ida_{geo}_nf_pulse.png")
    return written


def cases_scales(results, cases) -> np.ndarray:
    """The PGA grid [g] of the cases (records normalised to 1 g: the scale factors)."""
    return np.asarray(results[cases[0].name]["scale"], float)


def write_csv(path: pathlib.Path, rows: list[dict]) -> None:
    import csv

    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: (json.dumps(v) if isinstance(v, list) else v) for k, v in r.items()})


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="experiments/results/pulse_study")
    ap.add_argument(
        "--scheduler", default=None, help="Dask scheduler address (default: LocalCluster)"
    )
    ap.add_argument("--workers", type=int, default=None, help="LocalCluster worker processes")
    ap.add_argument("--dem-records-per-task", type=int, default=4)
    ap.add_argument("--housner-records-per-task", type=int, default=16)
    ap.add_argument("--quick", action="store_true", help="one block, 6 records per set, 16 scales")
    args = ap.parse_args(argv)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    wall = {}
    t_all = time.perf_counter()

    geometries = {"h3.00": GEOMETRIES["h3.00"]} if args.quick else GEOMETRIES
    scales = np.geomspace(0.02, 4.0, 16) if args.quick else SCALES
    blocks = {k: rj.Block(b=b, h=h) for k, (h, b) in geometries.items()}

    t0 = time.perf_counter()
    sets = load_records(args.quick)
    shapes = identify(sets)
    wall["records_and_pulses"] = time.perf_counter() - t0
    print(
        f"[1/4] {sum(map(len, sets.values()))} records, pulse shapes identified ({wall['records_and_pulses']:.1f} s)"
    )

    t0 = time.perf_counter()
    betas = calibrate(blocks, out / "beta.json")
    wall["calibration"] = time.perf_counter() - t0
    print(f"[2/4] beta calibrated for {len(betas)} block/mode pairs ({wall['calibration']:.1f} s)")

    t0 = time.perf_counter()
    cases = rj.campaign.grid(
        blocks, SETS, modes=MODES, models=MODELS, beta={k: v["beta"] for k, v in betas.items()}
    )
    results = rj.campaign.run(
        cases,
        sets,
        out / "campaign",
        scales=scales,
        records_per_task={
            "dem": args.dem_records_per_task,
            "housner": args.housner_records_per_task,
        },
        scheduler=args.scheduler,
        n_workers=args.workers,
    )
    wall["campaign"] = time.perf_counter() - t0
    n_runs = sum(ds["collapse"].size for ds in results.values())
    print(f"[3/4] campaign: {len(cases)} IDAs, {n_runs} runs ({wall['campaign']:.1f} s)")

    t0 = time.perf_counter()
    rows = capacities(results, cases, shapes)
    rng = np.random.default_rng(SEED)
    ratios = ratio_table(rows, rng)
    by_shape = shape_table(rows)
    pairs = pair_table(rows)
    models = model_table(rows)
    write_csv(out / "pulse_shapes.csv", shapes)
    write_csv(out / "capacities.csv", rows)
    write_csv(out / "pulse_ratio.csv", ratios)
    write_csv(out / "shape_ratio.csv", by_shape)
    write_csv(out / "pulse_pairs.csv", pairs)
    write_csv(out / "dem_vs_housner.csv", models)
    written = figures(out, rows, ratios, results, cases)
    wall["analysis"] = time.perf_counter() - t0
    wall["total"] = time.perf_counter() - t_all
    print(f"[4/4] analysis and figures ({wall['analysis']:.1f} s); total {wall['total']:.1f} s")

    summary = dict(
        command="python experiments/pulse_study.py" + (" --quick" if args.quick else ""),
        rockjax_version=rj.__version__,
        scales_g=[float(s) for s in scales],
        n_runs=int(n_runs),
        n_failed_runs=int(sum(int((ds["status"] != 0).sum()) for ds in results.values())),
        beta={f"{k[0]}/{k[1]}": v for k, v in betas.items()},
        ratios=ratios,
        shapes=by_shape,
        pulse_pairs=pairs,
        dem_vs_housner=models,
        shape_counts={
            s: {
                sh: sum(1 for r in shapes if r["subset"] == s and r["shape"] == sh)
                for sh in rj.pulses.SHAPES
            }
            for s in SUBSETS
        },
        wall_s=wall,
        figures=written,
    )
    (out / "summary.json").write_text(json.dumps(summary, indent=1, default=float))
    for t in ratios:
        print(
            f"  {t['geometry']} {t['mode']:9s} {t['model']:7s} median capacity [g]: "
            + ", ".join(f"{s} {t[f'median_{s}']:.3g}" for s in SUBSETS)
            + f"; pulse/no-pulse {t.get('ratio_pulse_over_NF no-pulse', np.nan):.2f}"
            + f", pulse/FF {t.get('ratio_pulse_over_FF', np.nan):.2f}"
        )
    return summary


if __name__ == "__main__":
    main()
