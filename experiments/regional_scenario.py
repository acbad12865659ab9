"""A regional scenario: parapet and facade collapses in a synthetic URM town, by the OpenQuake
engine on rockjax fragilities.

Steps (each timed, docs/openquake.md quotes the numbers):

1. **Catalogue.** ``rj.openquake.Catalogue.grid()``: parapets on the roof (b = 0.12 / 0.25 /
   0.38 m x h = 0.6 / 1.0 / 1.5 m) and top-storey facades (b = 0.25 / 0.38 / 0.50 m, h = 3 m,
   no gap) on uniform shear buildings of 1, 2 and 3 storeys (T1 = 0.1 s per storey, 5 %
   damping): 36 classes. Each class's IDA runs Housner's model (default restitution) on the
   floor motion under the 44 FEMA P695 far-field records (resampled to 0.005 s for the floor
   motions), 14 scale factors, as one resumable Dask campaign (``<out>/campaign``), and its
   collapse fragility is fitted in the ground PGA.
2. **Town.** ``--buildings`` (default 1000) buildings at random in a 4 x 3 km town, each with
   a parapet (60 %) or a facade (40 %) of random dimensions and 1-3 storeys; written as the
   inventory ``town.csv`` and, binned into the catalogue's classes, as the engine's exposure
   and ``taxonomy_mapping.csv``.
3. **Scenario.** One ground-motion field of PGA: a magnitude-6-like decay with distance from an
   epicentre 2 km outside the town (median 0.45 g at the epicentre, ``exp(-r / 6 km)``) with
   lognormal scatter (0.3) between sites, written as ``sites.csv`` and ``gmfs.csv``.
4. **Engine.** ``oq run job.ini`` (scenario_damage), then the per-building collapse fractions
   read back: expected collapses per class (``collapses_per_class.csv``), a map
   (``map.png``), and the check that every building's engine fraction equals
   ``Fragility.prob`` at its PGA (clipped to the IDA's range as the engine does).

    python experiments/regional_scenario.py [--out DIR] [--buildings N] [--quick]

``--quick`` runs 4 classes on 12 records for a smoke test; ``--hundred`` a catalogue of 100
classes (4 x 4 parapet and 4 facade bins on 1- to 5-storey buildings), to measure its cost.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

import rockjax as rj
from rockjax.constants import G

oq = rj.openquake

SCALES = np.geomspace(0.05, 8.0, 14)  # [-] on the unnormalised far-field records
DT_FLOOR = 0.005  # [s]: the floor motions' step (the buildings' highest mode at >= 12 samples)
TOWN_LON, TOWN_LAT = 13.40, 42.35  # [deg] the town's south-west corner
EPICENTRE = (13.37, 42.37)  # [deg]
PGA_EPICENTRE = 0.45  # [g] median at the epicentre
DECAY_KM = 6.0  # [km]
SCATTER = 0.3  # [-] lognormal scatter of the field between sites
AGREE_ATOL = 1e-4  # engine fraction vs Fragility.prob (the engine's CSV keeps 7 digits)


def catalogue(quick: bool, hundred: bool = False) -> oq.Catalogue:
    if hundred:  # 4 x 4 parapet bins and 4 facade bins on 5 host buildings: 100 classes
        return oq.Catalogue.grid(
            parapet_b=(0.12, 0.2, 0.3, 0.4),
            parapet_h=(0.6, 0.9, 1.2, 1.6),
            facade_b=(0.25, 0.32, 0.4, 0.5),
            storeys=(1, 2, 3, 4, 5),
        )
    if quick:
        return oq.Catalogue.grid(
            parapet_b=(0.2,), parapet_h=(0.8, 1.2), facade_b=(0.3, 0.45), storeys=(2,)
        )
    return oq.Catalogue.grid()


def town(cat: oq.Catalogue, n: int, seed: int = 0) -> pd.DataFrame:
    """A synthetic inventory: id, lon, lat, storeys, element, b, h (inside the bins)."""
    rng = np.random.default_rng(seed)
    storeys = rng.choice(sorted(cat.periods), n)
    element = np.where(rng.random(n) < 0.6, "parapet", "facade")
    b, h = np.empty(n), np.empty(n)
    for el in ("parapet", "facade"):
        pick = element == el
        bb, hh = np.asarray(cat.b[el]), np.asarray(cat.h[el])
        b[pick] = rng.choice(bb, pick.sum()) * rng.uniform(0.9, 1.1, pick.sum())
        h[pick] = rng.choice(hh, pick.sum()) * rng.uniform(0.9, 1.1, pick.sum())
    return pd.DataFrame(
        {
            "id": [f"bldg_{i:04d}" for i in range(n)],
            "lon": TOWN_LON + 0.05 * rng.random(n),
            "lat": TOWN_LAT + 0.027 * rng.random(n),
            "storeys": storeys,
            "element": element,
            "b": b.round(3),
            "h": h.round(3),
        }
    )


def scenario_pga(lon, lat, seed: int = 1) -> np.ndarray:
    """The scenario's PGA at each site [g]."""
    km_lon = 111.32 * np.cos(np.radians(EPICENTRE[1]))
    r = np.hypot(
        (np.asarray(lon) - EPICENTRE[0]) * km_lon, (np.asarray(lat) - EPICENTRE[1]) * 110.57
    )
    rng = np.random.default_rng(seed)
    return PGA_EPICENTRE * np.exp(-r / DECAY_KM) * np.exp(SCATTER * rng.standard_normal(r.size))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="experiments/results/regional_scenario")
    ap.add_argument("--buildings", type=int, default=1000)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--hundred", action="store_true", help="a 100-class catalogue (its cost)")
    ap.add_argument("--workers", type=int, default=None, help="Dask workers (default: cores)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    times = {}
    t0 = time.perf_counter()

    cat = catalogue(args.quick, args.hundred)
    records = rj.records.fema_p695("farfield")
    if args.quick:
        records = records[:12]
    records = [r.resampled(DT_FLOOR) if r.dt > DT_FLOOR else r for r in records]
    times["records_s"] = time.perf_counter() - t0
    t = time.perf_counter()
    datasets, frags = cat.run(
        records, out / "campaign", im="pga", scales=SCALES, n_workers=args.workers
    )
    times["catalogue_s"] = time.perf_counter() - t
    rows = []
    for cid, f in frags.items():
        c = next(c for c in cat.classes if c.id == cid)
        rows.append(
            dict(
                class_id=cid,
                element=c.element,
                b=c.b,
                h=c.h,
                storeys=c.storeys,
                period=c.period,
                median_g=f.median_g,
                beta_log=f.beta_log,
                im_lo_g=f.im_range[0] / G,
                im_hi_g=f.im_range[1] / G,
                campaign_seconds=float(datasets[cid].attrs.get("campaign_seconds", np.nan)),
            )
        )
    classes = pd.DataFrame(rows).set_index("class_id")
    classes.to_csv(out / "classes.csv")

    t = time.perf_counter()
    inv = town(cat, args.buildings)
    inv.to_csv(out / "town.csv", index=False)
    job_dir = out / "job"
    paths = oq.exposure(out / "town.csv", job_dir, cat.class_of)
    imt = oq.fragility_model(frags, job_dir / "fragility.xml")
    pga = scenario_pga(inv.lon, inv.lat)
    gm = oq.ground_motion_fields(inv.lon, inv.lat, pga, job_dir, imt=imt)
    job = oq.scenario_job(
        job_dir,
        fragility=job_dir / "fragility.xml",
        exposure=paths["exposure"],
        sites=gm["sites"],
        gmfs=gm["gmfs"],
        imt=imt,
        taxonomy_mapping=paths["taxonomy_mapping"],
    )
    times["files_s"] = time.perf_counter() - t
    t = time.perf_counter()
    damage = oq.run_job(job)
    times["engine_s"] = time.perf_counter() - t

    mapping = pd.read_csv(paths["taxonomy_mapping"]).set_index("taxonomy")["risk_id"]
    inv = inv.set_index("id")
    inv["class_id"] = mapping.loc[inv.index].to_numpy()
    inv["pga_g"] = pga
    inv["collapse"] = damage.loc[inv.index, "collapse"].to_numpy()
    # the independent check: Fragility.prob at each building's PGA, clipped as the engine does
    expected = np.empty(len(inv))
    for i, (cid, g) in enumerate(zip(inv.class_id, inv.pga_g, strict=True)):
        f = frags[cid]
        lo, hi = f.im_range
        x = np.clip(g * G, lo, hi)
        expected[i] = 0.0 if g * G <= lo else float(f.prob(x))
    gap = float(np.max(np.abs(inv.collapse - expected)))
    per_class = inv.groupby("class_id").agg(
        buildings=("collapse", "size"),
        expected_collapses=("collapse", "sum"),
        mean_pga_g=("pga_g", "mean"),
    )
    per_class.to_csv(out / "collapses_per_class.csv")
    inv.to_csv(out / "town_damage.csv")
    plot_map(inv, out / "map.png")
    times["total_s"] = time.perf_counter() - t0
    summary = dict(
        command=" ".join(sys.argv),
        classes=len(cat.classes),
        records=len(records),
        scales=len(SCALES),
        buildings=len(inv),
        expected_collapses=float(inv.collapse.sum()),
        max_abs_engine_minus_prob=gap,
        times=times,
        seconds_per_class=times["catalogue_s"] / len(cat.classes),
    )
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    print(per_class.sort_values("expected_collapses", ascending=False).head(12).to_string())
    print(json.dumps(summary, indent=2))
    if gap > AGREE_ATOL:
        print(f"engine and Fragility.prob differ by {gap:.3g} > {AGREE_ATOL}", file=sys.stderr)
        return 1
    return 0


def plot_map(inv: pd.DataFrame, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    s = ax[0].scatter(inv.lon, inv.lat, c=inv.pga_g, s=6, cmap="viridis")
    fig.colorbar(s, ax=ax[0], label="PGA [g]")
    ax[0].set_title("scenario PGA")
    for el, marker in (("parapet", "o"), ("facade", "s")):
        pick = inv.element == el
        s = ax[1].scatter(
            inv.lon[pick],
            inv.lat[pick],
            c=inv.collapse[pick],
            s=7,
            marker=marker,
            cmap="magma_r",
            vmin=0,
            vmax=1,
            label=el,
        )
    fig.colorbar(s, ax=ax[1], label="P(collapse)")
    ax[1].set_title("collapse probability (engine)")
    ax[1].legend(loc="lower right", fontsize=8)
    for a in ax:
        a.plot(*EPICENTRE, "r*", ms=12)
        a.set_xlabel("lon [deg]")
        a.set_ylabel("lat [deg]")
        a.set_aspect(1 / np.cos(np.radians(TOWN_LAT)))
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    raise SystemExit(main())
