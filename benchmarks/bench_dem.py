"""Benchmarks of the DEM model (``rockjax.simulate_dem``): compile time, one 20 s history and
batched throughput. A script that prints tables, not a test (STYLE.md section 5).

    python benchmarks/bench_dem.py            # full: also the XLA-flag, 2-device, layout,
                                              # chunking and one-core comparisons (~1.5-2 min)
    python benchmarks/bench_dem.py --quick    # compile, histories, batched vmap (< 40 s)
    python benchmarks/bench_dem.py --contact  # only one 20 s history per contact law:
                                              # n_sub 2, 12 and "exact" (the face law)

Every time is the median of repeated calls after a warm-up call, each ended by
``jax.block_until_ready``; the minimum is printed beside it because the machine may be shared
(the load average is printed at the start and the end). The comparisons that need different
XLA settings run in subprocesses of this script (``--worker``), because XLA reads its flags
once, when its CPU backend starts. Results and their reading: docs/benchmarks.md, "## DEM".

The step is the default one, ``rj.stable_dt(block, beta)``: chosen for accuracy
(``accuracy / (omega_max (1 + zeta))``, docs/theory.md "Time stepping"), so the steps per record
sample printed below follow that rule. To time an older version of rockjax with this script,
put it first on ``PYTHONPATH``.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import re
import subprocess
import sys
import time

# XLA_FLAGS as given, before rockjax adds its option: the subprocesses start from these
XLA_FLAGS_GIVEN = os.environ.get("XLA_FLAGS", "")

if __name__ == "__main__" and "--worker" in sys.argv and "--one-core" in sys.argv:
    # before XLA starts its thread pool: every thread it makes inherits this affinity
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})

try:
    import rockjax as rj
except ImportError:  # run from a checkout without installing
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    import rockjax as rj

# rockjax's XLA:CPU option, before the backend starts, with any XLA_FLAGS (a worker's device
# count too); none in the workers run with ROCKJAX_NO_XLA_TUNING=1
rj.compilation.configure_cpu()

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
from _timing import machine, timed  # noqa: E402

RECORD_DT = 0.01  # [s] record sampling step
HISTORY_S = 20.0  # [s] one history
BLOCKS = {"0.25x3": (0.25, 3.0), "0.2x1.5": (0.2, 1.5)}
BATCH_BLOCK = "0.25x3"
TARGET_HISTORY_S = 5e-3  # one 20 s history
TARGET_THROUGHPUT = 5e7  # block-steps/s, batch >= 1024
TARGET_MIN_BATCH = 1024


# ----------------------------------------------------------------------------- helpers


def ricker(duration: float) -> rj.GroundMotion:
    return rj.GroundMotion.ricker(pga=3.0, period=0.5, dt=RECORD_DT, duration=duration)


def block_and_beta(name: str):
    b, h = BLOCKS[name]
    block = rj.Block(b=b, h=h)
    return block, float(rj.beta_dejong(block))


def first_call(fn):
    t0 = time.perf_counter()
    jax.block_until_ready(fn())
    return time.perf_counter() - t0


def substeps(block, beta) -> int:
    """DEM steps per record sample (the step ``simulate_dem`` picks: dt_out / n_in)."""
    r = rj.simulate_dem(block, ricker(0.05), beta=beta, dt=rj.stable_dt(block, beta))
    return round(RECORD_DT / float(r.extras["dt"]))


def amplitude_batch(block, beta, dt, ag):
    """The function to batch: ``theta_max`` of one run on the record ``ag`` scaled by ``scale``."""

    def one(scale):
        motion = rj.GroundMotion(ag=scale * ag, dt=RECORD_DT)
        return rj.simulate_dem(block, motion, beta=beta, dt=dt, throw=False).theta_max

    return one


def loop_stats(hlo: str) -> list[dict]:
    """Per while loop of a compiled HLO module: trip count, fusions and arithmetic ops in one
    iteration of its body (nested loops not included), and the first arrays of its carry."""
    comps, cur = {}, None
    for line in hlo.splitlines():
        m = re.match(r"^(?:ENTRY )?%(\S+) ", line)
        if m and line.rstrip().endswith("{"):
            cur = comps.setdefault(m.group(1), [])
        elif cur is not None:
            cur.append(line)
    arith = re.compile(
        r"= \S+ (multiply|add|subtract|divide|select|compare|maximum|minimum|negate|abs|and|or|not)\("
    )
    loops = []
    for lines in comps.values():
        for line in lines:
            m = re.search(r" while\(.*body=%([^,\s]+)", line)
            trip = re.search(r'"known_trip_count":\{"n":"(\d+)"\}', line)
            if not (m and trip):
                continue
            body = comps[m.group(1)]
            fusions = [
                re.search(r"calls=%([^,\s]+)", x) for x in body if re.search(r"= \S+ fusion\(", x)
            ]
            ops = sum(1 for f in fusions for x in comps.get(f.group(1), []) if arith.search(x))
            carry = re.search(r"= \((.*?)\) while\(", line)
            arrays = re.findall(
                r"(?:f64|s64|pred)\[[0-9,]*\]\{[0-9,]*\}", carry.group(1) if carry else ""
            )
            loops.append(
                {
                    "trip": int(trip.group(1)),
                    "fusions": len(fusions),
                    "arith_ops": ops,
                    "carry": [a for a in arrays if "[]" not in a][:2],
                }
            )
    return sorted(loops, key=lambda d: d["trip"])


# ----------------------------------------------------------------------------- sections


def bench_compile() -> list[dict]:
    """First call minus the next calls, in a process where nothing ran before."""
    block, beta = block_and_beta(BATCH_BLOCK)
    rec = ricker(HISTORY_S)
    t1 = first_call(lambda: rj.stable_dt(block, beta))
    t2, _ = timed(lambda: rj.stable_dt(block, beta), 5)
    rows = [{"entry": "rj.stable_dt(block, beta)", "first": t1, "next": t2}]
    t1 = first_call(lambda: rj.simulate_dem(block, rec, beta=beta).theta)
    t2, _ = timed(lambda: rj.simulate_dem(block, rec, beta=beta).theta, 3)
    rows.append(
        {"entry": "rj.simulate_dem(block, 20 s record, beta=beta)", "first": t1, "next": t2}
    )
    dt = rj.stable_dt(block, beta)
    one = amplitude_batch(block, beta, dt, jnp.asarray(rec.ag))
    t0 = time.perf_counter()
    lowered = jax.jit(one).lower(1.0)
    t1 = time.perf_counter()
    lowered.compile()
    t2 = time.perf_counter()
    rows.append(
        {"entry": "jit(simulate_dem, dt fixed): trace + lower", "first": t1 - t0, "next": 0.0}
    )
    rows.append(
        {"entry": "jit(simulate_dem, dt fixed): XLA compile", "first": t2 - t1, "next": 0.0}
    )
    return rows


def bench_history(repeats: int) -> list[dict]:
    rec = ricker(HISTORY_S)
    ag = jnp.asarray(rec.ag)
    rows = []
    for name in BLOCKS:
        block, beta = block_and_beta(name)
        dt = rj.stable_dt(block, beta)
        steps = rec.n * substeps(block, beta)
        f = jax.jit(amplitude_batch(block, beta, dt, ag))
        # the block's numbers as data, as the eager call passes them to its compiled program
        data = jax.tree.map(jnp.asarray, block)
        g = jax.jit(
            lambda blk: (
                rj.simulate_dem(
                    blk, rj.GroundMotion(ag=ag, dt=RECORD_DT), beta=beta, dt=dt, throw=False
                ).theta_max
            )
        )
        for how, fn in (
            (
                "rj.simulate_dem(block, rec, beta=beta)",
                lambda: rj.simulate_dem(block, rec, beta=beta).theta,
            ),
            ("jit(simulate_dem), block+dt closed over", lambda: f(1.0)),
            ("jit(simulate_dem), block as data", lambda: g(data)),
        ):
            med, best = timed(fn, repeats)
            rows.append(
                {"block": name, "how": how, "beta": beta, "steps": steps, "med": med, "min": best}
            )
    return rows


def bench_contact(repeats: int) -> list[dict]:
    """One 20 s history per block and contact law (``n_sub`` 2, 12, ``"exact"``), each at its
    own default step, jitted with the block and step closed over."""
    rec = ricker(HISTORY_S)
    ag = jnp.asarray(rec.ag)
    rows = []
    for name in BLOCKS:
        block, beta = block_and_beta(name)
        for n_sub in (2, 12, "exact"):
            joint = rj.Joint(n_sub=n_sub)
            dt = rj.stable_dt(block, beta, joint=joint)

            def one(scale, dt=dt, joint=joint):
                motion = rj.GroundMotion(ag=scale * ag, dt=RECORD_DT)
                return rj.simulate_dem(block, motion, beta=beta, dt=dt, joint=joint).theta_max

            f = jax.jit(one)
            r = rj.simulate_dem(block, ricker(0.05), beta=beta, dt=dt, joint=joint)
            steps = rec.n * round(RECORD_DT / float(r.extras["dt"]))
            med, best = timed(lambda: f(1.0), repeats)
            rows.append({"block": name, "n_sub": n_sub, "steps": steps, "med": med, "min": best})
    return rows


def bench_batched(batches, record_s: float, mode: str = "vmap", chunk: int = 256) -> list[dict]:
    """Block-steps/s of ``simulate_dem`` batched over the amplitude of one record.

    mode: ``vmap``; ``chunked`` (``lax.map(..., batch_size=chunk)`` over a vmapped chunk);
    ``records-batch-first`` / ``records-time-major`` (vmap over a ``(B, T)`` / ``(T, B)`` array
    of records); ``shard_map`` / ``shard_map-chunked`` (the batch split over all local
    devices, then vmap / chunked on each).
    """
    block, beta = block_and_beta(BATCH_BLOCK)
    rec = ricker(record_s)
    ag = jnp.asarray(rec.ag)
    dt = rj.stable_dt(block, beta)
    steps = rec.n * substeps(block, beta)
    one = amplitude_batch(block, beta, dt, ag)

    def one_record(a):
        return rj.simulate_dem(
            block, rj.GroundMotion(ag=a, dt=RECORD_DT), beta=beta, dt=dt, throw=False
        ).theta_max

    rows = []
    for n in batches:
        scale = jnp.linspace(0.5, 1.5, n)
        if mode == "vmap":
            f, x = jax.jit(jax.vmap(one)), scale
        elif mode == "chunked":
            f, x = jax.jit(lambda s: jax.lax.map(one, s, batch_size=min(chunk, n))), scale
        elif mode == "records-batch-first":
            f, x = jax.jit(jax.vmap(one_record)), scale[:, None] * ag[None, :]
        elif mode == "records-time-major":
            f, x = jax.jit(jax.vmap(one_record, in_axes=1)), ag[:, None] * scale[None, :]
        elif mode in ("shard_map", "shard_map-chunked"):
            from jax.sharding import NamedSharding, PartitionSpec

            mesh = jax.make_mesh((len(jax.devices()),), ("batch",))
            spec = PartitionSpec("batch")
            if mode == "shard_map":
                local = jax.vmap(one)
            else:
                local = lambda s: jax.lax.map(one, s, batch_size=min(chunk, s.shape[0]))  # noqa: E731
            # check_vma=False: simulate_dem's scan carries start unvarying (docs/benchmarks.md)
            f = jax.jit(
                jax.shard_map(local, mesh=mesh, in_specs=spec, out_specs=spec, check_vma=False)
            )
            x = jax.device_put(scale, NamedSharding(mesh, spec))
        else:
            raise ValueError(mode)
        x = jax.block_until_ready(x)
        compile_s = first_call(lambda: f(x))
        repeats = 5 if n * steps <= 2e7 else 3
        med, best = timed(lambda: f(x), repeats)
        rows.append(
            {
                "mode": mode,
                "batch": n,
                "steps": steps,
                "compile": compile_s,
                "med": med,
                "min": best,
                "rate": n * steps / med,
                "rate_best": n * steps / best,
            }
        )
    return rows


def hlo_stats(record_s: float, batches=(1, 1024)) -> list[dict]:
    block, beta = block_and_beta(BATCH_BLOCK)
    rec = ricker(record_s)
    dt = rj.stable_dt(block, beta)
    n_in = substeps(block, beta)
    one = amplitude_batch(block, beta, dt, jnp.asarray(rec.ag))
    rows = []
    for n in batches:
        f = jax.jit(one) if n == 1 else jax.jit(jax.vmap(one))
        hlo = f.lower(jnp.ones(()) if n == 1 else jnp.ones(n)).compile().as_text()
        rows.append({"batch": n, "n_in": n_in, "loops": loop_stats(hlo)})
    return rows


# ----------------------------------------------------------------------------- workers


def worker(task: str, record_s: float, batches: list[int]) -> None:
    if task == "history":
        out = bench_history(5)
    elif task == "devices":
        out = bench_batched(batches, record_s, "vmap")
        out += bench_batched(batches, record_s, "shard_map")
        out += bench_batched(batches[-1:], record_s, "shard_map-chunked")
    else:
        out = bench_batched(batches, record_s, task)
    for row in out:
        row["devices"] = len(jax.devices())
        row["affinity"] = len(os.sched_getaffinity(0))
        row["xla_flags"] = os.environ.get("XLA_FLAGS", "")
        print("@@" + json.dumps(row), flush=True)


def run_worker(task: str, record_s: float, batches, env_extra: dict, one_core=False) -> list[dict]:
    env = dict(os.environ, XLA_FLAGS=XLA_FLAGS_GIVEN)
    env.update(env_extra)
    cmd = [sys.executable, os.path.abspath(__file__), "--worker", task, "--record-s", str(record_s)]
    cmd += ["--batches", ",".join(map(str, batches))] + (["--one-core"] if one_core else [])
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        print(f"  worker {task} {env_extra} failed:\n{proc.stderr[-2000:]}")
        return []
    return [json.loads(line[2:]) for line in proc.stdout.splitlines() if line.startswith("@@")]


# ----------------------------------------------------------------------------- printing


def ratio(measured, target, higher_is_better: bool) -> str:
    r = measured / target if higher_is_better else target / measured
    return f"{r:6.2f} {'ok' if r >= 1 else 'MISS'}"


def print_batched(title: str, rows: list[dict]) -> None:
    print(f"\n{title}")
    if rows and "xla_flags" in rows[0]:
        r = rows[0]
        print(
            f"  [subprocess: XLA_FLAGS={r['xla_flags']!r}, {r['devices']} device(s), {r['affinity']} core(s)]"
        )
    print(
        f"  {'mode':<22}{'batch':>6}{'compile s':>10}{'median ms':>11}{'min ms':>9}"
        f"{'block-steps/s':>15}{'(best)':>10}   ratio vs 5e7"
    )
    for r in rows:
        tgt = (
            ratio(r["rate"], TARGET_THROUGHPUT, True)
            if r["batch"] >= TARGET_MIN_BATCH
            else "     -"
        )
        print(
            f"  {r['mode']:<22}{r['batch']:>6}{r['compile']:>10.2f}{r['med'] * 1e3:>11.1f}"
            f"{r['min'] * 1e3:>9.1f}{r['rate']:>15.3g}{r['rate_best']:>10.3g}   {tgt}"
        )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="compile, histories and plain vmap only")
    p.add_argument(
        "--contact", action="store_true", help="only the contact laws: n_sub 2, 12, 'exact'"
    )
    p.add_argument("--worker", help=argparse.SUPPRESS)
    p.add_argument("--record-s", type=float, default=2.0, help=argparse.SUPPRESS)
    p.add_argument("--batches", default="1024", help=argparse.SUPPRESS)
    p.add_argument("--one-core", action="store_true", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.worker:
        worker(args.worker, args.record_s, [int(b) for b in args.batches.split(",") if b])
        return

    t_start = time.perf_counter()
    if args.contact:
        print(
            f"One {HISTORY_S:g} s history (Ricker pga 3 m/s^2), beta = beta_dejong(block), the "
            f"default step of each contact law, jit; median of 7. {machine()}"
        )
        print(f"  {'block':<8}{'n_sub':>7}{'steps':>8}{'median ms':>11}{'min ms':>9}{'ns/step':>9}")
        for r in bench_contact(7):
            print(
                f"  {r['block']:<8}{r['n_sub']!s:>7}{r['steps']:>8}{r['med'] * 1e3:>11.2f}"
                f"{r['min'] * 1e3:>9.2f}{r['med'] / r['steps'] * 1e9:>9.0f}"
            )
        return
    record_s = 1.0 if args.quick else 2.0
    batches = [1, 64, 1024, 8192]
    print(
        f"rockjax DEM benchmarks{' (--quick)' if args.quick else ''}  "
        f"{datetime.datetime.now().isoformat(timespec='seconds')}"
    )
    print(
        f"  machine: {machine()}; python {platform.python_version()}, jax {jax.__version__}, "
        f"backend {jax.default_backend()}, devices {len(jax.devices())}"
    )
    print(f"  XLA_FLAGS={os.environ.get('XLA_FLAGS', '')!r}")
    print(
        f"  load average at start: {' '.join(f'{x:.2f}' for x in os.getloadavg())} (1, 5, 15 min)"
    )

    print("\n1. Compile time (first call minus the next calls, fresh process)")
    for r in bench_compile():
        nxt = f"{r['next'] * 1e3:9.2f}" if r["next"] else "        -"
        print(
            f"  {r['entry']:<50}{r['first'] - r['next']:>8.3f} s   (first {r['first']:.3f} s, next ms {nxt})"
        )

    print(
        f"\n2. One {HISTORY_S:g} s history (Ricker pga 3 m/s^2, T 0.5 s, record dt {RECORD_DT} s), "
        f"beta = beta_dejong(block), dt = stable_dt (the default); median of 7"
    )
    print(
        f"  {'block':<8}{'how':<42}{'steps':>8}{'median ms':>11}{'min ms':>9}{'ns/step':>9}   ratio vs 5 ms"
    )
    for r in bench_history(7):
        print(
            f"  {r['block']:<8}{r['how']:<42}{r['steps']:>8}{r['med'] * 1e3:>11.2f}{r['min'] * 1e3:>9.2f}"
            f"{r['med'] / r['steps'] * 1e9:>9.0f}   {ratio(r['med'], TARGET_HISTORY_S, False)}"
        )

    title = (
        f"3. Batched throughput, block {BATCH_BLOCK}, vmap over the amplitude of a {record_s:g} s "
        f"record (f64; block-steps/s from the median)"
    )
    print_batched(title, bench_batched(batches, record_s, "vmap"))

    print(
        "\n4. Compiled HLO (block-sweep function of 3): per while loop, fusions and arithmetic ops in one"
    )
    print(
        "   iteration (the inner loop runs n_in - 1 DEM steps per record sample, the outer one 1 step"
    )
    print(
        "   plus the sample's bookkeeping), and the first non-scalar arrays it carries (shape{layout})"
    )
    for r in hlo_stats(record_s):
        for loop in r["loops"]:
            print(
                f"  batch {r['batch']:>5}  loop x{loop['trip']:<5} {loop['fusions']:>3} fusions {loop['arith_ops']:>5} "
                f"arithmetic ops   carry {', '.join(loop['carry'])}"
            )

    if not args.quick:
        print_batched(
            "5a. Chunked: lax.map(batch_size=256) over vmapped chunks",
            bench_batched([8192], record_s, "chunked"),
        )
        rows = bench_batched([1024], record_s, "records-batch-first")
        rows += bench_batched([1024], record_s, "records-time-major")
        print_batched(
            "5b. Record layout: vmap over a (B, T) array (in_axes=0) or a (T, B) array (in_axes=1)",
            rows,
        )
        rows = run_worker("vmap", record_s, [1, 64, 1024, 8192], {"ROCKJAX_NO_XLA_TUNING": "1"})
        print_batched(
            "5c. Without the small-while-loop flag (subprocess, ROCKJAX_NO_XLA_TUNING=1)", rows
        )
        rows = run_worker("history", record_s, [], {"ROCKJAX_NO_XLA_TUNING": "1"})
        print("  one 20 s history without the flag:")
        for r in rows:
            print(
                f"    {r['block']:<8}{r['how']:<42}{r['med'] * 1e3:>8.2f} ms  {r['med'] / r['steps'] * 1e9:>6.0f} ns/step"
            )
        env = {"XLA_FLAGS": f"{XLA_FLAGS_GIVEN} --xla_force_host_platform_device_count=2".strip()}
        rows = run_worker("devices", record_s, [1024, 8192], env)
        print_batched(
            "5d. Two host devices (subprocess, --xla_force_host_platform_device_count=2): "
            "vmap on device 0 vs shard_map over both (chunked: lax.map(batch_size=256) per device)",
            rows,
        )
        rows = run_worker("vmap", record_s, [1024], {}, one_core=True)
        print_batched("5e. Pinned to one core (subprocess, sched_setaffinity)", rows)

    print(
        f"\n  load average at end: {' '.join(f'{x:.2f}' for x in os.getloadavg())} (1, 5, 15 min); total {time.perf_counter() - t_start:.0f} s"
    )


if __name__ == "__main__":
    main()
