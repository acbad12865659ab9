"""Benchmark: why the first ``rj.fit_beta`` of a process stays above 3 s (docs/benchmarks.md,
"Compilation").

1. The DEM's forward-mode derivative against the run it differentiates: one free-rocking run of
   the calibration problem of ``rockjax calibrate --b 0.25 --h 1.5`` (release 0.5 eta, beta =
   2e-3 s, saved every 2 ms), compiled plain and as ``jax.jvp`` in ``beta``: the run time (min
   of 5), the compiled HLO's size and its number of fusion instructions.
2. Loading compiled programs: the seeding scan of the fit (``stats_batch`` over 9 values of
   beta) compiled, serialised (``jax.experimental.serialize_executable``) and loaded back in
   this process: the size of the serialised executable and the time to load it (min of 3).

    python benchmarks/bench_fit_derivative.py

About a minute on 2 cores.
"""

from __future__ import annotations

import re
import time

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from _timing import load, machine, timed
from jax.experimental import serialize_executable

import rockjax as rj
from rockjax.calibration import problems


def main() -> None:
    print(f"machine: {machine()}; load {load()}; jax {jax.__version__}")
    block = rj.Block(b=0.25, h=1.5)
    prob, _ = problems.build_problem(block, e=float(rj.e_housner(block)))
    th0 = float(prob.theta0[0])

    def run(beta):
        return problems.dem_run(prob, beta, th0).theta

    def tangent(beta):
        return jax.jvp(run, (beta,), (jnp.ones_like(beta),))

    beta = jnp.asarray(2e-3)
    print("\n1. one DEM release, plain and its jvp in beta:")
    rows = {}
    for name, f in (("run", run), ("jvp", tangent)):
        compiled = jax.jit(f).lower(beta).compile()
        text = compiled.as_text()
        fusions = len(re.findall(r"= \S+ fusion\(", text))
        rows[name] = (timed(lambda: compiled(beta), 5)[1], len(text), fusions)
        t, size, fus = rows[name]
        print(f"   {name:4s} {t * 1e3:8.1f} ms   HLO {size / 1e6:5.2f} M chars   {fus} fusions")
    print(
        f"   jvp / run: time x{rows['jvp'][0] / rows['run'][0]:.1f}, "
        f"HLO x{rows['jvp'][1] / rows['run'][1]:.1f}"
    )

    print("\n2. the fit's seeding scan (stats_batch, 9 values of beta), serialised and loaded:")
    dyn, static = eqx.partition(prob, eqx.is_array)
    leaves, treedef = jax.tree.flatten(dyn)

    def scan(leaves, betas):
        p = eqx.combine(jax.tree.unflatten(treedef, leaves), static)
        return jax.tree.leaves(problems.stats_batch(p, betas))

    betas = jax.device_put(np.linspace(0.0, 5e-3, 9))
    compiled = jax.jit(scan).lower(leaves, betas).compile()
    payload, in_tree, out_tree = serialize_executable.serialize(compiled)
    loads = []
    for _ in range(3):
        t0 = time.perf_counter()
        serialize_executable.deserialize_and_load(payload, in_tree, out_tree)
        loads.append(time.perf_counter() - t0)
    print(
        f"   serialised {len(payload) / 1e6:.2f} MB, loaded in {min(loads):.2f} s "
        f"({min(loads) / (len(payload) / 1e6):.2f} s per MB)"
    )
    print(f"load at the end: {load()}")


if __name__ == "__main__":
    main()
