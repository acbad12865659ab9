"""Benchmark ``rockjax.simulate_housner``: compile time, one record, and batched throughput.

Run: ``python benchmarks/bench_housner.py [--batches 64 256 1024] [--devices N]
[--max-impacts K] [--chunk C] [--no-grad] [--no-diffrax]`` (about a minute with the defaults on
2 cores).
Measured figures, before and after the Housner rest rule of docs/theory.md: docs/verification.md,
"Housner".

Records: 20 s at dt = 0.01 s of random-phase band-limited noise (0.5-5 Hz) under a
trapezoidal envelope, with a fixed PRNG key, scaled to PGA = 1-2 g tan(eta) so that every
record lifts the block and a good share rock to large amplitudes (the costly case; records
that stay at rest or overturn early are cheaper for the batch only if all do). The block is a
0.25 m x 1.5 m parapet (p = 3.1 rad/s, eta = 0.165 rad), so p dt = 0.03 and n_sub = 1.

``--devices N`` splits each batch over N host CPU devices (``jax.sharding``), to use N cores:
XLA runs one CPU computation on one core. It must be set before JAX starts, so this script
sets ``XLA_FLAGS`` itself.

``--max-impacts K`` passes ``max_impacts_per_step=K`` (default: the library's, 64; a step runs
passes only until every record of the batch has reached its end, so K is a cap, not a cost);
``--chunk C`` batches with ``lax.map(batch_size=C)`` over vmapped chunks instead of one vmap.
Compile times are those of ``jit(...).lower(...).compile()`` plus one run; a batch's "first
call" is trace, compile and one run.

"Through diffrax": the single record again with ``solver=diffrax.Tsit5()`` and
``diffrax.Dopri8()`` (``simulate_housner``'s diffrax path, default ``PIDController(rtol=1e-8,
atol=1e-10)``): compile, run, and its ``theta_max`` against the default loop's.

The script prints wall-clock times (median of ``--repeat`` runs) and the process CPU time.
"""

from __future__ import annotations

import argparse
import datetime
import os
import sys
import time


def _parse():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batches", type=int, nargs="+", default=[64, 256, 1024])
    ap.add_argument("--duration", type=float, default=20.0, help="record length [s]")
    ap.add_argument("--dt", type=float, default=0.01, help="record step [s]")
    ap.add_argument("--devices", type=int, default=1, help="host CPU devices to shard over")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument(
        "--max-impacts", type=int, default=None, help="simulate_housner's max_impacts_per_step"
    )
    ap.add_argument(
        "--chunk", type=int, default=0, help="batch through lax.map(batch_size=CHUNK) of vmap"
    )
    ap.add_argument("--no-grad", action="store_true", help="skip the grad timing")
    ap.add_argument("--no-diffrax", action="store_true", help="skip the diffrax path's timing")
    return ap.parse_args()


# Parsed only when run as a script: bench_peers.py imports `records` from this module.
ARGS = _parse() if __name__ == "__main__" else None
if ARGS is not None and ARGS.devices > 1:
    os.environ["XLA_FLAGS"] = (
        os.environ.get("XLA_FLAGS", "") + f" --xla_force_host_platform_device_count={ARGS.devices}"
    )

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import rockjax as rj  # noqa: E402
from rockjax.constants import G  # noqa: E402

rj.compilation.configure_cpu()  # XLA:CPU's option for the time loops, with the flags above


def records(key, n_rec: int, n: int, dt: float, eta: float, pga=(1.0, 2.0)) -> jax.Array:
    """``(n_rec, n)`` accelerations [m/s^2]: band-limited noise, enveloped, scaled to a PGA
    drawn uniformly in ``pga`` [units of g tan(eta)]."""
    k_noise, k_pga = jax.random.split(key)
    freqs = jnp.fft.rfftfreq(n, dt)
    band = ((freqs > 0.5) & (freqs < 5.0)).astype(float)
    phase = jax.random.uniform(k_noise, (n_rec, freqs.size), maxval=2 * jnp.pi)
    ag = jnp.fft.irfft(band[None, :] * jnp.exp(1j * phase), n, axis=-1)
    t = jnp.arange(n) * dt
    env = jnp.clip(jnp.minimum(t / 2.0, (t[-1] - t) / 6.0), 0.0, 1.0)
    ag = ag * env[None, :]
    pga = jax.random.uniform(k_pga, (n_rec, 1), minval=pga[0], maxval=pga[1]) * G * jnp.tan(eta)
    return ag / jnp.max(jnp.abs(ag), axis=-1, keepdims=True) * pga


SINGLE_PGA = 1.5  # [g tan(eta)]: this record rocks through its strong phase without overturning


def _time(fn, *args, repeat: int):
    walls, cpus = [], []
    for _ in range(repeat):
        w, c = time.perf_counter(), time.process_time()
        jax.block_until_ready(fn(*args))
        walls.append(time.perf_counter() - w)
        cpus.append(time.process_time() - c)
    return float(np.median(walls)), float(np.median(cpus))


def main() -> None:
    block = rj.Block(b=0.25, h=1.5)
    eta = float(block.eta)
    n = int(round(ARGS.duration / ARGS.dt)) + 1
    dt = ARGS.dt
    print(f"rockjax Housner benchmark  {datetime.datetime.now().isoformat(timespec='seconds')}")
    print(f"jax {jax.__version__}, devices: {jax.devices()}, python {sys.version.split()[0]}")
    print(f"load average at start: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(
        f"block b=0.25 m h=1.5 m: p={float(block.p):.3f} rad/s, eta={eta:.4f} rad; "
        f"records: {ARGS.duration:g} s at dt={dt} s ({n} samples)"
    )

    def one(ag):
        kw = {} if ARGS.max_impacts is None else dict(max_impacts_per_step=ARGS.max_impacts)
        r = rj.simulate_housner(block, rj.GroundMotion(ag=ag, dt=dt), throw=False, **kw)
        return r.theta_max, r.overturned, r.extras["n_impacts"][-1], r.status

    single = jax.jit(one)
    ag1 = records(jax.random.PRNGKey(0), 1, n, dt, eta, pga=(SINGLE_PGA, SINGLE_PGA))[0]
    w = time.perf_counter()
    theta_max, over, n_imp, _ = jax.block_until_ready(single.lower(ag1).compile()(ag1))
    compile_s = time.perf_counter() - w
    wall, cpu = _time(single, ag1, repeat=ARGS.repeat)
    print(
        f"single record: compile {compile_s:.2f} s; run {wall * 1e3:.1f} ms (cpu {cpu * 1e3:.1f} "
        f"ms); theta_max/eta {float(theta_max) / eta:.2f}, overturned {bool(over)}, "
        f"{int(n_imp)} impacts"
    )

    if not ARGS.no_diffrax:
        through_diffrax(block, ag1, dt, float(theta_max))

    def energy_at_end(scale):
        return rj.simulate_housner(block, rj.GroundMotion(ag=scale * ag1, dt=dt)).energy[-1]

    if not ARGS.no_grad:
        grad = jax.jit(jax.grad(energy_at_end))
        w = time.perf_counter()
        jax.block_until_ready(grad.lower(1.0).compile()(1.0))
        compile_s = time.perf_counter() - w
        wall, cpu = _time(grad, 1.0, repeat=ARGS.repeat)
        print(
            f"grad of that record's final energy: compile {compile_s:.2f} s; "
            f"run {wall * 1e3:.1f} ms"
        )

    batched = jax.jit(jax.vmap(one))
    if ARGS.chunk:
        batched = jax.jit(lambda a: jax.lax.map(one, a, batch_size=ARGS.chunk))
    if ARGS.devices > 1:
        # Each device runs jit(vmap) on its share of the records (shard_map keeps the batch
        # local, so the solver's batch-wide skips see only that device's records). check_vma
        # is off: the solver's lax.cond skips return the unchanged (possibly unsharded) state.
        mesh = jax.make_mesh((ARGS.devices,), ("rec",))
        spec = jax.sharding.PartitionSpec("rec")
        sharding = jax.sharding.NamedSharding(mesh, spec)
        batched = jax.jit(
            jax.shard_map(jax.vmap(one), mesh=mesh, in_specs=spec, out_specs=spec, check_vma=False)
        )
    for n_rec in ARGS.batches:
        ags = records(jax.random.PRNGKey(1), n_rec, n, dt, eta)
        if ARGS.devices > 1:
            ags = jax.device_put(ags, sharding)
        w = time.perf_counter()
        theta_max, over, n_imp, status = (
            np.asarray(x) for x in jax.block_until_ready(batched(ags))
        )
        first = time.perf_counter() - w
        wall, cpu = _time(batched, ags, repeat=ARGS.repeat)
        print(
            f"batch {n_rec:5d}: first call {first:6.2f} s, run {wall:6.3f} s "
            f"(cpu {cpu:6.3f} s) -> {n_rec / wall:7.1f} records/s; "
            f"overturned {np.mean(over):.0%}, median theta_max/eta "
            f"{np.median(theta_max) / eta:.2f}, mean impacts {np.mean(n_imp):.1f}, "
            f"status != 0: {np.count_nonzero(status)}"
        )
    print(f"load average at end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


def through_diffrax(block, ag, dt: float, theta_max_default: float) -> None:
    """The single record through ``simulate_housner(..., solver=...)``: compile and run times,
    and the peak against the default loop's ``theta_max_default`` [rad]."""
    import diffrax

    eta = float(block.eta)
    for name, solver in (("Tsit5", diffrax.Tsit5()), ("Dopri8", diffrax.Dopri8())):

        def one(ag, solver=solver):
            r = rj.simulate_housner(block, rj.GroundMotion(ag=ag, dt=dt), solver=solver)
            return r.theta_max, r.overturned, r.extras["n_impacts"][-1]

        single = jax.jit(one)
        w = time.perf_counter()
        theta_max, over, n_imp = jax.block_until_ready(single.lower(ag).compile()(ag))
        compile_s = time.perf_counter() - w
        wall, cpu = _time(single, ag, repeat=ARGS.repeat)
        print(
            f"through diffrax, {name}: compile {compile_s:.2f} s; run {wall * 1e3:.1f} ms (cpu "
            f"{cpu * 1e3:.1f} ms); theta_max/eta {float(theta_max) / eta:.4f} (default loop "
            f"{theta_max_default / eta:.4f}, relative gap "
            f"{abs(float(theta_max) / theta_max_default - 1):.1e}), {int(n_imp)} impacts"
        )


if __name__ == "__main__":
    main()
