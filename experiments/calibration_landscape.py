"""The loss landscape of the beta calibration: bounce loss and history error, and their AD
derivatives, over beta, with contact onsets inside the step (``onset="sub_step"``) and on the
step grid (``onset="step"``).

Block 0.25 x 3 m, target e = 0.95, release theta0 = eta/2, two-sided (the defaults of
``rj.fit_beta``). The loss is evaluated with the same helpers ``fit_beta`` uses
(``rockjax.calibration.problem`` / ``stats``); the derivative is forward mode
(``jax.jvp``) wrt beta, vmapped over the grid, and is compared with finite differences.

    python experiments/calibration_landscape.py [--out experiments/results] [--n 40]

Writes calibration_landscape.csv, calibration_landscape_summary.json and
calibration_landscape.png, and prints the numbers quoted in docs/calibration.md.
"""

import argparse
import csv
import json
import pathlib
import time

import jax
import jax.numpy as jnp
import numpy as np

import rockjax as rj
from rockjax import calibration as cal
from rockjax import metrics

B, H, E = 0.25, 3.0, 0.95
ONSETS = ("sub_step", "step")


def make(block, onset, beta_max):
    problem = cal.problem(
        block, E, target="e", mode="two_sided", beta_max=beta_max, joint=rj.Joint(onset=onset)
    )
    housner = cal.housner_reference(problem)[0]
    t_last = cal.last_compared_time(housner, problem)
    return problem, housner, t_last


def evaluator(problem, housner, t_last):
    th_ref = jnp.asarray(housner.theta)
    t_ref = np.asarray(housner.t)

    def f(beta):
        st = cal.stats(problem, beta)
        loss, gap = st[0], st[1]
        r = cal.dem_run(problem, beta)
        n = min(r.theta.shape[0], th_ref.shape[0])
        w = (jnp.asarray(t_ref[:n]) <= t_last).astype(float)
        herr = metrics.history_error(r.theta[:n], th_ref[:n], w)
        return jnp.stack([loss, herr, gap])

    def f_and_df(beta):
        return jax.jvp(f, (beta,), (jnp.ones_like(beta),))

    return jax.jit(jax.vmap(f_and_df))


def sign_changes(x):
    s = np.sign(x[np.isfinite(x) & (x != 0)])
    return int(np.sum(s[1:] != s[:-1]))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="experiments/results")
    ap.add_argument("--n", type=int, default=40, help="points per grid (coarse and fine)")
    args = ap.parse_args(argv)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    block = rj.Block(b=B, h=H)
    bdj = float(rj.beta_dejong(block))
    beta_max = 2.0 * bdj
    n = args.n
    coarse = np.linspace(0.0, 1.5, n)
    rows, summary = [], {"block": f"{B}x{H}", "e": E, "beta_dejong": bdj, "n": n, "onsets": {}}
    # the optimum (sub-step grid fit) centres the fine window for both onsets
    fit = rj.fit_beta(block, e=E, method="grid", n_grid=256)
    x_opt = fit.beta / bdj
    fine = x_opt + np.linspace(-1e-3, 1e-3, n)
    summary["beta_grid_over_bdj"] = x_opt
    for onset in ONSETS:
        problem, housner, t_last = make(block, onset, beta_max)
        ev = evaluator(problem, housner, t_last)
        res = {}
        for grid_name, x in (("coarse", coarse), ("fine", fine)):
            val, der = map(np.asarray, ev(jnp.asarray(x * bdj)))
            res[grid_name] = (x, val, der * bdj)  # derivatives per unit beta/beta_DeJong
            for i in range(x.size):
                rows.append(
                    dict(
                        joint=rj.Joint(onset=onset),
                        grid=grid_name,
                        beta_over_bdj=x[i],
                        beta_s=x[i] * bdj,
                        loss=val[i, 0],
                        dloss_ad=der[i, 0] * bdj,
                        history_error=val[i, 1],
                        dhistory_ad=der[i, 1] * bdj,
                        log_e_gap=val[i, 2],
                        dgap_ad=der[i, 2] * bdj,
                    )
                )
        s = {}
        for grid_name in ("coarse", "fine"):
            x, val, der = res[grid_name]
            fd = np.gradient(val, x, axis=0)  # finite differences along the grid
            for j, q in enumerate(("loss", "history", "gap")):
                s[f"{grid_name}_{q}_sign_changes_ad"] = sign_changes(der[:, j])
                s[f"{grid_name}_{q}_sign_changes_fd"] = sign_changes(fd[:, j])
                # AD slope vs finite-difference slope over the grid spacing (interior points,
                # where the FD slope is not ~ 0)
                ok = np.abs(fd[1:-1, j]) > 0.05 * np.max(np.abs(fd[1:-1, j]))
                r = der[1:-1, j][ok] / fd[1:-1, j][ok]
                s[f"{grid_name}_{q}_ad_over_fd_median"] = float(np.median(r)) if r.size else None
                s[f"{grid_name}_{q}_ad_over_fd_p10_p90"] = (
                    [float(np.percentile(r, 10)), float(np.percentile(r, 90))] if r.size else None
                )
            # outliers of the AD derivative: points where it differs from the finite difference
            # by more than 20 % of the largest |finite difference| over the grid
            for j, q in enumerate(("loss", "history", "gap")):
                tol = 0.2 * np.max(np.abs(fd[1:-1, j]))
                s[f"{grid_name}_{q}_ad_outliers"] = int(
                    np.sum(np.abs(der[1:-1, j] - fd[1:-1, j]) > tol)
                )
            # fine window: AD slope at the two ends vs the secant of the loss from the window's
            # centre to each end (the slope of the trend)
            if grid_name == "fine":
                c = x.size // 2
                for j, q in enumerate(("loss", "history")):
                    sec_hi = (val[-1, j] - val[c, j]) / (x[-1] - x[c])
                    sec_lo = (val[c, j] - val[0, j]) / (x[c] - x[0])
                    ad_hi = np.mean(der[c:, j])
                    ad_lo = np.mean(der[: c + 1, j])
                    s[f"fine_{q}_secant_slope_lo_hi"] = [float(sec_lo), float(sec_hi)]
                    s[f"fine_{q}_mean_ad_slope_lo_hi"] = [float(ad_lo), float(ad_hi)]
                    s[f"fine_{q}_range"] = float(np.ptp(val[:, j]))
                    s[f"fine_{q}_max_abs_second_diff"] = float(
                        np.max(np.abs(np.diff(val[:, j], 2)))
                    )
            i = int(np.nanargmin(val[:, 0]))
            s[f"{grid_name}_argmin_loss_over_bdj"] = float(x[i])
            s[f"{grid_name}_min_loss"] = float(val[i, 0])
        summary["onsets"][onset] = s
        res_all = summary.setdefault("_res", {})
        res_all[onset] = res
    res_all = summary.pop("_res")
    summary["seconds"] = time.perf_counter() - t0
    with open(out / "calibration_landscape.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    with open(out / "calibration_landscape_summary.json", "w") as f:
        json.dump(summary, f, indent=1)
    plot(res_all, x_opt, out / "calibration_landscape.png")
    print(json.dumps(summary, indent=1))


def plot(res, x_opt, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(4, 2, figsize=(11, 12), sharex="col")
    colors = {"sub_step": "C0", "step": "C3"}
    for col, grid_name in enumerate(("coarse", "fine")):
        for onset in ONSETS:
            x, val, der = res[onset][grid_name]
            xx = (x - x_opt) * 1e3 if grid_name == "fine" else x
            fd = np.gradient(val, x, axis=0)
            c = colors[onset]
            for j in range(2):
                y = val[:, j] - (np.min(val[:, j]) if grid_name == "fine" else 0.0)
                ax[2 * j, col].plot(xx, y, ".-", color=c, ms=3, lw=0.8, label=onset)
                ax[2 * j + 1, col].plot(
                    xx, der[:, j], ".-", color=c, ms=3, lw=0.8, label=f"{onset}: AD (jvp)"
                )
                ax[2 * j + 1, col].plot(
                    xx,
                    fd[:, j],
                    "x--",
                    color=c,
                    ms=3,
                    lw=0.6,
                    alpha=0.7,
                    label=f"{onset}: finite diff.",
                )
        sub = " - min" if grid_name == "fine" else ""
        ax[0, col].set_ylabel(f"bounce loss{sub} [-]")
        ax[1, col].set_ylabel("d loss / d(beta/beta_DJ)")
        ax[2, col].set_ylabel(f"history error{sub} [-]")
        ax[3, col].set_ylabel("d history err. / d(beta/beta_DJ)")
        for a in ax[:, col]:
            a.axhline(0, color="k", lw=0.4)
            a.grid(alpha=0.3)
        if grid_name == "coarse":
            ax[0, col].set_yscale("log")
            ax[3, col].set_xlabel("beta / beta_DeJong")
            ax[0, col].set_title("coarse: 0 .. 1.5 beta_DeJong")
        else:
            ax[3, col].set_xlabel("(beta - beta_opt) / beta_DeJong  [x 1e-3]")
            ax[0, col].set_title(f"fine: 2e-3 beta_DeJong around beta_opt = {x_opt:.5f} beta_DJ")
    ax[0, 0].legend(fontsize=8)
    ax[1, 1].legend(fontsize=7)
    fig.suptitle("rockjax fit_beta landscape: block 0.25 x 3 m, target e = 0.95")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    main()
