"""Compile time and step cost of tall brick walls: the unrolled step (every block and joint
written out) against the array layout of stacks (``rockjax.dem.run(layout="stacked")``, the
default from ``rockjax.dem.STACKED_MIN_BLOCKS`` blocks up in a batch, from
``rockjax.dem.STACKED_MIN_BLOCKS_ONE`` in one history), for stacks of 0.23 x 0.077 m brick
courses. A script that prints tables, not a test (STYLE.md section 5).

    python benchmarks/bench_tall_walls.py                       # n = 2, 5, 10, 20, 50, 100
    python benchmarks/bench_tall_walls.py --sizes 3,4,5,6,8     # where the layouts cross
    python benchmarks/bench_tall_walls.py --old-max 50          # the unrolled one up to 50

For each stack and layout: the compile of one history (``jax.jit`` of ``rockjax.dem.run``)
split into trace, lower and XLA compile [s], and its first call (the compile and a first run);
the same for a ``jax.vmap`` batch of ``--batch`` records; the same for one history by the
default rule (``layout=None``: from ``STACKED_MIN_BLOCKS_ONE`` to
``rockjax.dem.SOLVE_UNROLLED_MAX_BLOCKS`` blocks the stacked layout with its solve written
out, which the two named layouts do not run); then the step cost per block, the
process CPU time of a warm call divided by steps x blocks [ns], the programs timed in
alternation (``--rounds`` rounds, minima: the machine may be shared), and for the batch also
its wall time (XLA:CPU may run a wide batch's operations on a second thread, which adds CPU
time). The unrolled layout compiles in a time that grows with the stack (minutes from 20
blocks up): it runs up to ``--old-max`` blocks. The persistent compilation cache is off
(``ROCKJAX_CACHE_DIR=off``).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

os.environ.setdefault("ROCKJAX_CACHE_DIR", "off")

try:
    import rockjax as rj
except ImportError:  # run from a checkout without installing
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    import rockjax as rj

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from _timing import load, machine  # noqa: E402

from rockjax import dem  # noqa: E402

BRICK = dict(b=0.23, h=0.077)
RECORD_DT = 0.01
LAYOUTS = ("unrolled", "stacked")
DEFAULT = "default"  # one history by the default rule (layout=None)


def setup(n: int, duration: float, batch: int):
    asm = rj.Assembly.stack([rj.Block(**BRICK)] * n)
    p = dem.dem_params(asm, 1e-3)
    st0 = dem.initial_state(asm, p)
    n_in = int(np.ceil(RECORD_DT / float(dem.default_step(p, dem.DT_ACCURACY["two_sided"]))))
    scales = np.linspace(0.5, 1.5, batch)
    gm = rj.GroundMotion.sine_cycle(pga=2.0, period=0.3, dt=RECORD_DT, duration=duration)
    ag = jnp.asarray(gm.ag)
    return p, st0, n_in, ag, jnp.asarray(scales[:, None] * np.asarray(gm.ag))


def programs(layout: str | None, n_in: int):
    """The one-history and the batch program of ``layout`` (None: the default rule; in one
    history a stacked stack of up to ``SOLVE_UNROLLED_MAX_BLOCKS`` blocks then writes its
    solve out)."""
    dt = RECORD_DT / n_in

    def one(p, st0, ag):
        z = jnp.zeros_like(ag)
        return dem.run(p, st0, ag, z, dt, RECORD_DT, n_in, one_history=True, layout=layout)

    def many(p, st0, ags):
        def run(ag):
            return dem.run(p, st0, ag, jnp.zeros_like(ag), dt, RECORD_DT, n_in, layout=layout)

        return jax.vmap(run)(ags)

    return jax.jit(one), jax.jit(many)


def compile_times(fn, *args):
    """(trace, lower, compile, first call) [s] and the compiled program."""
    t0 = time.perf_counter()
    traced = fn.trace(*args)
    t1 = time.perf_counter()
    lowered = traced.lower()
    t2 = time.perf_counter()
    compiled = lowered.compile()
    t3 = time.perf_counter()
    jax.block_until_ready(compiled(*args))
    t4 = time.perf_counter()
    return (t1 - t0, t2 - t1, t3 - t2, t4 - t0), compiled


def cpu_time(compiled, args) -> tuple[float, float]:
    """(process CPU time, wall time) of a call [s]."""
    t0, w0 = time.process_time(), time.perf_counter()
    jax.block_until_ready(compiled(*args))
    return time.process_time() - t0, time.perf_counter() - w0


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="2,5,10,20,50,100", help="blocks per stack")
    ap.add_argument("--old-max", type=int, default=20, help="largest unrolled stack")
    ap.add_argument("--batch", type=int, default=16, help="records in the vmap batch")
    ap.add_argument("--duration", type=float, default=0.3, help="record length [s]")
    ap.add_argument("--rounds", type=int, default=3, help="alternating timing rounds")
    args = ap.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",")]
    print(f"machine: {machine()}; load {load()}; jax {jax.__version__}, {jax.devices()[0]}")
    print(
        f"stacks of {BRICK['b']} x {BRICK['h']} m bricks, face law, beta 1e-3 s, a "
        f"{args.duration} s record; batch of {args.batch}; STACKED_MIN_BLOCKS = "
        f"{dem.STACKED_MIN_BLOCKS}, STACKED_MIN_BLOCKS_ONE = {dem.STACKED_MIN_BLOCKS_ONE}, "
        f"SOLVE_UNROLLED_MAX_BLOCKS = {dem.SOLVE_UNROLLED_MAX_BLOCKS}\n"
    )
    rows = []
    for n in sizes:
        p, st0, n_in, ag, ags = setup(n, args.duration, args.batch)
        steps = ag.shape[0] * n_in
        res = {}
        for layout in LAYOUTS:
            if layout == "unrolled" and n > args.old_max:
                continue
            one, many = programs(layout, n_in)
            c1, f1 = compile_times(one, p, st0, ag)
            cb, fb = compile_times(many, p, st0, ags)
            res[layout] = dict(one=c1, batch=cb, f1=f1, fb=fb, t1=[], tb=[])
            print(
                f"n={n:3d} {layout:8s} compile one {sum(c1[:3]):6.1f} s, batch "
                f"{sum(cb[:3]):6.1f} s",
                flush=True,
            )
        # one history by the default rule (layout=None), as the eager rj.simulate_dem runs it
        c1, f1 = compile_times(programs(None, n_in)[0], p, st0, ag)
        res[DEFAULT] = dict(one=c1, f1=f1, t1=[])
        print(f"n={n:3d} {DEFAULT:8s} compile one {sum(c1[:3]):6.1f} s", flush=True)
        for _ in range(args.rounds):
            for r in res.values():
                r["t1"].append(cpu_time(r["f1"], (p, st0, ag)))
                if "fb" in r:
                    r["tb"].append(cpu_time(r["fb"], (p, st0, ags)))
        for r in res.values():
            r["ns1"] = min(t[0] for t in r["t1"]) / (steps * n) * 1e9
            if "fb" in r:
                r["nsb"] = min(t[0] for t in r["tb"]) / (steps * n * args.batch) * 1e9
                r["wallb"] = min(t[1] for t in r["tb"]) / (steps * n * args.batch) * 1e9
        rows.append((n, n_in, res))

    def cell(res, key, fmt, idx=None):
        vals = []
        for layout in LAYOUTS:
            r = res.get(layout)
            v = None if r is None else (r[key] if idx is None else sum(r[key][:idx]))
            vals.append(v)
        old, new = vals
        ratio = "" if old is None else f" ({new / old:.2f})"
        return ("-" if old is None else fmt.format(old)) + " / " + fmt.format(new) + ratio

    print("\nunrolled / stacked (ratio stacked/unrolled); compile = trace + lower + XLA [s], step")
    print("cost per block = process CPU time / (steps x blocks) [ns] (and the batch's wall time),")
    print("minima over the rounds\n")
    print("| blocks | steps/sample | compile, one history [s] | compile, vmap batch [s] "
          "| ns per block-step, one | ns per block-step, batch (per record) "
          "| wall ns per block-step, batch |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    for n, n_in, res in rows:
        print(
            f"| {n} | {n_in} | {cell(res, 'one', '{:.1f}', 3)} | {cell(res, 'batch', '{:.1f}', 3)}"
            f" | {cell(res, 'ns1', '{:.0f}')} | {cell(res, 'nsb', '{:.0f}')}"
            f" | {cell(res, 'wallb', '{:.0f}')} |"
        )
    print("\none history by the default rule (layout=None, as the eager rj.simulate_dem runs it;")
    print("from STACKED_MIN_BLOCKS_ONE to SOLVE_UNROLLED_MAX_BLOCKS blocks: stacked, its solve")
    print("written out), against the unrolled step (ratio default / unrolled)\n")
    print("| blocks | compile [s] | ns per block-step |")
    print("|---|---|---|")
    for n, _, res in rows:
        d, u = res[DEFAULT], res.get("unrolled")
        ratio = "" if u is None else f" ({d['ns1'] / u['ns1']:.2f})"
        print(f"| {n} | {sum(d['one'][:3]):.1f} | {d['ns1']:.0f}{ratio} |")
    print("\nthe compile split, trace / lower / XLA, and the first call (compile and run) [s]\n")
    for n, _, res in rows:
        for layout, r in res.items():
            c1, cb = r["one"], r.get("batch")
            line = (
                f"n={n:3d} {layout:8s}: one {c1[0]:.1f} / {c1[1]:.1f} / {c1[2]:.1f}, first call "
                f"{c1[3]:.1f}"
            )
            if cb is not None:
                line += f"; batch {cb[0]:.1f} / {cb[1]:.1f} / {cb[2]:.1f}, first call {cb[3]:.1f}"
            print(line)


if __name__ == "__main__":
    main()
