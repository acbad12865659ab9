"""Tests of rockjax.housner: Housner rocking with impacts, solved with diffrax.

Independent references: energy conservation between impacts and the impact map (V ratio e^2
per impact), quadrature of the energy integral for impact times (scipy), the Housner numbers of
docs/verification.md ("Reference facts and their sources": Housner (1963) closed forms and
numbers, computed with an independent solver), the quasi-static uplift condition
|a_g| > g tan(eta), the Zeno time of free rocking by quadrature for the rest rule, dimensional
similarity (same page, "Similarity"), and central finite differences for derivatives.
Broadband records against an event-driven solver: tests/test_housner_events.py.
"""

import logging
import math

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import count_compiles, housner_time_to_impact
from scipy.integrate import quad

import rockjax as rj
from rockjax.constants import G
from rockjax.housner import REST_HORIZON
from rockjax.response import STATUS_BAD_INPUT, STATUS_OK, STATUS_UNSTABLE, find_peaks

# Energy is conserved between impacts up to Tsit5's error, (p dt)^6 ~ 1e-15 per step at
# p dt = 0.005, over a few hundred steps; the impact map is exact.
ENERGY_RTOL = 1e-9
# Peaks from the theta history: a 3-point parabola at dt = 1 ms is off by ~theta'''' dt^4
# ~ 1e-11 rad, i.e. ~1e-9 in V; 1e-6 leaves room.
PEAK_V_RTOL = 1e-6
# Impact times to 1e-6 s (measured error at dt = 5 ms: 5e-10 s).
IMPACT_T_ATOL = 1e-6
# The reference numbers have 6 decimals: half a unit in the last place, plus 1e-6.
REF6_ATOL = 5e-7 + 1e-6
# Same computation compiled two ways (jit vs eager, vmap vs loop): only rounding differs.
SAME_RTOL = 1e-12
# Dimensional similarity is exact for the EOM and the solver (all its thresholds scale with p):
# only rounding differs, amplified a little by the impacts.
SIMILARITY_ATOL = 1e-9
# Central differences with relative step 1e-6: truncation ~1e-12, round-off ~1e-10; the
# derivatives measured agree to ~1e-9.
FD_RTOL = 1e-6
FD_STEP = 1e-6
# theta_max between samples, from each step's Tsit5 dense output: measured 3.3e-10 relative at
# dt = 20 ms against the 1 ms run's peaks (whose 3-point parabola errs ~1e-11); the former
# end-point parabola erred 1e-6 and the sampled max errs 3e-4.
THETA_MAX_RTOL = 1e-8
# One-sided rebound lands on theta = 0 exactly (the impact map sets it); allow rounding.
ONE_SIDED_ATOL = 1e-12

ETA = 0.2
# docs/verification.md, Housner (1963) numbers: eta = 0.2, R = 1 m, g = 9.81 m/s^2 (checked:
# p t_1 = 1.318504 gives the tabulated 0.486090 s only with g = 9.81); we compare p t.
P_REF = math.sqrt(3.0 * 9.81 / 4.0)
REF_PEAKS = np.array([0.420356, 0.358023, 0.307494, 0.265648])  # theta/eta after impacts 1-4
REF_TIMES = np.array([0.486090, 1.328860, 2.076528, 2.749183])  # impact times [s], g = 9.81


@pytest.fixture(scope="module")
def block():
    """eta = 0.2 rad and R = 1 m exactly, the block of the reference numbers."""
    return rj.Block(b=2.0 * math.sin(ETA), h=2.0 * math.cos(ETA))


def _v(theta, eta=ETA):
    """Potential-energy function V = cos(eta - |theta|) - cos(eta) [-] (energy / (m g R))."""
    return np.cos(eta - np.abs(theta)) - np.cos(eta)


def _theta_from_v(v, eta=ETA):
    return eta - np.arccos(np.cos(eta) + v)


def _e_h(eta=ETA):
    return 1.0 - 1.5 * math.sin(eta) ** 2


def _impacts(resp):
    """Impact times [s] (exact, from the solver's root-find) and sample indices after each, for
    the samples after exactly one impact: the rocking phase. The chatter at the end of free
    rocking packs several impacts between two samples; those samples are left out."""
    n = np.asarray(resp.extras["n_impacts"])
    jumps = np.diff(n)
    first_multi = np.flatnonzero(jumps > 1)
    end = first_multi[0] if first_multi.size else jumps.size
    idx = np.flatnonzero(jumps[:end] == 1) + 1
    assert idx.size > 0, "no single impacts"
    return np.asarray(resp.extras["t_last_impact"])[idx], idx


def _free_rocking_reference(block, theta0, e, n):
    """Peaks and impact times after a release from rest at theta0 > 0 (quadrature).

    Between impacts energy is conserved, so a flight from 0 up to the peak theta_k and back
    lasts twice the fall time from rest at theta_k; an impact multiplies V by e^2.
    """
    p = float(block.p)
    peaks, times = [], [housner_time_to_impact(p, ETA, theta0)]
    theta = theta0
    for _ in range(n):
        theta = _theta_from_v(e**2 * _v(theta))
        peaks.append(theta)
        times.append(times[-1] + 2.0 * housner_time_to_impact(p, ETA, theta))
    return np.array(peaks), np.array(times[:n])


# ----------------------------------------------------------------------------- free rocking


def test_tsit5_tableau_is_diffrax_s_bit_for_bit():
    """The solver's Tsit5 coefficients are written out (tracing then needs no diffrax); they
    must be diffrax's (Tsitouras 2011), to the last bit. The fifth-order convergence test below
    checks what they do."""
    a, c, b = rj.housner.tsit5_tableau()
    tab = diffrax.Tsit5.tableau  # stage 7 (FSAL, error estimate) is not used: stages 0-5
    np.testing.assert_array_equal(c, np.concatenate([[0.0], tab.c[:-1]]))
    for i, row in enumerate(tab.a_lower[:-1]):
        np.testing.assert_array_equal(a[i + 1, : row.size], row)
        np.testing.assert_array_equal(a[i + 1, row.size :], 0.0)
    np.testing.assert_array_equal(a[0], 0.0)
    np.testing.assert_array_equal(b, tab.b_sol[:-1])
    assert tab.b_sol[-1] == 0.0


def test_tsit5_dense_output_is_diffrax_s():
    """theta_max maximises each step's dense output ``y0 + h sum_i b_i(x) k_i`` (coefficients of
    ``b_i`` in ``tsit5_dense``, 7th slope at the step's end): on one step of a damped, forced
    oscillator it must equal diffrax's Tsit5 dense solution to round-off."""
    a, c, b = rj.housner.tsit5_tableau()
    dense = rj.housner.tsit5_dense()
    mat = jnp.array([[0.0, 1.0], [-9.0, -0.3]])

    def f(t, y, args=None):
        return mat @ y + jnp.array([0.0, jnp.sin(3.0 * t)])

    t0, h, y0 = 0.2, 0.4, jnp.array([0.3, -1.1])
    k = []
    for i in range(6):
        k.append(f(t0 + c[i] * h, y0 + h * sum(a[i, j] * k[j] for j in range(i))))
    y1 = y0 + h * sum(b[i] * k[i] for i in range(6))
    k.append(f(t0 + h, y1))
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(f),
        diffrax.Tsit5(),
        t0,
        t0 + h,
        h,
        y0,
        saveat=diffrax.SaveAt(dense=True),
        stepsize_controller=diffrax.ConstantStepSize(),
    )
    for x in (0.0, 0.13, 0.5, 0.87, 1.0):
        weights = dense @ np.array([x, x**2, x**3, x**4])
        ours = y0 + h * sum(w * ki for w, ki in zip(weights, k))
        np.testing.assert_allclose(ours, sol.evaluate(t0 + x * h), rtol=SAME_RTOL, atol=1e-15)


def test_free_rocking_peaks_decay_by_e_squared_in_v(block):
    e = _e_h()
    resp = rj.simulate_housner(block, theta0=0.5 * ETA, duration=8.0, dt=1e-3)
    assert resp.theta.dtype == jnp.float64 and resp.energy.dtype == jnp.float64
    _, amp = find_peaks(np.asarray(resp.t), np.abs(np.asarray(resp.theta)))
    v = _v(np.concatenate([[0.5 * ETA], amp[:8]]))
    np.testing.assert_allclose(v[1:] / v[:-1], e**2, rtol=PEAK_V_RTOL)


def test_free_rocking_energy_drops_by_e_squared_at_each_impact(block):
    e = 0.9
    resp = rj.simulate_housner(block, e=e, theta0=0.6 * ETA, duration=30.0)
    energy = np.asarray(resp.energy)
    _, idx = _impacts(resp)
    idx = idx[np.asarray(resp.extras["pivot"])[idx] != 0]  # the last impact puts it to rest
    assert idx.size >= 20
    np.testing.assert_allclose(energy[idx] / energy[idx - 1], e**2, rtol=ENERGY_RTOL)
    # between impacts the energy stays put
    flight = slice(idx[0] + 1, idx[1] - 1)
    np.testing.assert_allclose(energy[flight], energy[idx[0]], rtol=ENERGY_RTOL)


def test_impact_times_and_peaks_match_quadrature(block):
    resp = rj.simulate_housner(block, theta0=0.5 * ETA, duration=3.0)  # default dt = 5 ms
    peaks, times = _free_rocking_reference(block, 0.5 * ETA, _e_h(), 4)
    t_imp, idx = _impacts(resp)
    np.testing.assert_allclose(t_imp[:4], times, atol=IMPACT_T_ATOL)
    # peaks "exactly" via energy: at any sample after impact k, V(peak) = E / (m g R)
    m_g_r = float(block.m * G * block.R)
    v_after = np.asarray(resp.energy)[idx[:4]] / m_g_r
    np.testing.assert_allclose(_theta_from_v(v_after), peaks, rtol=PEAK_V_RTOL)


def test_free_rocking_matches_references_table(block):
    resp = rj.simulate_housner(block, theta0=0.5 * ETA, duration=3.0)
    t_imp, idx = _impacts(resp)
    # The reference numbers use g = 9.81: compare dimensionless times p t.
    np.testing.assert_allclose(t_imp[:4] * float(block.p) / P_REF, REF_TIMES, atol=REF6_ATOL)
    m_g_r = float(block.m * G * block.R)
    peaks = _theta_from_v(np.asarray(resp.energy)[idx[:4]] / m_g_r)
    np.testing.assert_allclose(peaks / ETA, REF_PEAKS, atol=REF6_ATOL)


def test_impact_time_error_converges_at_fifth_order(block):
    # Reference: quadrature. Tsit5 is 5th order and the crossing is located on the RK
    # trajectory to higher order, so the impact-time error must fall by at least 2^4.5 per
    # halving of the step (measured: 2^4.9). A zero record with dt given fixes the solver
    # step to the record step (p dt = 0.22, 0.11, 0.05), above the automatic 0.1 bound.
    _, times = _free_rocking_reference(block, 0.5 * ETA, _e_h(), 3)
    errors = []
    for dt in (0.08, 0.04, 0.02):
        gm = rj.GroundMotion.zeros(2.5, dt)
        resp = rj.simulate_housner(block, gm, theta0=0.5 * ETA, dt=dt)
        assert float(resp.extras["dt"]) == dt
        t_imp, _ = _impacts(resp)
        errors.append(np.max(np.abs(t_imp[:3] - times)))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > 4.5), (errors, orders)


def test_free_rocking_comes_to_rest_at_the_end_of_its_zeno_sequence(block):
    # Reference: free rocking is a sequence of flights that ends at the finite (Zeno) time
    # t_Z = t_fall(theta0) + sum_k 2 t_fall(theta_k), theta_k from V(theta_k) = e^(2k) V(theta0),
    # each fall time by quadrature. The rest rule (docs/theory.md) stops the impacts once the
    # rest of the sequence, estimated with the restoring acceleration at theta = 0,
    # A = p^2 sin(eta), lasts T = 2 w / ((1 - e) A) <= REST_HORIZON dt_record / 2, w the
    # rebound speed e^n v1 (energy conservation: v1 = p sqrt(2 V(theta0))). So the block is put
    # to rest at an impact t_rest <= t_Z <= t_rest + REST_HORIZON dt_record / 2, after the
    # counted impacts.
    e, theta0 = _e_h(), 0.5 * ETA
    resp = rj.simulate_housner(block, theta0=theta0, duration=30.0)
    p, dt_rec = float(block.p), float(resp.t[1] - resp.t[0]) * REST_HORIZON
    v1 = p * math.sqrt(2.0 * _v(theta0))
    a_rest = p**2 * math.sin(ETA)
    expected = math.ceil(math.log(4.0 * v1 / ((1.0 - e) * a_rest * dt_rec)) / -math.log(e))
    n = np.asarray(resp.extras["n_impacts"])
    assert n[-1] == expected

    def fall(theta_k):  # as helpers.housner_time_to_impact, without the cancellation
        def integrand(u):
            gap = theta_k * u * u  # theta_k - theta
            rate2 = 4.0 * p**2 * math.sin(ETA - theta_k + 0.5 * gap) * math.sin(0.5 * gap)
            if u == 0.0:
                return 2.0 * math.sqrt(theta_k / (2.0 * p**2 * math.sin(ETA - theta_k)))
            return 2.0 * theta_k * u / math.sqrt(rate2)

        return quad(integrand, 0.0, 1.0, epsabs=1e-15, epsrel=1e-13, limit=200)[0]

    t_z, k = fall(theta0), 1
    while e ** (2 * k) * _v(theta0) > 1e-12 * math.sin(ETA):  # down to theta_k ~ 1e-12 rad
        t_z += 2.0 * fall(_theta_from_v(e ** (2 * k) * _v(theta0)))
        k += 1
    t_rest = float(resp.extras["t_last_impact"][-1])
    assert t_rest <= t_z <= t_rest + 0.5 * dt_rec, (t_rest, t_z)
    assert t_z - t_rest > 0.5 * e * dt_rec  # and not one impact earlier
    assert int(resp.extras["n_unresolved"]) == 0
    at_rest = np.asarray(resp.extras["pivot"]) == 0
    assert at_rest[-1] and np.all(at_rest[np.argmax(at_rest) :])  # rests for good
    assert np.all(np.asarray(resp.theta)[at_rest] == 0.0)
    assert np.all(np.asarray(resp.theta_dot)[at_rest] == 0.0)
    assert not bool(resp.overturned) and int(resp.status) == STATUS_OK


def test_release_to_the_negative_side_mirrors_the_positive_side(block):
    pos = rj.simulate_housner(block, theta0=0.4 * ETA, duration=3.0)
    neg = rj.simulate_housner(block, theta0=-0.4 * ETA, duration=3.0)
    np.testing.assert_allclose(neg.theta, -pos.theta, atol=SAME_RTOL)
    np.testing.assert_allclose(neg.d, -pos.d, atol=SAME_RTOL)


def test_displacement_of_the_top_centre(block):
    # Reference: the top centre starts at (0, h); on the +x corner (b/2, 0) it rotates
    # clockwise by theta > 0, so its x is b/2 + (-b/2) cos(theta) + h sin(theta).
    resp = rj.simulate_housner(block, theta0=0.7 * ETA, duration=3.0)
    th, b, h = np.asarray(resp.theta), float(block.b), float(block.h)
    x_top = b / 2 - b / 2 * np.cos(th) + h * np.sin(th)
    assert np.sum(th > 0) > 100
    np.testing.assert_allclose(resp.d[th > 0], x_top[th > 0], rtol=SAME_RTOL)


# ----------------------------------------------------------------------------- ground motion


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_uplift_needs_more_than_g_tan_eta(block, sign):
    # Reference: quasi-static uplift, |a_g| > g tan(eta). A sine cycle sampled at its peak.
    threshold = G * math.tan(ETA)
    kw = dict(period=1.0, dt=1e-3, duration=3.0)
    below = rj.simulate_housner(block, rj.GroundMotion.sine_cycle(sign * 0.99 * threshold, **kw))
    above = rj.simulate_housner(block, rj.GroundMotion.sine_cycle(sign * 1.01 * threshold, **kw))
    assert np.all(np.asarray(below.theta) == 0.0) and float(below.theta_max) == 0.0
    assert np.all(np.asarray(below.extras["pivot"]) == 0.0)
    assert float(above.theta_max) > 0.0
    # positive a_g (base accelerating toward +x) drives theta negative
    th = np.asarray(above.theta)
    first = th[np.flatnonzero(th)[0]]
    assert np.sign(first) == -sign


def test_vertical_acceleration_lowers_the_uplift_threshold(block):
    # Reference: uplift needs |a_g| > (g + a_gv) tan(eta); a_gv = -g/2 halves the threshold.
    base = rj.GroundMotion.sine_cycle(0.6 * G * math.tan(ETA), period=1.0, dt=1e-3, duration=3.0)
    down = rj.GroundMotion(ag=base.ag, dt=base.dt, ag_v=np.full(base.n, -0.5 * G))
    assert float(rj.simulate_housner(block, base).theta_max) == 0.0
    assert float(rj.simulate_housner(block, down).theta_max) > 0.0


@pytest.mark.parametrize("factor, overturns", [(0.995, False), (1.005, True)])
def test_rectangular_pulse_overturning_threshold(block, factor, overturns):
    # docs/verification.md, Housner (1963) numbers: eta = 0.2, p t_p = 0.5 -> psi = 2.54595
    # (nonlinear EOM, first half-cycle, so e does not matter). The pulse is built so that the
    # linear interpolation of the samples has exactly the impulse a_p t_p: N full samples
    # then zeros put the ramp's half-sample on top, (N - 1/2) dt = t_p.
    psi, n_full = 2.54595 * factor, 1000
    dt = 0.5 / float(block.p) / (n_full - 0.5)
    ag = np.zeros(int(8.0 / dt))
    ag[:n_full] = -psi * G * math.tan(ETA)  # negative: rocks toward theta > 0
    resp = rj.simulate_housner(block, rj.GroundMotion(ag=ag, dt=dt))
    assert bool(resp.overturned) is overturns
    assert np.all(np.isfinite(np.asarray(resp.theta)))
    if overturns:  # frozen after the flag, just past eta, moving outward
        th = np.asarray(resp.theta)
        i = np.flatnonzero(np.abs(th) > ETA)[0]
        assert np.all(th[i:] == th[i]) and th[i] > ETA
    else:
        assert float(resp.theta_max) < ETA


def test_theta_max_includes_peaks_between_samples(block):
    # Reference: the same forcing (the record is linear between samples) sampled every 1 ms,
    # peaks refined by find_peaks; the 20 ms run's samples alone miss the peak by 3e-4.
    gm = rj.GroundMotion.sine_cycle(1.2 * G * math.tan(ETA), period=0.8, dt=0.02, duration=6.0)
    coarse = rj.simulate_housner(block, gm)
    t_fine = np.arange((gm.n - 1) * 20 + 1) * 1e-3
    fine = rj.simulate_housner(
        block, rj.GroundMotion(ag=np.interp(t_fine, gm.t, np.asarray(gm.ag)), dt=1e-3)
    )
    _, peaks = find_peaks(np.asarray(fine.t), np.abs(np.asarray(fine.theta)))
    assert not bool(coarse.overturned) and peaks.max() > 0.1 * ETA
    np.testing.assert_allclose(float(coarse.theta_max), peaks.max(), rtol=THETA_MAX_RTOL)
    assert np.abs(np.asarray(coarse.theta)).max() < peaks.max() * (1 - 10 * THETA_MAX_RTOL)


def test_duration_pads_the_record_with_zeros(block):
    gm = rj.GroundMotion.sine_cycle(2.0 * G * math.tan(ETA), period=0.5, dt=0.01, duration=1.0)
    short = rj.simulate_housner(block, gm)
    longer = rj.simulate_housner(block, gm, duration=3.0)
    assert longer.t.shape == (301,) and short.t.shape == (101,)
    np.testing.assert_allclose(longer.theta[:101], short.theta, rtol=SAME_RTOL, atol=1e-15)


@pytest.mark.parametrize("mode", ["two_sided", "one_sided"])
def test_grad_of_a_peak_between_samples_matches_finite_differences(block, mode):
    # A one-sine cycle just above the uplift threshold (1.05 g tan(eta)), sampled every 20 ms:
    # the block makes a short flight whose peak lies between two samples (two-sided: 15 %
    # above the largest sample), so theta_max comes from a step's dense output; its turning
    # point carries no derivative, which is right only where the dense output's slope is zero.
    sign = -1.0 if mode == "one_sided" else 1.0  # one-sided: toward the uplift of theta > 0
    thr = G * math.tan(float(block.eta))
    gm = rj.GroundMotion.sine_cycle(1.05 * sign * thr, period=0.3, dt=0.02, duration=1.0)
    args = (1.0, float(block.h))

    def peak(scale, h):
        return rj.simulate_housner(rj.Block(b=block.b, h=h), gm.scaled(scale), mode=mode).theta_max

    resp = rj.simulate_housner(block, gm, mode=mode)
    assert 0.0 < float(resp.theta_max) < 1e-3 * float(block.eta)
    if mode == "two_sided":
        assert float(resp.theta_max) > 1.1 * np.abs(np.asarray(resp.theta)).max()
    grads = jax.grad(peak, argnums=(0, 1))(*args)
    for i, grad in enumerate(grads):

        def along(x, i=i):
            return peak(*args[:i], x, *args[i + 1 :])

        fd = float(_central_difference(along, args[i]))
        assert abs(fd) > 1e-6 * float(block.eta)
        np.testing.assert_allclose(float(grad), fd, rtol=FD_RTOL)


# ----------------------------------------------------------------------------- one-sided


def test_one_sided_rebounds_and_decays_by_e_squared(block):
    e_1sr = abs((1.0 - 1.5 * math.sin(ETA) ** 2) ** 2 * (1.0 - 1.5 * math.cos(ETA) ** 2))
    resp = rj.simulate_housner(block, mode="one_sided", theta0=0.5 * ETA, duration=10.0)
    th = np.asarray(resp.theta)
    assert th.min() >= -ONE_SIDED_ATOL
    assert np.all(np.asarray(resp.extras["pivot"]) >= 0)
    energy = np.asarray(resp.energy)
    _, idx = _impacts(resp)
    idx = idx[np.asarray(resp.extras["pivot"])[idx] != 0]  # the last impact puts it to rest
    assert idx.size >= 4
    np.testing.assert_allclose(energy[idx] / energy[idx - 1], e_1sr**2, rtol=ENERGY_RTOL)
    # a user-given e is used by magnitude (Eq. 5 is negative for slender walls)
    neg = rj.simulate_housner(block, mode="one_sided", e=-e_1sr, theta0=0.5 * ETA, duration=10.0)
    np.testing.assert_allclose(neg.theta, resp.theta, rtol=SAME_RTOL)


def test_one_sided_lifts_only_for_outward_acceleration(block):
    kw = dict(period=1.0, dt=1e-3, duration=3.0)
    pga = 1.5 * G * math.tan(ETA)
    # a sine cycle with a positive first half: inward, then outward (negative) half
    inward_only = rj.GroundMotion(
        ag=np.maximum(rj.GroundMotion.sine_cycle(pga, **kw).ag, 0.0), dt=kw["dt"]
    )
    outward = rj.GroundMotion.sine_cycle(-pga, **kw)
    assert float(rj.simulate_housner(block, inward_only, mode="one_sided").theta_max) == 0.0
    resp = rj.simulate_housner(block, outward, mode="one_sided")
    assert float(resp.theta_max) > 0.0 and np.asarray(resp.theta).min() >= -ONE_SIDED_ATOL


# ----------------------------------------------------------------------------- similarity


def test_scaling_size_and_pulse_together_keeps_theta_of_pt(block):
    # docs/verification.md, Similarity: theta/eta = Phi(omega_p/p, psi, eta, e). R = 1, 4 m with
    # omega_p / p = 3 and psi = 2; sampling dt scaled with 1/p so samples match in p t.
    big = rj.Block(b=4.0 * float(block.b), h=4.0 * float(block.h))
    out = []
    for blk in (block, big):
        p = float(blk.p)
        period = 2.0 * math.pi / (3.0 * p)
        gm = rj.GroundMotion.sine_cycle(
            2.0 * G * math.tan(ETA), period, dt=0.01 / p, duration=30.0 / p
        )
        out.append(np.asarray(rj.simulate_housner(blk, gm).theta) / ETA)
    assert np.max(np.abs(out[0])) > 0.3  # it rocks, with impacts
    np.testing.assert_allclose(out[0], out[1], atol=SIMILARITY_ATOL)


# ----------------------------------------------------------------------------- transforms


def _sine_records():
    kw = dict(period=0.8, dt=0.01, duration=6.0)
    amps = np.array([1.2, 1.6, 2.0]) * G * math.tan(ETA)
    return np.stack([np.asarray(rj.GroundMotion.sine_cycle(a, **kw).ag) for a in amps])


def test_jit_equals_eager(block):
    ags = _sine_records()

    def run(ag, e):
        return rj.simulate_housner(block, rj.GroundMotion(ag=ag, dt=0.01), e=e).theta

    eager = run(ags[1], 0.9)
    jitted = jax.jit(run)(jnp.asarray(ags[1]), 0.9)
    assert float(jnp.max(jnp.abs(eager))) > 0.1 * ETA
    np.testing.assert_allclose(jitted, eager, rtol=SAME_RTOL, atol=1e-15)


def test_vmap_over_records_equals_a_loop(block):
    ags = _sine_records()

    def run(ag):
        resp = rj.simulate_housner(block, rj.GroundMotion(ag=ag, dt=0.01))
        return resp.theta, resp.theta_max, resp.extras["n_impacts"]

    batched = jax.vmap(run)(jnp.asarray(ags))
    for i, ag in enumerate(ags):
        single = run(ag)
        for got, want in zip(batched, single):
            np.testing.assert_allclose(got[i], want, rtol=SAME_RTOL, atol=1e-15)


def test_vmap_over_e_and_geometry_equals_a_loop(block):
    gm = rj.GroundMotion(ag=_sine_records()[2], dt=0.01)
    es = jnp.array([0.7, 0.85, 0.95])
    bs = jnp.array([0.9, 1.0, 1.1]) * float(block.b)
    hs = jnp.array([1.1, 1.0, 0.95]) * float(block.h)

    def run(e, b, h):
        return rj.simulate_housner(rj.Block(b=b, h=h), gm, e=e).theta

    batched = jax.vmap(run)(es, bs, hs)
    assert float(jnp.max(jnp.abs(batched))) > 0.1 * ETA
    for i in range(3):
        np.testing.assert_allclose(
            batched[i], run(float(es[i]), float(bs[i]), float(hs[i])), rtol=SAME_RTOL, atol=1e-15
        )


def _central_difference(f, x):
    eps = FD_STEP * max(abs(x), 1.0)
    return (f(x + eps) - f(x - eps)) / (2.0 * eps)


def test_grad_matches_finite_differences_in_free_rocking(block):
    # theta at t = 2.5 s, after three impacts: smooth in e, b and h (impact times move).
    args = (0.9, float(block.b), float(block.h))

    def theta_at(e, b, h):
        resp = rj.simulate_housner(rj.Block(b=b, h=h), e=e, theta0=0.1, duration=3.0, dt=0.01)
        return resp.theta[250]

    grads = jax.grad(theta_at, argnums=(0, 1, 2))(*args)
    for i, grad in enumerate(grads):

        def along(x, i=i):
            return theta_at(*args[:i], x, *args[i + 1 :])

        fd = float(_central_difference(along, args[i]))
        assert abs(float(grad)) > 1e-3
        np.testing.assert_allclose(float(grad), fd, rtol=FD_RTOL)


def test_grad_and_jvp_match_finite_differences_for_record_amplitude(block):
    gm = rj.GroundMotion(ag=_sine_records()[0], dt=0.01)

    def final_energy(scale, adjoint=None):
        resp = rj.simulate_housner(block, gm.scaled(scale), adjoint=adjoint)
        return resp.energy[400]  # t = 4 s, after the pulse and several impacts

    assert int(rj.simulate_housner(block, gm).extras["n_impacts"][400]) >= 2
    fd = float(_central_difference(final_energy, 1.0))
    grad = float(jax.grad(final_energy)(1.0))
    _, tangent = jax.jvp(lambda s: final_energy(s, diffrax.ForwardMode()), (1.0,), (1.0,))
    np.testing.assert_allclose(grad, fd, rtol=FD_RTOL)
    np.testing.assert_allclose(float(tangent), fd, rtol=FD_RTOL)


def test_grad_is_zero_at_rest_and_finite_through_impacts_and_overturning(block):
    # The solver's skipped branches (a quiet pass, a step without a flight, the rest rule
    # without an impact) take part in the derivative: their values where they are not taken
    # must not reach it. At rest the peak does not depend on e or the scale at all (exactly
    # zero); rocking and overturning give finite derivatives (the latter of a frozen state).
    pulse = rj.GroundMotion.ricker(pga=1.0, period=0.5, duration=6.0, dt=0.01).ag
    threshold = G * math.tan(float(block.eta))  # [m/s^2]: the uplift acceleration

    def peak(e, scale, mode):
        gm = rj.GroundMotion(ag=scale * threshold * pulse, dt=0.01)
        r = rj.simulate_housner(block, gm, e=e, mode=mode, throw=False)
        return r.theta_max, r.overturned

    seen = set()
    for mode, scales in (("two_sided", (0.5, 1.5, 4.0)), ("one_sided", (4.0,))):
        grad = jax.jit(jax.grad(lambda e, s, mode=mode: peak(e, s, mode)[0], argnums=(0, 1)))
        for scale in scales:
            theta_max, over = peak(0.9, scale, mode)
            g = [float(x) for x in grad(0.9, scale)]
            assert all(math.isfinite(x) for x in g), (scale, mode, g)
            if float(theta_max) == 0.0:
                seen.add("rest")
                assert g == [0.0, 0.0]
            else:
                seen.add("overturned" if bool(over) else "rocking")
    assert seen == {"rest", "rocking", "overturned"}


# ----------------------------------------------------------------------------- errors, status


def test_nonfinite_record_sample_is_refused_eagerly_under_jit_and_in_a_batch(block):
    ag = np.zeros(201)
    ag[50] = np.nan  # GroundMotion rejects it when built: put in afterwards, or traced
    still = eqx.tree_at(lambda g: g.ag, rj.GroundMotion(ag=np.zeros(201), dt=0.01), ag)
    with pytest.raises(ValueError, match=r"ag of record .* non-finite"):
        rj.simulate_housner(block, still)  # at rest: the NaN would never reach the state

    def status(ag, throw):
        gm = rj.GroundMotion(ag=ag, dt=0.01)
        return rj.simulate_housner(block, gm, throw=throw).status

    assert int(jax.jit(status, static_argnums=1)(ag, False)) == STATUS_BAD_INPUT
    with pytest.raises(RuntimeError, match=r"ag \[m/s\^2\] has non-finite"):
        jax.block_until_ready(jax.jit(status, static_argnums=1)(ag, True))


def test_traced_geometry_with_too_coarse_a_step_is_flagged():
    # Tiny block (R = 1 cm, p = 27 rad/s) under a vmap over h: p is unknown when the step is
    # chosen, so p dt = 1.4 > P_DT_LIMIT is reported, not silently used.
    gm = rj.GroundMotion(ag=np.zeros(101), dt=0.05)

    def status(h):
        blk = rj.Block(b=0.004, h=h)
        return rj.simulate_housner(blk, gm, theta0=0.01, throw=False).status

    assert np.all(np.asarray(jax.vmap(status)(jnp.array([0.0199, 0.0199]))) == STATUS_UNSTABLE)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(mode="three_sided", duration=1.0), "mode"),
        (dict(e=0.0, duration=1.0), "0 < e <= 1"),
        (dict(e=1.2, duration=1.0), "0 < e <= 1"),
        (dict(e=-0.5, duration=1.0), "0 < e <= 1"),
        (dict(e=1.5, mode="one_sided", duration=1.0), r"0 < \|e\| <= 1"),
        (dict(theta0=0.25, duration=1.0), "theta0 must satisfy"),
        (dict(theta0=-0.1, mode="one_sided", duration=1.0), "one-sided"),
        (dict(theta_dot0=-0.1, mode="one_sided", duration=1.0), "return walls"),
        (dict(), "duration"),
        (dict(duration=1.0, dt=0.0), "dt must be a positive"),
        (dict(duration=1.0, dt=-0.01), "dt must be a positive"),
        (dict(duration=-1.0), "duration must be"),
        (dict(duration=1.0, max_impacts_per_step=0), "max_impacts_per_step"),
    ],
)
def test_invalid_input_raises_value_error(block, kwargs, match):
    with pytest.raises(ValueError, match=match):
        rj.simulate_housner(block, **kwargs)


def test_coarse_record_step_with_a_user_dt_raises(block):
    # p dt = 2.71 * 0.5 > P_DT_LIMIT: dt=0.5 forbids the automatic subdivision.
    gm = rj.GroundMotion(ag=np.zeros(5), dt=0.5)
    with pytest.raises(ValueError, match="too coarse"):
        rj.simulate_housner(block, gm, dt=0.5)
    assert int(rj.simulate_housner(block, gm).status) == STATUS_OK  # subdivided by default


def test_default_e_out_of_range_for_squat_block_raises():
    squat = rj.Block(b=3.0, h=1.0)  # eta = 71.6 deg: e_H = 1 - 1.5 sin^2(eta) < 0
    with pytest.raises(ValueError, match="pass e explicitly"):
        rj.simulate_housner(squat, duration=1.0)


# ----------------------------------------------------------------------------- compile once


def _pulse(n, dt):
    """A decaying sine of ``n`` samples at step ``dt`` that rocks the reference block."""
    t = np.arange(n) * dt
    ag = 1.6 * G * math.tan(ETA) * np.sin(2.0 * np.pi * t / 0.8) * np.exp(-t / 2.0)
    return rj.GroundMotion(ag=ag, dt=dt)


def test_padded_run_equals_the_unpadded_one(block):
    # An eager call pads the record to its bucket and passes its length as data; under jit the
    # record is traced and runs at its own length. Same arithmetic: equal up to rounding.
    gm = _pulse(457, 0.01)
    assert rj.compilation.bucket_length(gm.n) > gm.n
    padded = rj.simulate_housner(block, gm)
    unpadded = jax.jit(lambda ag: rj.simulate_housner(block, rj.GroundMotion(ag=ag, dt=0.01)))(
        jnp.asarray(gm.ag)
    )
    assert int(padded.extras["n_impacts"][-1]) >= 2
    assert padded.theta.shape == unpadded.theta.shape == (gm.n,)
    for got, want in zip(jax.tree.leaves(padded), jax.tree.leaves(unpadded)):
        got, want = np.asarray(got, dtype=float), np.asarray(want, dtype=float)
        assert got.shape == want.shape
        # XLA rounds the two programs differently: near the zero crossings of a series only
        # an error relative to its amplitude is meaningful.
        scale = np.max(np.abs(want[np.isfinite(want)]), initial=1.0)
        np.testing.assert_allclose(got, want, rtol=SAME_RTOL, atol=SAME_RTOL * scale)


def test_records_of_other_lengths_and_steps_do_not_compile_again(block):
    rj.simulate_housner(block, _pulse(300, 0.01))  # compiles the bucket's solver (or reuses it)
    with count_compiles() as compiles:
        for n, dt in ((311, 0.01), (520, 0.02), (1234, 0.005)):
            resp = rj.simulate_housner(block, _pulse(n, dt))
            assert resp.theta.shape == (n,) and np.asarray(resp.extras["n_impacts"])[-1] >= 1
    assert compiles == []


def test_a_compiling_call_says_so_once(block, caplog):
    # Reference: a count of XLA compilations. The notice comes with the one call that
    # compiles and says what it compiles; another record, e or block of the same kind runs
    # that program, silently.
    kw = dict(max_impacts_per_step=61)  # a configuration that no other test compiles
    with caplog.at_level(logging.INFO, logger="rockjax"), count_compiles() as compiles:
        rj.simulate_housner(block, _pulse(200, 0.01), **kw)
        n_first = len(compiles)
        rj.simulate_housner(block, _pulse(300, 0.01), e=0.9, **kw)
        rj.simulate_housner(rj.Block(b=0.2, h=1.5), _pulse(300, 0.01), **kw)
    assert n_first >= 1 and len(compiles) == n_first
    notes = [r.getMessage() for r in caplog.records if "compiling the Housner" in r.getMessage()]
    assert notes == [
        f"rockjax: compiling the Housner solver (two-sided) for records of <= "
        f"{rj.compilation.bucket_length(200)} samples (once per session: every block, e, scale "
        "and record of this kind reuses it)..."
    ]


# ----------------------------------------------------------------------------- batches, bad input


def test_bad_lanes_are_flagged_and_the_others_run_as_alone(block):
    gm = rj.GroundMotion(ag=_sine_records()[1], dt=0.01)
    b, h = float(block.b), float(block.h)

    def run(e, theta0, b):
        resp = rj.simulate_housner(rj.Block(b=b, h=h), gm, e=e, theta0=theta0, throw=False)
        return resp.status, resp.theta, resp.theta_max

    # lanes: good, e > 1, theta0 beyond eta, b = 0, b = 1e200 (inertia overflows), good
    es = jnp.array([0.9, 1.5, 0.9, 0.9, 0.9, 0.95])
    theta0s = jnp.array([0.1, 0.1, 1.5, 0.1, 0.1, -0.2]) * ETA
    bs = jnp.array([b, b, b, 0.0, 1e200, b])
    status, theta, theta_max = jax.vmap(run)(es, theta0s, bs)
    bad = STATUS_BAD_INPUT
    assert np.asarray(status).tolist() == [STATUS_OK, bad, bad, bad, bad, STATUS_OK]
    assert np.all(np.isnan(np.asarray(theta)[1:5])) and np.all(np.isnan(theta_max[1:5]))
    for i in (0, 5):
        alone = run(float(es[i]), float(theta0s[i]), b)
        assert float(alone[2]) > 0.2 * ETA
        np.testing.assert_allclose(theta[i], alone[1], rtol=SAME_RTOL, atol=1e-15)


def test_a_traced_zero_width_is_blamed_on_b_not_on_theta0(block):
    gm = rj.GroundMotion(ag=_sine_records()[1], dt=0.01)

    def status(b):
        return rj.simulate_housner(rj.Block(b=b, h=float(block.h)), gm, theta0=0.01).status

    with pytest.raises(eqx.EquinoxRuntimeError) as info:
        jax.block_until_ready(jax.vmap(status)(jnp.array([float(block.b), 0.0])))
    assert "b and h [m] must be positive" in str(info.value)
    assert "theta0 must satisfy" not in str(info.value)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(duration=1e9), r"shorter duration"),  # refused before allocating 1.6 TB
        (dict(duration="1.0"), r"duration=1\.0 without quotes"),
        (dict(duration=1.0, dt="0.01"), r"dt=0\.01 without quotes"),
        (dict(duration=1.0, e=np.array([0.9, 0.8])), r"\be\b.*vmap"),
        (dict(duration=1.0, theta0=np.array([0.01, 0.02])), r"\btheta0\b.*vmap"),
        (dict(duration=1.0, adjoint=diffrax.DirectAdjoint()), r"adjoint must be"),
    ],
)
def test_more_invalid_input_raises_value_error(block, kwargs, match, user_view):
    with pytest.raises(ValueError, match=match):
        rj.simulate_housner(block, **kwargs)


def test_a_huge_duration_with_a_record_is_refused(block):
    with pytest.raises(ValueError, match=r"duration=1e\+09 s .* shorter duration"):
        rj.simulate_housner(block, _pulse(100, 0.01), duration=1e9)


def test_an_array_for_the_motion_asks_for_a_ground_motion(block, user_view):
    with pytest.raises(ValueError, match=r"motion must be a rockjax GroundMotion.*GroundMotion\("):
        rj.simulate_housner(block, np.zeros(100))


def test_batch_runs_equals_a_loop_and_runs_one_after_another_on_cpu(block):
    # Reference: each run on its own (eager simulate_housner). batch_runs must give the same
    # answers, through lax.map (a scan in the program) on CPU and vmap elsewhere.
    dt = 0.01
    base = np.asarray(_pulse(400, dt).ag)
    scales = jnp.array([0.8, 1.0, 1.5])

    def one(s):
        r = rj.simulate_housner(block, rj.GroundMotion(ag=s * base, dt=dt), throw=False)
        return r.theta_max, r.extras["n_impacts"][-1]

    got = jax.jit(lambda xs: rj.housner.batch_runs(one, xs))(scales)
    for k, s in enumerate(np.asarray(scales)):
        want = one(float(s))
        np.testing.assert_allclose(got[0][k], want[0], rtol=1e-12, atol=0)
        assert int(got[1][k]) == int(want[1])
    assert int(got[1][-1]) >= 1  # it rocks and impacts
    jaxpr = str(jax.make_jaxpr(lambda xs: rj.housner.batch_runs(one, xs))(scales))
    assert ("scan" in jaxpr) == (jax.default_backend() == "cpu")
