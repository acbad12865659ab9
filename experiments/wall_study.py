"""Walls of several blocks in their building: the vertically spanning strip and the parapet.

The out-of-plane strip of an unreinforced-masonry wall, one metre long, 0.23 m thick
(two-wythe brick; rho = 1800 kg/m^3, E = 1.8 GPa, the package defaults), in a two-storey
building, a linear shear building (``rj.ShearBuilding.uniform``, storeys 3 m high, 5 % modal
damping) of fundamental period T1 = 0.2 s or 0.35 s:

(a) **the ground-storey wall** spanning between the ground and floor 1, cracked at mid-height:
    two 0.23 x 1.5 m blocks (``rj.Assembly.stack(..., top="restrained")``), its top held by
    floor 1 (no gap), loaded by the weight of the storey above's wall, ``P = rho g b 3 m``
    = 12.2 kN/m (the floors span onto the cross walls, so the wall carries no floor load), in
    storey 1 of the building (``rj.ida(..., support_motion=bldg, storey=1)``: base on the
    ground, restraint moving with floor 1). Against the single-block idealisations of the
    same wall:

    * ``wall1_restrained``: one 0.23 x 3.0 m block with the same restraint and load (the wall
      taken as one rigid body between its supports: it cannot rotate without moving its top,
      so it never overturns: the unconservative idealisation);
    * ``wall1_free``: one 0.23 x 3.0 m block with the same load and a free top (the wall as a
      cantilever, its restraint ignored: the conservative one);

    and against the same two-block wall on the ground (``wall2_ground``: restraint moving with
    the ground), which isolates the effect of the storey drift. (``wall1_free`` stands on the
    ground with a free top: it does not see the building, and is the same in both.)

(b) **a parapet on the top-storey wall**: a 0.23 x 1.0 m parapet standing on the 0.23 x 3.0 m
    wall of storey 2, the two as one free stack on floor 1 (``parapet_on_wall``, storey 2:
    the wall not anchored to the roof, so the roof does not hold the stack), against the
    parapet alone on the roof (``parapet_roof``, storey 3: the wall below anchored to the roof
    and moving with it).

**Static reference.** ``rj.collapse_multiplier`` of each case's mechanism (docs/assemblies.md,
"Limit analysis"): ``"hinge"`` for the restrained two-block wall, ``"stack"`` (and ``"top"``)
for the free stacks; the restrained single block has no mechanism (``inf``). They are
multipliers of the acceleration at the wall's base (the ground for storey 1, floor 1 for the
parapet stack, the roof for the parapet alone), in g.

**beta.** The DEM's stiffness-proportional damping of each block is calibrated to Housner's
restitution ``e_H`` (Eq. 2) of that block in free rocking (``rj.fit_beta(block,
e=rj.e_housner(block))``, two-sided), as in experiments/pulse_study.py; an assembly takes the
beta of its governing block: the 1.5 m half for the two-block wall, the 3.0 m block for the
single-block walls, the parapet for both parapet cases (so the two differ only in what the
parapet stands on). Cached in ``beta.json``.

**Records.** The pulse-like components of the FEMA P695 near-field set (metadata
``pulse == "yes"``) less the two on a 0.0024 s step (NF03, which cannot be resampled exactly
to the common step), 26 records, normalised to PGA = 1 g: a scale factor is the ground PGA
in g. Records of step 0.01 and 0.02 s are resampled to 0.005 s (exact for the linear
interpolant every simulator takes, and 15 samples per period of the stiffer building's second
mode, 0.076 s). Each record is cut to its 0.5 %-99.5 % Arias-intensity window (the long
Chi-Chi records otherwise set the length of every run) and all runs last the longest window
plus a 2 s free-vibration tail (one compiled batch per case for both stages below).

**Capacity** of a record: the lowest sampled scale at which the wall collapses (the
assembly's collapse rule, ``rj.simulate_assembly``; failed runs left out; later resurrections
ignored, as ``rj.collapse_intervals``). Scales: 12 geometric over 0.03-4 g, then 4 inside each
record's bracket (below its first collapse; above the top scale where none collapsed), 16 per
record, capacities resolved to ~9 %.

Outputs (``--out``, default experiments/results/wall_study): ``capacities.csv`` (one row per
building, case and record), ``summary.csv`` (per building and case: median and 16/84 %
capacities, records without collapse, the static multiplier, the median per-record ratio to
the reference case: ``wall2_ground`` for ``wall2``, ``wall2`` for the single blocks,
``parapet_roof`` for ``parapet_on_wall``), ``summary.json`` (command, wall times, tables) and the figure
docs/figures/wall_study.png. Finished cases are cached in ``runs/*.npz`` with the spec they
ran (a case is redone if its blocks, beta, building, records or scales changed), so a re-run
is instant.

    python experiments/wall_study.py [--out DIR] [--quick]

Measured from scratch on 2 cores shared with other jobs (load average 3-5.6): 16 min 53 s
(484 s of CPU), of which 4 min 18 s the three beta fits; a cached re-run takes 13 s.

``--quick``: the T1 = 0.2 s building, two records cut to 4 s, 4 + 2 scales, the two-block
wall and the parapet on the roof, beta = 2e-3 s (no calibration); written to
``<out>/quick`` when ``--out`` is the default (a smoke run of the whole path).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import pathlib
import sys
import time

import numpy as np

import rockjax as rj
from rockjax.constants import G

B = 0.23  # wall thickness [m]
STOREY_HEIGHT = 3.0  # [m]
H_PARAPET = 1.0  # [m]
N_STOREYS = 2
DAMPING = 0.05  # [-]
BUILDINGS = {"T0.20": 0.20, "T0.35": 0.35}  # label: T1 [s]
TAIL = 2.0  # free vibration after the longest record [s]
DT = 0.005  # common record step [s]
ARIAS = (0.005, 0.995)  # the window kept of each record, in fractions of its Arias intensity
FIGURE = pathlib.Path("docs/figures/wall_study.png")
FULL = dict(
    coarse=np.geomspace(0.03, 4.0, 12),
    n_refine=4,
    chunk=52,
    n_records=None,
    max_duration=None,
    buildings=tuple(BUILDINGS),
    beta=None,
)
QUICK = dict(
    coarse=np.geomspace(0.05, 4.0, 4),
    n_refine=2,
    chunk=4,
    n_records=2,
    max_duration=4.0,
    buildings=("T0.20",),
    beta=2e-3,
)
CASES = (  # name, what, reference for the per-record ratio
    ("wall2", "two-block wall, storey 1", "wall2_ground"),
    ("wall1_restrained", "one 3 m block, restrained", "wall2"),
    ("wall1_free", "one 3 m block, free top", "wall2"),
    ("wall2_ground", "two-block wall on the ground", "wall2"),
    ("parapet_on_wall", "parapet on the storey-2 wall", "parapet_roof"),
    ("parapet_roof", "parapet on the roof", None),
)
QUICK_CASES = ("wall2", "parapet_roof")


# ----------------------------------------------------------------------------- the walls
def blocks() -> dict[str, rj.Block]:
    return {
        "half": rj.Block(b=B, h=0.5 * STOREY_HEIGHT),
        "full": rj.Block(b=B, h=STOREY_HEIGHT),
        "parapet": rj.Block(b=B, h=H_PARAPET),
    }


def overburden() -> float:
    """The weight of the storey above's wall on the ground-storey wall [N/m]."""
    full = blocks()["full"]
    return float(full.rho) * G * B * STOREY_HEIGHT


def cases() -> dict[str, tuple[rj.Assembly, int | None, str, tuple[str, ...]]]:
    """Case -> (assembly, storey (None: on the ground), the block its beta comes from, its
    limit-analysis mechanisms)."""
    blk = blocks()
    p = overburden()
    half, full, par = blk["half"], blk["full"], blk["parapet"]
    return {
        "wall2": (
            rj.Assembly.stack([half, half], top="restrained", overburden=p),
            1,
            "half",
            ("hinge",),
        ),
        "wall1_restrained": (
            rj.Assembly.stack([full], top="restrained", overburden=p),
            1,
            "full",
            (),
        ),
        "wall1_free": (rj.Assembly.stack([full], top="free", overburden=p), 1, "full", ("stack",)),
        "wall2_ground": (
            rj.Assembly.stack([half, half], top="restrained", overburden=p),
            None,
            "half",
            ("hinge",),
        ),
        "parapet_on_wall": (
            rj.Assembly.stack([full, par], top="free"),
            2,
            "parapet",
            ("stack", "top"),
        ),
        "parapet_roof": (
            rj.Assembly.stack([par], top="free"),
            N_STOREYS + 1,
            "parapet",
            ("stack",),
        ),
    }


def limit_analysis(case_defs) -> dict[str, dict[str, float]]:
    """``rj.collapse_multiplier`` [g] of each case's mechanisms, and the lowest (inf: none)."""
    out = {}
    for name, (asm, _, _, mechanisms) in case_defs.items():
        lam = {m: float(rj.collapse_multiplier(asm, m)) for m in mechanisms}
        lam["governing"] = min(lam.values()) if lam else math.inf
        out[name] = lam
    return out


def calibrate_beta(path: pathlib.Path, fixed: float | None) -> dict[str, dict]:
    """beta [s] per block: fitted to e_H (two-sided free rocking), cached in ``path``."""
    if fixed is not None:
        return {k: dict(beta=fixed, source="fixed (quick run)") for k in blocks()}
    cached = json.loads(path.read_text()) if path.exists() else {}
    out = {}
    for label, blk in blocks().items():
        spec = dict(b=float(blk.b), h=float(blk.h))
        if label in cached and cached[label]["block"] == spec:
            out[label] = cached[label]
            continue
        t0 = time.perf_counter()
        e_h = float(rj.e_housner(blk))
        fit = rj.fit_beta(blk, e=e_h, mode="two_sided")
        out[label] = dict(
            block=spec,
            beta=float(fit.beta),
            beta_dejong=float(rj.beta_dejong(blk)),
            source=f"fit to e_H = {e_h:.4f} (Eq. 2)",
            e_effective=float(fit.e_effective),
            seconds=time.perf_counter() - t0,
        )
        print(f"      beta {label} {spec}: {fit.beta:.4g} s ({out[label]['seconds']:.1f} s)")
        path.write_text(json.dumps({**cached, **out}, indent=1))
    path.write_text(json.dumps(out, indent=1))
    return out


# ----------------------------------------------------------------------------- records
def arias_window(ag: np.ndarray, lo: float, hi: float) -> tuple[int, int]:
    """Sample indices ``[i0, i1]`` bounding the ``lo``-``hi`` fractions of the Arias
    intensity (proportional to the cumulative sum of ``ag^2``)."""
    ia = np.cumsum(ag**2)
    ia = ia / ia[-1]
    return int(np.searchsorted(ia, lo)), int(np.searchsorted(ia, hi))


def load_records(n_records: int | None, max_duration: float | None) -> list[rj.GroundMotion]:
    """The pulse-like near-field components on the common step (PGA 1 g), each cut to its
    Arias window (``max_duration`` [s]: shorter still, for the quick run)."""
    recs = [r for r in rj.records.fema_p695("nearfield") if r.metadata["pulse"] == "yes"]
    recs = [r for r in recs if abs(r.dt / DT - round(r.dt / DT)) < 1e-9]
    if n_records is not None:
        recs = recs[:n_records]
    out = []
    for r in recs:
        ratio = int(round(r.dt / DT))
        ag = np.asarray(r.ag, float)
        if ratio > 1:  # exact: every simulator takes the record as linear between samples
            t = np.arange((r.n - 1) * ratio + 1) * DT
            ag = np.interp(t, np.arange(r.n) * r.dt, ag)
        i0, i1 = arias_window(ag, *ARIAS)
        if max_duration is not None:
            i1 = min(i1, i0 + int(round(max_duration / DT)))
        ag = ag[i0 : i1 + 1]
        gm = rj.GroundMotion(ag=ag, dt=DT, name=r.name, meta=r.meta)
        out.append(gm.scaled_to_pga(G))
    return out


# ----------------------------------------------------------------------------- runs
def lowest_collapse(scales, collapse, status) -> tuple[float, int]:
    """``(lowest collapsing scale among the valid runs (inf: none), number of collapse
    intervals)``, as rj.collapse_intervals counts them."""
    order = np.argsort(scales)
    s, c, ok = scales[order], collapse[order], status[order] == 0
    s, c = s[ok], c[ok]
    edges = np.diff(np.concatenate([[0], c.astype(np.int8), [0]]))
    starts = np.flatnonzero(edges == 1)
    return (float(s[starts[0]]) if starts.size else math.inf), int(starts.size)


def bracket(coarse: np.ndarray, first: float) -> float:
    """The lower end of the scale interval to refine: the coarse scale below the first
    collapse (one grid ratio below the lowest, or the top scale where none collapsed)."""
    ratio = coarse[1] / coarse[0]
    if not math.isfinite(first):
        return float(coarse[-1])
    k = int(np.searchsorted(coarse, first))
    return float(coarse[k - 1]) if k > 0 else float(coarse[0] / ratio)


def run_case(asm, storey, bldg, beta, records, t_end, cfg) -> dict[str, np.ndarray]:
    """The two-stage IDA of one case with ``rj.ida``: the coarse grid, then ``n_refine``
    scales inside each record's bracket (run as the record scaled to the bracket's lower end,
    times common relative scales: every stage has the same shapes, so it compiles once).
    Returns (record, run) arrays ``scales``, ``collapse``, ``status``, ``peak``
    (``max_theta_over_eta``)."""
    coarse = cfg["coarse"]
    kw = dict(model=rj.DEM(beta=beta), t_end=t_end, chunk_size=cfg["chunk"], progress=False)
    if storey is not None:
        kw.update(support_motion=bldg, storey=storey)
    ds = rj.ida(asm, records, coarse, **kw)
    col, st = np.asarray(ds.collapse, bool), np.asarray(ds.status, int)
    pk = np.asarray(ds.max_theta_over_eta, float)
    lo = np.array(
        [bracket(coarse, lowest_collapse(coarse, col[i], st[i])[0]) for i in range(len(records))]
    )
    rel = np.geomspace(1.0, coarse[1] / coarse[0], cfg["n_refine"] + 2)[1:-1]
    ds2 = rj.ida(asm, [r.scaled(s) for r, s in zip(records, lo)], rel, **kw)
    return dict(
        scales=np.concatenate([np.tile(coarse, (len(records), 1)), lo[:, None] * rel], axis=1),
        collapse=np.concatenate([col, np.asarray(ds2.collapse, bool)], axis=1),
        status=np.concatenate([st, np.asarray(ds2.status, int)], axis=1),
        peak=np.concatenate([pk, np.asarray(ds2.max_theta_over_eta, float)], axis=1),
    )


def case_spec(name, asm, storey, bldg_label, beta, records, t_end, cfg) -> str:
    """What a cached case ran: it is redone when any of this changed."""
    spec = dict(
        case=name,
        blocks=[[float(b.b), float(b.h), float(b.rho), float(b.E)] for b in asm.blocks],
        top=asm.top,
        overburden=float(asm.overburden),
        storey=storey,
        building=None if storey is None else [bldg_label, BUILDINGS[bldg_label], DAMPING],
        beta=beta,
        records=[[r.name, r.n, round(float(np.sum(np.asarray(r.ag) ** 2)), 6)] for r in records],
        t_end=t_end,
        coarse=np.round(cfg["coarse"], 12).tolist(),
        n_refine=cfg["n_refine"],
    )
    return json.dumps(spec, sort_keys=True)


def load_or_run(path, spec, run) -> tuple[dict, float, bool]:
    """The cached arrays of a case if ``spec`` matches, else ``run()`` and cache them;
    ``(arrays, seconds it took, cached)``."""
    if path.exists():
        z = np.load(path)
        if str(z["spec"]) == spec:
            keys = ("scales", "collapse", "status", "peak")
            return {k: z[k] for k in keys}, float(z["seconds"]), True
    t0 = time.perf_counter()
    arrays = run()
    seconds = time.perf_counter() - t0
    np.savez(path, spec=np.array(spec), seconds=np.array(seconds), **arrays)
    return arrays, seconds, False


# ----------------------------------------------------------------------------- analysis
def capacity_rows(results, records, limits) -> list[dict]:
    rows = []
    for (bl, name), arr in results.items():
        for i, r in enumerate(records):
            cap, n_int = lowest_collapse(arr["scales"][i], arr["collapse"][i], arr["status"][i])
            rows.append(
                dict(
                    building=bl,
                    case=name,
                    record=r.name,
                    capacity_g=cap,
                    n_intervals=n_int,
                    n_failed=int(np.sum(arr["status"][i] != 0)),
                    peak_theta_over_eta_top_scale=float(
                        arr["peak"][i][np.argmax(arr["scales"][i])]
                    ),
                    static_multiplier_g=limits[name]["governing"],
                )
            )
    return rows


def summary_rows(rows) -> list[dict]:
    out = []
    keys = list(dict.fromkeys((r["building"], r["case"]) for r in rows))
    ref_of = {name: ref for name, _, ref in CASES}
    for bl, name in keys:
        cap = np.array([r["capacity_g"] for r in rows if (r["building"], r["case"]) == (bl, name)])
        row = dict(
            building=bl,
            case=name,
            n_records=cap.size,
            median_g=float(np.median(cap)),
            # no interpolation: records without collapse (inf) rank above all
            p16_g=float(np.percentile(cap, 16, method="inverted_cdf")),
            p84_g=float(np.percentile(cap, 84, method="inverted_cdf")),
            n_no_collapse=int(np.sum(~np.isfinite(cap))),
            static_multiplier_g=next(r["static_multiplier_g"] for r in rows if r["case"] == name),
            reference=ref_of[name] or "",
            median_ratio_to_reference=math.nan,
        )
        ref = ref_of[name]
        # the reference in the same building, or on the ground (the wall without a building)
        ref_bl = next(
            (
                b
                for b in (bl, "ground")
                if any((r["building"], r["case"]) == (b, ref) for r in rows)
            ),
            None,
        )
        if ref is not None and ref_bl is not None:
            ref_cap = np.array(
                [r["capacity_g"] for r in rows if (r["building"], r["case"]) == (ref_bl, ref)]
            )
            with np.errstate(invalid="ignore"):
                row["median_ratio_to_reference"] = float(np.median(cap / ref_cap))
        out.append(row)
    return out


def write_csv(path: pathlib.Path, rows: list[dict]) -> None:
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})


def figure(path: pathlib.Path, rows, limits, top_scale: float) -> None:
    """Capacities per record and case; ``top_scale``: above the highest sampled scale, where
    records without collapse are drawn."""
    import matplotlib
    import matplotlib.ticker

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = {name: what for name, what, _ in CASES}
    groups = [
        (
            "ground-storey wall (capacity: ground PGA)",
            ("wall2", "wall1_restrained", "wall1_free", "wall2_ground"),
        ),
        ("parapet (capacity: ground PGA)", ("parapet_on_wall", "parapet_roof")),
    ]
    bls = list(dict.fromkeys(r["building"] for r in rows))
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.4), sharey=True, width_ratios=[2, 1])
    for ax, (title, names) in zip(axes, groups):
        names = [n for n in names if any(r["case"] == n for r in rows)]
        for k, name in enumerate(names):
            for j, bl in enumerate(bls):
                cap = np.array(
                    [r["capacity_g"] for r in rows if (r["building"], r["case"]) == (bl, name)]
                )
                if not cap.size:
                    continue
                x = k + (j - (len(bls) - 1) / 2) * 0.3
                shown = np.where(np.isfinite(cap), cap, top_scale)
                jitter = np.linspace(-0.06, 0.06, cap.size)
                ax.plot(x + jitter, shown, "o", ms=3, alpha=0.5, color=f"C{j}")
                ax.plot([x - 0.12, x + 0.12], [np.median(cap)] * 2, color=f"C{j}", lw=2.5)
            lam = limits[name]["governing"]
            if math.isfinite(lam):
                ax.plot([k - 0.4, k + 0.4], [lam] * 2, "k--", lw=1)
        ax.set_xticks(
            range(len(names)), [labels[n].replace(", ", ",\n") for n in names], fontsize=8
        )
        ax.set(title=title, yscale="log")
        ax.axhline(top_scale, color="0.7", lw=0.8, ls=":")
    axes[0].set_ylabel("collapse ground PGA [g]")
    axes[0].text(-0.45, top_scale * 1.07, "no collapse up to the highest scale", fontsize=7)
    axes[0].yaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    handles = [
        plt.Line2D(
            [],
            [],
            color=f"C{j}",
            lw=2.5,
            label=("on the ground" if bl == "ground" else f"building {bl}") + ", median",
        )
        for j, bl in enumerate(bls)
    ]
    handles.append(plt.Line2D([], [], color="k", ls="--", label="collapse_multiplier (base)"))
    axes[1].legend(handles=handles, fontsize=8, loc="lower right")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


# ----------------------------------------------------------------------------- main
def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="experiments/results/wall_study")
    ap.add_argument("--quick", action="store_true", help="2 short records, 4 + 2 scales")
    ap.add_argument("--figure", default=str(FIGURE), help="the figure's path")
    args = ap.parse_args(argv)
    cfg = QUICK if args.quick else FULL
    out = pathlib.Path(args.out)
    fig_path = pathlib.Path(args.figure)
    if args.quick and args.out == ap.get_default("out"):
        out = out / "quick"  # the smoke run does not overwrite the study's results
    if args.quick and args.figure == ap.get_default("figure"):
        fig_path = out / "wall_study.png"
    (out / "runs").mkdir(parents=True, exist_ok=True)
    wall_s: dict[str, float] = {}
    t_all = time.perf_counter()

    case_defs = cases()
    if args.quick:
        case_defs = {k: v for k, v in case_defs.items() if k in QUICK_CASES}
    limits = limit_analysis(cases())
    print(f"[1/4] limit analysis (rj.collapse_multiplier, g), overburden {overburden():.0f} N/m:")
    for name, lam in limits.items():
        print(f"      {name:17s} " + ", ".join(f"{k} {v:.4g}" for k, v in lam.items()))

    t0 = time.perf_counter()
    betas = calibrate_beta(out / "beta.json", cfg["beta"])
    wall_s["beta"] = time.perf_counter() - t0
    print(
        "[2/4] beta: "
        + ", ".join(f"{k} {v['beta']:.4g} s" for k, v in betas.items())
        + f" ({wall_s['beta']:.1f} s)"
    )

    t0 = time.perf_counter()
    records = load_records(cfg["n_records"], cfg["max_duration"])
    t_end = max(r.duration for r in records) + TAIL
    buildings = {
        bl: rj.ShearBuilding.uniform(N_STOREYS, STOREY_HEIGHT, BUILDINGS[bl], DAMPING)
        for bl in cfg["buildings"]
    }
    wall_s["records"] = time.perf_counter() - t0
    print(
        f"[3/4] {len(records)} records (Arias {ARIAS[0]:g}-{ARIAS[1]:g} windows, "
        f"{min(r.duration for r in records):.1f}-{max(r.duration for r in records):.1f} s; "
        f"runs of {t_end:.1f} s at dt {DT} s); buildings "
        + ", ".join(
            f"{bl}: T = {np.round(np.asarray(b.periods), 3).tolist()} s"
            for bl, b in buildings.items()
        )
    )

    t0 = time.perf_counter()
    results, case_s = {}, {}
    todo = [
        (bl, name)
        for name in case_defs
        for bl in (cfg["buildings"] if case_defs[name][1] is not None else ["ground"])
    ]
    for n, (bl, name) in enumerate(todo, 1):
        asm, storey, beta_of, _ = case_defs[name]
        beta = float(betas[beta_of]["beta"])
        bldg = buildings.get(bl)
        tag = f"{name}_{bl}" + ("_quick" if args.quick else "")
        spec = case_spec(name, asm, storey, bl, beta, records, t_end, cfg)
        arrays, seconds, cached = load_or_run(
            out / "runs" / f"{tag}.npz",
            spec,
            lambda: run_case(asm, storey, bldg, beta, records, t_end, cfg),
        )
        results[(bl, name)] = arrays
        case_s[tag] = seconds
        caps = [
            lowest_collapse(*(arrays[k][i] for k in ("scales", "collapse", "status")))[0]
            for i in range(len(records))
        ]
        print(
            f"      [{n}/{len(todo)}] {name:17s} {bl:6s}: median capacity "
            f"{np.median(caps):.3g} g, {int(np.sum(~np.isfinite(caps)))} without collapse, "
            f"{arrays['scales'].size} runs, {seconds:.1f} s" + (" (cached)" if cached else ""),
            flush=True,
        )
    wall_s["runs"] = time.perf_counter() - t0

    rows = capacity_rows(results, records, limits)
    summary = summary_rows(rows)
    write_csv(out / "capacities.csv", rows)
    write_csv(out / "summary.csv", summary)
    ratio = cfg["coarse"][1] / cfg["coarse"][0]
    figure(fig_path, rows, limits, float(cfg["coarse"][-1] * ratio**1.5))
    wall_s["total"] = time.perf_counter() - t_all
    print(f"[4/4] tables in {out}, figure {fig_path} ({wall_s['total']:.1f} s in all)")
    for s in summary:
        ratio = s["median_ratio_to_reference"]
        print(
            f"      {s['building']:6s} {s['case']:17s} median {s['median_g']:.3g} g "
            f"(16-84 %: {s['p16_g']:.3g}-{s['p84_g']:.3g}), static {s['static_multiplier_g']:.3g} g"
            + (f", / {s['reference']} {ratio:.3g}" if math.isfinite(ratio) else "")
        )
    result = dict(
        command="python experiments/wall_study.py" + (" --quick" if args.quick else ""),
        argv=sys.argv[1:] if argv is None else list(argv),
        overburden_N_per_m=overburden(),
        limits=limits,
        betas=betas,
        t_end=t_end,
        records=[r.name for r in records],
        wall_s=wall_s,
        case_s=case_s,
        summary=summary,
    )
    (out / "summary.json").write_text(json.dumps(result, indent=1, default=float))
    return result


if __name__ == "__main__":
    main()
