"""Two parameters at once: beta and the rocking width b from one free-rocking history.

Twin experiment. A "measured" history is a DEM run of a 3 m parapet whose corners are damaged
(effective rocking width b = 0.23 m instead of the nominal 0.25 m) with beta = 0.004 s, plus
Gaussian noise of 1e-4 rad. ``rj.fit_history`` starts from the nominal block and
beta0 = 0.002 s and fits (beta, b) by L-BFGS with forward-mode derivatives. For the cost
comparison the same loss is mapped on a vmapped 2-D grid (beta 0.002-0.006 s x b 0.22-0.26 m)
of n x n runs: the grid's accuracy is its spacing, so 2 % on both needs ~n = 20-40 (400-1600
runs), against the tens of runs of the gradient fit.

    python experiments/fit_two_parameters.py [--n 21] [--out experiments/results]

Writes fit_two_parameters.json and fit_two_parameters.png (loss map, fit path) and prints the
numbers quoted in docs/calibration.md.
"""

import argparse
import json
import pathlib
import time

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

import rockjax as rj
from rockjax import calibration as cal

TRUE = dict(beta=0.004, b=0.23)
NOMINAL_B = 0.25
H = 3.0
NOISE = 1e-4  # [rad]


def measured_history(dt=None):
    """The noisy "measured" history, at the DEM step ``dt`` [s] (default: the default step)."""
    true = rj.Block(b=TRUE["b"], h=H)
    theta0 = 0.5 * float(rj.Block(b=NOMINAL_B, h=H).eta)
    meas = rj.simulate_dem(
        true, beta=TRUE["beta"], theta0=theta0, duration=8.0, save_dt=0.005, dt=dt
    )
    noise = np.random.default_rng(0).normal(0.0, NOISE, meas.theta.shape)
    noise[0] = 0.0  # the release is known
    return eqx.tree_at(lambda r: r.theta, meas, meas.theta + jnp.asarray(noise))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=21, help="grid points per parameter")
    ap.add_argument("--out", default="experiments/results")
    args = ap.parse_args(argv)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    nominal = rj.Block(b=NOMINAL_B, h=H)
    # like with like: the "measurement" is made at the step the fit's runs take (at the default
    # step the DEM's restitution differs by up to the step rule's 1e-3, ~2 % in beta)
    dt = cal.history_problem(nominal, measured_history(), 0.002, "two_sided", 8).dt
    meas = measured_history(dt)

    fit = rj.fit_history(nominal, meas, beta0=0.002)  # compiles
    fit = rj.fit_history(nominal, meas, beta0=0.002)  # timed
    print(
        f"gradient fit: beta = {fit.beta:.5f} s ({fit.beta / TRUE['beta'] - 1:+.2%}), "
        f"b = {fit.b:.4f} m ({fit.b / TRUE['b'] - 1:+.2%}), loss {fit.loss:.3g}, "
        f"{fit.n_iterations} iterations, {fit.n_simulations} runs, {fit.seconds:.2f} s, "
        f"converged={fit.converged} {fit.reason}"
    )

    problem = cal.history_problem(nominal, meas, 0.002, "two_sided", 8)
    # the verdict's statistic (converged needs <= HISTORY_TOL) at the truth and along the valley
    n_compared = int(np.sum(rj.metrics.bounce_weights(problem.measured)[0]))
    gaps = {}
    for beta, b in [(TRUE["beta"], TRUE["b"]), (0.003, 0.235), (0.003, 0.24), (0.002, 0.245)]:
        run = rj.simulate_dem(
            eqx.tree_at(lambda k: k.b, nominal, b),
            beta=beta,
            theta0=float(meas.theta[0]),
            duration=float(meas.t[-1]),
            save_dt=problem.save_dt,
            dt=problem.dt,
        )
        gap = cal.history_peak_gap(run, meas, n_compared, float(problem.t_scale), "two_sided")
        gaps[f"beta={beta:g} s, b={b:g} m"] = gap
        print(f"peak gap at beta = {beta:g} s, b = {b:g} m: {gap:.3f}")
    # grids offset from the true values (a grid does not know them)
    betas = np.linspace(0.0021, 0.0061, args.n)
    bs = np.linspace(0.2213, 0.2613, args.n)
    bb, ww = np.meshgrid(betas, bs, indexing="ij")
    u = np.stack([np.log(bb / 0.002), np.log(ww / NOMINAL_B)], axis=-1).reshape(-1, 2)
    loss_map = eqx.filter_jit(jax.vmap(cal.history_loss, in_axes=(0, None)))
    jax.block_until_ready(loss_map(jnp.asarray(u[:4]), problem))  # compile a small batch
    t0 = time.perf_counter()
    vals = []
    for i in range(0, u.shape[0], 64):
        part = u[i : i + 64]
        pad = 64 - part.shape[0]
        v = loss_map(jnp.asarray(np.pad(part, ((0, pad), (0, 0)), mode="edge")), problem)
        vals.append(np.asarray(v)[: part.shape[0]])
    grid_s = time.perf_counter() - t0
    lmap = np.concatenate(vals).reshape(args.n, args.n)
    i, j = np.unravel_index(np.nanargmin(lmap), lmap.shape)
    print(
        f"grid {args.n}x{args.n} = {args.n**2} runs in {grid_s:.1f} s: best beta = "
        f"{betas[i]:.5f} s, b = {bs[j]:.4f} m (spacing {betas[1] - betas[0]:.1e} s, "
        f"{bs[1] - bs[0]:.1e} m)"
    )
    result = dict(
        true=TRUE,
        nominal_b=NOMINAL_B,
        noise_rad=NOISE,
        dt=dt,
        fit=dict(
            beta=fit.beta,
            b=fit.b,
            loss=fit.loss,
            n_iterations=fit.n_iterations,
            n_simulations=fit.n_simulations,
            seconds=fit.seconds,
            converged=fit.converged,
            reason=fit.reason,
        ),
        grid=dict(n=args.n, best_beta=float(betas[i]), best_b=float(bs[j]), seconds=grid_s),
        peak_gap=dict(tolerance=cal.HISTORY_TOL, n_compared=n_compared, **gaps),
        command="python experiments/fit_two_parameters.py",
    )
    (out / "fit_two_parameters.json").write_text(json.dumps(result, indent=2))

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.5, 4.5), constrained_layout=True)
    cs = ax.contourf(betas * 1e3, bs * 1e3, np.log10(lmap.T), levels=20, cmap="viridis")
    fig.colorbar(cs, ax=ax, label="log10 loss")
    path_beta = np.concatenate([[0.002], fit.history["beta"]]) * 1e3  # from the start
    path_b = np.concatenate([[NOMINAL_B], fit.history["b"]]) * 1e3
    ax.plot(path_beta, path_b, "w.-", lw=1, label="L-BFGS path")
    ax.plot(TRUE["beta"] * 1e3, TRUE["b"] * 1e3, "r*", ms=12, label="true")
    ax.set_xlabel("beta [ms]")
    ax.set_ylabel("rocking width b [mm]")
    ax.set_title(f"fit_history: {fit.n_simulations} runs vs grid {args.n}x{args.n}")
    ax.legend(loc="upper right", fontsize=8)
    fig.savefig(out / "fit_two_parameters.png", dpi=120)
    print(f"wrote {out / 'fit_two_parameters.json'} and {out / 'fit_two_parameters.png'}")


if __name__ == "__main__":
    main()
