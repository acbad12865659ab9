"""Figures build, label their axes with units, and save; matplotlib stays out of `import rockjax`.

The responses here are synthetic (a decaying cosine packed into a `Response`), not simulations:
these tests check the drawing code, not the physics.
"""

import subprocess
import sys

import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax import plot
from rockjax.constants import G

ETA = 0.0831  # [rad], the 0.25 x 3 m parapet


def _response(decay: float, overturned: bool = False, one_sided: bool = False) -> rj.Response:
    t = jnp.linspace(0.0, 6.0, 1201)
    theta = 0.5 * ETA * jnp.exp(-decay * t) * jnp.cos(2.6 * t)
    if one_sided:
        theta = jnp.abs(theta)
    return rj.Response(
        t=t,
        theta=theta,
        theta_dot=jnp.gradient(theta, t),
        d=3.0 * theta,
        overturned=jnp.asarray(overturned),
        status=jnp.asarray(0),
        theta_max=jnp.max(jnp.abs(theta)),
        eta=jnp.asarray(ETA),
        b=jnp.asarray(0.25),
    )


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plot._pyplot().close("all")


def _legend_texts(ax):
    return [t.get_text() for t in ax.get_legend().get_texts()]


def test_time_history_labels_and_saves(tmp_path):
    ax = plot.time_history(
        {"slow decay": _response(0.05), "fast decay": _response(0.4, overturned=True)},
        title="two responses",
    )
    assert ax.get_xlabel() == "time t [s]"
    assert "theta/\\eta" in ax.get_ylabel() and "[-]" in ax.get_ylabel()
    assert ax.get_title() == "two responses"
    texts = _legend_texts(ax)
    assert "slow decay" in texts and "fast decay (overturned)" in texts
    path = tmp_path / "th.png"
    ax.figure.savefig(path)
    assert path.stat().st_size > 1000


def test_time_history_in_radians_on_given_axes():
    plt = plot._pyplot()
    fig, ax = plt.subplots()
    out = plot.time_history({"r": _response(0.1)}, ax=ax, normalise=False)
    assert out is ax
    assert ax.get_ylabel().endswith("[rad]")
    y = ax.get_lines()[0].get_ydata()
    np.testing.assert_allclose(y[0], 0.5 * ETA)


def test_time_history_one_sided_draws_one_overturning_line():
    ax = plot.time_history({"facade": _response(0.3, one_sided=True)})
    levels = [line.get_ydata()[0] for line in ax.get_lines()[1:]]
    assert 1.0 in levels and -1.0 not in levels


def test_time_history_rejects_empty():
    with pytest.raises(ValueError, match="at least one response"):
        plot.time_history({})


def test_peaks_decay_starts_at_release_and_draws_reference(tmp_path):
    ax = plot.peaks_decay(
        {"a": _response(0.05), "b": _response(0.2)}, n_bounces=4, e_reference={"e_H": 0.99}
    )
    lines = ax.get_lines()
    assert len(lines) == 3  # two responses and one reference
    np.testing.assert_allclose(lines[0].get_ydata()[0], 0.5)  # |theta_0| / eta
    assert list(lines[0].get_xdata()) == [0, 1, 2, 3, 4]
    assert "bounce" in ax.get_xlabel() and "[-]" in ax.get_ylabel()
    assert "e_H (linearised)" in _legend_texts(ax)
    ax.figure.savefig(tmp_path / "peaks.png")


def test_e_beta_series_with_missing_bounces(tmp_path):
    betas = np.array([0.0, 0.006, 0.012])
    e = np.array([[1.0, 1.0, 1.0], [0.96, 0.96, np.nan], [np.nan, np.nan, np.nan]])
    ax = plot.e_beta(
        betas, {"closed": e, "clipped": np.array([1.0, 0.98, 0.97])}, e_h=0.99, beta_dejong=0.012
    )
    assert "[s]" in ax.get_xlabel() and "[-]" in ax.get_ylabel()
    texts = _legend_texts(ax)
    assert any(t.startswith("closed, mean of bounces 1-3") for t in texts)
    assert "clipped" in texts
    assert any("e_H" in t for t in texts) and any("DeJong" in t for t in texts)
    ax.figure.savefig(tmp_path / "e_beta.png")


def test_e_beta_rejects_mismatched_shape():
    with pytest.raises(ValueError, match="n_beta=3"):
        plot.e_beta([0.0, 0.01, 0.02], np.ones(2))


def test_ground_motion_units():
    gm = rj.GroundMotion.ricker(pga=4.0, period=0.5)
    ax = plot.ground_motion(gm)
    assert ax.get_xlabel() == "time t [s]" and "a_g/g" in ax.get_ylabel()
    np.testing.assert_allclose(np.max(ax.get_lines()[0].get_ydata()), 4.0 / G)
    ax = plot.ground_motion(gm, in_g=False)
    assert "m/s" in ax.get_ylabel()


def test_import_rockjax_does_not_import_matplotlib():
    code = "import sys, rockjax, rockjax.plot, rockjax.cli; print('matplotlib' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
