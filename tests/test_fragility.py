"""Tests of rockjax.fragility on synthetic data drawn from a known lognormal fragility.

Independent references: the true (theta, sigma) the data were drawn from, with tolerances from
the asymptotic standard errors (Fisher information, computed here with scipy.stats); and a
scipy.optimize maximisation of the same probit likelihood for the estimator itself.
"""

import dataclasses
import math

import numpy as np
import pytest
import xarray as xr
from scipy import optimize, stats

import rockjax as rj  # noqa: F401  (float64 and package import order)
from rockjax.fragility import Fragility, fragility

THETA, SIGMA = 3.0, 0.4  # true median [m/s^2] and log standard deviation [-]
N_REC, N_SCALE = 200, 20
N_SE = 4.0
"""Recovery tolerance in asymptotic standard errors: a 4-sigma miss has probability ~6e-5."""
REF_RTOL = 1e-6
"""Newton vs scipy Nelder-Mead (xatol 1e-10) on the same likelihood: both converged optima."""
N_BOOT = 200  # enough for a 90% interval to a few percent of its width, and fast


def _dataset(collapse, im, status=None):
    n_rec, n_scale = collapse.shape
    status = np.zeros(collapse.shape, np.int32) if status is None else status
    dims = ("record", "scale")
    return xr.Dataset(
        {
            "collapse": (dims, collapse),
            "status": (dims, status),
            "pga_scaled": (dims, im, {"units": "m/s^2"}),
        },
        coords={"record": [f"r{i}" for i in range(n_rec)], "scale": np.arange(1, n_scale + 1.0)},
    )


def _bernoulli(seed=1, n_rec=N_REC):
    """Every run an independent Bernoulli draw with P = Phi(ln(IM/THETA)/SIGMA)."""
    rng = np.random.default_rng(seed)
    pga = rng.uniform(2.0, 4.0, n_rec)
    im = pga[:, None] * np.linspace(0.1, 2.0, N_SCALE)[None, :]
    p = stats.norm.cdf(np.log(im / THETA) / SIGMA)
    return _dataset(rng.random(im.shape) < p, im)


def _fisher_se(im, mu, sigma):
    """Asymptotic standard errors of (mu, sigma) for the probit likelihood at these IMs."""
    z = (np.log(im.ravel()) - mu) / sigma
    p = stats.norm.cdf(z)
    wgt = stats.norm.pdf(z) ** 2 / (p * (1 - p))
    grad = np.stack([-np.ones_like(z), -z]) / sigma  # d z / d(mu, sigma)
    info = (grad * wgt) @ grad.T
    return np.sqrt(np.diag(np.linalg.inv(info)))


@pytest.fixture(scope="module")
def bern():
    ds = _bernoulli()
    return ds, fragility(ds, n_boot=N_BOOT, seed=0)


def test_mle_recovers_truth_within_sampling_error(bern):
    ds, frag = bern
    se_mu, se_sigma = _fisher_se(np.asarray(ds.pga_scaled), math.log(THETA), SIGMA)
    assert abs(math.log(frag.median) - math.log(THETA)) < N_SE * se_mu
    assert abs(frag.beta_log - SIGMA) < N_SE * se_sigma
    assert isinstance(frag, Fragility) and frag.method == "mle"
    assert (frag.n_records, frag.n_runs, frag.n_no_collapse) == (N_REC, N_REC * N_SCALE, 0)
    assert frag.im == "pga_scaled" and frag.im_units == "m/s^2"


def test_mle_matches_scipy_maximisation(bern):
    ds, frag = bern
    x = np.log(np.asarray(ds.pga_scaled)).ravel()
    s = np.where(np.asarray(ds.collapse).ravel(), 1.0, -1.0)

    def nll(q):
        return -np.sum(stats.norm.logcdf(s * (x - q[0]) / q[1]))

    ref = optimize.minimize(
        nll, [1.0, 0.5], method="Nelder-Mead", options=dict(xatol=1e-10, fatol=1e-12)
    )
    np.testing.assert_allclose(frag.median, math.exp(ref.x[0]), rtol=REF_RTOL)
    np.testing.assert_allclose(frag.beta_log, ref.x[1], rtol=REF_RTOL)


def test_bootstrap_ci_contains_truth_and_is_deterministic(bern):
    ds, frag = bern
    lo, hi = frag.median_ci
    assert lo < frag.median < hi and lo < THETA < hi
    lo, hi = frag.beta_log_ci
    assert lo < frag.beta_log < hi and lo < SIGMA < hi
    # a 90% interval spans about 2 x 1.645 standard errors (the runs of a record are
    # independent here, so resampling records matches the Fisher error to bootstrap noise)
    se_mu, _ = _fisher_se(np.asarray(ds.pga_scaled), math.log(THETA), SIGMA)
    width = math.log(frag.median_ci[1] / frag.median_ci[0])
    assert 0.6 < width / (2 * 1.645 * se_mu) < 1.6
    again = fragility(ds, n_boot=N_BOOT, seed=0)
    assert again == frag
    np.testing.assert_array_equal(again.boot_median, frag.boot_median)
    other = fragility(ds, n_boot=N_BOOT, seed=1)
    assert other.median == frag.median and other.median_ci != frag.median_ci
    assert frag.n_boot_failed == 0 and frag.boot_median.size == N_BOOT


def test_no_bootstrap_gives_nan_intervals():
    frag = fragility(_bernoulli(n_rec=20), n_boot=0)
    assert all(math.isnan(v) for v in frag.median_ci + frag.beta_log_ci)
    lo, hi = frag.prob_band(np.array([1.0, 3.0]))
    assert np.all(np.isnan(lo)) and np.all(np.isnan(hi))


def test_result_is_immutable(bern):
    _, frag = bern
    with pytest.raises(dataclasses.FrozenInstanceError):
        frag.median = 1.0
    with pytest.raises(ValueError):
        frag.boot_median[0] = 1.0


def test_prob_monotone_and_anchored(bern):
    _, frag = bern
    im = np.linspace(0.0, 20.0, 401)
    p = frag.prob(im)
    assert p.shape == im.shape and p.dtype == np.float64
    assert np.all(np.diff(p) >= 0) and p[0] == 0.0 and p[-1] > 0.999
    np.testing.assert_allclose(frag.prob(frag.median), 0.5, rtol=1e-14)
    ref = stats.norm.cdf(np.log(im[1:] / frag.median) / frag.beta_log)
    np.testing.assert_allclose(p[1:], ref, rtol=1e-12, atol=1e-300)
    lo, hi = frag.prob_band(im[1:])
    assert np.all(lo <= hi) and np.all(np.diff(lo) >= 0) and np.all(np.diff(hi) >= 0)


def _capacities(seed=2, n_rec=400):
    """Monotone IDA: record i collapses at every IM above a lognormal capacity."""
    rng = np.random.default_rng(seed)
    cap = THETA * np.exp(SIGMA * rng.standard_normal(n_rec))
    im = np.broadcast_to(np.geomspace(0.5, 20.0, 371), (n_rec, 371))  # ratio 1.01
    return _dataset(im >= cap[:, None], np.array(im)), cap


def test_first_collapse_method_of_moments():
    ds, cap = _capacities()
    frag = fragility(ds, first_collapse=True, n_boot=N_BOOT)
    n = cap.size
    # first collapse IM is the first grid IM >= capacity: at most one log step (0.01) high
    step = math.log(1.01)
    se_mu, se_sigma = SIGMA / math.sqrt(n), SIGMA / math.sqrt(2 * (n - 1))
    assert abs(math.log(frag.median / THETA)) < N_SE * se_mu + step
    assert abs(frag.beta_log - SIGMA) < N_SE * se_sigma + step
    # the estimator itself: moments of the first grid IM at or above each capacity
    first = np.log(np.asarray(ds.pga_scaled))[np.arange(n), np.argmax(np.asarray(ds.collapse), 1)]
    np.testing.assert_allclose(math.log(frag.median), first.mean(), rtol=1e-12)
    np.testing.assert_allclose(frag.beta_log, first.std(ddof=1), rtol=1e-12)
    assert frag.method == "first_collapse" and frag.n_records == n
    assert frag.median_ci[0] < THETA < frag.median_ci[1]
    assert frag.beta_log_ci[0] < SIGMA < frag.beta_log_ci[1]
    # on monotone data the per-run likelihood targets the same fragility
    mle = fragility(ds, n_boot=0)
    assert abs(math.log(mle.median / frag.median)) < N_SE * se_mu + step


def test_first_collapse_skips_records_without_collapse_and_resurrection():
    ds, _ = _capacities(n_rec=50)
    col = np.asarray(ds.collapse).copy()
    col[0] = False  # never collapses in the range
    col[1, -5:] = False  # "resurrection" at the top scales: the first collapse is unchanged
    frag = fragility(ds.assign(collapse=(("record", "scale"), col)), first_collapse=True, n_boot=0)
    ref = fragility(ds.isel(record=slice(1, None)), first_collapse=True, n_boot=0)
    assert frag.n_no_collapse == 1 and frag.n_records == 49
    np.testing.assert_allclose([frag.median, frag.beta_log], [ref.median, ref.beta_log])


def test_failed_runs_are_left_out():
    ds = _bernoulli(n_rec=30)
    status = np.zeros(ds.collapse.shape, np.int32)
    status[::3, ::2] = 1
    col = np.asarray(ds.collapse).copy()
    col[status == 1] = ~col[status == 1]  # garbage in the failed runs must not matter
    bad = ds.assign(collapse=(("record", "scale"), col), status=(("record", "scale"), status))
    frag = fragility(bad, n_boot=0)
    ref = fragility(ds.where(xr.DataArray(status == 0, dims=("record", "scale"))), n_boot=0)
    assert frag.n_runs == int((status == 0).sum())
    np.testing.assert_allclose([frag.median, frag.beta_log], [ref.median, ref.beta_log])


@pytest.mark.parametrize("first_collapse", [False, True])
def test_errors_without_collapse_or_survival(first_collapse):
    ds = _bernoulli(n_rec=10)
    none = ds.assign(collapse=ds.collapse & False)
    every = ds.assign(collapse=ds.collapse | True)
    with pytest.raises(ValueError, match="no valid run collapsed.*larger scale factors"):
        fragility(none, first_collapse=first_collapse)
    with pytest.raises(ValueError, match="every valid run collapsed.*smaller scale factors"):
        fragility(every, first_collapse=first_collapse)


def test_error_on_separated_data_and_bad_input():
    ds, _ = _capacities(n_rec=1)
    with pytest.raises(ValueError, match="sigma -> 0.*overlap"):
        fragility(ds)
    with pytest.raises(ValueError, match="at least two records"):
        fragility(ds, first_collapse=True)
    good = _bernoulli(n_rec=10)
    with pytest.raises(ValueError, match="no 'sa' variable"):
        fragility(good, "sa")
    with pytest.raises(ValueError, match="ci must be"):
        fragility(good, ci=90.0)
    with pytest.raises(ValueError, match="n_boot must be"):
        fragility(good, n_boot=-1)


def test_scale_coordinate_as_im():
    ds = _bernoulli(n_rec=40)
    frag = fragility(ds, "scale", n_boot=0)
    assert frag.im == "scale" and frag.im_units == "" and frag.median > 0


@pytest.mark.slow
def test_end_to_end_on_a_tiny_housner_ida():
    """rj.ida -> fragility: the Dataset it returns is accepted as is (~10 s, mostly compile)."""
    records = [
        rj.GroundMotion.sine_cycle(3.0, 0.5, dt=0.01, duration=1.5, name="sine"),
        rj.GroundMotion.ricker(3.0, 0.4, dt=0.005, duration=1.2, name="ricker"),
        rj.GroundMotion.ricker(3.0, 0.6, dt=0.005, duration=1.2, name="ricker_long"),
    ]
    block = rj.Block(b=0.2, h=1.0, length=1.0, rho=1800.0, E=1e9, nu=0.2)
    ds = rj.ida(block, records, np.linspace(0.1, 2.5, 12), model=rj.Housner(), progress=False)
    for first_collapse in (False, True):
        frag = fragility(ds, n_boot=100, first_collapse=first_collapse)
        assert frag.n_runs == int((ds.status == 0).sum()) and frag.im_units == "m/s^2"
        lowest = float(ds.pga_scaled.where(ds.collapse).min())
        highest = float(ds.pga_scaled.where(~ds.collapse).max())
        assert lowest / 2 < frag.median < 2 * highest
        assert frag.median_ci[0] <= frag.median <= frag.median_ci[1]


# ----------------------------------------------------------------------------- IMs and units


def _ida_like(seed=3, n_rec=60, pgv_per_pga=0.08, sa_per_pga=2.5):
    """Bernoulli runs on an rj.ida-shaped Dataset: per-record pga and pgv coordinates, the
    IDA's IM sa(0.3) as the variable ``im``; every record's PGV and Sa are fixed multiples of
    its PGA, so the three IMs differ by a constant factor on every run."""
    rng = np.random.default_rng(seed)
    pga = rng.uniform(2.0, 4.0, n_rec)
    scales = np.linspace(0.1, 2.0, N_SCALE)
    im = pga[:, None] * scales[None, :]
    collapse = rng.random(im.shape) < stats.norm.cdf(np.log(im / THETA) / SIGMA)
    dims = ("record", "scale")
    return xr.Dataset(
        {
            "collapse": (dims, collapse),
            "status": (dims, np.zeros(im.shape, np.int32)),
            "pga_scaled": (dims, im, {"units": "m/s^2"}),
            "im": (dims, sa_per_pga * im, {"units": "m/s^2"}),
        },
        coords={
            "record": [f"r{i}" for i in range(n_rec)],
            "scale": scales,
            "pga": ("record", pga, {"units": "m/s^2"}),
            "pgv": ("record", pgv_per_pga * pga, {"units": "m/s"}),
        },
        attrs={"im": "sa(0.3)"},
    )


def test_fragility_by_pga_pgv_and_the_ida_im():
    """Reference: the probit likelihood depends on the IM only through ln(IM), so multiplying
    every run's IM by a constant c multiplies the median by c and leaves beta_log unchanged."""
    ds = _ida_like()
    by_pga = fragility(ds, "pga", n_boot=0)
    by_pgv = fragility(ds, "pgv", n_boot=0)
    default = fragility(ds, n_boot=0)  # the IDA's IM
    shift_rtol = 1e-8  # two Newton solves converged to 1e-10 in the log parameters
    assert (by_pga.im, by_pga.im_units) == ("pga", "m/s^2")
    assert (by_pgv.im, by_pgv.im_units) == ("pgv", "m/s")
    assert (default.im, default.im_units) == ("sa(0.3)", "m/s^2")
    np.testing.assert_allclose(by_pgv.median, 0.08 * by_pga.median, rtol=shift_rtol)
    np.testing.assert_allclose(default.median, 2.5 * by_pga.median, rtol=shift_rtol)
    np.testing.assert_allclose(
        [by_pgv.beta_log, default.beta_log], by_pga.beta_log, rtol=shift_rtol
    )
    again = fragility(ds, "Sa(0.30)", n_boot=0)
    assert again.im == "sa(0.3)" and again.median == default.median
    with pytest.raises(ValueError, match=r"cannot give im='sa\(1\)'.*im='sa\(1\)'"):
        fragility(ds, "sa(1.0)")
    with pytest.raises(ValueError, match="cannot give im='pgv'"):
        fragility(ds.drop_vars("pgv"), "pgv")


def test_median_in_g_and_concise_repr():
    """Reference: g = 9.80665 m/s^2; a non-acceleration IM has no median in g."""
    ds = _ida_like()
    frag = fragility(ds, "pga", n_boot=50)
    np.testing.assert_allclose(frag.median_g, frag.median / 9.80665, rtol=1e-15)
    np.testing.assert_allclose(frag.median_ci_g, np.array(frag.median_ci) / 9.80665, rtol=1e-15)
    assert fragility(ds, "pgv", n_boot=0).median_g is None
    assert fragility(ds, "scale", n_boot=0).median_ci_g is None
    text = repr(frag)
    assert len(text) < 200 and "\n" not in text  # one line, not the bootstrap arrays
