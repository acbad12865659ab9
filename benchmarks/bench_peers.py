"""rockjax against its peers, side by side in one run, as ratios (peer time / rockjax time).

    python benchmarks/bench_peers.py            # all cases (~2 min on 2 cores)
    python benchmarks/bench_peers.py --quick    # fewer peer records, no diffrax (~1 min)

Peers, each written here independently of rockjax from the model equations:

* Housner (two-sided, 0.25 m x 1.5 m parapet, 20 s records at dt = 0.01 s from
  ``bench_housner.records``): ``scipy.integrate.solve_ivp`` (RK45, and DOP853 for the one
  record; rtol 1e-9, atol 1e-12) with terminal events, the usual way: integrate one flight on
  pivot ``s`` of ``theta_ddot = -p^2 [sin(s eta - theta) + (a_g/g) cos(s eta - theta)]``
  (``a_g`` linear between samples), stop at ``s theta = 0`` (impact: ``theta_dot -> e
  theta_dot``, ``s -> -s``, restart) or at ``s theta = eta`` (overturned); a non-terminal
  event at ``theta_dot = 0`` records the peaks. From rest, the record samples are searched for
  ``|a_g| > g tan(eta)`` and the uplift time is the threshold crossing of the linear record in
  that interval. An impact whose rebound is below ``p^2 sin(eta) dt`` puts the block to rest,
  as in rockjax. For a batch, scipy (RK45, the faster of the two here) loops over the records:
  timed on the first ``--scipy-records`` of the batch, reported per record and scaled to the
  batch (printed as such).
  Optional (not with ``--quick``): the restart-per-impact diffrax prototype, one
  ``diffeqsolve`` (Tsit5, PID rtol 1e-9, an ``Event`` with Newton root-finding) per flight
  inside a ``lax.while_loop`` over flights, ``jit`` and ``vmap`` (timed on the first
  ``--diffrax-records`` of the batch, scaled likewise).
* DEM (0.25 m x 3 m parapet, ``beta = beta_dejong``, ``dt`` from ``rj.stable_dt`` rounded
  down to divide the record step, a Ricker pulse of PGA 3 m/s^2, T = 0.5 s): the same explicit
  step in plain Python/NumPy (two corner sub-contacts, ``k_n = j_kn A``, incremental shear
  with Mohr-Coulomb, dashpot ``beta k`` on closed contacts, central differences with the
  damping from the lagged half-step velocity, linear record between samples, freeze on
  overturning). One history: a Python loop over steps on Python floats; a batch: the same
  code on NumPy arrays (a Python loop over steps, NumPy over the batch).

Each case checks that rockjax and the peer agree (printed in the table). Times are medians
of repeated calls after a warm-up call (``jax.block_until_ready`` for rockjax); compile
times are printed apart and are not in the ratios. Results: docs/benchmarks.md, "## Peers".
"""

from __future__ import annotations

import argparse
import datetime
import math
import os
import platform
import sys
import time

try:
    import rockjax as rj
except ImportError:  # run from a checkout without installing
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    import rockjax as rj

rj.compilation.configure_cpu()  # before the backend starts; the JAX peers run with it too

import diffrax  # noqa: E402
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import optimistix as optx  # noqa: E402
from _timing import timed  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

from rockjax.constants import G  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_housner import SINGLE_PGA, records  # noqa: E402

RECORD_DT = 0.01  # [s]
DURATION = 20.0  # [s]
N_SAMPLES = int(round(DURATION / RECORD_DT)) + 1
HOUSNER_BLOCK = (0.25, 1.5)  # b, h [m] (bench_housner.py)
HOUSNER_BATCH = 256
DEM_BLOCK = (0.25, 3.0)  # b, h [m] (bench_dem.py)
DEM_BATCH = 1024
DEM_BATCH_RECORD_S = 2.0  # [s] record of the batched DEM case (bench_dem.py section 3)


# ============================================================================ Housner: scipy


def housner_scipy(ag, dt, *, p, eta, e, rest_thr, method="RK45", rtol=1e-9, atol=1e-12):
    """Two-sided Housner rocking under the record ``ag`` [m/s^2] (linear between samples), from
    rest, with ``solve_ivp`` and terminal events (one solve per flight).

    Returns a dict: ``theta_max`` [rad] (max |theta| over the peaks found by the
    ``theta_dot = 0`` event and the impact/stop states), ``overturned``, ``impacts`` (times [s]).
    """
    ag = [float(a) for a in np.asarray(ag, float)]
    n = len(ag)
    slope = [(ag[k + 1] - ag[k]) / dt for k in range(n - 1)] + [0.0]
    t_end = (n - 1) * dt
    p2, inv_g, inv_dt = p * p, 1.0 / G, 1.0 / dt
    thr = G * math.tan(eta)
    abs_ag = np.abs(np.asarray(ag))
    sin, cos = math.sin, math.cos

    t, th, thd, s = 0.0, 0.0, 0.0, 0
    impacts, theta_max, overturned = [], 0.0, False

    while t < t_end:
        if s == 0:  # at rest: uplift when |a_g| first exceeds g tan(eta)
            k0 = min(int(t * inv_dt + 1e-9), n - 2)
            a_t = ag[k0] + (t - k0 * dt) * slope[k0]
            if abs(a_t) > thr:
                t_up, sg = t, (1.0 if a_t > 0 else -1.0)
            else:
                hits = np.flatnonzero(abs_ag[k0 + 1 :] > thr)
                if hits.size == 0:
                    break
                j = k0 + 1 + int(hits[0])
                sg = 1.0 if ag[j] > 0 else -1.0
                fa, fb = sg * ag[j - 1] - thr, sg * ag[j] - thr
                t_up = max(t, (j - 1) * dt + dt * (-fa) / (fb - fa))
            t, th, thd, s = t_up, 0.0, 0.0, -int(sg)  # a_g > 0 drives theta negative

        s_eta = s * eta

        def rhs(tt, y, s_eta=s_eta):
            k = int(tt * inv_dt)
            if k > n - 2:
                k = n - 2
            a = ag[k] + (tt - k * dt) * slope[k]
            phi = s_eta - y[0]
            return [y[1], -p2 * (sin(phi) + a * inv_g * cos(phi))]

        def impact(tt, y, s=s):
            return s * y[0]

        impact.terminal, impact.direction = True, -1

        def over(tt, y, s=s):
            return s * y[0] - eta

        over.terminal, over.direction = True, 1

        def peak(tt, y):
            return y[1]

        sol = solve_ivp(
            rhs,
            (t, t_end),
            [th, thd],
            method=method,
            rtol=rtol,
            atol=atol,
            events=[impact, over, peak],
        )
        if sol.y_events[2].size:
            theta_max = max(theta_max, float(np.max(np.abs(sol.y_events[2][:, 0]))))
        theta_max = max(theta_max, abs(float(sol.y[0, -1])))
        if sol.t_events[1].size:
            overturned = True
            break
        if sol.t_events[0].size:
            t = float(sol.t_events[0][0])
            thd = e * float(sol.y_events[0][0, 1])
            impacts.append(t)
            th, s = 0.0, -s
            if abs(thd) < rest_thr:
                thd, s = 0.0, 0
            continue
        break  # reached the end of the record
    return {"theta_max": theta_max, "overturned": overturned, "impacts": impacts}


def rockjax_impact_times(n_impacts, t_last, k_max: int) -> dict[int, float]:
    """Impact index -> time [s] from rockjax's per-sample ``n_impacts`` / ``t_last_impact``
    (only impacts alone in their sample step, whose time ``t_last_impact`` then holds)."""
    n_impacts, t_last = np.asarray(n_impacts), np.asarray(t_last)
    out, prev = {}, 0
    for k in range(n_impacts.size):
        if n_impacts[k] == prev + 1 and prev < k_max:
            out[prev] = float(t_last[k])
        prev = int(n_impacts[k])
        if prev >= k_max:
            break
    return out


# ============================================================================ Housner: diffrax


def make_diffrax_restart(block, e, rest_thr, n: int, dt: float, k_imp: int, max_flights: int):
    """The restart-per-impact prototype: one ``diffeqsolve`` with an ``Event`` per flight, in a
    ``lax.while_loop`` over flights. Returns ``f(ag) -> (overturned, n_impacts, first k_imp
    impact times)``, to be wrapped in ``jit`` / ``jit(vmap)``."""
    eta = float(block.eta)
    p2_over_g = float(block.p) ** 2 / G
    thr = G * math.tan(eta)
    t_end = (n - 1) * dt
    ts = jnp.arange(n) * dt

    def vf(t, y, args):
        interp, s = args
        th, thd = y
        phi = s * eta - th
        return thd, -p2_over_g * (G * jnp.sin(phi) + interp.evaluate(t) * jnp.cos(phi))

    event = diffrax.Event(
        cond_fn=(
            lambda t, y, args, **kw: args[1] * y[0],
            lambda t, y, args, **kw: args[1] * y[0] - eta,
        ),
        root_finder=optx.Newton(rtol=1e-12, atol=1e-12),
        direction=(False, True),
    )
    term = diffrax.ODETerm(vf)
    solver = diffrax.Tsit5()
    controller = diffrax.PIDController(rtol=1e-9, atol=1e-12)

    def run(ag):
        interp = diffrax.LinearInterpolation(ts=ts, ys=ag)
        idx = jnp.arange(n)

        def uplift(t):
            """First time >= t the linear record exceeds g tan(eta), its pivot, and whether."""
            k0 = jnp.minimum(jnp.floor(t / dt + 1e-9).astype(int), n - 2)
            a_t = interp.evaluate(t)
            hit = (idx > k0) & (jnp.abs(ag) > thr)
            j = jnp.argmax(hit)
            sg = jnp.sign(ag[j])
            fa, fb = sg * ag[j - 1] - thr, sg * ag[j] - thr
            t_cross = jnp.maximum(t, (j - 1) * dt + dt * (-fa) / (fb - fa))
            now = jnp.abs(a_t) > thr
            return (
                jnp.where(now, t, t_cross),
                jnp.where(now, -jnp.sign(a_t), -sg),
                now | jnp.any(hit),
            )

        def body(c):
            t, th, thd, s, n_imp, times, over, done, k = c
            t_up, s_up, lifts = uplift(t)
            rest = s == 0
            t0 = jnp.where(rest, t_up, t)
            s0 = jnp.where(rest, s_up, s)
            done = done | (rest & ~lifts)
            # finished records take a trivial solve (the batch runs until every record is done)
            t0 = jnp.where(done, t_end - 1e-6, jnp.minimum(t0, t_end - 1e-6))
            sol = diffrax.diffeqsolve(
                term,
                solver,
                t0=t0,
                t1=t_end,
                dt0=None,
                y0=(th, thd),
                args=(interp, s0),
                event=event,
                stepsize_controller=controller,
                saveat=diffrax.SaveAt(t1=True),
                max_steps=100_000,
                adjoint=diffrax.ForwardMode(),
                throw=False,
            )
            t1 = sol.ts[-1]
            th1, thd1 = sol.ys[0][-1], sol.ys[1][-1]
            hit_imp, hit_over = sol.event_mask
            live = ~done
            imp = live & hit_imp
            thd_plus = e * thd1
            rests = jnp.abs(thd_plus) < rest_thr
            times = jnp.where(imp & (idx[:k_imp] == n_imp), t1, times)
            return (
                jnp.where(live, t1, t),
                jnp.where(imp, 0.0, jnp.where(live, th1, th)),
                jnp.where(imp, jnp.where(rests, 0.0, thd_plus), jnp.where(live, thd1, thd)),
                jnp.where(imp, jnp.where(rests, 0.0, -s0), jnp.where(live, s0, s)),
                n_imp + imp,
                times,
                over | (live & hit_over),
                done | (live & ~hit_imp),
                k + 1,
            )

        zero = jnp.zeros(())
        c0 = (zero, zero, zero, zero, jnp.zeros((), int), jnp.full(k_imp, jnp.nan))
        c0 += (jnp.zeros((), bool), jnp.zeros((), bool), jnp.zeros((), int))
        c = jax.lax.while_loop(lambda c: ~c[7] & (c[8] < max_flights), body, c0)
        return c[6], c[4], c[5]

    return run


# ============================================================================ DEM: NumPy


class _FloatOps:
    """The three branchy operations of the step on Python floats."""

    where = staticmethod(lambda cond, a, b: a if cond else b)
    clip = staticmethod(lambda x, lo, hi: min(max(x, lo), hi))
    maximum = staticmethod(max)
    abs = staticmethod(abs)


class _NumpyOps:
    where = staticmethod(np.where)
    clip = staticmethod(np.clip)
    maximum = staticmethod(np.maximum)
    abs = staticmethod(np.abs)


class DemRef:
    """The DEM block of rockjax's model, written from the equations (dem.py, contact.py): two
    corner sub-contacts on the base, ``dashpot="closed"``, two-sided."""

    def __init__(self, b, h, beta, length=1.0, rho=1800.0, E=1.8e9, nu=0.25, phi_deg=50.0):
        self.b, self.h, self.beta = b, h, beta
        self.m = rho * b * h * length
        self.I_c = self.m * (b * b + h * h) / 12.0
        self.eta = math.atan2(b, h)
        j_kn = E / h
        j_ks = j_kn / (2.0 * (1.0 + nu))
        area = 0.5 * b * length  # trapezoidal tributary area of each of the two corners
        self.kn, self.ks = j_kn * area, j_ks * area
        self.tan_phi = math.tan(math.radians(phi_deg))
        self.u = (-0.5 * b, 0.5 * b)  # body coordinates of the corners
        self.v = -0.5 * h

    def initial_state(self, theta0=0.0):
        """(x, y, c, s, vx, vy, w, theta, theta_max, d_max, fs0, fs1) at rest (rockjax's)."""
        if theta0 == 0.0:
            sink, x0, c, s = self.m * G / (2 * self.kn), 0.0, 1.0, 0.0
            y0 = -sink - self.v
        else:
            up = math.copysign(0.5 * self.b, theta0)
            c, s = math.cos(theta0), math.sin(theta0)
            sink = self.m * G / self.kn
            x0 = up - (up * c + self.v * s)
            y0 = -sink - (-up * s + self.v * c)
        return [x0, y0, c, s, 0.0, 0.0, 0.0, theta0, abs(theta0), 0.0, 0.0, 0.0]

    def step(self, st, ag, dt, X):
        """One central-difference step (``X``: ``_FloatOps`` or ``_NumpyOps``)."""
        x, y, c, s, vx, vy, w, theta, theta_max, d_max, fs0, fs1 = st
        beta, kn, ks, tan_phi, v = self.beta, self.kn, self.ks, self.tan_phi, self.v
        fx = fy = mom = 0.0
        fs_new = []
        for u, fs_old in ((self.u[0], fs0), (self.u[1], fs1)):
            rx = u * c + v * s
            ry = -u * s + v * c
            delta = -(y + ry)  # penetration
            delta_dot = -(vy - w * rx)
            slip = vx + w * ry
            closed = delta > 0
            f_el = X.where(closed, kn * delta, 0.0)
            fn = f_el + X.where(closed, beta * kn * delta_dot, 0.0)
            limit = tan_phi * f_el
            fs = X.clip(fs_old - ks * slip * dt, -limit, limit)
            ft = fs - X.where(f_el > 0, beta * ks * slip, 0.0)
            fx, fy, mom = fx + ft, fy + fn, mom + (ry * ft - rx * fn)
            fs_new.append(fs)
        ax = fx / self.m - ag
        ay = fy / self.m - G
        aw = mom / self.I_c
        vx = vx + dt * ax
        vy = vy + dt * ay
        w = w + dt * aw
        dth = dt * w
        d2 = dth * dth
        cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0 - d2 / 720.0))
        sd = dth * (1.0 - d2 * (1.0 / 6.0 - d2 / 120.0))
        d = x + 0.5 * self.h * s
        return [
            x + dt * vx,
            y + dt * vy,
            c * cd - s * sd,
            s * cd + c * sd,
            vx,
            vy,
            w,
            theta + dth,
            X.maximum(theta_max, X.abs(theta)),
            X.maximum(d_max, X.abs(d)),
            fs_new[0],
            fs_new[1],
        ]

    def run(self, ag, dt_out, n_in, theta0=0.0, batch=None):
        """The record ``ag`` (shape ``(T,)``, or ``(T, B)`` with ``batch=B``) sampled every
        ``dt_out``, ``n_in`` steps per sample. Returns ``(theta at the samples, theta_max)``."""
        dt = dt_out / n_in
        X = _FloatOps if batch is None else _NumpyOps
        st = self.initial_state(theta0)
        if batch is not None:
            st = [np.full(batch, v) for v in st]
        ag = np.asarray(ag, float)
        ag_next = np.concatenate([ag[1:], ag[-1:]])
        if batch is None:
            ag, ag_next = ag.tolist(), ag_next.tolist()
        thetas, over = [], (False if batch is None else np.zeros(batch, bool))
        for k in range(len(ag)):
            a0 = ag[k]
            da = (ag_next[k] - a0) / n_in
            thetas.append(st[7])
            new = self.step(st, a0, dt, X)
            j = 1.0
            for _ in range(n_in - 1):
                new = self.step(new, a0 + j * da, dt, X)
                j += 1.0
            # overturning: past eta and moving outward; the block is frozen from then on
            th, w = new[7], new[6]
            if batch is None:
                if not over:
                    st = new
                over = over or (abs(th) > self.eta and th * w > 0)
            else:
                st = [np.where(over, o, n_) for o, n_ in zip(st, new)]
                over = over | ((np.abs(th) > self.eta) & (th * w > 0))
        return np.asarray(thetas), st[8]


# ============================================================================ main


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer peer records, no diffrax")
    ap.add_argument("--scipy-records", type=int, default=None, help="records scipy runs")
    ap.add_argument("--diffrax-records", type=int, default=64, help="batch of the diffrax run")
    ap.add_argument("--no-diffrax", action="store_true", help="skip the diffrax baseline")
    ap.add_argument(
        "--dem-single-s", type=float, default=None, help="seconds of the Python-loop DEM history"
    )
    args = ap.parse_args()
    quick = args.quick
    n_scipy = args.scipy_records or (8 if quick else 32)  # RK45: ~1 s a record
    dem_single_s = args.dem_single_s or (2.0 if quick else DURATION)
    run_diffrax = not (quick or args.no_diffrax)

    t_start = time.perf_counter()
    print(f"rockjax vs peers  {datetime.datetime.now().isoformat(timespec='seconds')}")
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(x.split(":", 1)[1].strip() for x in f if x.startswith("model name"))
    except (OSError, StopIteration):
        cpu = platform.processor() or "?"
    import scipy

    print(
        f"  {cpu}, {len(os.sched_getaffinity(0))} cores; python {platform.python_version()}, "
        f"jax {jax.__version__}, numpy {np.__version__}, scipy {scipy.__version__}, "
        f"diffrax {diffrax.__version__}"
    )
    print(f"  load average at start: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    rows = []  # (case, rockjax s, peer name, peer s, agreement, note)

    # ------------------------------------------------------------------ Housner
    block = rj.Block(b=HOUSNER_BLOCK[0], h=HOUSNER_BLOCK[1])
    eta, p = float(block.eta), float(block.p)
    e = 1.0 - 1.5 * math.sin(eta) ** 2
    print(
        f"\nHousner: block {HOUSNER_BLOCK[0]} x {HOUSNER_BLOCK[1]} m (p {p:.3f} rad/s, eta "
        f"{eta:.4f} rad, e_H {e:.4f}); {DURATION:g} s records at dt {RECORD_DT} s"
    )

    def one(ag):
        r = rj.simulate_housner(block, rj.GroundMotion(ag=ag, dt=RECORD_DT), throw=False)
        x = r.extras
        return r.theta_max, r.overturned, x["n_impacts"], x["t_last_impact"], x["dt"]

    ag1 = records(jax.random.PRNGKey(0), 1, N_SAMPLES, RECORD_DT, eta, (SINGLE_PGA, SINGLE_PGA))[0]
    ag1 = jax.block_until_ready(ag1)
    single = jax.jit(one)
    w = time.perf_counter()
    out1 = jax.block_until_ready(single(ag1))
    compile_h = time.perf_counter() - w
    t_rj1, _ = timed(lambda: single(ag1), 7)
    rest_thr = p * p * math.sin(eta) * float(out1[4])
    peer = {"p": p, "eta": eta, "e": e, "rest_thr": rest_thr}

    ag1_np = np.asarray(ag1)
    th_rj, n_rj = float(out1[0]), int(out1[2][-1])
    imp_rj = rockjax_impact_times(out1[2], out1[3], 5)
    print(
        f"  one record: rockjax compile {compile_h:.2f} s, run {t_rj1 * 1e3:.2f} ms; "
        f"theta_max/eta {th_rj / eta:.4f}, {n_rj} impacts"
    )
    for method in ("RK45", "DOP853"):
        ref1 = housner_scipy(ag1_np, RECORD_DT, method=method, **peer)
        t_sp1, _ = timed(
            lambda m=method: housner_scipy(ag1_np, RECORD_DT, method=m, **peer), 3, warmup=False
        )
        th_sp, imps = ref1["theta_max"], ref1["impacts"]
        d_imp = max(abs(imp_rj[i] - imps[i]) for i in imp_rj if i < len(imps))
        # the first impact whose time differs by more than 1e-5 s (the trajectories part)
        imp_all = rockjax_impact_times(out1[2], out1[3], n_rj)
        part = next(
            (i for i in imp_all if i < len(imps) and abs(imp_all[i] - imps[i]) > 1e-5), None
        )
        agree1 = (
            f"first {len(imp_rj)} impacts |dt| <= {d_imp:.1e} s (> 1e-5 s from impact "
            f"{part}); theta_max rel {abs(th_rj - th_sp) / th_sp:.1e}; impacts {n_rj} / {len(imps)}"
        )
        print(
            f"    scipy {method}: {t_sp1 * 1e3:.0f} ms; theta_max/eta {th_sp / eta:.4f}; {agree1}"
        )
        rows.append(("Housner, one 20 s record", t_rj1, f"scipy solve_ivp {method}", t_sp1, agree1))

    ags = jax.block_until_ready(
        records(jax.random.PRNGKey(1), HOUSNER_BATCH, N_SAMPLES, RECORD_DT, eta)
    )
    batched = jax.jit(jax.vmap(one))
    w = time.perf_counter()
    outb = jax.block_until_ready(batched(ags))
    first_b = time.perf_counter() - w
    t_rjb, _ = timed(lambda: batched(ags), 3)
    ags_np = np.asarray(ags)
    w = time.perf_counter()
    refs = [housner_scipy(ags_np[i], RECORD_DT, method="RK45", **peer) for i in range(n_scipy)]
    t_sp_sub = time.perf_counter() - w
    t_spb = t_sp_sub / n_scipy * HOUSNER_BATCH
    th_b, over_b = np.asarray(outb[0]), np.asarray(outb[1])
    same_over = sum(bool(over_b[i]) == r["overturned"] for i, r in enumerate(refs))
    # theta_max is compared on the records that stand in both (an overturned record stops at
    # eta in scipy and at the end of the step past eta in rockjax)
    standing = [i for i, r in enumerate(refs) if not (r["overturned"] or bool(over_b[i]))]
    rel = {i: abs(th_b[i] - refs[i]["theta_max"]) / refs[i]["theta_max"] for i in standing}
    close = [i for i in standing if rel[i] < 1e-3]
    d_imps = []
    for i, r in enumerate(refs):
        ti = rockjax_impact_times(np.asarray(outb[2][i]), np.asarray(outb[3][i]), 3)
        d_imps += [abs(ti[j] - r["impacts"][j]) for j in ti if j < len(r["impacts"])]
    agree_b = (
        f"{n_scipy} records: overturned same {same_over}/{n_scipy}; standing: theta_max within "
        f"1e-3 rel {len(close)}/{len(standing)} (median rel {np.median(list(rel.values())):.1e}); "
        f"first 3 impacts |dt| <= {max(d_imps):.1e} s"
    )
    print(
        f"  batch {HOUSNER_BATCH}: rockjax first call {first_b:.2f} s, run {t_rjb:.3f} s "
        f"({HOUSNER_BATCH / t_rjb:.0f} records/s); scipy {t_sp_sub:.2f} s for {n_scipy} records "
        f"({t_sp_sub / n_scipy * 1e3:.0f} ms/record, x{HOUSNER_BATCH / n_scipy:g} -> {t_spb:.1f} s)"
    )
    print(f"    agreement: {agree_b}")
    for i in [i for i in standing if i not in close]:
        print(
            f"    record {i}: theta_max/eta rockjax {th_b[i] / eta:.4f} scipy "
            f"{refs[i]['theta_max'] / eta:.4f}, overturned {bool(over_b[i])} / "
            f"{refs[i]['overturned']}, impacts {int(outb[2][i][-1])} / {len(refs[i]['impacts'])}"
        )
    rows.append(
        (
            f"Housner, batch of {HOUSNER_BATCH} (vmap)",
            t_rjb,
            f"scipy RK45 loop ({n_scipy} rec. x{HOUSNER_BATCH // n_scipy})",
            t_spb,
            agree_b,
        )
    )

    if run_diffrax:
        nd = args.diffrax_records
        k_imp = 5
        restart = make_diffrax_restart(block, e, rest_thr, N_SAMPLES, RECORD_DT, k_imp, 400)
        f1 = jax.jit(restart)
        w = time.perf_counter()
        o = jax.block_until_ready(f1(ag1))
        compile_d = time.perf_counter() - w
        t_d1, _ = timed(lambda: f1(ag1), 3)
        d1 = max(abs(imp_rj[i] - float(o[2][i])) for i in imp_rj if i < k_imp)
        agree_d1 = f"first {len(imp_rj)} impacts |dt| <= {d1:.1e} s; impacts {n_rj} / {int(o[1])}"
        fb = jax.jit(jax.vmap(restart))
        w = time.perf_counter()
        ob = jax.block_until_ready(fb(ags[:nd]))
        compile_db = time.perf_counter() - w
        t_db, _ = timed(lambda: fb(ags[:nd]), 1)
        t_db_scaled = t_db / nd * HOUSNER_BATCH
        same = sum(bool(ob[0][i]) == bool(over_b[i]) for i in range(nd))
        d_b = []
        for i in range(nd):
            ti = rockjax_impact_times(np.asarray(outb[2][i]), np.asarray(outb[3][i]), 3)
            d_b += [abs(ti[j] - float(ob[2][i][j])) for j in ti]
        agree_db = (
            f"{nd} records: overturned same {same}/{nd}; first 3 impacts |dt| <= {max(d_b):.1e} s"
        )
        print(
            f"  diffrax restart-per-impact: compile {compile_d:.1f} s (batched {compile_db:.1f} s); "
            f"one record {t_d1 * 1e3:.0f} ms ({agree_d1}); vmap over {nd} records {t_db:.2f} s "
            f"({t_db / nd * 1e3:.0f} ms/record, x{HOUSNER_BATCH / nd:g} -> {t_db_scaled:.1f} s); {agree_db}"
        )
        rows.append(("Housner, one 20 s record", t_rj1, "diffrax restart/impact", t_d1, agree_d1))
        rows.append(
            (
                f"Housner, batch of {HOUSNER_BATCH} (vmap)",
                t_rjb,
                f"diffrax restart, vmap ({nd} rec. x{HOUSNER_BATCH // nd})",
                t_db_scaled,
                agree_db,
            )
        )

    # ------------------------------------------------------------------ DEM
    dblock = rj.Block(b=DEM_BLOCK[0], h=DEM_BLOCK[1])
    beta = float(rj.beta_dejong(dblock))
    dt_stable = rj.stable_dt(dblock, beta)
    ref = DemRef(DEM_BLOCK[0], DEM_BLOCK[1], beta)
    print(f"\nDEM: block {DEM_BLOCK[0]} x {DEM_BLOCK[1]} m, beta_dejong {beta:.4g} s")

    # agreement: 1 s of free rocking from theta0 = eta/2 (save_dt 0.002 s)
    th0 = 0.5 * ref.eta
    r_free = rj.simulate_dem(dblock, None, beta=beta, theta0=th0, duration=1.0)
    n_in_free = round(0.002 / float(r_free.extras["dt"]))
    th_free, _ = ref.run(np.zeros(r_free.theta.shape[0]), 0.002, n_in_free, theta0=th0)
    d_free = float(np.max(np.abs(th_free - np.asarray(r_free.theta))))
    print(
        f"  free rocking 1 s from theta0 = eta/2 ({n_in_free} steps per 0.002 s): "
        f"max |theta_numpy - theta_rockjax| = {d_free:.1e} rad"
    )

    rec = rj.GroundMotion.ricker(pga=3.0, period=0.5, dt=RECORD_DT, duration=DURATION)
    w = time.perf_counter()
    r20 = rj.simulate_dem(dblock, rec, beta=beta)
    jax.block_until_ready(r20.theta)
    compile_dem = time.perf_counter() - w
    n_in = round(RECORD_DT / float(r20.extras["dt"]))
    steps20 = rec.n * n_in
    t_api, _ = timed(lambda: rj.simulate_dem(dblock, rec, beta=beta).theta, 9)
    dt_run = float(r20.extras["dt"])
    ag20 = jnp.asarray(rec.ag)
    jit_hist = jax.jit(
        lambda a: (
            rj.simulate_dem(
                dblock, rj.GroundMotion(ag=a, dt=RECORD_DT), beta=beta, dt=dt_run, throw=False
            ).theta
        )
    )
    t_jit, _ = timed(lambda: jit_hist(ag20), 9)

    n_part = int(round(dem_single_s / RECORD_DT)) + 1
    ag_part = np.asarray(rec.ag)[:n_part]
    w = time.perf_counter()
    th_np, _ = ref.run(ag_part, RECORD_DT, n_in)
    t_np_part = time.perf_counter() - w
    t_np1 = t_np_part * steps20 / (n_part * n_in)
    d20 = float(np.max(np.abs(th_np - np.asarray(r20.theta)[:n_part])))
    scale_note = "" if n_part == rec.n else f" ({dem_single_s:g} s run, x{rec.n / n_part:.2f})"
    agree_dem1 = f"theta(t) over {dem_single_s:g} s: max |diff| {d20:.1e} rad"
    print(
        f"  one {DURATION:g} s history ({steps20} steps, dt {dt_run:.4g} s): rockjax API "
        f"{t_api * 1e3:.2f} ms, jit {t_jit * 1e3:.2f} ms (first call {compile_dem:.2f} s); "
        f"Python loop {t_np_part:.2f} s for {dem_single_s:g} s{scale_note} -> {t_np1:.2f} s; "
        f"{agree_dem1}"
    )
    rows.append(
        ("DEM, one 20 s history, API", t_api, f"Python floats{scale_note}", t_np1, agree_dem1)
    )
    rows.append(
        ("DEM, one 20 s history, jit", t_jit, f"Python floats{scale_note}", t_np1, agree_dem1)
    )

    recb = rj.GroundMotion.ricker(pga=3.0, period=0.5, dt=RECORD_DT, duration=DEM_BATCH_RECORD_S)
    agb = jnp.asarray(recb.ag)

    def amp(scale):
        motion = rj.GroundMotion(ag=scale * agb, dt=RECORD_DT)
        return rj.simulate_dem(dblock, motion, beta=beta, dt=dt_stable, throw=False).theta_max

    scales = jnp.linspace(0.5, 1.5, DEM_BATCH)
    fdem = jax.jit(jax.vmap(amp))
    w = time.perf_counter()
    thm = np.asarray(jax.block_until_ready(fdem(scales)))
    first_dem = time.perf_counter() - w
    t_rjd, _ = timed(lambda: fdem(scales), 5)
    stepsb = recb.n * n_in
    ag_tb = np.asarray(recb.ag)[:, None] * np.asarray(scales)[None, :]
    t_npb, _ = timed(lambda: ref.run(ag_tb, RECORD_DT, n_in, batch=DEM_BATCH), 1, warmup=False)
    _, thm_np = ref.run(ag_tb, RECORD_DT, n_in, batch=DEM_BATCH)
    d_b = float(np.max(np.abs(thm_np - thm)))
    agree_demb = f"theta_max of {DEM_BATCH} blocks: max |diff| {d_b:.1e} rad"
    print(
        f"  batch {DEM_BATCH}, {DEM_BATCH_RECORD_S:g} s record ({stepsb} steps each): rockjax "
        f"{t_rjd * 1e3:.1f} ms ({DEM_BATCH * stepsb / t_rjd:.3g} block-steps/s, first call "
        f"{first_dem:.2f} s); NumPy {t_npb:.2f} s ({DEM_BATCH * stepsb / t_npb:.3g} block-steps/s); "
        f"{agree_demb}"
    )
    rows.append(
        (
            f"DEM, batch {DEM_BATCH} x {DEM_BATCH_RECORD_S:g} s (vmap)",
            t_rjd,
            "NumPy over the batch",
            t_npb,
            agree_demb,
        )
    )

    # ------------------------------------------------------------------ table
    print("\nPeer ratio = peer time / rockjax time (> 1: rockjax faster); compile not included")
    print(f"  {'case':<36}{'rockjax':>11}  {'peer':<38}{'peer time':>11}{'ratio':>9}  agreement")
    for case, t_r, name, t_p, agree in rows:
        print(
            f"  {case:<36}{_fmt_s(t_r):>11}  {name:<38}{_fmt_s(t_p):>11}{t_p / t_r:>9.3g}  {agree}"
        )
    print(
        f"\n  load average at end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}; "
        f"total {time.perf_counter() - t_start:.0f} s"
    )


def _fmt_s(t: float) -> str:
    return f"{t * 1e3:.2f} ms" if t < 1 else f"{t:.2f} s"


if __name__ == "__main__":
    main()
