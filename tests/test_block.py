import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax.constants import G


def test_derived_quantities_by_hand():
    """Reference: hand arithmetic for the 0.25 x 3 m parapet (rho 1800, E 1.8 GPa)."""
    blk = rj.Block(b=0.25, h=3.0)
    assert np.isclose(blk.m, 1800 * 0.25 * 3.0)
    assert np.isclose(blk.R, 0.5 * np.hypot(0.25, 3.0))
    assert np.isclose(blk.eta, np.arctan(0.25 / 3.0))
    assert np.isclose(blk.p, np.sqrt(3 * G / (4 * blk.R)))
    assert np.isclose(blk.I_O, blk.I_c + blk.m * blk.R**2)  # parallel axis theorem
    assert np.isclose(blk.j_kn, 1.8e9 / 3.0)
    assert np.isclose(blk.j_ks, blk.j_kn / 2.5)


def test_block_is_a_pytree_for_vmap_and_grad():
    hs = jnp.array([1.5, 3.0, 6.0])
    etas = jax.vmap(lambda h: rj.Block(b=0.25, h=h).eta)(hs)
    np.testing.assert_allclose(etas, np.arctan(0.25 / np.asarray(hs)), rtol=1e-14)
    d_eta = jax.grad(lambda b: rj.Block(b=b, h=3.0).eta)(0.25)
    assert np.isclose(d_eta, 3.0 / (3.0**2 + 0.25**2))


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(b=-0.1, h=3.0), "b must be a positive finite number in m"),
        (dict(b=0.25, h=0.0), "h must be a positive"),
        (dict(b=0.25, h=float("nan")), "h must be a positive"),
        (dict(b=0.25, h=3.0, rho=0.0), "rho must be"),
        (dict(b=0.25, h=3.0, E=-1.0), "E must be"),
        (dict(b=0.25, h=3.0, nu=0.6), "nu"),
        (dict(b=0.25, h=3.0, length=float("inf")), "length must be"),
        # unit slips: a silent wrong result before (E in MPa sank the block 177 m into the base)
        (dict(b=0.25, h=3.0, E=1800.0), r"E=1800.0 Pa is below 1e\+07 Pa.*did you give MPa"),
        (dict(b=250.0, h=3.0), "b=250.0 m is above 50 m.*did you give millimetres"),
        (dict(b=0.25, h=3000.0), "h=3000.0 m is above 50 m"),
    ],
)
def test_invalid_geometry_is_refused(kw, match):
    with pytest.raises(ValueError, match=match):
        rj.Block(**kw)


@pytest.mark.parametrize("theta", [-0.3, -1e-3, 0.0, 2e-2, 0.3])
def test_top_displacement_is_the_rotated_top_centre(theta):
    """Reference: the top centre (body coordinates relative to the pivot corner) rotated by a
    rotation matrix about that corner; the pivot is the +x corner for theta > 0."""
    blk = rj.Block(b=0.25, h=3.0)
    side = 1.0 if theta >= 0 else -1.0
    rel = np.array([-side * 0.125, 3.0])  # top centre minus pivot corner, at rest
    c, s = np.cos(theta), np.sin(theta)
    rotated = np.array([[c, s], [-s, c]]) @ rel  # theta > 0 moves the top toward +x
    np.testing.assert_allclose(blk.top_displacement(theta), rotated[0] - rel[0], atol=1e-15)


def test_block_can_be_built_inside_jit():
    """A Block made from Python floats inside a jitted function (its checks run in NumPy)."""
    eta = jax.jit(lambda h: rj.Block(b=0.25, h=3.0, nu=0.2).eta * h)(1.0)
    np.testing.assert_allclose(eta, np.arctan(0.25 / 3.0), rtol=1e-14)


def test_text_for_a_number_is_refused_by_name():
    """``Block(b="0.25")``: NumPy would read the text as a number and JAX fail deep inside.
    Run without the test suite's runtime type checks (which would refuse it first), as a user
    runs it."""
    code = (
        "import rockjax as rj\n"
        "for kw in ({'b': '0.25', 'h': 3.0}, {'b': 0.25, 'h': 3.0, 'E': '1.8e9'}):\n"
        "    try:\n"
        "        rj.Block(**kw)\n"
        "    except ValueError as err:\n"
        "        print(err)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "b must be a number in m, not text; got b='0.25'" in out.stdout
    assert "E must be a number in Pa, not text" in out.stdout
