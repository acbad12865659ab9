"""Blocks side by side (rockjax.Assembly.row): each block on its ground joint, neighbours on
smooth head joints (docs/assemblies.md, "Blocks side by side")."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax.assembly import Assembly, collapse_multiplier
from rockjax.constants import G
from rockjax.dem import simulate_assembly, stable_dt_assembly

EQUAL_RTOL = 1e-10  # apart, each block is simulate_dem's scheme: round-off only (measured 4e-15)
ENERGY_RTOL = 5e-3  # central differences conserve a shadow energy (as for a stack)
VMAP_RTOL = 1e-9  # vmap vs a Python loop: the same arithmetic, fused differently
MIRROR_RTOL = 1e-2  # [peak] the mirror puts the head joint's face on the other block: the
# penetration is measured from the other face, which differs at second order in the leaves'
# relative rotation (measured 1.1e-3 of the peak at beta_DeJong, 2.2e-3 at beta_DeJong / 5)
PUSH_RTOL = 0.1  # E = 1.8e10 Pa: the DEM peak below the rigid limit by the joints' compliance
# (measured -7.7 %; -3.6 % at 1.8e11, -1.6 % at 1.8e12: the slow test)

SLENDER = rj.Block(b=0.12, h=1.5)
SHORT = rj.Block(b=0.12, h=1.0)
SQUAT = rj.Block(b=0.2, h=1.2)
PULSE = rj.GroundMotion.ricker(pga_g=0.12, period=0.5, duration=2.0)


def test_row_geometry_and_joints():
    """Reference: the layout by hand: touching centres (b_0 + b_1)/2 apart, the ground joints
    over each bottom face, the head joint over the height both blocks share."""
    row = Assembly.row([SLENDER, SHORT, SQUAT])
    assert row.x_offset == pytest.approx((0.0, 0.12, 0.28))
    assert row.interfaces == (
        (0, -1, "bed"),
        (1, -1, "bed"),
        (2, -1, "bed"),
        (1, 0, "head"),
        (2, 1, "head"),
    )
    faces = [float(v) for i in range(5) for v in row.face(i)]
    assert faces[:6] == pytest.approx([-0.06, 0.06, -0.06, 0.06, -0.1, 0.1])
    # block 1 (h 1.0) against block 0 (h 1.5): its whole -x face; block 2 (h 1.2) against
    # block 1 (h 1.0): the lowest 1.0 m of its face, from -0.6 up to 0.4 in its frame
    assert faces[6:] == pytest.approx([-0.5, 0.5, -0.6, 0.4])
    assert float(row.height) == pytest.approx(1.5)


def test_blocks_apart_are_single_blocks():
    """Reference: rj.simulate_dem of each block alone. Blocks 1 m apart never meet, so each
    rocks on its own ground joint exactly as a single block (same joint law, same step)."""
    row = Assembly.row([SLENDER, SQUAT], x_offset=(0.0, 1.0))
    r = simulate_assembly(row, PULSE)
    assert int(r.status) == 0 and not bool(r.overturned)
    for k, blk in enumerate((SLENDER, SQUAT)):
        d = rj.simulate_dem(blk, PULSE, dt=float(r.dt))
        peak = float(jnp.max(jnp.abs(d.theta)))
        err = float(jnp.max(jnp.abs(r.theta[:, k] - d.theta)))
        assert err < EQUAL_RTOL * peak, (k, err, peak)
    assert float(jnp.max(jnp.abs(r.theta[:, 0]))) > 0.1 * float(SLENDER.eta)  # it rocked


def test_row_at_rest_carries_its_weight():
    """Reference: statics. Without motion each block settles on its own ground joint, under
    its own weight only (the head joints carry nothing), and stays there: the ground joint's
    sink is ``m g / (j_kn b L)``."""
    row = Assembly.row([SLENDER, SQUAT])
    r = simulate_assembly(row, duration=0.5)
    for k, blk in enumerate((SLENDER, SQUAT)):
        sink = float(blk.m * G / (blk.j_kn * blk.b * blk.length))
        assert float(r.y[-1, k]) == pytest.approx(0.5 * float(blk.h) - sink, rel=1e-9)
        assert float(jnp.max(jnp.abs(r.theta[:, k]))) < 1e-12
        assert float(jnp.max(jnp.abs(r.x[:, k]))) < 1e-12


def test_energy_never_grows_after_the_pulse():
    """Reference: the energy balance at beta = 0. After the pulse the base is at rest; the
    penalty springs are elastic and the head joints smooth, so the contact law's only
    non-conservative part is the release of a loaded shear spring of a ground joint as its
    contact opens. It only takes energy out: kinetic + gravity + springs never rise above
    their value at the end of the pulse by more than ENERGY_RTOL of the rocking energy over
    8 s. (The leaves' impacts on each other load the ground joints' shear springs, released
    as the leaves rock on: the row loses most of its rocking energy in those 8 s, as a facade
    loses it on its return walls, tests/test_assembly.py.)"""
    row = Assembly.row([SLENDER, SQUAT])
    kw = dict(save=("energy",), duration=10.0)
    rest = simulate_assembly(row, **kw)
    r = simulate_assembly(row, PULSE, **kw)
    assert int(r.status) == 0 and not bool(r.overturned)
    t, e = np.asarray(r.t), np.asarray(r.energy)
    after = t >= 2.0  # the record ends at 2 s
    e0 = e[after][0]
    scale = e0 - float(rest.energy[-1])
    assert scale > 0.0
    assert np.max(e[after] - e0) < ENERGY_RTOL * scale, np.max(e[after] - e0) / scale
    th = np.asarray(r.theta)
    assert np.sum(np.diff(np.sign(th[after, 0])) != 0) >= 2  # it kept rocking


def test_mirrored_row_mirrors_the_response():
    """Reference: mirror symmetry. The row [slender, short] under ``ag`` and its mirror image
    [short, slender] (positions negated) under ``-ag`` are the same physical system, so
    ``theta`` changes sign block by block; the head joint then lies on the other block's
    face (same stiffness E/b: equal b), which checks its geometry and normal in both
    orientations (MIRROR_RTOL: the two discretisations differ at second order)."""
    row = Assembly.row([SLENDER, SHORT])
    mirror = Assembly.row([SHORT, SLENDER], x_offset=(-0.12, 0.0))
    neg = rj.GroundMotion(ag=-PULSE.ag, dt=PULSE.dt)
    beta = float(rj.beta_dejong(SHORT))
    a = simulate_assembly(row, PULSE, beta=beta)
    b = simulate_assembly(mirror, neg, beta=beta, dt=float(a.dt))
    peak = float(jnp.max(jnp.abs(a.theta)))
    assert peak > 0.1 * float(SHORT.eta)
    err = float(jnp.max(jnp.abs(a.theta + b.theta[:, ::-1])))
    assert err < MIRROR_RTOL * peak, (err, peak)
    # the leaves met: the slender one does not rock as it would alone
    alone = rj.simulate_dem(SLENDER, PULSE, beta=beta, dt=float(a.dt))
    assert float(jnp.max(jnp.abs(alone.theta - a.theta[:, 0]))) > 0.1 * peak


def _push(E):
    pair = Assembly.row([rj.Block(b=0.10, h=1.5, E=E), rj.Block(b=0.25, h=1.5, E=E)])
    cap = rj.pushover(pair)
    return float(jnp.max(cap.load_multiplier)), float(collapse_multiplier(pair, "row"))


@pytest.mark.slow
def test_pushover_against_the_row_mechanism():
    """Reference: limit analysis (virtual work) of the row mechanism, the two leaves each
    about its own toe, ``sum W b / sum W h`` = 0.1381 for a 0.10 m leaf against a 0.25 m one
    (1.5 m tall): between the leaves' own b/h (0.067, 0.167), so the slender leaf leans on
    the squat one. The DEM's peak lies below it by the joints' compliance (PUSH_RTOL).
    (Slow: the thin leaf's head joint E/b sets a short step, about 30-90 s.)"""
    peak, lam = _push(1.8e10)
    assert lam == pytest.approx((0.1 * 0.1 + 0.25 * 0.25) / (0.35 * 1.5), rel=1e-12)
    assert -PUSH_RTOL < peak / lam - 1.0 < 0.0, peak / lam - 1.0


@pytest.mark.slow
def test_pushover_converges_to_the_row_mechanism_with_stiffness():
    """Reference: the same limit analysis; stiffer joints bring the DEM's peak to it (the
    rigid limit): within 2 % at E = 1.8e12 Pa, closer at each tenfold stiffness."""
    errs = [abs(p / lam - 1.0) for p, lam in (_push(E) for E in (1.8e10, 1.8e11, 1.8e12))]
    # (about 20 min: the step shrinks as 1 / sqrt(E))
    assert errs[0] > errs[1] > errs[2] and errs[2] < 0.02, errs


def test_end_block_overturning_is_collapse():
    """Reference: the row's collapse rule. A strong pulse tips the row over toward +x: the
    end block on that side passes its eta rotating outward, the run is frozen and flagged; a
    block leaning on a neighbour is not flagged alone (the rule is on the end blocks)."""
    row = Assembly.row([SLENDER, SQUAT])
    strong = rj.GroundMotion.ricker(pga_g=-1.0, period=0.5, duration=2.0)
    r = simulate_assembly(row, strong)
    assert bool(r.overturned) and int(r.status) == 0
    th = np.asarray(r.theta)
    assert np.all(np.isfinite(th))
    # frozen from the collapse on: the last samples repeat
    assert np.array_equal(th[-1], th[-2])
    past = (np.abs(th) > np.asarray(r.eta)).any(axis=0)
    assert past[0] or past[1]


def test_row_jit_and_vmap_over_records():
    """Reference: a Python loop over the same records (the same arithmetic)."""
    row = Assembly.row([SLENDER, SQUAT])
    beta = float(rj.beta_dejong(SQUAT))
    dt = stable_dt_assembly(row, beta)
    ag = PULSE.ag[: int(1.2 / PULSE.dt)]  # the pulse's first 1.2 s: the leaves meet
    ags = jnp.stack([ag, 0.8 * ag, -0.6 * ag])

    def run(ag):
        gm = rj.GroundMotion(ag=ag, dt=PULSE.dt)
        return simulate_assembly(row, gm, beta=beta, dt=dt).theta

    batch = jax.jit(jax.vmap(run))(ags)
    for i in range(ags.shape[0]):
        one = run(ags[i])
        peak = float(jnp.max(jnp.abs(one)))
        assert float(jnp.max(jnp.abs(batch[i] - one))) < VMAP_RTOL * peak


@pytest.mark.usefixtures("user_view")
@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: Assembly.row([SLENDER, SQUAT], x_offset=(0.0, 0.1)), "overlaps"),
        (
            lambda: Assembly(blocks=(SLENDER,), x_offset=(0.0,), top="restrained", layout="row"),
            "stands free",
        ),
        (
            lambda: Assembly(blocks=(SLENDER,), x_offset=(0.0,), overburden=1e3, layout="row"),
            "stands free",
        ),
        (lambda: Assembly(blocks=(SLENDER,), x_offset=(0.0,), layout="column"), "layout"),
        (lambda: simulate_assembly(Assembly.row([SLENDER, SQUAT]), theta0=0.01), "theta0"),
        (
            lambda: simulate_assembly(Assembly.row([SLENDER, SQUAT]), PULSE, mode="one_sided"),
            "one_sided",
        ),
        (lambda: collapse_multiplier(Assembly.row([SLENDER, SQUAT]), "stack"), "mechanism='row'"),
        (lambda: collapse_multiplier(Assembly.row([SLENDER], x_offset=(0.0,)), "top"), "row"),
        (
            lambda: collapse_multiplier(Assembly.row([SLENDER, SQUAT], x_offset=(0, 0.3)), "row"),
            "apart",
        ),
    ],
)
def test_row_bad_input(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_row_ida_equals_single_runs():
    """Reference: rj.simulate_assembly of the row on the same (zero-padded) record. The IDA's
    ``max_d_over_b`` is the +x end block's top displacement from its rest position over block
    0's ``b``: a block standing off x = 0 (every block of a row but the first) is measured from
    its own rest position (the IDA subtracted x_offset from displacements that were already
    relative to it)."""
    row = Assembly.row([SLENDER, SQUAT])
    beta = float(rj.beta_dejong(SQUAT))
    rec = rj.GroundMotion(ag=PULSE.ag[: int(1.2 / PULSE.dt)], dt=PULSE.dt, name="pulse")
    ds = rj.ida(row, [rec], [1.0], model=rj.DEM(beta=beta), tail=0.0, progress=False)
    n = int(round(float(ds.attrs["t_end"]) / rec.dt)) + 1
    ag = np.zeros(n)
    ag[: rec.n] = np.asarray(rec.ag)
    dt = stable_dt_assembly(row, beta)
    r = simulate_assembly(row, rj.GroundMotion(ag=ag, dt=rec.dt), beta=beta, dt=dt)
    d = np.asarray(r.x[:, -1]) + 0.5 * float(SQUAT.h) * np.sin(np.asarray(r.theta[:, -1]))
    assert float(np.max(np.abs(d))) > 1e-5  # it moved
    expect = float(np.max(np.abs(d))) / float(SLENDER.b)
    assert float(ds.max_d_over_b[0, 0]) == pytest.approx(expect, rel=VMAP_RTOL)
    theta = float(np.max(np.asarray(r.theta_max) / np.asarray(r.eta)))
    assert float(ds.max_theta_over_eta[0, 0]) == pytest.approx(theta, rel=VMAP_RTOL)
