import re

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pandas as pd
import pytest

import rockjax as rj
from rockjax.response import e_exp, find_peaks


def test_find_peaks_refines_a_sampled_cosine():
    """Reference: the exact maxima of |cos(2 pi t)| at t = k/2."""
    t = np.arange(0.0, 3.0, 0.013)
    tp, yp = find_peaks(t, np.abs(np.cos(2 * np.pi * t)))
    np.testing.assert_allclose(tp, np.arange(1, tp.size + 1) * 0.5, atol=2e-4)
    np.testing.assert_allclose(yp, 1.0, atol=1e-4)


def test_e_exp_inverts_the_linearised_decay():
    """Reference: amplitude_after_impacts (docs/verification.md, Housner closed forms) fed back through Eq. 6."""
    eta, theta0, e = 0.2, 0.1, 0.94
    for n in (1, 2, 3):
        th_n = rj.relations.amplitude_after_impacts(theta0, eta, e, n)
        assert np.isclose(e_exp(th_n, theta0, eta, n), e, rtol=1e-12)


def test_public_names_have_docstrings():
    names = rj.__all__
    missing = [n for n in names if not getattr(getattr(rj, n), "__doc__", None)]
    assert not missing, missing


# ----------------------------------------------------------------------------- outputs
BLOCK = rj.Block(b=0.25, h=3.0)


@pytest.fixture(scope="module")
def free_rocking():
    """Housner free rocking from 0.5 eta (1.5 s) and a DEM run of the same release (0.5 s)."""
    th0 = 0.5 * float(BLOCK.eta)
    h = rj.simulate_housner(BLOCK, theta0=th0, duration=1.5)
    d = rj.simulate_dem(
        BLOCK, theta0=th0, duration=0.5, beta=float(rj.beta_dejong(BLOCK)), save_dt=0.01
    )
    return h, d


def test_to_dataframe_round_trips_through_csv(free_rocking, tmp_path):
    h, d = free_rocking
    df = h.to_dataframe()
    assert df.index.name == "t [s]"
    np.testing.assert_array_equal(df.index.to_numpy(), np.asarray(h.t))
    expected = {
        "theta [rad]": h.theta,
        "theta_dot [rad/s]": h.theta_dot,
        "d [m]": h.d,
        "theta/eta [-]": np.asarray(h.theta) / float(BLOCK.eta),
        "d/b [-]": np.asarray(h.d) / 0.25,
        "energy [J]": h.energy,
        "n_impacts [-]": h.extras["n_impacts"],
    }
    for name, value in expected.items():
        np.testing.assert_allclose(df[name].to_numpy(), np.asarray(value), rtol=1e-15)
    assert df.attrs["model"] == "Housner" and df.attrs["status"] == 0
    assert df.attrs["overturned"] is False and df.attrs["eta [rad]"] == float(BLOCK.eta)
    # every column name carries a unit in brackets
    assert all(re.fullmatch(r".+ \[[^]]+\]", c) for c in df.columns), list(df.columns)
    # CSV round trip: 17 significant digits restore float64 exactly
    path = tmp_path / "h.csv"
    df.to_csv(path, float_format="%.17g")
    back = pd.read_csv(path, index_col=0)
    assert list(back.columns) == list(df.columns) and back.index.name == "t [s]"
    np.testing.assert_array_equal(back.to_numpy(), df.to_numpy())
    dem = d.to_dataframe()
    assert dem.attrs["model"] == "DEM" and {"x [m]", "y [m]"} <= set(dem.columns)
    assert dem.shape[0] == np.asarray(d.t).size


def test_to_dataframe_refuses_a_batch(free_rocking):
    h, _ = free_rocking
    batch = jax.tree.map(lambda x: jnp.stack([x, x]), h)  # what vmap over two runs returns
    with pytest.raises(ValueError, match=r"one run.*jax\.tree\.map\(lambda x: x\[i\], resp\)"):
        batch.to_dataframe()
    text = repr(batch)
    assert text.startswith("Response(Housner, batch (2,) of 2 runs") and "\n" not in text
    assert "0 overturned" in text and "0 with status != 0" in text


def test_response_repr_is_one_informative_line(free_rocking):
    h, d = free_rocking
    for resp, model in ((h, "Housner"), (d, "DEM")):
        text = repr(resp)
        assert "\n" not in text and len(text) < 160, text
        assert text.startswith(f"Response({model}, block 0.25 x 3 m, ")
        ratio = float(resp.theta_max / resp.eta)
        assert f"peak |theta|/eta {ratio:.4g}" in text and "standing" in text
        assert "status 0 (ok)" in text
    over = eqx.tree_at(lambda r: r.overturned, h, jnp.asarray(True))
    assert ", overturned, " in repr(over)

    # under jit the fields are tracers: repr falls back to the structure, without an error
    @jax.jit
    def traced(r):
        assert repr(r).startswith("Response(\n")
        return r.theta_max

    traced(h)


def test_calibration_repr_is_one_informative_line(free_rocking):
    """The Calibration result type's repr (rockjax.calibration.result), built here from a run
    instead of a fit (fits take seconds)."""
    from rockjax.calibration import Calibration

    _, d = free_rocking
    common = dict(
        loss=1e-6,
        peak_loss=2e-4,
        history_error=0.01,
        history={"beta": np.zeros(3), "loss": np.zeros(3)},
        n_simulations=17,
        n_iterations=6,
        e_range=(0.9, 0.99),
        beta_max=0.01,
        method="lbfgs",
        seconds=2.5,
        dem=d,
        housner=None,
    )
    fit = Calibration(
        beta=2.345e-3,
        e=0.975,
        e_effective=0.9748,
        e_exp=np.full(3, 0.97),
        converged=True,
        **common,
    )
    text = repr(fit)
    assert "\n" not in text and len(text) < 200, text
    for part in ("beta = 0.002345 s", "0.25 x 3 m", "e target 0.9750", "e_effective 0.9748"):
        assert part in text, text
    assert "converged" in text and "NOT" not in text and "lbfgs, 6 iterations, 17 runs" in text
    missed = Calibration(
        beta=1e-3,
        e=None,
        e_effective=float("nan"),
        e_exp=np.array([0.6, 0.7, np.nan]),
        converged=False,
        reason="bounce 3 did not happen",
        **common,
    )
    text = repr(missed)
    assert "e_exp 1-3 0.600, 0.700, nan" in text
    assert "NOT converged: bounce 3 did not happen" in text
