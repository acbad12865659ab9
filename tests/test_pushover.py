"""Quasi-static DEM pushover (``rockjax.pushover.pushover``).

References, derived here independently of the library:

* the rigid block (limit analysis / virtual work about the toe): with the horizontal load
  ``lambda W`` at the centroid, the weight ``W`` and an overburden ``P`` at the top centre,
  ``lambda(theta) = [W (b cos - h sin) + P (b cos - 2 h sin)] / [W (h cos + b sin)]``, so
  ``lambda_0 = (b/h) (1 + P/W)``;
* Coulomb friction: a squat block (``b/h > mu``) or stack slides on its base joint at
  ``lambda W = mu (W + P)``, ``mu = tan(phi)``;
* the rigid block on a tensionless Winkler joint (the integrated face law's statics): the
  pressure is a trapezoid (full contact) or a triangle of length ``ell = sqrt(2 N / (k s))``
  from the toe (``N = W + P``, ``k`` the joint stiffness per unit face length, ``s = sin
  theta``); moment equilibrium about the centroid gives ``lambda(theta)`` in closed form
  (:func:`_winkler_lambda`), and its small-rotation branch the initial stiffness.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax.constants import G
from rockjax.pushover import PULL_TIME, Capacity, pushover

STIFF = dict(b=0.5, h=1.0, E=1.8e13)  # Winkler peak 0.997 b/h: the contact's share is 0.3 %
SLENDER_STIFF = dict(b=0.17, h=1.5, E=1.8e12)
PAPER_WALL = dict(b=0.17, h=1.5)  # E = 1.8 GPa, rho = 1800 (the defaults), the paper's first

PEAK_RTOL = 0.01  # the stated accuracy; the Winkler peak (0.3 % low) and the dynamic overshoot
# where the stiff block starts to rock (0.5 % high at the default rate) are inside it
RIGID_TOL = 0.02  # [-] of lambda_0: the descending branch against the rigid block (the
# contact's offset ~ ell/3 over h/2 is 0.1-0.3 % here)
WINKLER_TOL = 0.01  # [-] of lambda_0: the whole flexible curve against its statics (measured
# 0.4 %: the block's inertia where it starts to rock)
STIFFNESS_RTOL = 0.02  # the initial branch's slope (the fit over a slightly curved branch)
RATE_TOL = 0.01  # [-] of lambda_0: the documented loading-rate criterion
ONE_SIDED_TOL = 2e-3  # [-] of lambda_0: a facade pulled off its wall is a parapet
FRICTION_RTOL = 1e-3  # a squat block sliding under the pull carries exactly its Coulomb force
# (the inertia is taken off lambda); measured 3e-11


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


TALL_STIFF = dict(b=0.25, h=3.0, E=1.8e12)  # the face law's Winkler peak: 2.95 % below b/h
NUMERICS_TOL = 2e-3  # [-] of lambda_0: what rate, sampling and damping may move the peak
# (measured 0.05 % for half the rate, 0.003 % for 4x the samples, 0 for beta / 4)


def test_stiff_block_shortfall_is_the_joint_not_the_numerics():
    """A stiff wall on the integrated face law peaks below b/h by its joint's compliance:
    reference, the closed-form Winkler statics (the contact's resultant moves inward by
    ell/3 while the block turns, a loss ~ E^(-1/3)). Half the rate, four times the samples
    and a quarter of the damping leave the peak where it is, and the same wall on corner
    contacts (sharp uplift) peaks at the rigid limit b/h (limit analysis) within 1 %."""
    blk = rj.Block(**TALL_STIFF)
    b, h = TALL_STIFF["b"], TALL_STIFF["h"]
    lam0 = b / h
    base = float(np.max(np.asarray(pushover(blk).load_multiplier)))
    dense = _winkler_lambda(
        np.geomspace(1e-7, 0.05, 200_001), b, h, float(blk.m) * G, float(blk.j_kn * blk.length)
    )
    assert dense.max() / lam0 < 0.975  # the joint's share, not the numerics'
    assert abs(base - dense.max()) < WINKLER_TOL * lam0, (base / lam0, dense.max() / lam0)
    for kwargs in (
        dict(duration=2 * PULL_TIME / float(blk.p)),
        dict(n_out=1600),
        dict(beta=0.25 * float(rj.beta_dejong(blk))),
    ):
        peak = float(np.max(np.asarray(pushover(blk, **kwargs).load_multiplier)))
        assert abs(peak - base) < NUMERICS_TOL * lam0, (kwargs, peak / lam0, base / lam0)
    corner = pushover(blk, joint=rj.Joint(n_sub=2))
    peak = float(np.max(np.asarray(corner.load_multiplier)))
    assert abs(peak / lam0 - 1) < PEAK_RTOL, peak / lam0


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


# ----------------------------------------------------------------------------- assemblies

# Walls of two blocks on corner contacts (whose uplift is sharp, so the peak is the rigid
# limit's) ten times stiffer than the paper's joints; pulled to d/b = 0.05 (past the peak)
# over 20 / p of the whole wall, 40 samples. References: the rigid mechanisms' multipliers
# by virtual work, written out here for these geometries (and rockjax.collapse_multiplier).
ASM_E = 1.8e10
ASM_KW = dict(joint=rj.Joint(n_sub=2), d_over_b=0.05, n_out=40)
ASM_PEAK_RTOL = 0.02  # the stated accuracy; measured -0.01 % (stack), +0.5 % (top: the top
# block's inertia where it starts to rock under the still-rising pull), +0.07 % (hinge)
ASM_RIGID_TOL = 0.02  # [-] of lambda_0: past the peak, the stack against the one-block curve
ASM_TRAVEL_RTOL = 0.15  # the pull's end d/b against the requested 0.05 (elastic share)


def _asm_pushover(wall):
    mono = rj.Block(b=0.2, h=2.0)  # the wall as one block: its p sets the pull's duration
    return pushover(wall, duration=20.0 / float(mono.p), **ASM_KW)


@pytest.fixture(scope="module")
def asm_free():
    """The stack mechanism (two equal blocks) and the top mechanism (a narrow block on a
    wide one); one compilation serves both."""
    from rockjax.assembly import Assembly

    stack = Assembly.stack([rj.Block(b=0.2, h=1.0, E=ASM_E)] * 2)
    top = Assembly.stack([rj.Block(b=0.4, h=1.0, E=ASM_E), rj.Block(b=0.15, h=1.0, E=ASM_E)])
    return {"stack": (stack, _asm_pushover(stack)), "top": (top, _asm_pushover(top))}


def test_assembly_capacity_is_float64_and_shaped(asm_free):
    _, cap = asm_free["stack"]
    assert isinstance(cap, Capacity)
    for name in ("load_multiplier", "d_over_b", "theta", "t"):
        arr = getattr(cap, name)
        assert arr.shape == (40,) and arr.dtype == np.float64
    assert cap.theta_blocks.shape == (40, 2) and cap.theta_blocks.dtype == np.float64
    assert float(cap.d_over_b[-1]) == pytest.approx(0.05, rel=ASM_TRAVEL_RTOL)


@pytest.mark.parametrize("case", ["stack", "top"])
def test_assembly_pushover_peaks_at_the_rigid_mechanism(asm_free, case):
    """Reference: virtual work. Stack (two equal 0.2 x 1.0 m blocks about the base toe):
    lambda_0 = b / (2 h) = 0.1. Top (a 0.15 x 1.0 m block on a 0.4 x 1.0 m one, about the
    top block's toe on the bed joint): lambda_0 = b_1 / h_1 = 0.15 (below the stack's
    (W_0 0.2 + W_1 0.2) / (W_0 0.5 + W_1 1.5) = 0.16 with W_1 = 0.375 W_0)."""
    from rockjax.assembly import collapse_multiplier

    wall, cap = asm_free[case]
    lam0 = {"stack": 0.2 / 2.0, "top": 0.15 / 1.0}[case]
    assert float(collapse_multiplier(wall, case)) == pytest.approx(lam0, rel=1e-12)
    assert float(cap.lambda_rigid) == pytest.approx(lam0, rel=1e-12)
    lam = np.asarray(cap.load_multiplier)
    assert abs(lam.max() / lam0 - 1) < ASM_PEAK_RTOL, lam.max() / lam0
    th = np.asarray(cap.theta_blocks)
    if case == "stack":  # one rigid body: both blocks rotate alike, the curve is b x 2h's
        assert np.max(np.abs(th[:, 1] - th[:, 0])) < 0.02 * np.max(np.abs(th))
        theta = th[-1, 0]
        rigid = _rigid_lambda(theta, 0.2, 2.0)
        assert abs(lam[-1] - rigid) < ASM_RIGID_TOL * lam0, (lam[-1], rigid)
    else:  # the top block alone: the lower one stays put
        assert np.max(np.abs(th[:, 0])) < 0.02 * np.max(np.abs(th[:, 1]))


def test_assembly_pushover_restrained_hinge():
    """Reference: virtual work for the two-block hinge (block 0 about its ground toe, block
    1 about the top restraint, the hinge at the bed joint's heel) with an overburden P:
    lambda_0 = (b / h)(2 + 1.5 P / W) for equal blocks b x h of weight W; block 1 rotates
    backward by h_0 / h_1 times block 0's rotation."""
    from rockjax.assembly import Assembly, collapse_multiplier

    b, h, p = 0.2, 1.0, 2e3
    blk = rj.Block(b=b, h=h, E=ASM_E)
    wall = Assembly.stack([blk] * 2, top="restrained", overburden=p)
    w = float(blk.m * G)
    lam0 = b / h * (2 + 1.5 * p / w)
    assert float(collapse_multiplier(wall, "hinge")) == pytest.approx(lam0, rel=1e-12)
    cap = _asm_pushover(wall)
    assert float(cap.lambda_rigid) == pytest.approx(lam0, rel=1e-12)
    lam = np.asarray(cap.load_multiplier)
    assert abs(lam.max() / lam0 - 1) < ASM_PEAK_RTOL, lam.max() / lam0
    th = np.asarray(cap.theta_blocks)
    assert th[-1, 0] > 0 and th[-1, 1] == pytest.approx(-th[-1, 0], rel=0.05)


def test_assembly_pushover_bad_input_is_refused():
    from rockjax.assembly import Assembly

    wall = Assembly.stack([rj.Block(b=0.2, h=1.0)] * 2)
    with pytest.raises(ValueError, match="overburden"):
        pushover(wall, overburden=1e3)
    with pytest.raises(ValueError, match="mode"):
        pushover(wall, mode="one_sided")
    with pytest.raises(ValueError, match="d_over_b"):
        pushover(wall, d_over_b=-1.0)


def test_assembly_pushover_peaks_at_the_limit_analysis():
    """Reference: the lowest mechanism by virtual work, written out here. A 0.45 x 1.0 m
    block under two 0.15 x 1.0 m ones: the two slender blocks turning together about the
    bed joint's toe, lambda_0 = b / (2 h) = 0.075 (the whole stack needs 0.2045); the DEM
    pushover peaks there, the lower block stays put and the upper two turn alike. The
    same peak is rockjax.limit_analysis's multiplier (its pull's lambda_rigid)."""
    from rockjax.assembly import Assembly

    wide = rj.Block(b=0.45, h=1.0, E=ASM_E)
    slender = rj.Block(b=0.15, h=1.0, E=ASM_E)
    wall = Assembly.stack([wide, slender, slender])
    lam0 = 0.15 / (2 * 1.0)
    cap = _asm_pushover(wall)
    assert float(cap.lambda_rigid) == pytest.approx(lam0, rel=1e-9)
    lam = np.asarray(cap.load_multiplier)
    assert abs(lam.max() / lam0 - 1) < ASM_PEAK_RTOL, lam.max() / lam0
    th = np.asarray(cap.theta_blocks)
    assert np.max(np.abs(th[:, 0])) < 0.02 * np.max(np.abs(th[:, 2]))
    assert np.max(np.abs(th[:, 2] - th[:, 1])) < 0.02 * np.max(np.abs(th[:, 2]))


def test_restrained_three_block_pushover_peaks_at_the_limit_analysis():
    """Reference: virtual work of the three-hinge mechanisms of three equal b x h blocks with
    the top held, written out here: blocks 0 and 1 together about the ground toe A, block 2
    about the hinge B at the heel of the upper bed joint (height 2h), its top face centre C
    held. Per unit rotation of the lower pair B moves by (2h, b), so block 2 turns back by 2
    (C does not move across); the centroids move by (h/2, b/2), (3h/2, b/2) and
    (2h - h, b + 2 b/2) = (h, 2b): lambda = (b/2 + b/2 + 2b) / (h/2 + 3h/2 + h) = b / h.
    The other pairs of hinges give more (rockjax.limit_analysis, tests/test_assembly_limit.py).
    The DEM pushover peaks there; blocks 0 and 1 turn alike and block 2 back by twice as
    much."""
    from rockjax.assembly import Assembly

    b, h = 0.23, 1.0
    wall = Assembly.stack([rj.Block(b=b, h=h, E=ASM_E)] * 3, top="restrained")
    lam0 = b / h
    cap = _asm_pushover(wall)
    assert float(cap.lambda_rigid) == pytest.approx(lam0, rel=1e-9)
    lam = np.asarray(cap.load_multiplier)
    assert abs(lam.max() / lam0 - 1) < ASM_PEAK_RTOL, lam.max() / lam0
    th = np.asarray(cap.theta_blocks)[-1]
    assert th[1] == pytest.approx(th[0], rel=0.05) and th[2] == pytest.approx(-2 * th[0], rel=0.05)


# ----------------------------------------------------------------------------- friction


@pytest.mark.parametrize("kind", ["block", "stack"])
@pytest.mark.parametrize("joint", [rj.Joint(), rj.Joint(n_sub=2)], ids=["face", "corners"])
def test_squat_pushover_plateaus_at_coulomb_friction(kind, joint):
    """Reference: Coulomb friction on the base joint, ``lambda W = mu (W + P)`` (the bed joint
    of the stack sticks: it carries ``lambda W_1 = mu W_1 (1 + P/W)``, below its cap
    ``mu (W_1 + P)``). A sliding joint's shear dashpot is off (docs/theory.md, "Friction on
    the whole joint"): it used to add ``beta k_s`` times the sliding rate, 1.7-2.1 times the
    friction at this rate."""
    from rockjax.assembly import Assembly

    mu = np.tan(np.radians(30.0))
    whole = rj.Block(b=1.0, h=0.5)  # b/h = 2 > mu: it slides; its p sets the pull's duration
    weight = float(whole.m) * G / float(whole.length)  # W [N/m]
    p_top = 0.5 * weight
    kw = dict(phi_deg=30.0, joint=joint, d_over_b=0.05, n_out=40, duration=20.0 / float(whole.p))
    if kind == "block":
        cap = pushover(whole, overburden=p_top, **kw)
    else:
        half = rj.Block(b=1.0, h=0.25)
        cap = pushover(Assembly.stack([half, half], overburden=p_top), **kw)
    lam = np.asarray(cap.load_multiplier) / (mu * (1.0 + p_top / weight))
    assert lam.max() < 1.0 + FRICTION_RTOL, lam.max()
    assert np.max(np.abs(lam[20:] - 1.0)) < FRICTION_RTOL, lam[20:]  # the plateau
    assert np.max(np.abs(np.asarray(cap.theta))) < 1e-4  # it slid without rocking


def _synthetic_capacity(theta_blocks=None):
    return Capacity(
        load_multiplier=jnp.linspace(0.1, 0.0, 7),
        d_over_b=jnp.linspace(0.0, 1.0, 7),
        theta=jnp.linspace(0.0, 0.1, 7),
        lambda_rigid=jnp.asarray(0.1),
        b=jnp.asarray(0.2),
        h=jnp.asarray(2.0),
        overburden=jnp.asarray(500.0),
        t=jnp.arange(7) * 0.5,
        theta_blocks=theta_blocks,
    )


def test_capacity_to_dataframe_columns_units_and_attrs():
    cap = _synthetic_capacity()
    df = cap.to_dataframe()
    assert df.index.name == "t [s]" and list(df.index) == [0.5 * k for k in range(7)]
    assert list(df.columns) == ["d/b [-]", "d [m]", "lambda [-]", "theta [rad]"]
    np.testing.assert_array_equal(df["d [m]"], 0.2 * np.linspace(0.0, 1.0, 7))
    np.testing.assert_array_equal(df["lambda [-]"], np.asarray(cap.load_multiplier))
    assert df.attrs == {
        "lambda_rigid [-]": 0.1,
        "b [m]": 0.2,
        "h [m]": 2.0,
        "overburden [N/m]": 500.0,
        "n_blocks": 1,
    }
    blocks = jnp.stack([jnp.linspace(0, 0.05, 7), jnp.linspace(0, 0.1, 7)], axis=1)
    df = _synthetic_capacity(blocks).to_dataframe()
    np.testing.assert_array_equal(df["theta_1 [rad]"], np.asarray(blocks)[:, 1])
    assert df.attrs["n_blocks"] == 2


def test_capacity_to_dataframe_refuses_a_batch():
    cap = _synthetic_capacity()
    batch = jax.tree.map(lambda x: jnp.stack([x, x]), cap)  # as jax.vmap returns them
    with pytest.raises(ValueError, match="needs one concrete curve"):
        batch.to_dataframe()
