"""Benchmark ``rockjax.ShearBuilding``: floor motions of a 3-storey building, against SciPy.

Run: ``python benchmarks/bench_building.py [--records 44] [--duration 20] [--dt 0.01]
[--repeat 5] [--no-ivp]`` (about 20 s on 2 cores; numbers in docs/building.md).

The building is ``ShearBuilding.uniform(3, 3.0, period=0.3, damping=0.05)``; the records are
band-limited noise (0.5-10 Hz) under a trapezoidal envelope, 20 s at dt = 0.01 s (2001
samples), PGA 3 m/s^2, from a fixed PRNG key. Timed: the absolute floor accelerations of one
record (``jit``) and of ``--records`` records at once (``jit(vmap)``); side by side
``scipy.signal.lsim`` on the same 6-state system (first-order hold, i.e. the same
piecewise-linear input and also exact, one record at a time) and ``scipy.integrate.solve_ivp``
(DOP853, rtol 1e-8, one call per record with the input interpolated; on the first record
only, scaled to the batch). The script prints each time, the peer / rockjax ratio and the
largest difference of the floor accelerations against lsim, relative to their peak.
"""

from __future__ import annotations

import argparse
import datetime
import os
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np
from scipy import integrate, signal

import rockjax as rj
from rockjax.building import ShearBuilding


def _parse():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--records", type=int, default=44, help="records of the batch")
    ap.add_argument("--duration", type=float, default=20.0, help="record length [s]")
    ap.add_argument("--dt", type=float, default=0.01, help="record step [s]")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--no-ivp", action="store_true", help="skip solve_ivp")
    return ap.parse_args()


def records(n_rec: int, n: int, dt: float) -> np.ndarray:
    """``(n_rec, n)`` accelerations [m/s^2]: band-limited noise, enveloped, PGA 3 m/s^2."""
    key_phase = jax.random.PRNGKey(0)
    freqs = np.fft.rfftfreq(n, dt)
    band = ((freqs > 0.5) & (freqs < 10.0)).astype(float)
    phase = np.asarray(jax.random.uniform(key_phase, (n_rec, freqs.size), maxval=2 * np.pi))
    ag = np.fft.irfft(band[None, :] * np.exp(1j * phase), n, axis=-1)
    t = np.arange(n) * dt
    env = np.clip(np.minimum(t / 2.0, (t[-1] - t) / 6.0), 0.0, 1.0)
    ag = ag * env[None, :]
    return 3.0 * ag / np.max(np.abs(ag), axis=-1, keepdims=True)


def _time(fn, *args, repeat: int) -> float:
    walls = []
    for _ in range(repeat):
        w = time.perf_counter()
        jax.block_until_ready(fn(*args))
        walls.append(time.perf_counter() - w)
    return float(np.median(walls))


def state_space(bldg: ShearBuilding):
    """``(A, B, C, D)`` of x = (u, v), input a_g, output the absolute floor accelerations;
    modal damping assembled from SciPy's modes (the reference needs its own C)."""
    from scipy import linalg

    m = np.asarray(bldg.masses)
    k = np.asarray(bldg.stiffnesses)
    n = m.size
    K = np.diag(k + np.append(k[1:], 0.0)) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    M = np.diag(m)
    lam, phi = linalg.eigh(K, M)
    w = np.sqrt(lam)
    C = M @ phi @ np.diag(2 * float(bldg.damping) * w) @ phi.T @ M
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]])
    B = np.concatenate([np.zeros(n), -np.ones(n)])[:, None]
    Cout = np.hstack([-Minv @ K, -Minv @ C])
    return A, B, Cout, np.zeros((n, 1))


def main() -> None:
    args = _parse()
    dt = args.dt
    n = int(round(args.duration / dt)) + 1
    print(f"rockjax building benchmark  {datetime.datetime.now().isoformat(timespec='seconds')}")
    print(f"jax {jax.__version__}, devices: {jax.devices()}, python {sys.version.split()[0]}")
    print(f"load average at start: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    bldg = ShearBuilding.uniform(3, 3.0, period=0.3, damping=0.05)
    print(
        f"building: 3 storeys, periods {np.round(np.asarray(bldg.periods), 4).tolist()} s, "
        f"modal damping 5 %; records: {args.duration:g} s at dt={dt} s ({n} samples)"
    )
    ags = records(args.records, n, dt)

    def floors(ag):
        return bldg.response(rj.GroundMotion(ag=ag, dt=dt)).acceleration

    single = jax.jit(floors)
    batched = jax.jit(jax.vmap(floors))
    w = time.perf_counter()
    acc1 = np.asarray(jax.block_until_ready(single(ags[0])))
    first_single = time.perf_counter() - w
    w = time.perf_counter()
    acc_all = np.asarray(jax.block_until_ready(batched(jnp.asarray(ags))))
    first_batch = time.perf_counter() - w
    t_single = _time(single, ags[0], repeat=args.repeat)
    t_batch = _time(batched, jnp.asarray(ags), repeat=args.repeat)
    t_api = _time(
        lambda: [f.ag for f in bldg.floor_motions(rj.GroundMotion(ags[0], dt))], repeat=args.repeat
    )

    A, B, C, D = state_space(bldg)
    system = signal.StateSpace(A, B, C, D)
    t = np.arange(n) * dt
    w = time.perf_counter()
    lsim_out = [signal.lsim(system, ag, t, interp=True)[1].T for ag in ags]
    t_lsim_batch = time.perf_counter() - w
    t_lsim = float(np.median([_timed_lsim(system, ags[0], t) for _ in range(args.repeat)]))
    diff = max(
        np.max(np.abs(acc_all[i] - lsim_out[i])) / np.max(np.abs(lsim_out[i]))
        for i in range(args.records)
    )
    diff1 = np.max(np.abs(acc1 - lsim_out[0])) / np.max(np.abs(lsim_out[0]))

    print(f"{'':34s} {'time':>12s} {'peer / rockjax':>15s}")
    print(
        f"{'rockjax jit, 1 record':34s} {t_single * 1e3:9.2f} ms {'':>15s}  (first call {first_single:.2f} s)"
    )
    print(f"{'rockjax floor_motions (API), 1 rec':34s} {t_api * 1e3:9.2f} ms")
    print(
        f"{f'rockjax jit(vmap), {args.records} records':34s} {t_batch * 1e3:9.2f} ms {'':>15s}  (first call {first_batch:.2f} s)"
    )
    print(f"{'scipy lsim, 1 record':34s} {t_lsim * 1e3:9.2f} ms {t_lsim / t_single:15.1f}")
    print(
        f"{f'scipy lsim, {args.records} records (loop)':34s} {t_lsim_batch * 1e3:9.2f} ms {t_lsim_batch / t_batch:15.1f}"
    )
    if not args.no_ivp:
        A_ = A

        def rhs(tt, x, ag):
            return A_ @ x + B[:, 0] * np.interp(tt, t, ag)

        w = time.perf_counter()
        sol = integrate.solve_ivp(
            rhs, (0.0, t[-1]), np.zeros(6), method="DOP853", t_eval=t, rtol=1e-8, atol=1e-12,
            args=(ags[0],),
        )  # fmt: skip
        t_ivp = time.perf_counter() - w
        acc_ivp = C @ sol.y
        diff_ivp = np.max(np.abs(acc1 - acc_ivp)) / np.max(np.abs(acc_ivp))
        print(
            f"{'scipy solve_ivp DOP853, 1 record':34s} {t_ivp * 1e3:9.2f} ms {t_ivp / t_single:15.1f}"
        )
        print(
            f"{f'solve_ivp, {args.records} records (x{args.records})':34s} "
            f"{t_ivp * args.records * 1e3:9.2f} ms {t_ivp * args.records / t_batch:15.1f}"
        )
        print(f"max |rockjax - solve_ivp| / peak, record 0: {diff_ivp:.1e}")
    print(f"max |rockjax - lsim| / peak: record 0 {diff1:.1e}, all records {diff:.1e}")
    print(f"load average at end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


def _timed_lsim(system, ag, t) -> float:
    w = time.perf_counter()
    signal.lsim(system, ag, t, interp=True)
    return time.perf_counter() - w


if __name__ == "__main__":
    main()
