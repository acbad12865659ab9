"""Limit analysis of assemblies (``rockjax.limit_analysis``, ``rockjax.collapse_multiplier``).

References, written here independently of the library's linear programme: virtual work on
the generators of the joints' kinematics. A rigid joint without tension and with associative
Coulomb friction lets the part above it turn about either end of its contact face (opening
the other) or slip along it while opening by ``tan(phi)`` per unit slip. Under a load
``lambda W_k`` proportional to the weights, a mechanism's multiplier is the work of the dead
loads over that of the horizontal ones, a ratio of linear forms; over a cone of mechanisms it
is smallest on an extreme ray (a mediant is never below both its terms). So:

* a free top: the joints move independently, the rays are each sub-stack turning about the
  +x end of its joint or slipping on it, and ``lambda`` is the smallest of those;
* a restrained top (its top face centre held horizontally): the rays are pairs of joint
  rotations, a clockwise one about the +x end of joint ``i`` and a counter-clockwise one about
  the -x end of joint ``j != i``, in the ratio that keeps the top still (joints that cannot
  slip, ``phi = 90``);
* a row of touching blocks: the closed form ``lambda_j`` of ``collapse_multiplier(row, "row")``
  (docs/assemblies.md, derived there by virtual work).
"""

import itertools
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax.assembly import Assembly
from rockjax.constants import G

LP_RTOL = 1e-9  # HiGHS's dual simplex returns a vertex: the exact solution to round-off
VW_RTOL = 1e-9  # the mechanism's own virtual work against its multiplier (the dual)


def _geometry(wall: Assembly):
    """Weights [N], centroids [m], the joints' heights and faces' ends (absolute) of a stack."""
    w = [float(b.m) * G for b in wall.blocks]
    h = [float(b.h) for b in wall.blocks]
    x = [float(v) for v in wall.x_offset]
    base = [sum(h[:k]) for k in range(len(h))]
    y = [base[k] + 0.5 * h[k] for k in range(len(h))]
    ends = []
    for k, blk in enumerate(wall.blocks):
        lo, hi = -0.5 * float(blk.b), 0.5 * float(blk.b)
        if k > 0:  # the overlap with the block below
            below = wall.blocks[k - 1]
            lo = max(lo, x[k - 1] - x[k] - 0.5 * float(below.b))
            hi = min(hi, x[k - 1] - x[k] + 0.5 * float(below.b))
        ends.append((x[k] + lo, x[k] + hi))
    return w, x, y, base, ends, float(wall.top_load)


def _rotation(k0, pivot, omega, x, y, n):
    """Velocities (u, v) of the centroids of blocks k0..n-1 turning clockwise by ``omega``
    about ``pivot``; blocks below stay."""
    u, v = np.zeros(n), np.zeros(n)
    for k in range(k0, n):
        u[k] = omega * (y[k] - pivot[1])
        v[k] = omega * (pivot[0] - x[k])
    return u, v


def _ratio(w, p, u, v, v_q):
    """lambda of a mechanism: the dead loads' work over the horizontal loads' (per lambda);
    ``v_q`` the top face centre's vertical velocity (the overburden's point)."""
    return (np.dot(w, v) + p * v_q) / np.dot(w, u)


def _free_stack_reference(wall: Assembly, mu=math.inf):
    """Smallest lambda over the rays of a free stack: each sub-stack turning about the +x end
    of its joint, or slipping on it with dilatancy (``mu`` = tan phi)."""
    w, x, y, base, ends, p = _geometry(wall)
    n = len(w)
    lams = []
    for i in range(n):
        pivot = (ends[i][1], base[i])
        u, v = _rotation(i, pivot, 1.0, x, y, n)
        lams.append(_ratio(w, p, u, v, pivot[0] - x[-1]))
        if math.isfinite(mu):
            u = np.where(np.arange(n) >= i, 1.0, 0.0)
            lams.append(_ratio(w, p, u, mu * u, mu))
    return min(lams)


def _restrained_reference(wall: Assembly):
    """Smallest lambda over the rays of a restrained stack without slip: a clockwise rotation
    about the +x end of joint i and a counter-clockwise one about the -x end of joint j != i,
    the top face centre held horizontally."""
    w, x, y, base, ends, p = _geometry(wall)
    n = len(w)
    top = (x[-1], base[-1] + float(wall.blocks[-1].h))
    lams = []
    for i, j in itertools.permutations(range(n), 2):
        toe = (ends[i][1], base[i])
        heel = (ends[j][0], base[j])
        # Q's horizontal velocity: (y_Q - y_pivot) per unit clockwise rotation
        a = top[1] - toe[1]
        c = top[1] - heel[1]
        r_i, r_j = 1.0, a / c  # r_i a - r_j c = 0
        u1, v1 = _rotation(i, toe, r_i, x, y, n)
        u2, v2 = _rotation(j, heel, -r_j, x, y, n)
        v_q = r_i * (toe[0] - top[0]) - r_j * (heel[0] - top[0])
        lam = _ratio(w, p, u1 + u2, v1 + v2, v_q)
        if np.dot(w, u1 + u2) > 0:
            lams.append(lam)
    return min(lams)


def _limit(wall, **kw):
    la = rj.limit_analysis(wall, **kw)
    return float(la.load_multiplier), np.asarray(la.velocity)


def _virtual_work(wall, vel):
    """lambda from the returned mechanism by virtual work (the dual's own check)."""
    w, _, _, _, _, p = _geometry(wall)
    # the top face centre lies above the top block's centroid: it rises as the centroid does
    v_q = vel[-1, 1]
    return (np.dot(w, vel[:, 1]) + p * v_q) / np.dot(w, vel[:, 0])


def test_single_block_rocks_at_b_over_h_or_slides_at_mu():
    """Reference: one block about its toe, b/h (1 + P/W); sliding, mu (1 + P/W)."""
    blk = rj.Block(b=0.2, h=1.0)
    w = float(blk.m) * G
    lam, vel = _limit(Assembly.stack([blk]))
    assert lam == pytest.approx(0.2, rel=LP_RTOL)
    # the toe is fixed: the centroid moves (h/2, b/2) per unit clockwise rotation
    np.testing.assert_allclose(vel[0], [0.5, 0.1, 1.0], rtol=LP_RTOL, atol=1e-12)
    lam, _ = _limit(Assembly.stack([blk], overburden=0.5 * w))
    assert lam == pytest.approx(0.2 * 1.5, rel=LP_RTOL)
    squat = rj.Block(b=1.0, h=1.0)
    mu = 0.3
    phi = math.degrees(math.atan(mu))
    lam, vel = _limit(Assembly.stack([squat]), phi_deg=phi)
    assert lam == pytest.approx(mu, rel=LP_RTOL)
    np.testing.assert_allclose(vel[0], [1.0, mu, 0.0], rtol=LP_RTOL, atol=1e-12)  # a slip
    ws = float(squat.m) * G
    lam, _ = _limit(Assembly.stack([squat], overburden=ws), phi_deg=phi)
    assert lam == pytest.approx(2 * mu, rel=LP_RTOL)
    lam, _ = _limit(Assembly.stack([squat]), phi_deg=60.0)  # b/h = 1 < tan 60
    assert lam == pytest.approx(1.0, rel=LP_RTOL)


# the stack of the limit analysis's motivating case: a wide bottom block and two slender
# blocks on it; the whole stack about the ground toe needs 2.7 times the lowest mechanism,
# the two slender blocks turning together about the bed joint's toe (b / 2h = 0.075)
WIDE = rj.Block(b=0.45, h=1.0)
SLENDER = rj.Block(b=0.15, h=1.0)
FREE_STACKS = {
    "two equal": Assembly.stack([rj.Block(b=0.2, h=1.0)] * 2),
    "narrow on wide": Assembly.stack([rj.Block(b=0.4, h=1.0), rj.Block(b=0.15, h=1.0)]),
    "wide, two slender": Assembly.stack([WIDE, SLENDER, SLENDER]),
    "loaded, offset": Assembly.stack(
        [rj.Block(b=0.5, h=0.8), rj.Block(b=0.3, h=1.2), rj.Block(b=0.2, h=0.6)],
        x_offset=(0.0, 0.08, -0.03),
        overburden=2e3,
    ),
    "four courses": Assembly.stack(
        [rj.Block(b=0.6, h=0.5), rj.Block(b=0.25, h=1.5), rj.Block(b=0.25, h=0.3)] * 1
        + [rj.Block(b=0.2, h=1.0)]
    ),
}


@pytest.mark.parametrize("name", list(FREE_STACKS))
def test_free_stack_is_its_lowest_sub_stack(name):
    """Reference: the smallest multiplier over the sub-stacks turning about their joints'
    toes (no slip at phi = 90)."""
    wall = FREE_STACKS[name]
    lam, vel = _limit(wall, phi_deg=90.0)
    ref = _free_stack_reference(wall)
    assert lam == pytest.approx(ref, rel=LP_RTOL), (lam, ref)
    assert _virtual_work(wall, vel) == pytest.approx(lam, rel=VW_RTOL)
    assert float(rj.collapse_multiplier(wall, phi_deg=90.0)) == pytest.approx(lam, rel=0)


def test_wide_bottom_two_slender_blocks_top_sub_stack_governs():
    """Reference: the two slender blocks about the bed joint's toe, b / (2 h) = 0.075, while
    the whole stack needs (W_0 + W_1 + W_2) (b_0 / 2) / sum W_k y_k = 0.2045 (2.7 times):
    the named "stack" mechanism misses the lowest one; the lower block stays put and the two
    upper ones turn together."""
    wall = FREE_STACKS["wide, two slender"]
    lam, vel = _limit(wall)  # the default friction (50 deg): rocking governs
    assert lam == pytest.approx(0.15 / 2.0, rel=LP_RTOL)
    w0, w1 = 0.45, 0.15  # per unit height and density
    whole = (w0 + 2 * w1) * 0.225 / (w0 * 0.5 + w1 * 1.5 + w1 * 2.5)
    assert float(rj.collapse_multiplier(wall, "stack")) == pytest.approx(whole, rel=1e-12)
    assert whole / lam > 2.7
    np.testing.assert_allclose(vel[0], 0.0, atol=1e-12)
    assert vel[1, 2] == pytest.approx(vel[2, 2], rel=1e-9) and vel[1, 2] > 0


def test_sliding_governs_a_squat_stack_with_low_friction():
    """Reference: the rays of a free stack with slip (associative: the dilatant slip)."""
    wall = Assembly.stack([rj.Block(b=1.0, h=0.6), rj.Block(b=0.8, h=0.5)])
    for phi in (10.0, 20.0, 35.0, 60.0):
        lam, vel = _limit(wall, phi_deg=phi)
        ref = _free_stack_reference(wall, mu=math.tan(math.radians(phi)))
        assert lam == pytest.approx(ref, rel=LP_RTOL), (phi, lam, ref)
        assert _virtual_work(wall, vel) == pytest.approx(lam, rel=VW_RTOL)
    lam, vel = _limit(wall, phi_deg=10.0)  # the upper block slips on the bed joint
    np.testing.assert_allclose(vel[0], 0.0, atol=1e-12)
    assert abs(vel[1, 2]) < 1e-12 and vel[1, 0] == pytest.approx(1.0)


RESTRAINED = {
    "two equal, 2 kN/m": Assembly.stack(
        [rj.Block(b=0.2, h=1.0)] * 2, top="restrained", overburden=2e3
    ),
    "three equal": Assembly.stack([rj.Block(b=0.23, h=1.0)] * 3, top="restrained"),
    "three mixed, 5 kN/m": Assembly.stack(
        [rj.Block(b=0.35, h=1.2), rj.Block(b=0.25, h=0.8), rj.Block(b=0.2, h=1.0)],
        top="restrained",
        overburden=5e3,
    ),
    "four, offset": Assembly.stack(
        [rj.Block(b=0.3, h=0.7), rj.Block(b=0.3, h=0.7), rj.Block(b=0.25, h=0.9)]
        + [rj.Block(b=0.2, h=0.5)],
        x_offset=(0.0, 0.0, 0.02, -0.01),
        top="restrained",
        overburden=1e3,
    ),
}


@pytest.mark.parametrize("name", list(RESTRAINED))
def test_restrained_wall_is_its_lowest_three_hinge_mechanism(name):
    """Reference: the smallest multiplier over the three-hinge mechanisms (a toe below or
    above a heel, the top held), no slip."""
    wall = RESTRAINED[name]
    lam, vel = _limit(wall, phi_deg=90.0)
    ref = _restrained_reference(wall)
    assert lam == pytest.approx(ref, rel=LP_RTOL), (lam, ref)
    assert _virtual_work(wall, vel) == pytest.approx(lam, rel=VW_RTOL)
    top = len(wall.blocks) - 1
    h_top = float(wall.blocks[top].h)
    assert abs(vel[top, 0] + 0.5 * h_top * vel[top, 2]) < 1e-9  # the top is held


def test_restrained_two_blocks_is_the_hinge_closed_form():
    """Reference: the hinge's closed form (b/h)(2 + 1.5 P/W), docs/assemblies.md."""
    blk = rj.Block(b=0.2, h=1.0)
    wall = RESTRAINED["two equal, 2 kN/m"]
    w = float(blk.m) * G
    lam = float(rj.collapse_multiplier(wall))
    assert lam == pytest.approx(0.2 * (2 + 1.5 * 2e3 / w), rel=LP_RTOL)
    assert lam == pytest.approx(float(rj.collapse_multiplier(wall, "hinge")), rel=LP_RTOL)


def test_row_is_the_row_mechanism_and_blocks_apart_stand_alone():
    """Reference: collapse_multiplier(row, "row") (virtual work, docs/assemblies.md); blocks
    apart at rest are single blocks (the smallest b/h)."""
    row = Assembly.row([rj.Block(b=0.10, h=1.5), rj.Block(b=0.25, h=1.5)])
    lam, vel = _limit(row)
    assert lam == pytest.approx(float(rj.collapse_multiplier(row, "row")), rel=LP_RTOL)
    assert lam == pytest.approx((0.10**2 + 0.25**2) / (1.5 * 0.35), rel=LP_RTOL)
    np.testing.assert_allclose(vel[:, 2], vel[0, 2], rtol=1e-9)  # both turn alike
    apart = Assembly.row([rj.Block(b=0.10, h=1.5), rj.Block(b=0.25, h=1.5)], x_offset=(0, 0.5))
    assert _limit(apart)[0] == pytest.approx(0.10 / 1.5, rel=LP_RTOL)


def test_named_mechanisms_are_upper_bounds():
    """The static theorem's value lies below every mechanism's (the kinematic theorem)."""
    for wall in FREE_STACKS.values():
        lam = float(rj.collapse_multiplier(wall))
        for name in ("stack", "top"):
            assert lam <= float(rj.collapse_multiplier(wall, name)) * (1 + LP_RTOL)


def test_limit_analysis_is_float64_and_refuses_bad_input():
    wall = FREE_STACKS["two equal"]
    la = rj.limit_analysis(wall)
    assert la.load_multiplier.dtype == jnp.float64 and la.velocity.shape == (2, 3)
    for phi in (0.0, -5.0, 95.0):
        with pytest.raises(ValueError, match="phi_deg"):
            rj.limit_analysis(wall, phi_deg=phi)

    @jax.jit
    def traced(b):
        return rj.collapse_multiplier(Assembly.stack([rj.Block(b=b, h=1.0)] * 2))

    with pytest.raises(ValueError, match="outside jit"):
        traced(0.2)
    # the named closed forms stay traceable
    f = jax.jit(
        lambda b: rj.collapse_multiplier(Assembly.stack([rj.Block(b=b, h=1.0)] * 2), "stack")
    )
    assert float(f(0.2)) == pytest.approx(0.1, rel=1e-12)
