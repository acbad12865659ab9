"""A one-block facade's open steps (``rockjax.dem.run``'s ``n_open``): while its return wall is
out of reach the DEM steps by ``extras["dt_open"]``, set by the block's base alone, and by
``extras["dt"]`` (set by the wall's springs too) from the sample where the wall comes within
reach.

References: the uniform step (a concrete ``dt`` inside ``jit`` fixes the steps a sample in the
program, and every one is ``dt``), at the open step where the wall stays out of reach (the
same arithmetic: central differences whose first step changes its length), and four times
finer than the default on far-field records (the converged peak).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax.constants import G

BLOCK = rj.Block(b=0.2, h=1.5)
BETA = 3.0e-4  # [s], about the fitted beta of this facade (experiments/facade_ida_step.py)
DT_OUT = 0.005  # [s]

SAME_TOL = 1e-12  # [rad]: the same steps, the first one's length changed at rest (measured
# 1.4e-14 rad)
PEAK_RTOL = 2e-3  # [-] of the peak d/b against a 4x finer uniform step: on these four runs
# the uniform default step errs by 3.9e-5-4.2e-4 and the open steps by 5.2e-5-4.3e-4
# (measured); over 103 rocking far-field runs the uniform step's median error is 6.3e-4
# (docs/verification.md, "Open steps")


def uniform(motion, dt, mode):
    """The run with every step ``dt``: ``dt`` concrete inside the caller's ``jit``."""

    def run(ag):
        gm = rj.GroundMotion(ag=ag, dt=motion.dt)
        return rj.simulate_dem(BLOCK, gm, beta=BETA, mode=mode, dt=dt, throw=False)

    return jax.jit(run)(jnp.asarray(motion.ag))


def test_open_steps_are_central_differences_off_the_wall():
    """A facade 8 cm off its wall, rocked by a pulse that does not bring it back to the wall
    in 1.5 s, takes open steps only: the history of a uniform run at ``dt_open``."""
    t = np.arange(300) * DT_OUT
    ag = np.where(t < 0.4, 0.25 * G * np.sin(2 * np.pi * t / 0.4), 0.0)
    gm = rj.GroundMotion(ag=ag, dt=DT_OUT)
    mode = rj.Facade(gap=0.08)
    r = rj.simulate_dem(BLOCK, gm, beta=BETA, mode=mode)
    dt, dt_open = float(r.extras["dt"]), float(r.extras["dt_open"])
    assert dt_open >= 2 * dt  # the wall's springs set dt, not dt_open
    theta = np.asarray(r.theta)
    assert theta.max() > 0.5 * float(r.eta)  # it rocks out
    assert -0.08 / 1.5 < theta.min() < -0.5 * 0.08 / 1.5  # and back, short of its wall
    ref = uniform(gm, dt_open, mode)
    np.testing.assert_allclose(theta, ref.theta, rtol=0, atol=SAME_TOL)


def test_open_steps_only_for_a_facade_of_one_block():
    gm = rj.GroundMotion.ricker(pga=1.0, period=0.3, dt=DT_OUT, duration=0.2)
    facade = rj.simulate_dem(BLOCK, gm, beta=BETA, mode=rj.Facade(gap=0.001))
    assert float(facade.extras["dt_open"]) > float(facade.extras["dt"])
    parapet = rj.simulate_dem(BLOCK, gm, beta=BETA)
    assert "dt_open" not in parapet.extras
    stack = rj.simulate_dem(rj.Assembly.stack([BLOCK, BLOCK]), gm, beta=BETA, mode="one_sided")
    assert stack.dt_open is None


@pytest.fixture(scope="module")
def records():
    recs = rj.records.fema_p695("farfield")
    return {i: recs[i].scaled_to_pga(target_pga_g=1.0) for i in (8, 12)}


@pytest.mark.parametrize("index, pga_g", [(8, 0.22), (8, 0.4), (12, 0.16), (12, 0.22)])
def test_open_steps_converged_on_records(records, index, pga_g):
    """The peak d/b of far-field records (facade 1 mm off its wall, rocking to 0.05-0.4 b and
    standing) within ``PEAK_RTOL`` of a uniform step four times finer than the default.
    Screened for conditioning: the uniform default step is within 4.2e-4 of it on each."""
    rec = records[index]
    gm = rj.GroundMotion(ag=rec.ag * pga_g, dt=rec.dt)
    mode = rj.Facade(gap=0.001)
    r = rj.simulate_dem(BLOCK, gm, beta=BETA, mode=mode, throw=False)
    ref = uniform(gm, float(r.extras["dt"]) / 4, mode)
    assert not bool(ref.overturned) and not bool(r.overturned)
    peak, peak_ref = float(r.extras["d_max"]), float(ref.extras["d_max"])
    assert 0.03 < peak_ref / BLOCK.b < 0.6
    assert abs(peak / peak_ref - 1) < PEAK_RTOL
