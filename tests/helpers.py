"""Shared reference cases for the tests."""

import contextlib
import io

import numpy as np
from scipy.integrate import quad

import rockjax as rj
from rockjax.cli import main as cli_main
from rockjax.constants import G

PARAPET = dict(b=0.25, h=3.0)  # the paper's 3.00 x 0.250 m geometry
SQUAT = dict(b=0.2, h=1.5)


def smooth_push(amp, period, n, dt):
    """A return wall's push ``u_top = amp sin^2(pi t / period)`` [m] for one period, then 0
    (it starts and ends at rest), at ``n`` samples of step ``dt`` [s]; and its exact velocity."""
    t = np.arange(n) * dt
    on = t < period
    w = np.pi / period
    u = np.where(on, amp * np.sin(w * t) ** 2, 0.0)
    v = np.where(on, amp * w * np.sin(2 * w * t), 0.0)
    return u, v


def housner_time_to_impact(p, eta, theta0):
    """Time [s] for the nonlinear Housner EOM to fall from rest at theta0 > 0 to theta = 0.

    Energy conservation gives theta_dot^2 = 2 p^2 (cos(eta - theta0) - cos(eta - theta)); the
    substitution theta = theta0 (1 - u^2) removes the endpoint singularity for quad.
    """

    def integrand(u):
        th = theta0 * (1.0 - u * u)
        rate2 = 2.0 * p**2 * (np.cos(eta - theta0) - np.cos(eta - th))
        return (
            2.0 * theta0 * u / np.sqrt(rate2)
            if u > 0
            else 2.0 * np.sqrt(theta0) / (np.sqrt(2.0 * p**2 * np.sin(eta - theta0)))
        )

    return quad(integrand, 0.0, 1.0, epsabs=1e-13, epsrel=1e-13, limit=200)[0]


def first_downcrossing(t, theta):
    """Linear-interpolated time of the first sign change of theta [s]."""
    t = np.asarray(t)
    th = np.asarray(theta)
    i = int(np.flatnonzero(np.sign(th[1:]) != np.sign(th[:-1]))[0])
    return t[i] + (t[i + 1] - t[i]) * th[i] / (th[i] - th[i + 1])


def block(**kw):
    return rj.Block(**{**PARAPET, **kw})


def run_cli(argv):
    """Run the ``rockjax`` command in-process: ``(exit code, stdout, stderr)``."""
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        try:
            rc = cli_main([str(a) for a in argv])
        except SystemExit as exit_:  # argparse
            rc = exit_.code
    return rc, stdout.getvalue(), stderr.getvalue()


@contextlib.contextmanager
def count_compiles():
    """Collect, in the yielded list, one entry per program that had to be compiled or loaded
    from the persistent compilation cache while the block runs (the suite shares a cache
    between its processes: a cache hit must not hide a compilation)."""
    import jax

    events = []

    def on_duration(event, seconds, **kwargs):
        if event == "/jax/core/compile/backend_compile_duration":
            events.append(("compiled", seconds))

    def on_event(event, **kwargs):
        if event == "/jax/compilation_cache/cache_hits":
            events.append(("cache hit", 0.0))

    jax.monitoring.register_event_duration_secs_listener(on_duration)
    jax.monitoring.register_event_listener(on_event)
    try:
        yield events
    finally:
        jax.monitoring.unregister_event_duration_listener(on_duration)
        jax.monitoring.unregister_event_listener(on_event)


def coulomb_slip(ag, dt, mu, g=G):
    """Slip [m] of a rigid block on a base with Coulomb friction ``mu`` [-], at the samples of
    the base acceleration ``ag`` [m/s^2] (``dt`` [s] apart, linear in between, as the DEM
    reads a record), integrated exactly piece by piece.

    Relative to the base the block obeys ``u'' = -ag - mu g sign(u')`` while it slides, and it
    sticks (``u' = 0``) while ``|ag| <= mu g``. On a piece ``ag = a + s tau`` is linear, so a
    sliding phase has ``u'`` quadratic and ``u`` cubic in ``tau``: the piece is split where
    ``u'`` returns to zero (the block sticks, or turns if ``|ag| > mu g`` there) and where a
    sticking block's ``|ag|`` reaches ``mu g`` (it starts to slide away from ``ag``)."""
    ag = np.asarray(ag, float)
    cap = mu * g
    u = np.zeros(ag.shape[0])
    pos = vel = 0.0
    sense = 0  # 0 sticking; +-1 the sign of u' while sliding

    def start(a):  # the state of a block at rest relative to the base under ag = a
        return 0 if abs(a) <= cap else (-1 if a > 0 else 1)

    for k in range(ag.shape[0] - 1):
        a0, s = ag[k], (ag[k + 1] - ag[k]) / dt
        t = 0.0
        while t < dt:
            rest, a = dt - t, a0 + s * t
            if sense == 0:
                # stick until |ag| reaches the cap
                ends = [(lim - a) / s for lim in (cap, -cap) if s != 0.0]
                ends = [tau for tau in ends if 0.0 < tau <= rest]
                if not ends:
                    break
                t += min(ends)
                sense = -1 if a0 + s * t > 0 else 1
                continue
            acc = a + sense * cap  # u'' = -acc - s tau
            # the first root of u'(tau) = vel - acc tau - s tau^2 / 2 within the piece
            if s == 0.0:
                roots = [vel / acc] if acc != 0.0 else []
            else:
                disc = acc * acc + 2.0 * s * vel
                roots = [(-acc + sg * np.sqrt(disc)) / s for sg in (1, -1)] if disc >= 0 else []
            roots = [tau for tau in roots if 1e-14 * dt < tau <= rest]
            tau = min(roots) if roots else rest
            pos += vel * tau - 0.5 * acc * tau**2 - s * tau**3 / 6.0
            vel -= acc * tau + 0.5 * s * tau**2
            t += tau
            if roots:
                vel, sense = 0.0, start(a0 + s * t)
        u[k + 1] = pos
    return u


def assert_same_table(df, ref, rtol, atol):
    """Two DataFrames hold the same index and columns, to ``rtol`` / ``atol`` (a table
    written to CSV by the ``rockjax`` command and read back, against the API's)."""
    assert list(df.columns) == list(ref.columns)
    np.testing.assert_allclose(df.index.to_numpy(), ref.index.to_numpy(), rtol=rtol)
    np.testing.assert_allclose(df.to_numpy(), ref.to_numpy(), rtol=rtol, atol=atol)


def assert_refused(argv, match, out):
    """``rockjax <argv> --out <out>`` refuses its options: exit status 2, one ``error: ...``
    line on stderr matching the regular expression ``match``, and no output folder."""
    import re

    rc, _, stderr = run_cli([*argv, "--out", out])
    assert rc == 2
    assert stderr.startswith("error: ") and stderr.count("\n") == 1, stderr
    assert re.search(match, stderr), stderr
    assert not out.exists()
