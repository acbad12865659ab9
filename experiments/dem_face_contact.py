"""The integrated face contact law (``rj.Joint()``, ``n_sub="exact"``) against many sub-contacts, and its
convergence in the time step.

1. ``limit``: first-impact e_exp,1 (Eq. 6) of parapets (two-sided free rocking from 0.5 eta)
   and the first rebound peak / eta of facades (one-sided, gap 0, phi 30 deg, E 4.05 GPa),
   for n_sub in {2, 16, 32, 64} (parapets also 128) and "exact", each at half its default
   step (the default step changes these by < 5e-5 for parapets, < 1.6 % for facades).
2. ``dt``: the same quantities of the integrated law at the default step dt_d times
   2, 1, 1/2, 1/4, 1/16 (parapets h/b 4-24 at 0, 0.5, 1.5 beta_DeJong; facades at 0, 0.5, 1
   beta_Hcrit); reference dt_d/16.
3. ``shear``: the three shear-history rules of the face law (``rj.Joint(shear_release=...)``:
   release the share of a pressure-shaped or a uniform stress that opens, or none) against
   n_sub = 64 at beta = 0, where the sub-contacts lose energy by releasing their shear springs,
   and on two parapets at 0.5 beta_DeJong.

    python experiments/dem_face_contact.py [--parts limit,dt,shear] [--out experiments/results]

Writes dem_face_contact_{limit,dt,shear}.csv and prints the tables quoted in
docs/verification.md ("Integrated face contact").
"""

import argparse
import csv
import pathlib
import time

import numpy as np

import rockjax as rj
from rockjax import metrics

PARAPETS = ((0.25, 1.0), (0.2, 1.5), (0.25, 3.0), (0.15, 2.4), (0.1, 2.4))  # h/b 4 ... 24
FACADES = ((0.11, 2.4), (0.2, 1.5), (0.3, 2.4))
FACADE_E = 4.05e9  # [Pa]
SAMPLE = 2.5e-4  # [s] output interval
LIMIT_NSUB = (2, 16, 32, 64)
REFINE = (0.5, 1, 2, 4, 16)  # dt = dt_default / f


def _save_dt(dt):
    return dt * max(1, round(SAMPLE / dt))


def _block(kind, b, h):
    return rj.Block(b=b, h=h) if kind == "parapet" else rj.Block(b=b, h=h, E=FACADE_E)


def _beta(kind, blk, frac):
    return frac * float(rj.beta_dejong(blk) if kind == "parapet" else rj.beta_hcrit(blk))


def value(kind, blk, beta, n_sub, f=2.0, duration=None, release="uniform"):
    """e_exp,1 (parapet) or the first rebound peak / eta (facade) at dt_d(n_sub) / f."""
    mode = "two_sided" if kind == "parapet" else "one_sided"
    joint = rj.Joint(n_sub=n_sub, shear_release=release)
    dt = rj.stable_dt(blk, beta, mode=mode, joint=joint) / f
    r = rj.simulate_dem(
        blk,
        beta=beta,
        mode=mode,
        theta0=0.5 * blk.eta,
        duration=duration or (2.5 if kind == "parapet" else 1.8),
        dt=dt,
        save_dt=_save_dt(dt),
        joint=joint,
    )
    if kind == "parapet":
        return float(r.e_exp(1)[0])
    pk = metrics.peaks(r.t, r.theta, blk.eta, 1, mode="one_sided")
    return float(np.asarray(pk.amplitude)[1] / float(blk.eta))


def study_limit():
    rows = []
    cases = [("parapet", 0.2, 1.5, f) for f in (0.0, 0.5)]
    cases += [("parapet", 0.25, 3.0, f) for f in (0.0, 0.5)]
    cases += [("facade", b, h, f) for b, h in FACADES for f in (0.0, 0.5)]
    for kind, b, h, frac in cases:
        blk = _block(kind, b, h)
        beta = _beta(kind, blk, frac)
        n_subs = LIMIT_NSUB + ((128,) if kind == "parapet" else ()) + ("exact",)
        row = dict(kind=kind, b=b, h=h, beta_frac=frac)
        for n in n_subs:
            t0 = time.perf_counter()
            row[f"n{n}"] = value(kind, blk, beta, n)
            print(
                f"  {kind} {b}x{h} beta {frac} n_sub={n}: {row[f'n{n}']:.5f} "
                f"({time.perf_counter() - t0:.0f} s)",
                flush=True,
            )
        rows.append(row)
    return rows


def study_dt():
    rows = []
    cases = [("parapet", b, h, f) for b, h in PARAPETS for f in (0.0, 0.5, 1.5)]
    cases += [("facade", b, h, f) for b, h in FACADES for f in (0.0, 0.5, 1.0)]
    for kind, b, h, frac in cases:
        blk = _block(kind, b, h)
        beta = _beta(kind, blk, frac)
        mode = "two_sided" if kind == "parapet" else "one_sided"
        v = np.array([value(kind, blk, beta, "exact", f=f) for f in REFINE])
        ref = v[-1]
        err = v - ref if kind == "parapet" else v / ref - 1.0
        fit = slice(0, 4)
        order = np.polyfit(
            np.log(1.0 / np.array(REFINE[fit])), np.log(np.maximum(np.abs(err[fit]), 1e-12)), 1
        )[0]
        row = dict(
            kind=kind,
            b=b,
            h=h,
            beta_frac=frac,
            dt_default=rj.stable_dt(blk, beta, mode=mode, joint=rj.Joint(n_sub="exact")),
        )
        row.update({f"dt/{f:g}": float(x) for f, x in zip(REFINE, v)})
        row.update(err_default=float(err[1]), order=float(order))
        rows.append(row)
        print(
            f"  {kind} {b}x{h} beta {frac}: {' '.join(f'{x:.6f}' for x in v)}  "
            f"err(dt_d) {err[1]:+.2e}  order {order:.2f}",
            flush=True,
        )
    return rows


def study_shear():
    rows = []
    cases = [("parapet", 0.2, 1.5, 0.0), ("parapet", 0.25, 1.0, 0.0), ("parapet", 0.25, 3.0, 0.0)]
    cases += [("facade", b, h, 0.0) for b, h in FACADES]
    cases += [("parapet", 0.25, 1.0, 0.5), ("parapet", 0.2, 1.5, 0.5)]  # damped: 0.5 beta_DJ
    for kind, b, h, frac in cases:
        blk = _block(kind, b, h)
        beta = _beta(kind, blk, frac)
        row = dict(kind=kind, b=b, h=h, beta_frac=frac, n64=value(kind, blk, beta, 64))
        for release in ("pressure", "uniform", "none"):
            row[f"exact_{release}"] = value(kind, blk, beta, "exact", release=release)
        rows.append(row)
        print("  " + " ".join(f"{k}={v}" for k, v in row.items()), flush=True)
    return rows


def write_csv(path, rows):
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="experiments/results")
    ap.add_argument("--parts", default="limit,dt,shear")
    args = ap.parse_args(argv)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    for name, study in (("limit", study_limit), ("dt", study_dt), ("shear", study_shear)):
        if name in args.parts.split(","):
            print(name, flush=True)
            write_csv(out / f"dem_face_contact_{name}.csv", study())
    print(f"total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
