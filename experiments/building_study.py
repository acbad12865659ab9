"""Parapets and facades in their building: roof parapets and facades with moving return walls.

The paper's four walls (h x b = 1.50 x 0.170, 3.00 x 0.250, 6.44 x 0.375, 8.00 x 0.375 m;
E = 1.8 GPa, rho = 1800 kg/m^3) in two representative unreinforced-masonry buildings, linear
shear buildings (``rj.ShearBuilding.uniform``) of 2 storeys (T1 = 0.2 s) and 3 storeys
(T1 = 0.3 s), storeys 3.2 m high, 5 % modal damping:

(a) **roof parapets** (two-sided): the input is the roof's absolute acceleration
    (``bldg.response(gm).acceleration[-1]``), against the same parapet on the ground;
(b) **facades** (one-sided, no gap) standing on the ground whose return walls move with the
    building (``wall_motion=(u_top, v_top)`` from ``rj.wall_top_motion(bldg, gm, h)``: the
    building's floor displacements interpolated at the facade height, the roof's above the
    roof), against the facade on a fixed wall.

Each case is run with the paper's three models: the DEM (beta per wall and mode from
``experiments/results/pulse_study/beta.json``), Housner (default restitution: e_H, Eq. 2,
two-sided; |e_1SR|, Eq. 5, one-sided) and the analytical model with the three-branch law
(``simulate_housner(..., law=law)``, Housner's default restitution), its Delta_1, Delta_2,
Delta_u fitted to the wall's DEM pushover (``rj.pushover``: ``mode="one_sided"`` for the
facade, ``"two_sided"`` for the parapet; the default joint and pull) with the rigid line
through lambda_0 = b/h (the paper's calibration, Fig. 9). The records: the 28 pulse-like
components of the FEMA P695 near-field set (metadata ``pulse == "yes"``), each normalised to
PGA = 1 g, so a scale factor is the ground PGA in g. A record's **capacity** is the lowest
sampled scale at which the block overturns (failed runs left out, later resurrections ignored,
as ``rj.collapse_intervals``). Scales: a coarse geometric grid (14 scales over 0.02-4 g), then
6 scales inside each record's bracket below its first coarse collapse (20 per record; capacity
resolved to ~6 %).

Records of step 0.01 or 0.02 s are resampled to 0.005 s: exact, since every simulator takes the
record as linear between its samples, and it puts the building's highest mode (0.074 s) at 15
samples per period for the floor motions. Every record gets a 2 s free-vibration tail (the
building and the block go on moving after it ends); records are batched in groups of one
step and similar length (one compiled batch per group).

Outputs (``--out``, default experiments/results/building_study): ``capacities.csv`` (one row
per wall, element, base and model and record), ``capacity_table.csv`` (medians),
``ratios.csv`` (per-record capacity ratios: roof / ground parapet, moving / fixed facade,
facade / parapet without and with the building), ``model_ratios.csv`` (per-record ratios
between the models: three-branch / Housner, three-branch / DEM, Housner / DEM, per wall,
element and base), ``three_branch_laws.csv`` (the fitted law per wall and element),
``roof_amplification.csv`` (median floor spectra), ``pulse_study_check.csv`` (the ground cases
against the pulse study's capacities of the same records), ``summary.json`` (command, wall
times, tables) and figures
``capacities.png``, ``ratios.png``, ``roof_spectra.png``, ``three_branch_laws.png``.
Finished cases are cached in ``runs/*.npz`` (with the three-branch law they ran with: a case
is redone if the law changed) and the pushover curves in ``runs/pushover_*.npz`` (an
interrupted run resumes; a re-run redoes only the fits, tables and figures).
The findings are written up in experiments/README.md.

    python experiments/building_study.py [--out DIR] [--quick]

``--quick``: the 3 m wall, 4 records, 8 + 4 scales, the three models (a smoke run, < 2 min),
written to ``<out>/quick`` when ``--out`` is the default.
"""

from __future__ import annotations

import argparse
import csv
import functools
import json
import math
import pathlib
import time
import types

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

import rockjax as rj
from rockjax.batching import host_threads, in_threads
from rockjax.building import ShearBuilding
from rockjax.constants import G
from rockjax.supports import wall_top_motion

GEOMETRIES = {  # label: (h, b) [m]
    "h1.50": (1.50, 0.170),
    "h3.00": (3.00, 0.250),
    "h6.44": (6.44, 0.375),
    "h8.00": (8.00, 0.375),
}
E = 1.8e9  # [Pa]
RHO = 1800.0  # [kg/m^3]
BUILDINGS = {  # label: (storeys, T1 [s])
    "2st": (2, 0.2),
    "3st": (3, 0.3),
}
STOREY_HEIGHT = 3.2  # [m]
DAMPING = 0.05  # [-]
MODELS = ("dem", "housner", "three_branch")
MODEL_LABEL = {"dem": "DEM", "housner": "Housner", "three_branch": "three-branch"}
ELEMENTS = ("parapet", "facade")
MODE_OF = {"parapet": "two_sided", "facade": "one_sided"}
TAIL = 2.0  # free vibration after each record [s]
DT_FINE = 0.005  # records of a step that is a multiple of it are resampled to it [s]
LONG = 60.0  # records longer than this [s] are batched apart (the DEM scan has a fixed length)
BETA_FILE = pathlib.Path("experiments/results/pulse_study/beta.json")
PULSE_STUDY_CAPACITIES = pathlib.Path("experiments/results/pulse_study/capacities.csv")
FULL = dict(coarse=np.geomspace(0.02, 4.0, 14), n_refine=6, chunk=32, n_records=None)
QUICK = dict(coarse=np.geomspace(0.02, 4.0, 8), n_refine=4, chunk=16, n_records=4)


# ----------------------------------------------------------------------------- records
def load_records(n_records: int | None) -> list[rj.GroundMotion]:
    """The pulse-like FEMA P695 near-field components, normalised to PGA = 1 g, on a step of
    0.005 s where theirs is a multiple of it (exact for the linear interpolant)."""
    recs = [r for r in rj.records.fema_p695("nearfield") if r.metadata["pulse"] == "yes"]
    if n_records is not None:  # the quick run: records of two different steps
        recs = [recs[0], recs[1], recs[6], recs[7]][:n_records]
    out = []
    for r in recs:
        r = r.scaled_to_pga(G)
        ratio = r.dt / DT_FINE
        if ratio > 1 + 1e-9 and abs(ratio - round(ratio)) < 1e-9:
            n = int(round((r.n - 1) * ratio)) + 1
            t = np.arange(n) * DT_FINE
            ag = np.interp(t, np.arange(r.n) * r.dt, np.asarray(r.ag))
            r = rj.GroundMotion(ag=ag, dt=DT_FINE, name=r.name, meta=r.meta)
        out.append(r)
    return out


class Group:
    """Records of one step and similar length, zero-padded to one length (longest + TAIL)."""

    def __init__(self, idx: list[int], records: list[rj.GroundMotion]):
        self.idx = np.asarray(idx)
        self.dt = records[idx[0]].dt
        t_end = max(records[i].duration for i in idx) + TAIL
        self.n = int(math.floor(t_end / self.dt + 1e-9)) + 1
        self.ag = np.zeros((len(idx), self.n))
        for row, i in enumerate(idx):
            self.ag[row, : records[i].n] = np.asarray(records[i].ag)
        self.names = [records[i].name for i in idx]

    def motion(self, row: int) -> rj.GroundMotion:
        return rj.GroundMotion(ag=self.ag[row], dt=self.dt, name=self.names[row])


def group_records(records) -> list[Group]:
    keys: dict[tuple, list[int]] = {}
    for i, r in enumerate(records):
        keys.setdefault((round(r.dt, 9), r.duration > LONG), []).append(i)
    return [Group(idx, records) for _, idx in sorted(keys.items())]


# ----------------------------------------------------------------------------- inputs
class Inputs:
    """Base accelerations and wall motions of every group, per building, at PGA 1 g."""

    def __init__(self, groups: list[Group], buildings: dict[str, ShearBuilding], heights):
        self.roof = {}  # (building, group index) -> (n_rec, n) roof absolute acceleration
        self.wall = {}  # (building, group index, h) -> ((n_rec, n) u_top, (n_rec, n) v_top)
        self.roof_pga = {}  # building -> {record: roof PGA / ground PGA}
        for bl, bldg in buildings.items():
            self.roof_pga[bl] = {}
            for gi, g in enumerate(groups):
                roof = np.zeros_like(g.ag)
                walls = {h: (np.zeros_like(g.ag), np.zeros_like(g.ag)) for h in heights}
                for row in range(len(g.idx)):
                    gm = g.motion(row)
                    roof[row] = np.asarray(bldg.response(gm).acceleration[-1])
                    self.roof_pga[bl][g.names[row]] = float(np.max(np.abs(roof[row])) / G)
                    for h in heights:
                        u, v = wall_top_motion(bldg, gm, h)
                        walls[h][0][row], walls[h][1][row] = np.asarray(u), np.asarray(v)
                self.roof[(bl, gi)] = roof
                for h in heights:
                    self.wall[(bl, gi, h)] = walls[h]


# ----------------------------------------------------------------------------- three-branch law
LAW_FIELDS = ("lambda_0", "Delta_1", "Delta_2", "Delta_u")


def fit_law(d_over_b, load_multiplier, lambda_0: float | None) -> rj.ThreeBranchFit:
    """The paper's calibration (Fig. 9): the three-branch law fitted to a DEM pushover curve
    on the curve from its start to the first point past the peak where it drops below zero
    (beyond it the block is falling, not held).

    Args:
        d_over_b: Top displacement over thickness along the pushover [-].
        load_multiplier: The pushover's ``lambda = a/g`` [-].
        lambda_0: The rigid line's intercept [-]: ``b/h`` for the paper's calibration (only
            the Deltas are fitted); None fits it too.

    Returns:
        The :class:`rockjax.ThreeBranchFit`.
    """
    d, lam = np.asarray(d_over_b, float), np.asarray(load_multiplier, float)
    i_peak = int(np.argmax(lam))
    below = np.flatnonzero(lam[i_peak:] < 0)
    end = i_peak + int(below[0]) if below.size else d.size - 1
    curve = types.SimpleNamespace(d_over_b=d[: end + 1], load_multiplier=lam[: end + 1])
    return rj.fit_three_branch(curve, lambda_0=lambda_0)


def wall_laws(blocks: dict, out: pathlib.Path) -> tuple[dict, dict, list[dict]]:
    """The three-branch law of each wall and element from its DEM pushover (facade:
    ``mode="one_sided"``, parapet: ``"two_sided"``; the default joint, pull rate and ``beta``).
    The curves are cached in ``runs/pushover_*.npz``. Returns the laws by ``(wall,
    element)``, the curves by ``(wall, element)`` and one table row per wall and element."""
    laws, curves, rows = {}, {}, []
    for geo, blk in blocks.items():
        b, h = float(blk.b), float(blk.h)
        for el in ELEMENTS:
            mode = MODE_OF[el]
            path = out / "runs" / f"pushover_{geo}_{mode}.npz"
            if path.exists():
                z = np.load(path)
                d, lam, seconds = z["d_over_b"], z["load_multiplier"], float(z["seconds"])
            else:
                t0 = time.perf_counter()
                cap = rj.pushover(blk, mode)
                d, lam = np.asarray(cap.d_over_b), np.asarray(cap.load_multiplier)
                seconds = time.perf_counter() - t0
                np.savez(path, d_over_b=d, load_multiplier=lam, seconds=seconds)
            fit = fit_law(d, lam, b / h)
            free = fit_law(d, lam, None).law  # lambda_0 fitted too: for comparison only
            laws[(geo, el)] = fit.law
            curves[(geo, el)] = (d, lam)
            i_peak = int(np.argmax(lam))
            rows.append(
                dict(
                    geometry=geo,
                    h=h,
                    b=b,
                    element=el,
                    mode=mode,
                    **{k: float(getattr(fit.law, k)) for k in LAW_FIELDS},
                    lambda_p=float(fit.law.lambda_p),
                    rmse_over_lambda_0=float(fit.rmse) / (b / h),
                    max_error_over_lambda_0=float(fit.max_error) / (b / h),
                    pushover_peak_over_lambda_0=float(lam[i_peak]) / (b / h),
                    pushover_d_over_b_at_peak=float(d[i_peak]),
                    free_fit_lambda_0_over_b_h=float(free.lambda_0) / (b / h),
                    free_fit_Delta_1=float(free.Delta_1),
                    free_fit_Delta_2=float(free.Delta_2),
                    free_fit_Delta_u=float(free.Delta_u),
                    pushover_s=seconds,
                )
            )
    return laws, curves, rows


# ----------------------------------------------------------------------------- runs
@eqx.filter_jit
def run_chunk(
    block, ag, rec_idx, scale, wall_u, wall_v, *, model, mode, beta, dt_rec, dt_step, law=None
):
    """Overturning, status and peak theta/eta of the runs ``scale[k] * ag[rec_idx[k]]``, the
    return wall (if any) at ``scale[k] * (wall_u, wall_v)[rec_idx[k]]`` (the building is
    linear, so its motion scales with the record). ``model="three_branch"``: Housner with the
    three-branch ``law`` (its defaults otherwise)."""

    def one(i, s):
        gm = rj.GroundMotion(ag=s * ag[i], dt=dt_rec)
        kw = {} if wall_u is None else dict(wall_motion=(s * wall_u[i], s * wall_v[i]))
        if model == "dem":
            r = rj.simulate_dem(block, gm, beta=beta, mode=mode, dt=dt_step, throw=False, **kw)
        else:
            if model == "three_branch":
                kw["law"] = law
            r = rj.simulate_housner(block, gm, mode=mode, throw=False, **kw)
        ok = r.status == 0
        return r.overturned & ok, r.status.astype(jnp.int32), r.theta_max / r.eta

    if model == "dem":
        return jax.vmap(one)(rec_idx, scale)
    return rj.housner.batch_runs(one, rec_idx, scale)  # one run after another on CPU


def run_pairs(block, model, mode, beta, group: Group, ag, wall, rows, scales, chunk, law=None):
    """Runs of (record row, scale) pairs in fixed-size chunks (one compilation per group)."""
    n = len(rows)
    pad = (-n) % chunk
    rows_p = np.concatenate([rows, np.zeros(pad, int)]).astype(np.int32)
    scales_p = np.concatenate([scales, np.zeros(pad)])
    dt_step = rj.stable_dt(block, beta, mode=mode) if model == "dem" else None
    ag = jnp.asarray(ag)
    wu, wv = (None, None) if wall is None else (jnp.asarray(wall[0]), jnp.asarray(wall[1]))

    def chunk_at(k):
        out = run_chunk(
            block,
            ag,
            jnp.asarray(rows_p[k : k + chunk]),
            jnp.asarray(scales_p[k : k + chunk]),
            wu,
            wv,
            model=model,
            mode=mode,
            beta=beta,
            dt_rec=group.dt,
            dt_step=dt_step,
            law=law,
        )
        return tuple(np.asarray(a) for a in out)

    # the first chunk compiles, alone; the others run one per core at once, as rj.ida's
    # (rockjax.batching.in_threads, host_threads; the same results to the bit)
    starts = range(0, n + pad, chunk)
    tasks = ((functools.partial(chunk_at, k), k == 0) for k in starts)
    parts = dict(in_threads(tasks, host_threads()))
    col, st, pk = zip(*(parts[i] for i in sorted(parts)))
    return np.concatenate(col)[:n], np.concatenate(st)[:n], np.concatenate(pk)[:n]


def lowest_collapse(scales, collapse, status) -> tuple[float, int]:
    """``(lowest collapsing scale among the valid runs (inf: none), number of collapse
    intervals)``, as rj.collapse_intervals counts them."""
    order = np.argsort(scales)
    s, c, ok = scales[order], collapse[order], status[order] == 0
    s, c = s[ok], c[ok]
    edges = np.diff(np.concatenate([[0], c.astype(np.int8), [0]]))
    starts = np.flatnonzero(edges == 1)
    return (float(s[starts[0]]) if starts.size else math.inf), int(starts.size)


def run_case(block, model, mode, beta, groups, base, walls, cfg, law=None) -> dict:
    """One IDA-like case: a coarse grid, then ``n_refine`` scales inside each record's bracket
    below its first coarse collapse. Returns per-record arrays of all runs and capacities."""
    coarse = cfg["coarse"]
    per_rec = {}
    for gi, g in enumerate(groups):
        ag = base[gi]
        wall = None if walls is None else walls[gi]
        nr, nc = len(g.idx), coarse.size
        rows = np.repeat(np.arange(nr), nc)
        scales = np.tile(coarse, nr)
        c, s, p = run_pairs(
            block, model, mode, beta, g, ag, wall, rows, scales, cfg["chunk"], law=law
        )
        runs = {r: [scales[rows == r], c[rows == r], s[rows == r], p[rows == r]] for r in range(nr)}
        rows2, scales2 = [], []
        for r in range(nr):
            first, _ = lowest_collapse(*[runs[r][k] for k in (0, 1, 2)])
            if math.isfinite(first) and first > coarse[0]:
                lo = coarse[np.searchsorted(coarse, first) - 1]
                inner = np.geomspace(lo, first, cfg["n_refine"] + 2)[1:-1]
                rows2 += [r] * inner.size
                scales2 += list(inner)
        if rows2:
            rows2, scales2 = np.asarray(rows2), np.asarray(scales2)
            c2, s2, p2 = run_pairs(
                block, model, mode, beta, g, ag, wall, rows2, scales2, cfg["chunk"], law=law
            )
            for r in range(nr):
                m = rows2 == r
                if m.any():
                    for k, arr in enumerate((scales2, c2, s2, p2)):
                        runs[r][k] = np.concatenate([runs[r][k], arr[m]])
        for r in range(nr):
            sc, co, stt, pk = runs[r]
            per_rec[g.names[r]] = record_result(sc, co, stt, pk, coarse)
    return per_rec


def record_result(scales, collapse, status, peak, coarse) -> dict:
    """One record's runs of a case (sorted by scale) and its capacity [g]."""
    cap, n_int = lowest_collapse(scales, collapse, status)
    return dict(
        scales=scales,
        collapse=collapse,
        status=status,
        peak=peak,
        capacity_g=cap,
        n_intervals=n_int,
        n_failed=int(np.sum(status != 0)),
        at_lowest_scale=bool(cap == coarse[0]),
    )


def law_array(law) -> np.ndarray:
    """``(lambda_0, Delta_1, Delta_2, Delta_u)`` of a three-branch law (empty for None)."""
    if law is None:
        return np.zeros(0)
    return np.array([float(getattr(law, k)) for k in LAW_FIELDS])


def save_case(path: pathlib.Path, per_rec: dict, seconds: float, law=None) -> None:
    names = list(per_rec)
    arrays = {"names": np.array(names), "seconds": np.array(seconds), "law": law_array(law)}
    for i, nm in enumerate(names):
        for k in ("scales", "collapse", "status", "peak"):
            arrays[f"{k}_{i}"] = per_rec[nm][k]
    np.savez(path, **arrays)


def load_case(path: pathlib.Path, coarse, law=None) -> tuple[dict, float] | tuple[None, None]:
    """The cached runs of a case and the seconds they took, or ``(None, None)`` (none cached,
    or cached on another scale grid or with another three-branch ``law``)."""
    if not path.exists():
        return None, None
    z = np.load(path)
    cached_law = z["law"] if "law" in z else np.zeros(0)
    want = law_array(law)
    if cached_law.shape != want.shape or not np.allclose(cached_law, want, rtol=1e-12, atol=0):
        return None, None  # another law: run again
    per_rec = {}
    for i, nm in enumerate(z["names"]):
        sc, co, stt, pk = (z[f"{k}_{i}"] for k in ("scales", "collapse", "status", "peak"))
        if not np.all(np.isin(coarse, sc)):
            return None, None  # another grid: run again
        per_rec[str(nm)] = record_result(sc, co, stt, pk, coarse)
    return per_rec, float(z["seconds"]) if "seconds" in z else math.nan


# ----------------------------------------------------------------------------- analysis
def _median(x) -> float:
    """Median with censored values (inf: no collapse up to the top scale) ranked above all."""
    x = np.sort(np.asarray(x, float))
    return float(np.median(x)) if x.size else math.nan


def capacity_table(rows) -> list[dict]:
    table = []
    keys = sorted({(r["geometry"], r["element"], r["base"], r["model"]) for r in rows})
    for key in keys:
        sel = [r for r in rows if (r["geometry"], r["element"], r["base"], r["model"]) == key]
        cap = np.array([r["capacity_g"] for r in sel])
        base_cap = np.array([r["capacity_base_pga_g"] for r in sel])
        table.append(
            dict(
                geometry=key[0],
                element=key[1],
                base=key[2],
                model=key[3],
                n_records=len(sel),
                median_capacity_g=_median(cap),
                q25=float(np.quantile(np.sort(cap), 0.25)),
                q75=float(np.quantile(np.sort(cap), 0.75)),
                median_capacity_base_pga_g=_median(base_cap),
                n_censored=int(np.sum(~np.isfinite(cap))),
                n_at_lowest_scale=sum(r["at_lowest_scale"] for r in sel),
                n_failed_runs=sum(r["n_failed_runs"] for r in sel),
                n_runs=sum(r["n_runs"] for r in sel),
                n_resurrecting=sum(r["n_collapse_intervals"] > 1 for r in sel),
            )
        )
    return table


RATIOS = {  # name: (numerator (element, base), denominator (element, base))
    "parapet roof2st/ground": (("parapet", "roof 2st"), ("parapet", "ground")),
    "parapet roof3st/ground": (("parapet", "roof 3st"), ("parapet", "ground")),
    "facade walls2st/fixed": (("facade", "walls 2st"), ("facade", "fixed")),
    "facade walls3st/fixed": (("facade", "walls 3st"), ("facade", "fixed")),
    "facade/parapet ground": (("facade", "fixed"), ("parapet", "ground")),
    "facade/parapet 2st": (("facade", "walls 2st"), ("parapet", "roof 2st")),
    "facade/parapet 3st": (("facade", "walls 3st"), ("parapet", "roof 3st")),
}


def ratio_table(rows) -> list[dict]:
    """Per-record capacity ratios (both finite), summarised per wall, model and ratio."""
    cap = {(r["geometry"], r["element"], r["base"], r["model"], r["record"]): r for r in rows}
    table = []
    for geo in sorted({r["geometry"] for r in rows}):
        for model in MODELS:
            for name, (num, den) in RATIOS.items():
                vals, n_cens = [], 0
                recs = sorted(
                    {
                        k[4]
                        for k in cap
                        if k[:4] == (geo, *num, model) or k[:4] == (geo, *den, model)
                    }
                )
                for rec in recs:
                    a = cap.get((geo, *num, model, rec))
                    b = cap.get((geo, *den, model, rec))
                    if a is None or b is None:
                        continue
                    if math.isfinite(a["capacity_g"]) and math.isfinite(b["capacity_g"]):
                        vals.append(a["capacity_g"] / b["capacity_g"])
                    else:
                        n_cens += 1
                if not vals and not n_cens:
                    continue
                v = np.array(vals)
                med_num = _median(
                    [cap[k]["capacity_g"] for k in cap if k[:4] == (geo, *num, model)]
                )
                med_den = _median(
                    [cap[k]["capacity_g"] for k in cap if k[:4] == (geo, *den, model)]
                )
                table.append(
                    dict(
                        geometry=geo,
                        model=model,
                        ratio=name,
                        n_pairs=int(v.size),
                        n_censored_pairs=n_cens,
                        median=float(np.median(v)) if v.size else math.nan,
                        q25=float(np.quantile(v, 0.25)) if v.size else math.nan,
                        q75=float(np.quantile(v, 0.75)) if v.size else math.nan,
                        frac_below_1=float(np.mean(v < 1.0)) if v.size else math.nan,
                        ratio_of_medians=med_num / med_den if med_den > 0 else math.nan,
                    )
                )
    return table


MODEL_RATIOS = {  # name: (numerator model, denominator model)
    "three_branch/housner": ("three_branch", "housner"),
    "three_branch/dem": ("three_branch", "dem"),
    "housner/dem": ("housner", "dem"),
}


def model_ratio_table(rows) -> list[dict]:
    """Per-record capacity ratios between models for the same wall, element and base (both
    finite), summarised like :func:`ratio_table`."""
    cap = {
        (r["geometry"], r["element"], r["base"], r["model"], r["record"]): r["capacity_g"]
        for r in rows
    }
    table = []
    cases = sorted({(r["geometry"], r["element"], r["base"]) for r in rows})
    for geo, el, base in cases:
        for name, (num, den) in MODEL_RATIOS.items():
            recs = sorted({k[4] for k in cap if k[:3] == (geo, el, base)})
            pairs = [
                (cap[(geo, el, base, num, rec)], cap[(geo, el, base, den, rec)])
                for rec in recs
                if (geo, el, base, num, rec) in cap and (geo, el, base, den, rec) in cap
            ]
            if not pairs:
                continue
            v = np.array([a / b for a, b in pairs if math.isfinite(a) and math.isfinite(b)])
            table.append(
                dict(
                    geometry=geo,
                    element=el,
                    base=base,
                    ratio=name,
                    n_pairs=int(v.size),
                    n_censored_pairs=len(pairs) - int(v.size),
                    median=float(np.median(v)) if v.size else math.nan,
                    q25=float(np.quantile(v, 0.25)) if v.size else math.nan,
                    q75=float(np.quantile(v, 0.75)) if v.size else math.nan,
                    frac_below_1=float(np.mean(v < 1.0)) if v.size else math.nan,
                    frac_above_1=float(np.mean(v > 1.0)) if v.size else math.nan,
                )
            )
    return table


def pulse_study_check(rows, path: pathlib.Path) -> list[dict]:
    """The study's ground parapets and fixed-wall facades against the pulse study's
    capacities of the same records (``capacities.csv``: a 48-scale grid, 11.9 % apart), record
    by record: the same models, a different scale grid and run length."""
    if not path.exists():
        return []
    with path.open() as f:
        ref = {
            (r["geometry"], r["mode"], r["model"], r["record"]): float(r["capacity_g"])
            for r in csv.DictReader(f)
        }
    table = []
    step = (4.0 / 0.02) ** (1 / 47)  # the pulse study's scale ratio
    for geo in sorted({r["geometry"] for r in rows}):
        for el, base in (("parapet", "ground"), ("facade", "fixed")):
            for model in MODELS:
                ratio = []
                for r in rows:
                    if (r["geometry"], r["element"], r["base"], r["model"]) != (
                        geo,
                        el,
                        base,
                        model,
                    ):
                        continue
                    other = ref.get((geo, MODE_OF[el], model, r["record"]))
                    if other and math.isfinite(other) and math.isfinite(r["capacity_g"]):
                        ratio.append(r["capacity_g"] / other)
                if not ratio:
                    continue
                ratio = np.array(ratio)
                table.append(
                    dict(
                        geometry=geo,
                        element=el,
                        model=model,
                        n_records=int(ratio.size),
                        median_this_over_pulse_study=float(np.median(ratio)),
                        frac_within_one_step=float(np.mean(np.abs(np.log(ratio)) <= np.log(step))),
                        frac_higher_by_more_than_one_step=float(np.mean(ratio > step)),
                        frac_lower_by_more_than_one_step=float(np.mean(ratio < 1 / step)),
                    )
                )
    return table


def roof_spectra(groups, buildings, periods) -> dict:
    """Median (over records) roof / ground 5 %-damped spectral acceleration, per building."""
    out = {}
    ground = []
    for g in groups:
        for row in range(len(g.idx)):
            ground.append(np.asarray(rj.response_spectrum(g.motion(row), periods).sa))
    ground = np.array(ground)
    out["ground_median_g"] = np.median(ground, axis=0) / G
    for bl, bldg in buildings.items():
        roof = []
        for g in groups:
            for row in range(len(g.idx)):
                roof.append(np.asarray(rj.floor_spectra(bldg, g.motion(row), periods).sa[-1]))
        roof = np.array(roof)
        out[f"roof_{bl}_median_g"] = np.median(roof, axis=0) / G
        out[f"amplification_{bl}_median"] = np.median(roof / ground, axis=0)
    return out


def write_csv(path: pathlib.Path, rows: list[dict]) -> None:
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def figures(out: pathlib.Path, rows, ratios, spectra, periods) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []
    geos = sorted({r["geometry"] for r in rows})
    bases = {
        "parapet": ("ground", "roof 2st", "roof 3st"),
        "facade": ("fixed", "walls 2st", "walls 3st"),
    }
    colors = {"dem": "tab:blue", "housner": "tab:orange", "three_branch": "tab:green"}

    # 1. capacity per record and median, per wall: parapets then facades, DEM and Housner
    fig, axes = plt.subplots(1, len(geos), figsize=(4.4 * len(geos), 4.4), squeeze=False)
    for ax, geo in zip(axes[0], geos):
        labels = []
        x = 0
        for el in ELEMENTS:
            for base in bases[el]:
                for k, model in enumerate(MODELS):
                    c = np.array(
                        [
                            r["capacity_g"]
                            for r in rows
                            if (r["geometry"], r["element"], r["base"], r["model"])
                            == (geo, el, base, model)
                        ]
                    )
                    if not c.size:
                        continue
                    xx = x + (k - (len(MODELS) - 1) / 2) * 0.27
                    fin = c[np.isfinite(c)]
                    jit = np.random.default_rng(x * 7 + k).uniform(-0.06, 0.06, fin.size)
                    ax.scatter(xx + jit, fin, s=6, color=colors[model], alpha=0.5, lw=0)
                    ax.plot([xx - 0.1, xx + 0.1], [_median(c)] * 2, color=colors[model], lw=2.5)
                labels.append(f"{el}\n{base}")
                x += 1
        h, b = GEOMETRIES[geo]
        ax.axhline(b / h, color="0.4", ls=":", lw=1)
        ax.axvline(2.5, color="0.7", lw=0.8)
        ax.set_yscale("log")
        ax.set_xticks(range(len(labels)))
        ax.set_xticklabels(labels, fontsize=7)
        ax.set_title(f"h x b = {h:.2f} x {b:.3f} m")
        ax.grid(True, which="both", axis="y", alpha=0.3)
    axes[0][0].set_ylabel("capacity: lowest overturning ground PGA [g]")
    for model in MODELS:
        axes[0][0].plot([], [], color=colors[model], lw=2.5, label=f"{MODEL_LABEL[model]} (median)")
    axes[0][0].plot([], [], color="0.4", ls=":", label="static b/h")
    axes[0][0].legend(fontsize=7)
    n_rec = len({r["record"] for r in rows})
    fig.suptitle(f"{n_rec} pulse-like FEMA P695 near-field components, normalised to PGA 1 g")
    fig.tight_layout()
    fig.savefig(out / "capacities.png", dpi=130)
    plt.close(fig)
    written.append("capacities.png")

    # 2. ratios: median and interquartile range of the per-record ratios
    names = list(RATIOS)
    fig, axes = plt.subplots(1, len(MODELS), figsize=(5.5 * len(MODELS), 4.6), sharey=True)
    markers = dict(zip(geos, "osD^"))
    for ax, model in zip(axes, MODELS):
        for j, geo in enumerate(geos):
            for i, nm in enumerate(names):
                t = [
                    r for r in ratios if (r["geometry"], r["model"], r["ratio"]) == (geo, model, nm)
                ]
                if not t or not t[0]["n_pairs"]:
                    continue
                t = t[0]
                xx = i + (j - (len(geos) - 1) / 2) * 0.15
                ax.errorbar(
                    xx,
                    t["median"],
                    yerr=[[t["median"] - t["q25"]], [t["q75"] - t["median"]]],
                    fmt=markers[geo],
                    ms=5,
                    color=f"C{j}",
                    label=geo if i == 0 else None,
                )
        ax.axhline(1.0, color="0.3", lw=0.8)
        ax.set_yscale("log")
        ax.set_xticks(range(len(names)))
        ax.set_xticklabels([n.replace(" ", "\n", 1) for n in names], fontsize=7)
        ax.set_title(f"{MODEL_LABEL[model]}: capacity ratios per record")
        ax.grid(True, which="both", axis="y", alpha=0.3)
    axes[0].set_ylabel("ratio of capacities [-] (median, IQR)")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "ratios.png", dpi=130)
    plt.close(fig)
    written.append("ratios.png")

    # 3. roof spectra
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4.2))
    pos = periods > 0  # T = 0 (the PGA) goes into the legend: a log axis has no 0
    ax1.plot(periods[pos], spectra["ground_median_g"][pos], color="k", label="ground")
    for k, bl in enumerate(BUILDINGS):
        n, t1 = BUILDINGS[bl]
        lab = f"roof, {n} storeys, T1 = {t1} s"
        ax1.plot(periods[pos], spectra[f"roof_{bl}_median_g"][pos], color=f"C{k}", label=lab)
        amp0 = spectra[f"amplification_{bl}_median"][~pos][0]
        ax2.plot(
            periods[pos],
            spectra[f"amplification_{bl}_median"][pos],
            color=f"C{k}",
            label=f"{lab} (PFA / PGA {amp0:.2f})",
        )
        ax2.axvline(t1, color=f"C{k}", ls=":", lw=0.8)
    ax1.set_ylabel("median Sa (5 %) [g], records at PGA 1 g")
    ax2.set_ylabel("median Sa roof / Sa ground [-]")
    for ax in (ax1, ax2):
        ax.set_xlabel("period T [s]")
        ax.set_xscale("log")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "roof_spectra.png", dpi=130)
    plt.close(fig)
    written.append("roof_spectra.png")
    return written


def law_figure(out: pathlib.Path, blocks, laws, curves) -> str:
    """The DEM pushover of each wall with its fitted three-branch laws (facade, parapet)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    geos = list(blocks)
    fig, axes = plt.subplots(1, len(geos), figsize=(3.6 * len(geos), 3.4), squeeze=False)
    for ax, geo in zip(axes[0], geos):
        b, h = float(blocks[geo].b), float(blocks[geo].h)
        for k, el in enumerate(ELEMENTS):
            d, lam = curves[(geo, el)]
            law = laws[(geo, el)]
            ax.plot(d, lam / (b / h), color=f"C{k}", lw=1.6 - 0.8 * k, label=f"DEM, {el}")
            x = np.linspace(0.0, 1.0, 401)
            lam_law = np.asarray(law.load_multiplier(x)) / (b / h)
            ax.plot(x, lam_law, color=f"C{k}", ls="--", lw=1.0, label=f"law, {el}")
        ax.plot([0, 1], [1, 0], color="0.5", ls=":", lw=0.8, label="rigid block")
        ax.set_ylim(0, 1.05)
        ax.set_xlim(0, 1)
        ax.set_xlabel("d / b [-]")
        ax.set_title(f"h x b = {h:.2f} x {b:.3f} m", fontsize=9)
        ax.grid(True, alpha=0.3)
    axes[0][0].set_ylabel("load multiplier / (b/h) [-]")
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "three_branch_laws.png", dpi=130)
    plt.close(fig)
    return "three_branch_laws.png"


# ----------------------------------------------------------------------------- main
def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="experiments/results/building_study")
    ap.add_argument("--quick", action="store_true", help="one wall, 4 records, 8 + 4 scales")
    ap.add_argument("--beta", default=str(BETA_FILE), help="beta per wall and mode (JSON)")
    args = ap.parse_args(argv)
    cfg = QUICK if args.quick else FULL
    out = pathlib.Path(args.out)
    if args.quick and args.out == ap.get_default("out"):
        out = out / "quick"  # the smoke run does not overwrite the study's results
    (out / "runs").mkdir(parents=True, exist_ok=True)
    wall_s: dict[str, float] = {}
    t_all = time.perf_counter()

    geometries = {"h3.00": GEOMETRIES["h3.00"]} if args.quick else GEOMETRIES
    blocks = {k: rj.Block(b=b, h=h, E=E, rho=RHO) for k, (h, b) in geometries.items()}
    betas_file = json.loads(pathlib.Path(args.beta).read_text())
    betas = {}
    for label, (h, b) in geometries.items():
        for el in ELEMENTS:
            entry = betas_file[f"{label}/{MODE_OF[el]}"]
            if entry["block"] != dict(h=h, b=b):
                raise ValueError(f"{args.beta}: {label}/{MODE_OF[el]} is for {entry['block']}")
            betas[(label, el)] = float(entry["beta"])
    buildings = {
        bl: ShearBuilding.uniform(n, STOREY_HEIGHT, t1, DAMPING)
        for bl, (n, t1) in BUILDINGS.items()
    }

    t0 = time.perf_counter()
    records = load_records(cfg["n_records"])
    groups = group_records(records)
    heights = sorted({float(blk.h) for blk in blocks.values()})
    inputs = Inputs(groups, buildings, heights)
    wall_s["records_and_buildings"] = time.perf_counter() - t0
    print(
        f"[1/5] {len(records)} pulse-like records in {len(groups)} groups "
        f"({', '.join(f'{len(g.idx)} x {g.n} at {g.dt:g} s' for g in groups)}); buildings "
        + ", ".join(
            f"{bl}: T = {np.round(np.asarray(bd.periods), 3).tolist()} s"
            for bl, bd in buildings.items()
        )
        + f" ({wall_s['records_and_buildings']:.1f} s)"
    )
    for bl in buildings:
        amp = np.array(list(inputs.roof_pga[bl].values()))
        print(
            f"      roof PGA / ground PGA, {bl}: median {np.median(amp):.2f} "
            f"(range {amp.min():.2f}-{amp.max():.2f})"
        )

    t0 = time.perf_counter()
    laws, curves, law_rows = wall_laws(blocks, out)
    wall_s["pushovers_and_fits"] = time.perf_counter() - t0
    print(f"[2/5] three-branch laws from DEM pushovers ({wall_s['pushovers_and_fits']:.1f} s)")
    for r in law_rows:
        print(
            f"      {r['geometry']} {r['element']:7s} ({r['mode']}): Delta_1 {r['Delta_1']:.4f} "
            f"Delta_2 {r['Delta_2']:.4f} Delta_u {r['Delta_u']:.4f} (lambda_0 = b/h, "
            f"lambda_p = {r['lambda_p'] / r['lambda_0']:.3f} b/h, rmse "
            f"{r['rmse_over_lambda_0']:.3f} b/h; pushover peak "
            f"{r['pushover_peak_over_lambda_0']:.3f} b/h, {r['pushover_s']:.1f} s)"
        )

    t0 = time.perf_counter()
    cases = []  # (geometry, element, base, model)
    for geo in geometries:
        for model in MODELS:
            cases += [(geo, "parapet", "ground", model)]
            cases += [(geo, "parapet", f"roof {bl}", model) for bl in buildings]
            cases += [(geo, "facade", "fixed", model)]
            cases += [(geo, "facade", f"walls {bl}", model) for bl in buildings]
    results = {}
    case_s = {}  # seconds each case took when it was computed (cached ones: then)
    for n_case, (geo, el, base, model) in enumerate(cases, 1):
        blk = blocks[geo]
        mode = MODE_OF[el]
        beta = betas[(geo, el)] if model == "dem" else None
        law = laws[(geo, el)] if model == "three_branch" else None
        tag = f"{geo}_{el}_{base.replace(' ', '')}_{model}" + ("_quick" if args.quick else "")
        path = out / "runs" / f"{tag}.npz"
        tc = time.perf_counter()
        per_rec, seconds = load_case(path, cfg["coarse"], law)
        cached = per_rec is not None
        if per_rec is None:
            if base.startswith("roof"):
                base_ag = [inputs.roof[(base.split()[1], gi)] for gi in range(len(groups))]
            else:
                base_ag = [g.ag for g in groups]
            if base.startswith("walls"):
                bl = base.split()[1]
                walls = [inputs.wall[(bl, gi, float(blk.h))] for gi in range(len(groups))]
            elif el == "facade" and model == "dem":
                # a fixed wall is a wall that does not move: the DEM takes it as zero motion
                # anyway, and passing zeros shares the compiled batch with the moving walls
                walls = [(np.zeros_like(g.ag), np.zeros_like(g.ag)) for g in groups]
            else:
                walls = None
            per_rec = run_case(blk, model, mode, beta, groups, base_ag, walls, cfg, law=law)
            seconds = time.perf_counter() - tc
            save_case(path, per_rec, seconds, law)
        case_s[tag] = seconds
        results[(geo, el, base, model)] = per_rec
        caps = np.array([v["capacity_g"] for v in per_rec.values()])
        n_failed = sum(v["n_failed"] for v in per_rec.values())
        n_runs = sum(v["scales"].size for v in per_rec.values())
        print(
            f"  [{n_case}/{len(cases)}] {geo} {el:7s} {base:9s} {model:12s}: median capacity "
            f"{_median(caps):.3g} g (ground PGA), censored {int(np.sum(~np.isfinite(caps)))}, "
            f"failed runs {n_failed}/{n_runs} "
            f"({f'cached, computed in {seconds:.1f} s' if cached else f'{seconds:.1f} s'})",
            flush=True,
        )
    wall_s["runs"] = time.perf_counter() - t0
    wall_s["runs_as_computed"] = float(sum(case_s.values()))
    print(
        f"[3/5] {len(cases)} cases ({wall_s['runs']:.1f} s; computing them took "
        f"{wall_s['runs_as_computed']:.1f} s)"
    )

    t0 = time.perf_counter()
    rows = []
    for (geo, el, base, model), per_rec in results.items():
        for rec, v in per_rec.items():
            amp = inputs.roof_pga[base.split()[1]][rec] if base.startswith("roof") else 1.0
            rows.append(
                dict(
                    geometry=geo,
                    h=GEOMETRIES[geo][0],
                    b=GEOMETRIES[geo][1],
                    element=el,
                    base=base,
                    model=model,
                    beta=betas[(geo, el)] if model == "dem" else "",
                    record=rec,
                    capacity_g=v["capacity_g"],
                    capacity_base_pga_g=v["capacity_g"] * amp,
                    base_pga_over_ground_pga=amp,
                    n_collapse_intervals=v["n_intervals"],
                    at_lowest_scale=v["at_lowest_scale"],
                    n_failed_runs=v["n_failed"],
                    n_runs=int(v["scales"].size),
                )
            )
    table = capacity_table(rows)
    ratios = ratio_table(rows)
    model_ratios = model_ratio_table(rows)
    periods = np.concatenate([[0.0], np.geomspace(0.05, 3.0, 40)])
    spectra = roof_spectra(groups, buildings, periods)
    check = pulse_study_check(rows, PULSE_STUDY_CAPACITIES)
    if check:
        write_csv(out / "pulse_study_check.csv", check)
    write_csv(out / "capacities.csv", rows)
    write_csv(out / "capacity_table.csv", table)
    write_csv(out / "ratios.csv", ratios)
    write_csv(out / "model_ratios.csv", model_ratios)
    write_csv(out / "three_branch_laws.csv", law_rows)
    write_csv(
        out / "roof_amplification.csv",
        [
            dict(period_s=float(t), **{k: float(v[i]) for k, v in spectra.items()})
            for i, t in enumerate(periods)
        ],
    )
    wall_s["analysis"] = time.perf_counter() - t0
    print(f"[4/5] tables ({wall_s['analysis']:.1f} s)")
    t0 = time.perf_counter()
    written = figures(out, rows, ratios, spectra, periods)
    written.append(law_figure(out, blocks, laws, curves))
    wall_s["figures"] = time.perf_counter() - t0
    wall_s["total"] = time.perf_counter() - t_all
    print(f"[5/5] figures {written} ({wall_s['figures']:.1f} s); total {wall_s['total']:.1f} s")

    for t in ratios:
        print(
            f"  {t['geometry']} {t['model']:12s} {t['ratio']:24s} median {t['median']:.3g} "
            f"[IQR {t['q25']:.3g}-{t['q75']:.3g}], n {t['n_pairs']}, censored pairs "
            f"{t['n_censored_pairs']}, below 1: {t['frac_below_1']:.2f}"
        )
    for t in model_ratios:
        print(
            f"  {t['geometry']} {t['element']:7s} {t['base']:9s} {t['ratio']:21s} median "
            f"{t['median']:.3g} [IQR {t['q25']:.3g}-{t['q75']:.3g}], n {t['n_pairs']}, "
            f"below 1: {t['frac_below_1']:.2f}, above 1: {t['frac_above_1']:.2f}"
        )
    for t in check:
        print(
            f"  vs pulse study: {t['geometry']} {t['element']:7s} {t['model']:7s} median ratio "
            f"{t['median_this_over_pulse_study']:.3f}, within one step "
            f"{t['frac_within_one_step']:.2f}, higher {t['frac_higher_by_more_than_one_step']:.2f}"
            f", lower {t['frac_lower_by_more_than_one_step']:.2f}"
        )
    summary = dict(
        command="python experiments/building_study.py" + (" --quick" if args.quick else ""),
        rockjax_version=rj.__version__,
        buildings={
            bl: dict(
                n_storeys=n,
                T1_s=t1,
                periods_s=np.asarray(buildings[bl].periods).tolist(),
                storey_height_m=STOREY_HEIGHT,
                damping=DAMPING,
                roof_pga_over_ground_median=float(np.median(list(inputs.roof_pga[bl].values()))),
            )
            for bl, (n, t1) in BUILDINGS.items()
        },
        records=[r.name for r in records],
        coarse_scales_g=cfg["coarse"].tolist(),
        n_refine=cfg["n_refine"],
        beta={f"{k[0]}/{MODE_OF[k[1]]}": v for k, v in betas.items()},
        capacity_table=table,
        ratios=ratios,
        three_branch_laws=law_rows,
        model_ratios=model_ratios,
        pulse_study_check=check,
        wall_s=wall_s,
        case_s=case_s,
        figures=written,
    )
    (out / "summary.json").write_text(json.dumps(summary, indent=1, default=float))
    return summary


if __name__ == "__main__":
    main()
