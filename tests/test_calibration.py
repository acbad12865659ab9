"""rockjax.calibration: fit_beta against the dense-grid optimum, reachability, fit_e round trip,
and the promise of a result: refusals before the optimisation, ``converged`` only when the target
is met (checked here with a peak finder of this file, independent of the code's two).

One parapet (the paper's 0.25 x 3 m) and one facade (0.2 x 1.5 m) so the compiled problems are
shared; the benchmark (benchmarks/bench_calibrate.py) covers 6 geometries x 3 targets x 5 starts.
Tolerances: docs/verification.md, Calibration.
"""

import logging
import math

import jax
import numpy as np
import pytest
from helpers import count_compiles
from scipy.signal import find_peaks

import rockjax as rj
from rockjax import calibration

BLOCK = rj.Block(b=0.25, h=3.0)
BDJ = float(rj.beta_dejong(BLOCK))
E_TARGET = 0.95
FACADE = rj.Block(b=0.2, h=1.5)
E_ISR = abs(float(rj.e_isr(FACADE)))  # 0.4493: Eq. 5 for this facade
PEAK_TOL = 2e-4  # this file's peaks vs the code's: parabola through 3 samples of a 2 ms history


def _bounces(resp, mode):
    """Bounce amplitudes [rad] from the saved history, by scipy's prominence (a bounce rises from
    a valley near the wall: prominence >= half its height), parabola-refined; independent of
    rockjax's own peak finders."""
    th = np.asarray(resp.theta)
    y = np.abs(th) if mode == "two_sided" else np.maximum(th, 0.0)
    idx, props = find_peaks(y, prominence=0.0)
    idx = idx[(props["prominences"] >= 0.5 * y[idx]) & (y[idx] > 1e-3 * float(resp.eta))]
    y0, y1, y2 = y[idx - 1], y[idx], y[idx + 1]
    s = np.clip(0.5 * (y0 - y2) / np.minimum(y0 - 2 * y1 + y2, -1e-300), -1, 1)
    return y1 - 0.25 * (y0 - y2) * s


def _e_least_squares(resp, mode, n):
    """Least-squares e of U_k = e^(2k) U_0 over the first n bounces keeping 2 % of U_0."""
    eta, th0 = float(resp.eta), abs(float(resp.theta[0]))
    amp = _bounces(resp, mode)[:n]
    ratio = (np.cos(eta - amp) - np.cos(eta)) / (np.cos(eta - th0) - np.cos(eta))
    k = 2.0 * np.arange(1, amp.size + 1)[ratio >= 0.02]
    y = np.log(ratio[ratio >= 0.02])
    return math.exp(np.sum(k * y) / np.sum(k * k)) if k.size else math.nan


@pytest.fixture(scope="module")
def grid_fit():
    return rj.fit_beta(BLOCK, e=E_TARGET, method="grid", n_grid=128)


@pytest.mark.parametrize("start", [0.0, 1.6])
def test_gradient_fit_lands_on_grid_optimum_from_spread_starts(grid_fit, start):
    """Within 2 % (in beta) of the dense-grid optimum, and the DEM's own e (peaks found in
    NumPy, an independent path from the loss) within E_TOL = 2e-3 of the target."""
    fit = rj.fit_beta(BLOCK, e=E_TARGET, beta0=start * BDJ)
    assert fit.converged
    assert abs(fit.beta - grid_fit.beta) / grid_fit.beta < 0.02
    assert abs(fit.e_effective - E_TARGET) < 2e-3
    assert fit.loss <= grid_fit.loss + 1e-8  # |log-gap| within 1e-4 of the grid best
    assert fit.history["beta"].shape == fit.history["loss"].shape
    assert fit.n_simulations >= fit.n_iterations


def test_root_find_baseline_agrees(grid_fit):
    fit = rj.fit_beta(BLOCK, e=E_TARGET, method="root")
    assert abs(fit.beta - grid_fit.beta) / grid_fit.beta < 0.02
    assert fit.n_simulations < 20
    # every exit path keeps the promise: converged means the target is met, measured here
    for f in (grid_fit, fit):
        assert f.converged and f.reason == ""
        assert abs(_e_least_squares(f.dem, "two_sided", 8) - E_TARGET) <= calibration.E_TOL


def test_seeded_default_fit_and_range(grid_fit):
    fit = rj.fit_beta(BLOCK, e=E_TARGET)
    assert abs(fit.beta - grid_fit.beta) / grid_fit.beta < 0.02
    lo, hi = fit.e_range
    # the paper's intercept question: at beta = 0 this DEM is nearly elastic (e ~ 1), not e_H
    # (0.990); beta_max = 2 beta_DeJong reaches far below the target (measured 0.851)
    assert hi > 0.999 and lo < E_TARGET - 0.05
    # the paper's weighted-mean history error is reported
    assert np.isfinite(fit.history_error) and fit.history_error > 0.0


def test_second_identical_fit_neither_traces_nor_compiles(caplog):
    """A second identical fit in one process reuses every compiled program: nothing is traced
    or compiled again, not even a small eager operation (``jax.log_compiles`` logs each)."""
    first = rj.fit_beta(BLOCK, e=E_TARGET)
    with jax.log_compiles(True), caplog.at_level(logging.DEBUG, logger="jax"):
        again = rj.fit_beta(BLOCK, e=E_TARGET)
    work = [
        r.getMessage()
        for r in caplog.records
        if r.getMessage().startswith(("Finished tracing", "Finished XLA compilation"))
    ]
    assert work == []
    assert again.beta == first.beta


def test_a_fit_of_another_geometry_in_the_bucket_compiles_nothing_and_says_nothing(caplog):
    """A loop over geometries compiles the fit's programs once per bucket of run durations.
    Reference: a count of XLA compilations (cache hits included). The notice comes with a
    fit that compiles, and only then."""
    first, other = rj.Block(b=0.2, h=1.5), rj.Block(b=0.18, h=1.8)  # h/b 7.5 and 10
    with caplog.at_level(logging.INFO, logger="rockjax"), count_compiles() as compiles:
        fit_a = rj.fit_beta(first, e=E_TARGET)
    noted = [r for r in caplog.records if "compiling the parapet calibration" in r.getMessage()]
    assert len(noted) == (1 if compiles else 0)
    caplog.clear()
    with caplog.at_level(logging.INFO, logger="rockjax"), count_compiles() as compiles:
        fit_b = rj.fit_beta(other, e=E_TARGET)
    # the same bucket: both free-rocking runs last as long
    assert fit_b.dem.t[-1] == fit_a.dem.t[-1]
    assert compiles == []
    assert not [r for r in caplog.records if "compiling" in r.getMessage()]
    assert fit_b.converged and abs(fit_b.beta - fit_a.beta) > 1e-5  # a fit of its own


def test_history_error_small_for_corner_contacts_only(grid_fit):
    """The paper's history error (Eq. 8) at a fitted beta is small for its model, two corner
    contacts (measured 0.155), which pivot on the corner as Housner's block does; on the
    converged joint (the default) the same bounce energies come with a longer rocking period
    (the contact triangle's resultant lies inside the corner; docs/verification.md), so the
    histories drift out of phase (measured 0.974)."""
    corners = rj.Joint(n_sub=2)
    fit = rj.fit_beta(BLOCK, e=E_TARGET, joint=corners)
    assert fit.converged and fit.history_error < 0.3
    assert grid_fit.history_error > 0.5


def test_unreachable_target_names_the_range():
    with pytest.raises(ValueError, match=r"not reachable.*spans e = 0\.\d+ .* to (0\.99|1\.00)"):
        rj.fit_beta(BLOCK, e=0.5)
    with pytest.raises(ValueError, match="not reachable"):
        rj.fit_beta(BLOCK, e=1.0)
    # with corner contacts the clipped dashpot saturates near 0.96 (docs/verification.md,
    # Calibration); on the converged joint it reaches 0.907 at 2 beta_DeJong
    with pytest.raises(ValueError, match=r"spans e = 0\.9[67]\d+ .*clipped.*saturates"):
        rj.fit_beta(BLOCK, e=0.95, joint=rj.Joint(n_sub=2, dashpot="clipped"))


def test_bad_input():
    with pytest.raises(ValueError, match="needs the target restitution"):
        rj.fit_beta(BLOCK)
    with pytest.raises(ValueError, match="theta0"):
        rj.fit_beta(BLOCK, e=0.95, theta0=2 * float(BLOCK.eta))
    with pytest.raises(ValueError, match="one_sided"):
        rj.fit_beta(BLOCK, target="bounces")
    with pytest.raises(ValueError, match="method"):
        rj.fit_beta(BLOCK, e=0.95, method="adam")


def test_fit_e_round_trip(grid_fit):
    """The paper's direction and back: fit_e at the grid beta returns the target e (within
    E_TOL), and its Housner e matches the DEM's own e."""
    fe = rj.fit_e(BLOCK, beta=grid_fit.beta)
    assert abs(fe.e - E_TARGET) < calibration.E_TOL
    assert abs(fe.e - fe.e_effective) < calibration.E_TOL
    assert fe.converged and fe.reason == ""


def test_e_effective_is_smooth_and_monotone():
    """With sub-step contact onsets e(beta) is monotone even on a fine beta scale (1e-3
    beta_DeJong steps), which a gradient method needs; its beta = 0 value is ~1."""
    betas = 0.3 * BDJ + np.arange(9) * 1e-3 * BDJ
    out = rj.calibration.e_effective(BLOCK, np.concatenate([[0.0], betas]))
    assert out["ok"].all()
    assert abs(out["e"][0] - 1.0) < 1e-3
    assert np.all(np.diff(out["e"][1:]) < 0)


TWIN = {"beta": 0.004, "b": 0.23}  # the "measured" block of the twin experiment (3 m parapet)


def _twin(dt=None):
    """A free-rocking DEM history at TWIN plus 1e-4 rad of noise (the release kept exact)."""
    import equinox as eqx
    import jax.numpy as jnp

    true = rj.Block(b=TWIN["b"], h=3.0)
    theta0 = 0.5 * float(BLOCK.eta)
    meas = rj.simulate_dem(
        true, beta=TWIN["beta"], theta0=theta0, duration=8.0, save_dt=0.005, dt=dt
    )
    noise = np.random.default_rng(0).normal(0, 1e-4, meas.theta.shape)
    noise[0] = 0.0
    return eqx.tree_at(lambda r: r.theta, meas, meas.theta + jnp.asarray(noise))


@pytest.fixture(scope="module")
def twin():
    """The twin history at the step the fit uses (like with like: at the default step of
    1.25 ms the DEM's restitution differs by up to the step rule's 1e-3, which moves the
    fitted beta by ~2 %), and its problem."""
    dt = calibration.history_problem(BLOCK, _twin(), 0.002).dt
    meas = _twin(dt)
    return meas, calibration.history_problem(BLOCK, meas, 0.002)


def _at(problem, beta, b):
    return np.array([math.log(beta / float(problem.beta_ref)), math.log(b / float(BLOCK.b))])


def test_history_loss_has_no_cliff_at_the_record_end(twin):
    """A trial whose last compared bounce comes after the measured one is still compared: the
    DEM runs past the record. When it stopped at the record's end, the loss jumped from 0.015
    to 4.52 between b = 0.245 and 0.244 m (beta = 2 ms) and L-BFGS stopped at that cliff with
    converged=True."""
    meas, problem = twin
    assert problem.duration > float(meas.t[-1])
    a, b = (
        float(calibration.history_loss(jax.numpy.asarray(_at(problem, 0.002, w)), problem))
        for w in (0.244, 0.245)
    )
    assert a < 0.05 and b < 0.05 and abs(a - b) < 0.01


def test_history_verdict_needs_the_measured_peaks_matched(twin):
    """converged of fit_history is measured: the DEM at the true parameters matches the noisy
    history within HISTORY_TOL; the loss valley's point (b, beta) = (0.245 m, 2 ms), where
    L-BFGS used to stop, misses by 0.12 (docs/calibration.md). The NumPy peak finder does not
    count a noise maximum on the release's flight as a bounce (it did: 7 bounces for 6)."""
    meas, problem = twin
    clean = rj.simulate_dem(
        rj.Block(b=TWIN["b"], h=3.0),
        beta=TWIN["beta"],
        theta0=float(meas.theta[0]),
        duration=8.0,
        save_dt=0.005,
        dt=problem.dt,
    )
    assert calibration.bounce_peaks(meas, "two_sided")[0].size == _bounces(clean, "two_sided").size
    n = int(np.sum(rj.metrics.bounce_weights(problem.measured)[0]))
    assert n == 6
    t_scale = float(problem.t_scale)
    assert calibration.history_missed(clean, meas, n, t_scale, "two_sided") == []
    off = rj.simulate_dem(
        rj.Block(b=0.245, h=3.0),
        beta=0.002,
        theta0=float(meas.theta[0]),
        duration=8.0,
        save_dt=0.005,
        dt=problem.dt,
    )
    (why,) = calibration.history_missed(off, meas, n, t_scale, "two_sided")
    assert "HISTORY_TOL" in why


def test_fit_history_runs_as_a_user_calls_it(twin):
    """One iteration of the two-parameter fit, called eagerly (the whole fit, against its
    twin, is the slow test below): a result with finite parameters, no convergence claimed
    after one step, and the DEM at the result over the measured record."""
    meas, _ = twin
    fit = rj.fit_history(BLOCK, meas, beta0=0.002, max_iter=1)
    assert isinstance(fit, calibration.HistoryFit)
    assert np.isfinite(fit.beta) and np.isfinite(fit.b) and fit.n_iterations <= 1
    assert not fit.converged and fit.reason
    assert float(fit.dem.t[-1]) == pytest.approx(float(meas.t[-1]))


@pytest.mark.slow
def test_fit_history_recovers_two_parameters(twin):
    """Twin experiment: the noisy history at (beta, b) = (0.004 s, 0.23 m) fitted from the
    nominal b = 0.25 m and beta0 = 0.002 s; both come back within 1 % (measured 0.25 % and
    0.17 %), and converged=True is the measured verdict."""
    meas, _ = twin
    fit = rj.fit_history(BLOCK, meas, beta0=0.002)
    assert fit.converged, fit.reason
    assert abs(fit.beta / TWIN["beta"] - 1) < 0.01
    assert abs(fit.b / TWIN["b"] - 1) < 0.01


# --------------------------------------------------------------------------- what a result promises


def test_one_sided_defaults_to_the_bounce_targets():
    """A facade's default target is its measured bounces; an e needs target='e' explicitly
    (this call used to return beta = 1.8e-7 s, loss 0, converged=True)."""
    assert calibration.default_target("one_sided") == "bounces"
    assert calibration.default_target("two_sided") == "e"
    with pytest.raises(ValueError, match=r"target='bounces'.*target='e'"):
        rj.fit_beta(FACADE, e=E_ISR, mode="one_sided")


def test_one_sided_housner_reference_bounces_are_found():
    """Housner's one-sided impacts are instantaneous, so a 2 ms sample rarely lies on the wall;
    the loss's peak finder must still cut the history there. Exact: U_k = e^(2k) U_0, so the
    least-squares e of the reference is e (to the peak refinement, 2e-5). The reference used
    to show no bounce at all, which made a facade's target='e' loss identically zero."""
    import jax

    ref = calibration.problem(FACADE, 0.6, target="e", mode="one_sided", n_bounces=3).ref
    assert bool(np.all(ref.valid))
    assert abs(float(np.exp(jax.vmap(rj.metrics.log_e_fit)(ref))[0]) - 0.6) < 2e-5


def test_refused_before_any_optimisation():
    """n_bounces < 1 (used to report converged with e_effective NaN), and a target e whose
    Housner reference keeps no bounce with 2 % of its energy (e^2 < 0.02: the loss would be
    identically zero, and used to 'converge')."""
    for call in (
        lambda: rj.fit_beta(BLOCK, e=E_TARGET, n_bounces=0),
        lambda: rj.fit_e(BLOCK, beta=0.3 * BDJ, n_bounces=0),
        lambda: calibration.e_effective(BLOCK, 0.3 * BDJ, n_bounces=-1),
    ):
        with pytest.raises(ValueError, match="n_bounces"):
            call()
    with pytest.raises(ValueError, match=r"no informative bounce.*target='bounces'"):
        rj.fit_beta(FACADE, e=0.1, target="e", mode="one_sided")
    with pytest.raises(ValueError, match="no informative bounce"):
        rj.fit_beta(BLOCK, e=0.12)


@pytest.mark.parametrize(
    ("e", "beta_max_hcrit"),
    [(E_ISR, None), (0.99, 1.5), (0.55, 1.5)],
    ids=["e_isr-default-range", "above-range", "e0.55-narrow-range"],
)
def test_facade_target_e_meets_its_tolerance_or_raises(e, beta_max_hcrit):
    """target='e' on a facade: a ValueError naming the fix, or a result whose converged flag
    tells the truth about |e_DEM - e| <= E_TOL, the DEM's e measured here from its history.
    (e = |e_ISR| and e = 0.99 used to return converged=True with e_effective 0.644, loss 0.)"""
    bmax = None if beta_max_hcrit is None else beta_max_hcrit * float(rj.beta_hcrit(FACADE))
    try:
        fit = rj.fit_beta(FACADE, e=e, target="e", mode="one_sided", beta_max=bmax, method="root")
    except ValueError as err:
        assert "target='bounces'" in str(err)
        # |e_ISR| lies in this DEM's reachable range: the fit finds its own bracket (it used to
        # refuse at the default beta_max, "the reachable range of e is undefined")
        assert beta_max_hcrit is not None, err
        return
    e_here = _e_least_squares(fit.dem, "one_sided", 3)
    assert all(np.isfinite(x) for x in (fit.beta, fit.loss, *fit.e_range))
    assert abs(e_here - fit.e_effective) <= PEAK_TOL or not np.isfinite(e_here)
    if fit.converged:
        assert abs(e_here - e) <= calibration.E_TOL + PEAK_TOL
    else:  # and not converged only when the target is missed, measured here
        assert "max_iter" in fit.reason or not abs(e_here - e) <= calibration.E_TOL - PEAK_TOL
        assert "e_effective" in fit.reason or "max_iter" in fit.reason


def test_verdict_rule():
    """converged needs finite numbers, the stopping rule and the target within tolerance."""
    assert calibration.verdict(True, [], loss=0.0, beta=1e-3) == (True, "")
    ok, why = calibration.verdict(True, [], loss=math.nan, beta=1e-3)
    assert not ok and "loss is not finite" in why
    assert not calibration.verdict(False, [], loss=0.0)[0]
    assert calibration.e_missed(0.95, 0.95 + 0.9 * calibration.E_TOL) == []
    assert calibration.e_missed(0.95, 0.95 + 1.1 * calibration.E_TOL)
    assert calibration.e_missed(0.95, math.nan)
    # the measured bands of bounces 1 and 2 (the paper, Sect. 2.2; docs/verification.md)
    assert calibration.BOUNCE_BANDS[:2] == ((0.64, 0.72), (0.74, 0.86))
    mid = np.asarray(calibration.BOUNCE_FRACTIONS) * E_ISR
    assert calibration.bounces_missed(mid, -E_ISR) == []
    assert len(calibration.bounces_missed(mid * [0.9, 1.0, math.nan], E_ISR)) == 2


def test_target_e_finds_its_own_bracket_and_refuses_only_outside_the_range():
    """At the default beta_max the facade's bounces vanish long before (~2.5 beta_Hcrit): the
    fit cuts its bracket where the DEM still bounces, and refuses an e outside the reachable
    range naming it. The range's ends are the DEM's own e, measured here with scipy's peaks."""
    with pytest.raises(ValueError, match=r"spans e = 0\.\d+ \(beta = .* s\) to 0\.\d+") as err:
        rj.fit_beta(FACADE, e=0.99, target="e", mode="one_sided", method="root")
    assert "keeps no bounce" in str(err.value) and "widen beta_max" not in str(err.value)
    fit = rj.fit_beta(FACADE, e=E_ISR, target="e", mode="one_sided", method="root")
    e_lo, e_hi = fit.e_range
    assert e_lo < E_ISR < e_hi and fit.beta < fit.beta_max
    bh = float(rj.beta_hcrit(FACADE))
    assert fit.beta_max < 0.5 * calibration.FACADE_BETA_MAX_HCRIT * bh  # cut at the edge
    edge = calibration.dem_run(
        calibration.problem(FACADE, E_ISR, target="e", mode="one_sided"), fit.beta_max
    )
    assert abs(_e_least_squares(edge, "one_sided", 3) - e_lo) <= 10 * PEAK_TOL
    if fit.converged:
        e_here = _e_least_squares(fit.dem, "one_sided", 3)
        assert abs(e_here - E_ISR) <= calibration.E_TOL + PEAK_TOL


STEP = 0.01  # relative beta step of the local parabola that checks a minimum
MIN_BETA_RTOL = 0.01  # a fit's beta vs the vertex of that parabola (the grid benchmark's is 2 %)


def _vertex(y_lo, y_mid, y_hi):
    """The vertex of the parabola through (1 - STEP, 1, 1 + STEP) in units of the middle beta;
    +-inf where it is not a minimum (no curvature or a maximum)."""
    den = y_lo - 2.0 * y_mid + y_hi
    return 1.0 + 0.5 * STEP * (y_lo - y_hi) / den if den > 0 else math.inf


@pytest.fixture(scope="module")
def facade_fit():
    return rj.fit_beta(FACADE, mode="one_sided")


def test_facade_default_is_the_best_match_and_reports_the_bands(facade_fit):
    """The paper chose the beta that best matched the measured bounce pattern: the default
    facade fit converges to the minimum of its loss (here: within 1 % of the vertex of the
    parabola through the loss 1 % either side),
    and target_met says whether each e_exp (scipy peaks here) lies in its band. In this DEM no
    beta meets all three (docs/calibration.md, "Facades"): it used to report NOT converged."""
    fit = facade_fit
    assert fit.converged and fit.reason == ""
    p = calibration.problem(FACADE, mode="one_sided")
    side = np.asarray(calibration.stats_batch(p, fit.beta * np.array([1 - STEP, 1 + STEP]))[0])
    assert abs(_vertex(side[0], fit.loss, side[1]) - 1.0) <= MIN_BETA_RTOL
    amp = _bounces(fit.dem, "one_sided")[:3]
    eta, th0 = float(FACADE.eta), abs(float(fit.dem.theta[0]))
    e_here = rj.relations.e_exp(amp, th0, eta, np.arange(1, amp.size + 1)) / E_ISR
    np.testing.assert_allclose(np.asarray(fit.e_exp) / E_ISR, e_here, atol=5e-3)
    met = all(lo <= r <= hi for r, (lo, hi) in zip(e_here, calibration.BOUNCE_BANDS))
    assert fit.target_met == met and (fit.target_missed == "") == met
    assert "best match" in repr(fit) or met


@pytest.mark.slow  # 55-70 s: the facade's whole walk; ./test.sh -m slow
def test_facade_best_match_walks_off_a_shoulder():
    """On the 0.1 x 1 m facade L-BFGS stopped on a shoulder of the loss, 3.4 % of beta short of
    its minimum at a loss 7.5 % higher, and reported converged (docs/calibration.md,
    "Facades"); the walk to a local minimum now ends there: within 1 % of the vertex of the
    parabola through the loss 1 % either side, computed here."""
    facade = rj.Block(b=0.1, h=1.0)
    fit = rj.fit_beta(facade, mode="one_sided", progress=False)
    assert fit.converged
    p = calibration.problem(facade, mode="one_sided")
    side = np.asarray(calibration.stats_batch(p, fit.beta * np.array([1 - STEP, 1 + STEP]))[0])
    assert fit.loss <= side.min()
    assert abs(_vertex(side[0], fit.loss, side[1]) - 1.0) <= MIN_BETA_RTOL


def test_response_e_exp_is_the_fits_bounce_finder(facade_fit):
    """Response.e_exp used to count a facade's wall chatter as bounces (0.334 / 0.214 / 0.506
    where the fit gave 0.334 / 0.360 / 0.405): one finder now, the mode read from the history."""
    dem = facade_fit.dem
    assert rj.response.rocking_mode(dem) == "one_sided"
    np.testing.assert_array_equal(dem.e_exp(3), facade_fit.e_exp)
    amp = _bounces(dem, "one_sided")[:3]  # scipy's prominence, independent of both
    np.testing.assert_allclose(dem.bounces()[1][:3], amp, rtol=0, atol=PEAK_TOL * float(FACADE.eta))


def test_history_loss_input_checks():
    with pytest.raises(ValueError, match="method='lbfgs'"):
        rj.fit_beta(BLOCK, e=E_TARGET, loss="history", method="grid")
    with pytest.raises(ValueError, match="target='e'"):
        rj.fit_beta(FACADE, mode="one_sided", target="bounces", loss="history")
    with pytest.raises(ValueError, match="loss"):
        rj.fit_beta(BLOCK, e=E_TARGET, loss="energy")


@pytest.mark.slow
def test_history_loss_finds_the_nearby_minimum_on_a_facade():
    """loss='history' from the bounce-loss optimum ends at a local minimum of the history
    error against one-sided Housner with |e_ISR|: within 1 % of the vertex of the parabola
    through the error 1 % either side (history_stat_batch)."""
    fit = rj.fit_beta(FACADE, mode="one_sided", loss="history")
    assert fit.converged and fit.loss_kind == "history"
    p = calibration.problem(FACADE, E_ISR, target="e", mode="one_sided")
    side = np.asarray(calibration.history_stat_batch(p, fit.beta * np.array([1 - STEP, 1 + STEP])))
    assert abs(_vertex(side[0], fit.loss, side[1]) - 1.0) <= MIN_BETA_RTOL
