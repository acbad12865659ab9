"""The array layout of tall stacks (``rockjax.dem.run(layout="stacked")``, the default from
``rockjax.dem.STACKED_MIN_BLOCKS`` blocks up) against the unrolled step it replaces: the same
model written block by block, run on the same stack with the same step (the independent
reference is that other program: its joints, solve and collapse rule are each written out per
block). The two differ only in the order of floating-point sums."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax import dem

ROUNDOFF_RAD = 1e-12
"""Largest theta difference [rad] between the two layouts: round-off (sums in another order,
~1e-16 relative a step) grown over a short rocking history; a wrong joint, view or solve
entry differs by orders more (a joint off by one block moves theta by > 1e-6 within a step of
contact)."""

ROUNDOFF_REL = 1e-10
"""Relative difference of the saved energy between the layouts (round-off)."""

ROUNDOFF_FORCE_REL = 1e-8
"""Relative difference of the saved forces between the layouts: a joint's force is its
stiffness times a penetration ~1e-5 m, so one ulp of a position (~4e-16 m at 2 m) is ~1e-10
of it, and a history accumulates a few (measured 3.6e-10 on the restrained wall)."""

FD_REL = 1e-4
"""Relative agreement of reverse-mode d(theta)/d(beta) with a central finite difference
(step 1e-6 of beta ~1e-3: truncation ~1e-6, cancellation ~1e-9 relative)."""

BRICK = dict(b=0.23, h=0.3)
N_BLOCKS = 7
DT_OUT = 0.01


def _stack(n=N_BLOCKS, **kw):
    return rj.Assembly.stack([rj.Block(**BRICK)] * n, **kw)


def _both(asm, gm, beta=1e-3, mode="two_sided", top=None, wall=None, save=("energy",),
          layouts=("stacked", "unrolled"), one_history=False):  # fmt: skip
    p = dem.dem_params(asm, beta, mode=mode)
    st0 = dem.initial_state(asm, p)
    dt = float(dem.default_step(p, 0.5))
    n_in = int(np.ceil(DT_OUT / dt))
    ag = jnp.asarray(gm.ag)
    z = jnp.zeros_like(ag)

    def one(layout):
        return dem.run(p, st0, ag, z, DT_OUT / n_in, DT_OUT, n_in, save, False, top, wall,
                       one_history=one_history, layout=layout)  # fmt: skip

    return tuple(one(layout) for layout in layouts)


def _assert_same(a, b, keys=("energy",)):
    assert int(a.status) == int(b.status) == 0
    assert bool(a.overturned) == bool(b.overturned)
    err = float(jnp.max(jnp.abs(a.theta - b.theta)))
    assert err <= ROUNDOFF_RAD, err
    np.testing.assert_allclose(a.theta_max, b.theta_max, rtol=0, atol=ROUNDOFF_RAD)
    for key in keys:
        x, y = getattr(a, key), getattr(b, key)
        scale = float(jnp.max(jnp.abs(y)))
        tol = ROUNDOFF_REL if key in ("energy", "work_wall") else ROUNDOFF_FORCE_REL
        assert float(jnp.max(jnp.abs(x - y))) <= tol * scale, key


def test_stacked_parapet_equals_unrolled():
    gm = rj.GroundMotion.sine_cycle(pga=6.0, period=0.25, dt=DT_OUT, duration=1.0)
    a, b = _both(_stack(), gm, save=("energy", "forces"))
    # it rocks: the layouts are compared on contact changes, not at rest
    assert float(jnp.max(jnp.abs(b.theta))) > 1e-3
    _assert_same(a, b, keys=("energy", "normal_forces", "shear_forces"))


def test_stacked_facade_on_a_moving_wall_equals_unrolled():
    gm = rj.GroundMotion.sine_cycle(pga=5.0, period=0.25, dt=DT_OUT, duration=1.0)
    t = np.arange(gm.n) * DT_OUT
    omega = 2 * np.pi / 0.4
    wall = (jnp.asarray(0.004 * np.sin(omega * t)), jnp.asarray(0.004 * omega * np.cos(omega * t)))
    a, b = _both(_stack(), gm, mode=rj.Facade(gap=0.001), wall=wall, save=("energy", "forces"))
    assert float(jnp.max(jnp.abs(b.theta))) > 1e-3
    _assert_same(a, b, keys=("energy", "work_wall", "wall_forces", "normal_forces"))


def test_one_history_with_its_solve_written_out_equals_unrolled():
    # one history by the default rule (layout=None) from STACKED_MIN_BLOCKS_ONE blocks: the
    # stacked layout with its solve written out block by block (SOLVE_UNROLLED_MAX_BLOCKS),
    # here a facade on a moving wall, whose back faces add to every diagonal block
    n = dem.STACKED_MIN_BLOCKS_ONE
    assert n <= dem.SOLVE_UNROLLED_MAX_BLOCKS
    gm = rj.GroundMotion.sine_cycle(pga=5.0, period=0.25, dt=DT_OUT, duration=1.0)
    t = np.arange(gm.n) * DT_OUT
    omega = 2 * np.pi / 0.4
    wall = (jnp.asarray(0.004 * np.sin(omega * t)), jnp.asarray(0.004 * omega * np.cos(omega * t)))
    a, b = _both(_stack(n), gm, mode=rj.Facade(gap=0.001), wall=wall, save=("energy", "forces"),
                 layouts=(None, "unrolled"), one_history=True)  # fmt: skip
    assert float(jnp.max(jnp.abs(b.theta))) > 1e-3
    _assert_same(a, b, keys=("energy", "work_wall", "wall_forces", "normal_forces"))


def test_stacked_restrained_top_with_overburden_equals_unrolled():
    gm = rj.GroundMotion.sine_cycle(pga=8.0, period=0.25, dt=DT_OUT, duration=1.0)
    t = np.arange(gm.n) * DT_OUT
    omega = 2 * np.pi / 0.3
    top = (jnp.asarray(0.003 * np.sin(omega * t)), jnp.asarray(0.003 * omega * np.cos(omega * t)))
    asm = _stack(top="restrained", overburden=5e3, gap=0.001)
    a, b = _both(asm, gm, top=top, save=("energy", "forces"))
    assert float(jnp.max(jnp.abs(b.theta))) > 1e-4
    _assert_same(a, b, keys=("energy", "restraint_force", "normal_forces"))


def test_stacked_collapse_equals_unrolled():
    gm = rj.GroundMotion.sine_cycle(pga=12.0, period=0.6, dt=DT_OUT, duration=1.5)
    a, b = _both(_stack(), gm, beta=0.0)
    assert bool(b.overturned)
    # frozen at the same sample: the collapse rule fired at the same step in both
    np.testing.assert_array_equal(np.asarray(a.theta[-1]), np.asarray(a.theta[-2]))
    _assert_same(a, b)


def test_simulate_dem_of_a_tall_stack_is_the_stacked_run():
    # the default layout of one history of STACKED_MIN_BLOCKS_ONE blocks is the array one
    asm = _stack(dem.STACKED_MIN_BLOCKS_ONE)
    gm = rj.GroundMotion.sine_cycle(pga=6.0, period=0.25, dt=DT_OUT, duration=0.5)
    r = rj.simulate_dem(asm, gm, beta=1e-3, accuracy=0.5)
    (a,) = _both(asm, gm, layouts=("stacked",))
    np.testing.assert_allclose(r.theta, a.theta, rtol=0, atol=ROUNDOFF_RAD)


def _equations(jaxpr) -> int:
    count = 0
    for eqn in jaxpr.eqns:
        count += 1
        for sub in jax.extend.core.jaxprs_in_params(eqn.params):
            count += _equations(sub)
    return count


def test_stacked_program_does_not_grow_with_the_stack():
    # the traced run (what XLA compiles) is the same program for 20 and 160 blocks: one copy
    # of each joint, of the solve's elimination and of the collapse rule
    sizes = []
    gm = rj.GroundMotion.sine_cycle(pga=1.0, period=0.25, dt=DT_OUT, duration=0.1)
    for n in (20, 160):
        asm = _stack(n, top="restrained", overburden=5e3)
        p = dem.dem_params(asm, 1e-3, mode=rj.Facade(gap=0.001))
        st0 = dem.initial_state(asm, p)
        ag = jnp.asarray(gm.ag)

        def f(p, st0, ag):
            return dem.run(p, st0, ag, ag, 1e-4, DT_OUT, 100, ("energy", "forces"))

        sizes.append(_equations(jax.make_jaxpr(f)(p, st0, ag).jaxpr))
    assert sizes[0] == sizes[1], sizes


def test_default_layout_of_one_history_and_of_a_batch():
    # one history unrolls a stack below STACKED_MIN_BLOCKS_ONE blocks (its step is cheaper
    # and it compiles in under 10 s there), a batch from STACKED_MIN_BLOCKS blocks stacks it:
    # the default rule's program is the named layout's, the stacked one does not grow with the
    # stack, the unrolled one does. In one history up to SOLVE_UNROLLED_MAX_BLOCKS blocks the
    # stacked layout writes its solve out: a program between the two, growing by a solve's block
    gm = rj.GroundMotion.sine_cycle(pga=1.0, period=0.25, dt=DT_OUT, duration=0.1)
    ag = jnp.asarray(gm.ag)

    def size(n, one_history, layout=None):
        p = dem.dem_params(_stack(n), 1e-3)
        st0 = dem.initial_state(_stack(n), p)

        def f(p, st0, ag):
            return dem.run(p, st0, ag, ag, 1e-4, DT_OUT, 100, one_history=one_history,
                           layout=layout)  # fmt: skip

        return _equations(jax.make_jaxpr(f)(p, st0, ag).jaxpr)

    n_one, n_batch, n_out = (
        dem.STACKED_MIN_BLOCKS_ONE, dem.STACKED_MIN_BLOCKS, dem.SOLVE_UNROLLED_MAX_BLOCKS
    )  # fmt: skip
    assert n_batch < n_one <= n_out
    # a batch
    stacked_batch = size(20, False)
    assert size(n_batch, False) == stacked_batch == size(n_batch, False, "stacked")
    assert size(n_batch - 1, False) == size(n_batch - 1, False, "unrolled") != stacked_batch
    # one history
    assert size(n_one - 1, True) == size(n_one - 1, True, "unrolled")
    written = [size(n, True) for n in (n_one, n_one + 1, n_out)]
    assert size(n_one, True, "stacked") < written[0] < size(n_one, True, "unrolled")
    # the solve written out grows by one block's elimination a block, up to n_out blocks
    assert (written[2] - written[1]) == (n_out - n_one - 1) * (written[1] - written[0]) > 0
    assert size(n_out + 1, True) == size(40, True) == size(40, True, "stacked")


def test_a_stack_inside_a_transform_takes_the_batch_layout():
    # rj.simulate_dem under jax.jit or jax.grad stacks from STACKED_MIN_BLOCKS blocks, as a
    # batch does: the reverse-mode program of an unrolled 8-block stack compiled in 69 s,
    # of the stacked one in 22 s (docs/benchmarks.md, "Tall walls: one history and batches")
    gm = rj.GroundMotion.sine_cycle(pga=1.0, period=0.25, dt=DT_OUT, duration=0.1)

    def size(n):
        asm = _stack(n)

        def f(beta):
            return rj.simulate_dem(asm, gm, beta=beta, dt=2e-4, throw=False).theta_max

        return _equations(jax.make_jaxpr(f)(1e-3).jaxpr)

    assert dem.STACKED_MIN_BLOCKS < dem.STACKED_MIN_BLOCKS_ONE
    assert size(dem.STACKED_MIN_BLOCKS) == size(20)


def test_a_batch_of_stacks_keeps_its_solve_out_of_library_reductions():
    """A batch of 64 six-block stacks: the solve's entries (21 a block) are kept whole by two
    reductions of 12 and 9 outputs, which XLA:CPU compiles itself. One reduction per array
    (``diag`` alone: 6 x 64 x 9 values) went to the YNNPACK library (``__ynn_fusion``), where
    a batch of tall stacks stepped 1.4-2.0x slower (docs/benchmarks.md, "Tall walls: the
    solve's reductions"). On a jaxlib without YNNPACK there is nothing to find."""
    asm = _stack(dem.STACKED_MIN_BLOCKS)
    p = dem.dem_params(asm, 1e-3)
    st0 = dem.initial_state(asm, p)
    ags = jnp.ones((64, 3))

    def one(ag):
        return dem.run(p, st0, ag, jnp.zeros_like(ag), 1e-4, DT_OUT, 100).theta_max

    text = jax.jit(jax.vmap(one)).lower(ags).compile().as_text()
    assert "__ynn_fusion" not in text


@pytest.mark.slow  # 20-23 s (three runs of a tall stack); ./test.sh -m slow
def test_grad_through_a_tall_stack_matches_finite_differences():
    asm = _stack(8)
    gm = rj.GroundMotion.sine_cycle(pga=6.0, period=0.25, dt=DT_OUT, duration=0.3)
    p0 = dem.dem_params(asm, 1e-3)
    st0 = dem.initial_state(asm, p0)
    dt = float(dem.default_step(p0, 0.5))
    n_in = int(np.ceil(DT_OUT / dt))
    ag = jnp.asarray(gm.ag)

    @jax.jit
    def top_theta(beta):
        p = dem.dem_params(asm, beta)
        r = dem.run(p, st0, ag, jnp.zeros_like(ag), DT_OUT / n_in, DT_OUT, n_in)
        return r.theta[-1, -1]

    assert float(jnp.abs(top_theta(1e-3))) > 1e-4
    g = float(jax.grad(top_theta)(1e-3))
    eps = 1e-6
    fd = float((top_theta(1e-3 + eps) - top_theta(1e-3 - eps)) / (2 * eps))
    assert np.isfinite(g) and g != 0.0
    assert abs(g - fd) <= FD_REL * abs(fd), (g, fd)


def test_an_unknown_layout_is_refused():
    body = rj.Assembly.stack([rj.Block(b=0.23, h=0.3)] * 2)
    p = dem.dem_params(body, 1e-3)
    s0 = dem.initial_state(body, p)
    z = np.zeros(64)
    with pytest.raises(ValueError, match=r"layout must be one of \['stacked', 'unrolled'\]"):
        dem.run(p, s0, z, z, np.asarray(1e-4), np.asarray(0.01), 10, (), False, None, None,
                layout="stack")  # fmt: skip
