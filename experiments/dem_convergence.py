"""Convergence of the DEM model in the time step and in the number of sub-contacts.

1. Parapets (two-sided free rocking from 0.5 eta), h/b 4-24, beta in {0, 0.5, 1, 1.5}
   beta_DeJong: first-impact restitution e_exp,1 (Eq. 6) at the default step dt_d times
   2, 1, 1/2, 1/4, 1/8, 1/16, 1/32. Reference: dt_d/32 and its Richardson extrapolation
   (order 2) from dt_d/16 and dt_d/32; observed order from a log-log fit over 2, 1, 1/2, 1/4.
2. Facades (one-sided free rocking from 0.5 eta, phi = 30 deg, gap 0, E = 4.05 GPa),
   0.11 x 2.4, 0.2 x 1.5, 0.3 x 2.4 m, beta in {0, 0.5, 1, 2} beta_Hcrit: the first three
   rebound peaks (rockjax.metrics.peaks, one-sided) at dt_d times 2, 1, 1/2, 1/4, 1/8, 1/16.
3. Sub-contacts: e_exp,1 of two parapets and the first rebound peak of the facades for
   n_sub in {2, 3, 4, 6, 8, 12, 16}, each at its default step and at a quarter of it.

    python experiments/dem_convergence.py [--parts parapets,facades,nsub]
                                          [--out experiments/results] [--figures docs/figures]

Writes dem_convergence_{parapets,facades,nsub}.csv (the parts run; the figures are drawn from
all three files), prints the tables quoted in docs/verification.md ("DEM time step:
convergence") and draws dem_convergence_{dt,nsub}.png. About 20 min on a shared 2-core
machine (parapets 5, facades 8, n_sub 7) before facades took open steps off their walls; the
facades part now takes under a minute.
"""

import argparse
import csv
import pathlib
import time

import numpy as np

import rockjax as rj
from rockjax import metrics

PARAPETS = ((0.25, 1.0), (0.2, 1.5), (0.25, 3.0), (0.15, 2.4), (0.1, 2.4))  # h/b 4 ... 24
PARAPET_BETAS = (0.0, 0.5, 1.0, 1.5)  # fractions of beta_DeJong
FACADES = ((0.11, 2.4), (0.2, 1.5), (0.3, 2.4))
FACADE_E = 4.05e9  # [Pa]
FACADE_BETAS = (0.0, 0.5, 1.0, 2.0)  # fractions of beta_Hcrit
PARAPET_REFINE = (0.5, 1, 2, 4, 8, 16, 32)  # dt = dt_default / f
FACADE_REFINE = (0.5, 1, 2, 4, 8, 16)
N_SUBS = (2, 3, 4, 6, 8, 12, 16)
SAMPLE = 2.5e-4  # [s] output interval (peak parabola error ~(pi SAMPLE / T)^2 / 8 < 1e-6)
N_PEAKS = 3


def _save_dt(dt):
    return dt * max(1, round(SAMPLE / dt))


def parapet_e1(blk, beta, dt, joint=rj.Joint()):
    eta = float(blk.eta)
    r = rj.simulate_dem(
        blk, beta=beta, theta0=0.5 * eta, duration=2.5, dt=dt, save_dt=_save_dt(dt), joint=joint
    )
    return float(r.e_exp(1)[0])


def facade_peaks(blk, beta, dt, joint=rj.Joint(), duration=3.0):
    """First N_PEAKS rebound peaks / eta (NaN where the run has no such bounce)."""
    eta = float(blk.eta)
    r = rj.simulate_dem(
        blk,
        beta=beta,
        mode="one_sided",
        gap=0.0,
        theta0=0.5 * eta,
        duration=duration,
        dt=dt,
        save_dt=_save_dt(dt),
        joint=joint,
    )
    pk = metrics.peaks(r.t, r.theta, eta, N_PEAKS, mode="one_sided")
    amp = np.asarray(pk.amplitude)[1:] / eta
    return np.where(np.asarray(pk.valid)[1:] | (amp > 0.01), amp, np.nan)


def observed_order(dts, errs):
    """Slope of log|err| against log dt (least squares)."""
    x, y = np.log(dts), np.log(np.maximum(np.abs(errs), 1e-12))
    return float(np.polyfit(x, y, 1)[0])


def study_parapets():
    rows = []
    for b, h in PARAPETS:
        blk = rj.Block(b=b, h=h)
        bdj = float(rj.beta_dejong(blk))
        for frac in PARAPET_BETAS:
            beta = frac * bdj
            dt_d = rj.stable_dt(blk, beta)
            e = np.array([parapet_e1(blk, beta, dt_d / f) for f in PARAPET_REFINE])
            e_rich = e[-1] + (e[-1] - e[-2]) / 3.0
            fit = [i for i, f in enumerate(PARAPET_REFINE) if f <= 4]
            p = observed_order(dt_d / np.array(PARAPET_REFINE)[fit], e[fit] - e_rich)
            row = dict(b=b, h=h, h_over_b=h / b, beta_over_bdj=frac, beta=beta, dt_default=dt_d)
            row.update({f"e_dt/{f:g}": float(x) for f, x in zip(PARAPET_REFINE, e)})
            row.update(e_richardson=e_rich, order=p, err_default=float(e[1] - e_rich))
            rows.append(row)
            print(
                f"  parapet {b}x{h} (h/b {h / b:4.1f}) beta={frac:.1f} bDJ dt_d={dt_d:.3e} "
                f"e: {' '.join(f'{x:.6f}' for x in e)}  limit {e_rich:.6f} "
                f"err(dt_d) {e[1] - e_rich:+.1e}  order {p:.2f}",
                flush=True,
            )
    return rows


def study_facades():
    rows = []
    for b, h in FACADES:
        blk = rj.Block(b=b, h=h, E=FACADE_E)
        bh = float(rj.beta_hcrit(blk))
        for frac in FACADE_BETAS:
            beta = frac * bh
            dt_d = rj.stable_dt(blk, beta, mode="one_sided")
            pk = np.array([facade_peaks(blk, beta, dt_d / f) for f in FACADE_REFINE])
            ref = pk[-1]
            rel = pk[1] / ref - 1.0
            errs = np.abs(pk[:4, 0] - ref[0])
            p = observed_order(dt_d / np.array(FACADE_REFINE[:4]), errs)
            row = dict(b=b, h=h, beta_over_bhcrit=frac, beta=beta, dt_default=dt_d, order1=p)
            for f, v in zip(FACADE_REFINE, pk):
                for k in range(N_PEAKS):
                    row[f"peak{k + 1}_dt/{f:g}"] = float(v[k])
            for k in range(N_PEAKS):
                row[f"relerr{k + 1}_default"] = float(rel[k])
            rows.append(row)
            print(
                f"  facade {b}x{h} beta={frac:.1f} bH dt_d={dt_d:.3e} peaks/eta: "
                + " | ".join(" ".join(f"{x:.4f}" for x in v) for v in pk)
                + f"  rel.err(dt_d vs dt_d/16) {' '.join(f'{x:+.3f}' for x in rel)}  order1 {p:.2f}",
                flush=True,
            )
    return rows


def study_nsub():
    rows = []
    cases = [("parapet", 0.2, 1.5, 0.5), ("parapet", 0.25, 3.0, 0.5)]
    cases += [("facade", b, h, frac) for b, h in FACADES for frac in (0.0, 0.5)]
    for kind, b, h, frac in cases:
        if kind == "parapet":
            blk = rj.Block(b=b, h=h)
            beta = frac * float(rj.beta_dejong(blk))
        else:
            blk = rj.Block(b=b, h=h, E=FACADE_E)
            beta = frac * float(rj.beta_hcrit(blk))
        mode = "two_sided" if kind == "parapet" else "one_sided"
        for n in N_SUBS:
            dt_d = rj.stable_dt(blk, beta, mode=mode, joint=rj.Joint(n_sub=n))
            vals = []
            for f in (1, 4):
                if kind == "parapet":
                    vals.append(parapet_e1(blk, beta, dt_d / f, joint=rj.Joint(n_sub=n)))
                else:
                    vals.append(
                        float(
                            facade_peaks(
                                blk, beta, dt_d / f, joint=rj.Joint(n_sub=n), duration=1.8
                            )[0]
                        )
                    )
            rows.append(
                dict(
                    kind=kind,
                    b=b,
                    h=h,
                    beta_frac=frac,
                    joint=rj.Joint(n_sub=n),
                    value_dt_d=vals[0],
                    value_dt_d4=vals[1],
                )
            )
            what = "e_exp1" if kind == "parapet" else "peak1/eta"
            print(
                f"  {kind} {b}x{h} beta={frac:.1f} n_sub={n:2d} {what}: {vals[0]:.5f} (dt_d), {vals[1]:.5f} (dt_d/4)",
                flush=True,
            )
    return rows


def read_csv(path):
    rows = []
    with open(path, newline="") as fh:
        for r in csv.DictReader(fh):
            rows.append({k: (v if k == "kind" else float(v)) for k, v in r.items()})
    for r in rows:
        if "n_sub" in r:
            r["n_sub"] = int(r["n_sub"])
    return rows


def write_csv(path, rows):
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def plot(par, fac, nsub, figdir):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    for r in par:
        f = np.array(PARAPET_REFINE[:-2], float)
        err = np.abs([r[f"e_dt/{x:g}"] - r["e_richardson"] for x in PARAPET_REFINE[:-2]])
        ax[0].loglog(
            1 / f,
            np.maximum(err, 1e-8),
            "o-",
            ms=3,
            lw=0.8,
            alpha=0.8,
            label=f"h/b {r['h_over_b']:.1f}, {r['beta_over_bdj']:.1f} bDJ",
        )
    x = np.array([1 / 16, 2])
    ax[0].loglog(x, 3e-4 * x**2, "k--", lw=1, label="slope 2")
    ax[0].axhline(1e-3, color="r", lw=1)
    ax[0].axvline(1, color="gray", lw=0.8)
    ax[0].set_xlabel("dt / default dt")
    ax[0].set_ylabel("|e_exp,1 - limit|")
    ax[0].set_title("Parapets: first-impact restitution")
    ax[0].legend(fontsize=5, ncol=2)
    for r in fac:
        f = np.array(FACADE_REFINE[:-1], float)
        ref = r["peak1_dt/16"]
        err = np.abs([r[f"peak1_dt/{x:g}"] / ref - 1 for x in FACADE_REFINE[:-1]])
        ax[1].loglog(
            1 / f,
            np.maximum(err, 1e-6),
            "o-",
            ms=3,
            lw=0.8,
            label=f"{r['b']}x{r['h']}, {r['beta_over_bhcrit']:.1f} bH",
        )
    ax[1].loglog(x, 5e-3 * x**2, "k--", lw=1, label="slope 2")
    ax[1].axhline(0.02, color="r", lw=1)
    ax[1].axvline(1, color="gray", lw=0.8)
    ax[1].set_xlabel("dt / default dt")
    ax[1].set_ylabel("|peak_1 / peak_1(dt/16) - 1|")
    ax[1].set_title("Facades (gap 0): first rebound peak")
    ax[1].legend(fontsize=5, ncol=2)
    fig.tight_layout()
    fig.savefig(figdir / "dem_convergence_dt.png", dpi=130)

    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    for kind, axi, lab in (
        ("parapet", ax[0], "e_exp,1"),
        ("facade", ax[1], "first rebound peak / eta"),
    ):
        keys = sorted({(r["b"], r["h"], r["beta_frac"]) for r in nsub if r["kind"] == kind})
        for key in keys:
            rr = [r for r in nsub if r["kind"] == kind and (r["b"], r["h"], r["beta_frac"]) == key]
            n = [r["n_sub"] for r in rr]
            axi.plot(
                n,
                [r["value_dt_d4"] for r in rr],
                "o-",
                ms=3,
                label=f"{key[0]}x{key[1]}, beta {key[2]:.1f} x {'bDJ' if kind == 'parapet' else 'bH'}",
            )
            axi.plot(n, [r["value_dt_d"] for r in rr], "x", color=axi.lines[-1].get_color(), ms=4)
        axi.set_xlabel("n_sub (sub-contacts per face)")
        axi.set_ylabel(lab + " (o: dt_d/4, x: dt_d)")
        axi.set_title(f"{kind}s: convergence in n_sub")
        axi.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(figdir / "dem_convergence_nsub.png", dpi=130)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="experiments/results")
    ap.add_argument("--figures", default="docs/figures")
    ap.add_argument("--parts", default="parapets,facades,nsub")
    args = ap.parse_args(argv)
    parts = set(args.parts.split(","))
    out, figdir = pathlib.Path(args.out), pathlib.Path(args.figures)
    out.mkdir(parents=True, exist_ok=True)
    figdir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    studies = (
        (
            "parapets",
            "1. parapets: e_exp,1 vs dt (columns dt_d x 2, 1, 1/2, ..., 1/32)",
            study_parapets,
        ),
        (
            "facades",
            "2. facades: rebound peaks 1-3 / eta vs dt (dt_d x 2, 1, 1/2, ..., 1/16)",
            study_facades,
        ),
        ("nsub", "3. n_sub", study_nsub),
    )
    results = {}
    for name, title, study in studies:
        path = out / f"dem_convergence_{name}.csv"
        if name in parts:
            print(title)
            results[name] = study()
            write_csv(path, results[name])
        else:
            results[name] = read_csv(path)
    par, fac, nsub = results["parapets"], results["facades"], results["nsub"]
    plot(par, fac, nsub, figdir)
    worst_p = max(abs(r["err_default"]) for r in par)
    worst_f = max(abs(r["relerr1_default"]) for r in fac)
    print(f"worst |e_exp,1(dt_d) - limit| over parapets: {worst_p:.2e}")
    print(f"worst |peak1(dt_d)/peak1(dt_d/16) - 1| over facades: {worst_f:.3f}")
    print(f"total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
