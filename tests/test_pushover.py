"""Quasi-static DEM pushover (``rockjax.pushover.pushover``).

References, derived here independently of the library:

* the rigid block (limit analysis / virtual work about the toe): with the horizontal load
  ``lambda W`` at the centroid, the weight ``W`` and an overburden ``P`` at the top centre,
  ``lambda(theta) = [W (b cos - h sin) + P (b cos - 2 h sin)] / [W (h cos + b sin)]``, so
  ``lambda_0 = (b/h) (1 + P/W)``;
* the rigid block on a tensionless Winkler joint (the integrated face law's statics): the
  pressure is a trapezoid (full contact) or a triangle of length ``ell = sqrt(2 N / (k s))``
  from the toe (``N = W + P``, ``k`` the joint stiffness per unit face length, ``s = sin
  theta``); moment equilibrium about the centroid gives ``lambda(theta)`` in closed form
  (:func:`_winkler_lambda`), and its small-rotation branch the initial stiffness.
"""

import numpy as np
import pytest

import rockjax as rj
from rockjax.constants import G
from rockjax.pushover import PULL_TIME, Capacity, pushover

STIFF = dict(b=0.5, h=1.0, E=1.8e13)  # Winkler peak 0.997 b/h: the contact's share is 0.3 %
SLENDER_STIFF = dict(b=0.17, h=1.5, E=1.8e12)
PAPER_WALL = dict(b=0.17, h=1.5)  # E = 1.8 GPa, rho = 1800 (the defaults), the paper's first

PEAK_RTOL = 0.01  # the brief's limit; the Winkler peak (0.3 % low) and the dynamic overshoot
# where the stiff block starts to rock (0.5 % high at the default rate) are inside it
RIGID_TOL = 0.02  # [-] of lambda_0: the descending branch against the rigid block (the
# contact's offset ~ ell/3 over h/2 is 0.1-0.3 % here)
WINKLER_TOL = 0.01  # [-] of lambda_0: the whole flexible curve against its statics (measured
# 0.4 %: the block's inertia where it starts to rock)
STIFFNESS_RTOL = 0.02  # the initial branch's slope (the fit over a slightly curved branch)
RATE_TOL = 0.01  # [-] of lambda_0: the brief's loading-rate criterion
ONE_SIDED_TOL = 2e-3  # [-] of lambda_0: a facade pulled off its wall is a parapet


def _rigid_lambda(theta, b, h, psi=0.0):
    """Rigid block, virtual work about the toe (psi = P / W)."""
    c, s = np.cos(theta), np.sin(theta)
    return (b * c - h * s + psi * (b * c - 2 * h * s)) / (h * c + b * s)


def _rigid_top(theta, b, h):
    """Top-centre displacement of the rigid block rotating about its toe [m]."""
    return 0.5 * b * (1 - np.cos(theta)) + h * np.sin(theta)


def _winkler_lambda(theta, b, h, weight, k, p_top=0.0):
    """lambda(theta) of a rigid block on a tensionless Winkler joint: normal pressures
    vertical, the base shear horizontal at the closed part's centroid (face coordinate t_s),
    the normal resultant at t_r; moments about the centroid."""
    theta = np.asarray(theta, float)
    c, s = np.cos(theta), np.sin(theta)
    n = weight + p_top
    ell = np.sqrt(2 * n / (k * np.maximum(s, 1e-300)))
    partial = ell < b
    t_r = np.where(partial, b / 2 - ell / 3, k * s * b**3 / (12 * n))
    t_s = np.where(partial, b / 2 - ell / 2, 0.0)
    arm = t_r * c - 0.5 * h * s  # horizontal arm of the normal resultant from the centroid
    return (n * arm - 0.5 * h * s * p_top) / (weight * (0.5 * h * c + t_s * s))


def _curve(cap):
    return (
        np.asarray(cap.load_multiplier),
        np.asarray(cap.d_over_b),
        np.asarray(cap.theta),
        float(cap.lambda_rigid),
    )


@pytest.fixture(scope="module")
def stiff():
    return pushover(rj.Block(**STIFF))


@pytest.fixture(scope="module")
def paper_wall():
    return pushover(rj.Block(**PAPER_WALL))


def test_capacity_is_float64_and_shaped(stiff):
    assert isinstance(stiff, Capacity)
    for name in ("load_multiplier", "d_over_b", "theta", "t"):
        arr = getattr(stiff, name)
        assert arr.shape == (400,) and arr.dtype == np.float64
    lam, d, _, _ = _curve(stiff)
    assert np.all(np.isfinite(lam)) and d[-1] > 0.95


def test_stiff_block_peaks_at_b_over_h(stiff):
    """Reference: the rigid block's uplift multiplier b/h (limit analysis)."""
    lam, _, _, lam0 = _curve(stiff)
    assert lam0 == pytest.approx(STIFF["b"] / STIFF["h"], rel=1e-12)
    assert abs(lam.max() / lam0 - 1) < PEAK_RTOL, lam.max() / lam0


def test_stiff_descending_branch_is_the_rigid_curve(stiff):
    """Reference: the rigid block's lambda(theta) and top displacement d(theta)."""
    lam, d, theta, lam0 = _curve(stiff)
    b, h = STIFF["b"], STIFF["h"]
    past = (d > 0.05) & (d < 0.95)
    assert np.max(np.abs(lam - _rigid_lambda(theta, b, h))[past]) < RIGID_TOL * lam0
    assert np.max(np.abs(d * b - _rigid_top(theta, b, h))[past]) < 1e-3 * b


def test_slender_stiff_block_follows_the_linear_law():
    """Reference: for a slender rigid block lambda = (b/h)(1 - d/b) up to O(theta^2) terms
    (the exact rigid curve and the linear law differ by < 1 % of b/h for h/b ~ 9)."""
    cap = pushover(rj.Block(**SLENDER_STIFF))
    lam, d, theta, lam0 = _curve(cap)
    b, h = SLENDER_STIFF["b"], SLENDER_STIFF["h"]
    past = (d > 0.05) & (d < 0.95)
    assert np.max(np.abs(lam - _rigid_lambda(theta, b, h))[past]) < RIGID_TOL * lam0
    assert np.max(np.abs(lam - lam0 * (1 - d))[past]) < RIGID_TOL * lam0


def test_overburden_raises_the_capacity_by_virtual_work():
    """Reference: virtual work about the toe with the overburden at the top centre:
    lambda_0 = (b/h)(1 + P/W), and the rigid curve with P."""
    blk = rj.Block(**STIFF)
    weight = float(blk.m) * G  # [N], per metre of length (length = 1)
    n_top = 0.5 * weight  # [N/m]
    cap = pushover(blk, overburden=n_top)
    lam, d, theta, lam0 = _curve(cap)
    b, h = STIFF["b"], STIFF["h"]
    assert lam0 == pytest.approx(b / h * 1.5, rel=1e-12)
    assert abs(lam.max() / lam0 - 1) < PEAK_RTOL, lam.max() / lam0
    past = (d > 0.05) & (d < 0.45)  # rigid lambda reaches 0 at d/b ~ 0.5 with psi = 0.5
    ref = _rigid_lambda(theta, b, h, psi=0.5)
    assert np.max(np.abs(lam - ref)[past]) < RIGID_TOL * lam0


def test_flexible_curve_matches_winkler_statics(paper_wall):
    """Reference: the closed-form statics of the rigid block on the tensionless Winkler joint
    (E = 1.8 GPa: the peak is 0.81 b/h, not b/h)."""
    blk = rj.Block(**PAPER_WALL)
    lam, d, theta, lam0 = _curve(paper_wall)
    ref = _winkler_lambda(theta, blk.b, blk.h, float(blk.m) * G, float(blk.j_kn * blk.length))
    moved = theta > 1e-6
    assert np.max(np.abs(lam - ref)[moved]) < WINKLER_TOL * lam0
    dense = _winkler_lambda(
        np.geomspace(1e-7, 0.1, 100_001),
        blk.b,
        blk.h,
        float(blk.m) * G,
        float(blk.j_kn * blk.length),
    )
    assert 0.7 < dense.max() / lam0 < 0.9  # the joint's flexibility lowers the peak
    assert abs(lam.max() - dense.max()) < WINKLER_TOL * lam0


def test_flexible_initial_stiffness_matches_winkler(paper_wall):
    """Reference: the full-contact branch of the Winkler joint. Rotation about the base
    centre against k b^3 / 12 less the weight's overturning (P-delta) h W / 2, plus the base
    shear spring's slip lambda W / (k_s b):
    d lambda / d(d/b) = b / (W / (k_s b) + h / K_theta), K_theta = (k b^3/12 - h W/2) / (W h/2)."""
    blk = rj.Block(**PAPER_WALL)
    lam, d, _, lam0 = _curve(paper_wall)
    b, h = PAPER_WALL["b"], PAPER_WALL["h"]
    weight = float(blk.m) * G
    k, k_s = float(blk.j_kn * blk.length), float(blk.j_ks * blk.length)
    k_theta = (k * b**3 / 12 - 0.5 * h * weight) / (0.5 * weight * h)
    slope_ref = b / (weight / (k_s * b) + h / k_theta)
    # the full-contact range ends at lambda_0 / 3 (the resultant at the kern's edge, b/6)
    sel = (lam > 0.02 * lam0) & (lam < 0.25 * lam0) & (np.arange(lam.size) < np.argmax(lam))
    assert sel.sum() >= 5
    slope = np.sum(lam[sel] * d[sel]) / np.sum(d[sel] ** 2)
    assert abs(slope / slope_ref - 1) < STIFFNESS_RTOL, (slope, slope_ref)


def test_halving_the_rate_changes_lambda_little(paper_wall):
    """Quasi-static check: twice the pull duration (half the rate) moves the curve by < 1 %
    of lambda_0, on a grid of d/b and at the peak."""
    blk = rj.Block(**PAPER_WALL)
    slow = pushover(blk, duration=2 * PULL_TIME / float(blk.p))
    lam1, d1, _, lam0 = _curve(paper_wall)
    lam2, d2, _, _ = _curve(slow)
    grid = np.linspace(0.02, 0.95, 100)
    diff = np.abs(np.interp(grid, d1, lam1) - np.interp(grid, d2, lam2))
    assert np.max(diff) < RATE_TOL * lam0
    assert abs(lam1.max() - lam2.max()) < RATE_TOL * lam0


def test_facade_pulled_off_its_wall_is_a_parapet(paper_wall):
    """A facade (mode="one_sided") pulled outward leaves its return wall at once: with the
    same friction angle its curve is the parapet's."""
    blk = rj.Block(**PAPER_WALL)
    facade = pushover(blk, "one_sided", phi_deg=50.0)
    lam1, d1, _, lam0 = _curve(paper_wall)
    lam2, d2, _, _ = _curve(facade)
    grid = np.linspace(0.0, 0.95, 100)
    diff = np.abs(np.interp(grid, d1, lam1) - np.interp(grid, d2, lam2))
    assert np.max(diff) < ONE_SIDED_TOL * lam0


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(mode="sideways"), "mode"),
        (dict(overburden=-1.0), "overburden"),
        (dict(d_over_b=0.0), "d_over_b"),
        (dict(n_out=1), "n_out"),
        (dict(duration=-1.0), "duration"),
    ],
)
def test_bad_input_is_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        pushover(rj.Block(**PAPER_WALL), **kwargs)
