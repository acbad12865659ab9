import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax.constants import G


def test_from_g_converts_units():
    gm = rj.GroundMotion.from_g([0.0, 0.5, -1.0], dt=0.01)
    np.testing.assert_allclose(gm.ag, [0.0, 0.5 * G, -G])
    assert gm.n == 3 and np.isclose(gm.duration, 0.02)


def test_pulses_have_requested_peak_and_period():
    """Reference: the analytic pulse definitions (peak value, zero crossings)."""
    r = rj.GroundMotion.ricker(pga=2.0, period=0.5, dt=0.001)
    assert np.isclose(np.max(np.abs(r.ag)), 2.0, rtol=1e-6)
    # zeros of 1 - 2 pi^2 tau^2 / T^2 at tau = T / (pi sqrt 2)
    t0 = 0.75
    tz = t0 + 0.5 / (np.pi * np.sqrt(2))
    assert abs(np.interp(tz, r.t, r.ag)) < 1e-2
    s = rj.GroundMotion.sine_cycle(pga=-3.0, period=0.4, dt=0.001)
    assert np.isclose(s.ag.min(), -3.0, rtol=1e-4) and np.isclose(s.ag.max(), 3.0, rtol=1e-4)
    assert np.all(s.ag[s.t > 0.4 + 1e-9] == 0.0)


def test_scaled():
    gm = rj.GroundMotion.sine_cycle(pga=1.0, period=0.5)
    assert np.isclose(float(gm.scaled(2.5).pga), 2.5)


def test_lists_of_numbers_are_records():
    """`ag=[...]` (a list, ints or a tuple) is stored as a float64 array: `.scaled(2.5)` scales
    every sample instead of failing on `list * float` (a TypeError naming neither ag nor its
    unit)."""
    gm = rj.GroundMotion(ag=[0.0, 1.0, -2.0], dt=0.01, ag_v=(0, 1, 0))
    assert isinstance(gm.ag, np.ndarray) and gm.ag.dtype == np.float64
    np.testing.assert_array_equal(gm.scaled(2.5).ag, [0.0, 2.5, -5.0])
    np.testing.assert_array_equal(gm.scaled(2.5).ag_v, [0.0, 2.5, 0.0])
    # linear interpolation at the midpoints: exact up to round-off of the sample times
    np.testing.assert_allclose(gm.resampled(0.005).ag, [0.0, 0.5, 1.0, -0.5, -2.0], atol=1e-15)
    with pytest.raises(ValueError, match=r"ag must be a real number in m/s\^2"):
        rj.GroundMotion(ag=["0", "1"], dt=0.01)  # text is refused, not converted


def test_bad_records_are_refused():
    with pytest.raises(ValueError, match="non-finite samples"):
        rj.GroundMotion(ag=np.array([0.0, np.nan, 1.0]), dt=0.01)
    with pytest.raises(ValueError, match="at least 2 samples"):
        rj.GroundMotion(ag=np.array([]), dt=0.01)
    with pytest.raises(ValueError, match="dt must be a positive"):
        rj.GroundMotion(ag=np.zeros(4), dt=0.0)
    with pytest.raises(ValueError, match="not uniformly sampled"):
        rj.GroundMotion.from_time_series([0.0, 0.01, 0.03], [0.0, 1.0, 0.0])


# ------------------------------------------------------------------ new analytic pulses
def _trapz_rtol(dt, period):
    """Trapezoid rule (twice) plus sampling of the peak, for a pulse of period T sampled every dt:
    the cumulative-integral error pi^3 dt^2 / (3 T^2) and the peak-sampling error
    (pi dt / T)^2 / 2 of a peak of width T / (2 pi), with a factor 2 of margin."""
    return 2.0 * (np.pi**3 / 3 + np.pi**2 / 2) * (dt / period) ** 2


def test_antisymmetric_ricker_peak_sign_and_zero_mean():
    """Reference: the closed form ag = -pga f(tau) / f_max, f = tau (3 - 2 pi^2 tau^2 / T^2)
    exp(-pi^2 tau^2 / T^2) (a Gaussian's third derivative): odd about t0, so zero mean and no
    residual velocity or displacement; main-lobe peaks +-pga at t0 -+ T sqrt(x1) / pi."""
    pga, period, dt = -2.0, 0.5, 0.001
    r = rj.GroundMotion.ricker_antisymmetric(pga=pga, period=period, dt=dt)
    ag = np.asarray(r.ag)
    assert ag.dtype == np.float64 and r.name == "ricker_anti_T0.5s"
    # the peaks fall between samples: a sample is short of the analytic peak by at most
    # c dt^2 with c = pi^2 / T^2 (f''/f = -8c at the peak, nearest sample within dt/2)
    rtol_sampled_peak = np.pi**2 * dt**2 / period**2
    assert abs(pga) * (1 - rtol_sampled_peak) <= np.max(np.abs(ag)) <= abs(pga)
    t0, s1 = 1.5 * period, np.sqrt(0.5 * (3 - np.sqrt(6))) / np.pi
    first, second = np.interp([t0 - s1 * period, t0 + s1 * period], r.t, ag)
    np.testing.assert_allclose([first, second], [pga, -pga], rtol=rtol_sampled_peak)
    assert np.argmax(np.abs(ag)) < np.searchsorted(r.t, t0)  # the first main lobe is the larger
    # the record starts and ends at |tau| >= 1.5 T, where the truncated tails are ~1e-8 pga
    atol_tails = 1e-7
    assert abs(np.mean(ag)) <= atol_tails * abs(pga)
    assert abs(float(r.velocity()[-1])) <= atol_tails * abs(pga) * period
    assert abs(float(r.displacement()[-1])) <= atol_tails * abs(pga) * period**2


def test_cosine_cycle_closed_forms():
    """Reference: Makris's one-cosine (type-B) pulse: v = pga T / (2 pi) sin(2 pi tau / T),
    PGV = pga T / (2 pi), PGD = pga T^2 / (2 pi^2), zero residual velocity and displacement."""
    pga, period, dt = 1.5, 0.4, 0.001
    rtol = _trapz_rtol(dt, period)
    for t0 in (0.0, 0.1):  # the jump at the record start, and both jumps inside the record
        c = rj.GroundMotion.cosine_cycle(pga=pga, period=period, dt=dt, t0=t0)
        ag = np.asarray(c.ag)
        k0, k1 = round(t0 / dt), round((t0 + period) / dt)
        assert ag[k0] == (pga if k0 == 0 else 0.5 * pga) and ag[k1] == 0.5 * pga
        assert np.all(ag[:k0] == 0.0) and np.all(ag[k1 + 1 :] == 0.0)
        assert np.isclose(np.min(ag), -pga, rtol=1e-15)
        np.testing.assert_allclose(c.pgv, pga * period / (2 * np.pi), rtol=rtol)
        np.testing.assert_allclose(c.pgd, pga * period**2 / (2 * np.pi**2), rtol=rtol)
        # the jump rule gives the exact impulse: no residual velocity; the start ramp of t0=0
        # leaves a displacement of pga dt^2 / 4 at most
        assert abs(float(c.velocity()[-1])) <= 1e-12 * pga * period
        assert abs(float(c.displacement()[-1])) <= pga * dt**2 / 4 * (1 + 1e-9)


def test_sine_cycle_pgv_pgd():
    """Reference: one sine cycle a = A sin(w tau): v = A/w (1 - cos w tau), PGV = A T / pi at
    tau = T/2; d = A/w (tau - sin(w tau)/w) reaches A T^2 / (2 pi) at tau = T and stays."""
    pga, period, dt = 3.0, 0.5, 0.001
    s = rj.GroundMotion.sine_cycle(pga=pga, period=period, dt=dt)
    rtol = _trapz_rtol(dt, period)
    assert s.pgv.dtype == np.float64 and s.pgd.dtype == np.float64
    np.testing.assert_allclose(s.pgv, pga * period / np.pi, rtol=rtol)
    np.testing.assert_allclose(s.pgd, pga * period**2 / (2 * np.pi), rtol=rtol)
    np.testing.assert_allclose(s.displacement()[-1], pga * period**2 / (2 * np.pi), rtol=rtol)


def test_arias_intensity_and_significant_duration_of_a_sine():
    """Reference: a = A sin(w t) over N whole cycles: I_A = pi A^2 N T / (4 g); the Husid curve
    H(t) = (t/2 - sin(2 w t)/(4 w)) / (N T / 2), its 5 % and 95 % times solved with brentq."""
    from scipy.optimize import brentq

    amp, period, cycles, dt = 2.0, 0.2, 7, 0.001
    t = np.arange(round(cycles * period / dt) + 1) * dt
    w = 2 * np.pi / period
    gm = rj.GroundMotion(ag=amp * np.sin(w * t), dt=dt)
    # the trapezoid rule integrates sin^2 over whole periods exactly (aliasing-free grid)
    rtol_arias = 1e-12
    assert gm.arias_intensity.dtype == np.float64
    np.testing.assert_allclose(
        gm.arias_intensity, np.pi * amp**2 * cycles * period / (4 * G), rtol=rtol_arias
    )

    def husid(x, q):
        return (x / 2 - np.sin(2 * w * x) / (4 * w)) / (cycles * period / 2) - q

    def t_q(q):
        return brentq(husid, 0.0, cycles * period, args=(q,), xtol=1e-14)

    # the crossings lie where sin^2 = 0.65; trapezoid and interpolation errors of the
    # cumulative integral (<= 0.3 w dt^2) become <= 0.5 w dt^2 in time at each end
    atol_duration = w * dt**2
    for lo, hi in ((0.05, 0.95), (0.05, 0.75), (0.2, 0.8)):
        np.testing.assert_allclose(
            gm.significant_duration(lo, hi), t_q(hi) - t_q(lo), rtol=0, atol=atol_duration
        )
    with pytest.raises(ValueError, match="need 0 < lo < hi < 1"):
        gm.significant_duration(0.95, 0.05)
    with pytest.raises(ValueError, match="all zeros"):
        rj.GroundMotion.zeros(1.0).significant_duration()


# ------------------------------------------------------------------ transformations
def test_resampled_sine_to_interpolation_error():
    """Reference: linear interpolation of a sampled sine errs by at most dt^2 / 8 max|a''|
    = dt^2 A w^2 / 8 between the old samples (and not at all on them)."""
    amp, period, dt = 1.3, 0.3, 0.002
    t = np.arange(1501) * dt
    w = 2 * np.pi / period
    gm = rj.GroundMotion(ag=amp * np.sin(w * t), dt=dt, ag_v=-amp * np.cos(w * t))
    gm = gm.with_metadata(station="X")
    atol_interp = dt**2 * amp * w**2 / 8 * (1 + 1e-9)
    for dt_new in (0.0007, 0.002, 0.0053):
        r = gm.resampled(dt_new)
        assert r.dt == dt_new and r.name == gm.name and r.metadata == {"station": "X"}
        assert r.duration <= gm.duration + 1e-12 and r.duration > gm.duration - dt_new
        np.testing.assert_allclose(r.ag, amp * np.sin(w * r.t), rtol=0, atol=atol_interp)
        np.testing.assert_allclose(r.ag_v, -amp * np.cos(w * r.t), rtol=0, atol=atol_interp)
    # same grid: the samples back, up to round-off in the interpolation weights
    np.testing.assert_allclose(gm.resampled(dt).ag, gm.ag, rtol=0, atol=1e-15 * amp)
    with pytest.raises(ValueError, match="longer than record"):
        gm.resampled(10.0)
    with pytest.raises(ValueError, match="dt_new must be a positive"):
        gm.resampled(-0.01)


def test_scaled_to_pga():
    base = rj.GroundMotion(
        ag=np.array([0.0, 0.4, -0.8, 0.2]), dt=0.01, ag_v=np.array([0.1, 0.0, 0.2, 0.0])
    ).with_metadata(event="e")
    gm = base.scaled_to_pga(0.3 * G)
    np.testing.assert_allclose(gm.pga, 0.3 * G, rtol=1e-15)
    np.testing.assert_allclose(gm.ag_v, base.ag_v * 0.3 * G / 0.8, rtol=1e-15)
    assert gm.metadata == {"event": "e"}
    with pytest.raises(ValueError, match="all zeros"):
        rj.GroundMotion.zeros(1.0).scaled_to_pga(1.0)
    with pytest.raises(ValueError, match="target_pga must be a positive"):
        base.scaled_to_pga(-1.0)


def test_baseline_correction():
    """Reference: the method is a least-squares projection. (1) A constant acceleration offset
    integrates to a straight velocity line, which order >= 1 removes exactly; (2) a linear
    acceleration (quadratic velocity) is removed entirely by order 2; (3) the corrected
    velocity has no trend of degree 1..order left (checked with numpy.polyfit; exactly for
    order <= 2, to the trapezoid rule's O(dt^2) above)."""
    rtol_projection = 1e-10  # a least-squares solve on a well-conditioned basis, n ~ 2000
    sine = rj.GroundMotion.sine_cycle(pga=2.0, period=0.5, dt=0.002, t0=0.3)
    offset = rj.GroundMotion(ag=np.asarray(sine.ag) + 0.05, dt=sine.dt)
    for order in (1, 2, 3):
        np.testing.assert_allclose(
            offset.baseline_corrected(order).ag,
            sine.baseline_corrected(order).ag,
            rtol=0,
            atol=rtol_projection * sine.pga,
        )
    ramp = rj.GroundMotion(ag=0.3 - 0.2 * sine.t, dt=sine.dt, ag_v=0.1 + 0.0 * sine.t)
    corrected = ramp.baseline_corrected(2)
    np.testing.assert_allclose(corrected.ag, 0.0, atol=rtol_projection)
    np.testing.assert_allclose(corrected.ag_v, 0.0, atol=rtol_projection)
    for order in (1, 2, 3):
        c = offset.baseline_corrected(order)
        v = np.asarray(c.velocity())
        assert v[0] == 0.0  # still from rest
        trend = np.polyfit(c.t / c.duration, v, order)[:-1]  # all but the constant
        before = np.polyfit(offset.t / offset.duration, np.asarray(offset.velocity()), order)[:-1]
        if order <= 2:  # exact: the trapezoid rule integrates the linear dp/dt exactly
            np.testing.assert_allclose(trend, 0.0, atol=rtol_projection * float(offset.pgv))
        else:  # the trapezoid rule integrates dp/dt to O(dt^2): (dt / t_end)^2 ~ 5e-7 here
            assert np.max(np.abs(trend)) < 1e-4 * np.max(np.abs(before))
    with pytest.raises(ValueError, match="order must be an integer"):
        sine.baseline_corrected(0)
    with pytest.raises(ValueError, match="order must be an integer"):
        sine.baseline_corrected(True)


# ------------------------------------------------------------------ metadata and transforms
def test_metadata_is_static_and_kept():
    gm = rj.GroundMotion.sine_cycle(pga=1.0, period=0.5)
    assert gm.meta == () and gm.metadata == {}
    tagged = gm.with_metadata(event="Nahanni", azimuth_deg=280)
    assert tagged.metadata == {"event": "Nahanni", "azimuth_deg": "280"}
    tagged.metadata["event"] = "changed"  # a copy
    assert tagged.metadata["event"] == "Nahanni"
    assert tagged.with_metadata(event="x").metadata == {"event": "x", "azimuth_deg": "280"}
    for derived in (tagged.scaled(2.0), tagged.resampled(0.01), tagged.baseline_corrected()):
        assert derived.meta == tagged.meta and derived.name == tagged.name
    # meta is a static field: it is not a leaf, and it must be hashable
    assert len(jax.tree_util.tree_leaves(tagged)) == 1
    hash(tagged.meta)
    with pytest.raises((ValueError, TypeError), match="meta"):
        rj.GroundMotion(ag=np.zeros(3), dt=0.01, meta={"event": "x"})


def test_intensity_measures_jit_and_vmap():
    """jit equals eager and vmap over scale factors equals a Python loop (STYLE §4)."""
    rtol_transform = 1e-12  # same float64 operations, possibly reordered by XLA
    gm = rj.GroundMotion.sine_cycle(pga=2.0, period=0.5).with_metadata(event="e")

    def measures(m):
        return jnp.stack([m.pga, m.pgv, m.pgd, m.arias_intensity, m.significant_duration()])

    np.testing.assert_allclose(eqx.filter_jit(measures)(gm), measures(gm), rtol=rtol_transform)
    scales = jnp.array([0.5, 1.0, 3.0])
    batched = jax.vmap(lambda s: measures(gm.scaled(s)))(scales)
    looped = jnp.stack([measures(gm.scaled(float(s))) for s in scales])
    np.testing.assert_allclose(batched, looped, rtol=rtol_transform)
    targets = jnp.array([1.0, 4.0])
    np.testing.assert_allclose(
        jax.vmap(lambda p: gm.scaled_to_pga(p).pga)(targets), targets, rtol=1e-15
    )


# ------------------------------------------------------------------ units: g and plausibility
@pytest.mark.parametrize("ctor", ["ricker", "sine_cycle", "ricker_antisymmetric", "cosine_cycle"])
def test_pulses_accept_pga_in_g(ctor):
    """Reference: pga_g = x is the record of pga = x * 9.80665 m/s^2 (standard gravity)."""
    make = getattr(rj.GroundMotion, ctor)
    in_g = make(pga_g=-0.4, period=0.5, dt=0.01)
    in_si = make(-0.4 * 9.80665, 0.5, dt=0.01)
    np.testing.assert_array_equal(in_g.ag, in_si.ag)
    np.testing.assert_allclose(in_g.pga_g, in_g.pga / 9.80665, rtol=1e-15)
    with pytest.raises(ValueError, match=r"exactly one of pga \[m/s\^2\] or pga_g \[g\]"):
        make(pga=1.0, pga_g=0.1, period=0.5)
    with pytest.raises(ValueError, match=r"exactly one of pga \[m/s\^2\] or pga_g \[g\]"):
        make(period=0.5)
    with pytest.raises(ValueError, match="needs period"):
        make(pga_g=0.3)
    with pytest.raises(ValueError, match="pga must be one finite number in m/s\\^2"):
        make(pga=np.nan, period=0.5)  # the argument named, not "ag"


def test_plausibility_guard_on_accelerations():
    """Records and PGAs above 10 g raise with the unit fix; the FEMA P695 records (peaks up to
    ~1.8 g) and 10 g itself pass."""
    limit = 10.0 * G
    rj.GroundMotion(ag=np.array([0.0, limit, -limit]), dt=0.01)  # at the limit: accepted
    with pytest.raises(ValueError, match=r"did you pass cm/s\^2 or mm/s\^2.*ag / 100"):
        rj.GroundMotion(ag=np.array([0.0, 350.0, -120.0]), dt=0.01)  # 0.36 g in cm/s^2
    with pytest.raises(ValueError, match="ag_v of record"):
        rj.GroundMotion(ag=np.zeros(3), dt=0.01, ag_v=np.array([0.0, 200.0, 0.0]))
    with pytest.raises(ValueError, match="did you pass cm/s"):
        rj.GroundMotion.ricker(pga=300.0, period=0.5)
    with pytest.raises(ValueError, match=r"pga_g is in g.*did you pass m/s\^2"):
        rj.GroundMotion.ricker(pga_g=4.0 * G, period=0.5)
    with pytest.raises(ValueError, match="a scaled record must stay below 10 g"):
        rj.GroundMotion.sine_cycle(pga_g=1.0, period=0.5).scaled(11.0)
    with pytest.raises(ValueError, match="target_pga of the target peaks at"):
        rj.GroundMotion.sine_cycle(1.0, 0.5).scaled_to_pga(150.0)
    # traced values are not checked here (they are data inside jit/vmap, e.g. an IDA's scales)
    big = jax.jit(lambda s: rj.GroundMotion.sine_cycle(pga_g=1.0, period=0.5).scaled(s).pga)(20.0)
    np.testing.assert_allclose(big, 20.0 * G, rtol=1e-15)


def test_scaled_to_pga_in_g():
    base = rj.GroundMotion(ag=np.array([0.0, 0.4, -0.8, 0.2]), dt=0.01)
    np.testing.assert_allclose(base.scaled_to_pga(target_pga_g=0.3).pga, 0.3 * G, rtol=1e-15)
    np.testing.assert_allclose(base.scaled_to_pga(target_pga_g=0.3).pga_g, 0.3, rtol=1e-15)
    with pytest.raises(ValueError, match="exactly one of target_pga .m/s.2. or target_pga_g"):
        base.scaled_to_pga(1.0, target_pga_g=0.1)
    with pytest.raises(ValueError, match="exactly one of target_pga"):
        base.scaled_to_pga()
    with pytest.raises(ValueError, match="target_pga_g must be a positive finite number in g"):
        base.scaled_to_pga(target_pga_g=-0.3)
