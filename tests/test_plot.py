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
    plot.pyplot().close("all")


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
    plt = plot.pyplot()
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


def test_namespaces_list_no_imported_modules():
    """`dir(rockjax)` and `dir(rj.plot)` (tab completion) list rockjax's own names, not the
    modules they import."""
    imported = {"np", "os", "sys", "jax", "re", "warnings", "math", "jnp"}
    assert not imported & set(dir(rj)), sorted(imported & set(dir(rj)))
    assert not imported & set(dir(rj.plot))
    assert set(dir(rj.plot)) == set(rj.plot.__all__)
    assert all(callable(getattr(rj.plot, name)) for name in rj.plot.__all__)


def test_import_rockjax_does_not_import_matplotlib():
    code = "import sys, rockjax, rockjax.plot, rockjax.cli; print('matplotlib' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


# ----------------------------------------------------------------------------- IDA and fragility


def _ida_dataset(pga=(2.0, 3.0, 4.0), shift=0.0):
    """A hand-made IDA Dataset (3 records x 6 scales) with the variables rockjax.ida returns."""
    import xarray as xr

    scales = np.linspace(0.25, 1.5, 6)
    pga = np.asarray(pga)
    im = pga[:, None] * scales[None, :]
    d = 0.1 * (im / 3.0) ** 2 + shift
    collapse = im > np.array([3.5, 2.5, 4.5])[:, None]
    collapse[1, -1] = False  # a "resurrection"
    status = np.zeros(im.shape, np.int32)
    status[2, 0] = 1  # a failed run: not drawn
    dims = ("record", "scale")
    return xr.Dataset(
        {
            "max_d_over_b": (dims, np.where(status == 0, d, np.nan), {"units": "1"}),
            "max_theta_over_eta": (dims, 2.0 * d, {"units": "1"}),
            "collapse": (dims, collapse),
            "status": (dims, status),
            "pga_scaled": (dims, im, {"units": "m/s^2"}),
        },
        coords={"record": ["A", "B", "C"], "scale": ("scale", scales, {"units": "1"})},
    )


def test_ida_curves_per_record_with_collapse_marks(tmp_path):
    ds = _ida_dataset()
    ax = plot.ida(ds)
    assert ax.get_xlabel().endswith("[-]") and "|d|/b" in ax.get_xlabel()
    assert ax.get_ylabel() == "PGA [g]"
    texts = _legend_texts(ax)
    assert {"A", "B", "C", "collapse"} <= set(texts)
    curves = [line for line in ax.get_lines() if line.get_linestyle() == "-"]
    assert len(curves) == 3
    np.testing.assert_allclose(curves[0].get_ydata(), np.asarray(ds.pga_scaled[0]) / G)
    assert len(curves[2].get_xdata()) == 5  # the failed run is left out
    path = tmp_path / "ida.png"
    ax.figure.savefig(path)
    assert path.stat().st_size > 1000


def test_ida_other_edp_and_units():
    ax = plot.ida(_ida_dataset(), edp="max_theta_over_eta", units="m/s^2")
    assert "theta" in ax.get_xlabel() and ax.get_ylabel() == "PGA [m/s$^2$]"
    ax = plot.ida(_ida_dataset(), im="scale")
    assert ax.get_ylabel() == "scale factor [-]"
    with pytest.raises(ValueError, match="units must be"):
        plot.ida(_ida_dataset(), units="cm/s^2")
    with pytest.raises(ValueError, match="no 'sa' variable"):
        plot.ida(_ida_dataset(), im="sa")


def test_fragility_curve_band_and_empirical_fractions(tmp_path):
    from rockjax.fragility import fragility

    ds = _ida_dataset()
    frag = fragility(ds, n_boot=50)
    ax = plot.fragility(frag, ds=ds)
    assert ax.get_xlabel() == "PGA [g]" and ax.get_ylabel() == "probability of collapse [-]"
    texts = _legend_texts(ax)
    assert any("bootstrap band" in t for t in texts)
    assert "collapsed fraction per scale" in texts
    emp = ax.get_lines()[-1].get_ydata()
    assert emp.shape == (6,) and np.all((emp >= 0) & (emp <= 1))
    curve = ax.get_lines()[0]
    assert np.all(np.diff(curve.get_ydata()) >= 0)
    path = tmp_path / "fragility.png"
    ax.figure.savefig(path)
    assert path.stat().st_size > 1000
    ax = plot.fragility(frag, units="m/s^2")
    assert ax.get_xlabel() == "PGA [m/s$^2$]"


def test_pairs_facade_against_parapet(tmp_path):
    facade = _ida_dataset()
    parapet = _ida_dataset(shift=0.02).isel(scale=slice(0, 5))  # matched on the intersection
    ax = plot.pairs(facade, parapet)
    assert ax.get_xlabel().startswith("facade") and ax.get_xlabel().endswith("[-]")
    assert ax.get_ylabel().startswith("parapet") and ax.get_ylabel().endswith("[-]")
    texts = _legend_texts(ax)
    assert "1:1" in texts and "both standing" in texts
    diag = ax.get_lines()[-1]
    np.testing.assert_allclose(diag.get_xdata(), diag.get_ydata())
    n_points = sum(len(line.get_xdata()) for line in ax.get_lines()[:-1])
    assert n_points == 3 * 5 - 1  # 5 shared scales, one failed run
    ax.figure.savefig(tmp_path / "pairs.png")
    with pytest.raises(ValueError, match="share no"):
        plot.pairs(facade, parapet.assign_coords(record=["X", "Y", "Z"]))


def test_ida_and_fragility_in_g_for_the_ida_im():
    """An IDA run with im="sa(T)" is drawn against its IM, in g by default (the Dataset holds
    m/s^2); "pga" and "pgv" are drawn from the same Dataset."""
    from rockjax.fragility import fragility

    ds = _ida_dataset()
    ds = ds.assign(im=(("record", "scale"), 2.0 * ds["pga_scaled"].values, {"units": "m/s^2"}))
    ds = ds.assign_coords(pgv=("record", [0.2, 0.3, 0.4], {"units": "m/s"}))
    ds.attrs["im"] = "sa(0.5)"
    ax = plot.ida(ds)
    assert ax.get_ylabel() == "$S_a$(0.5 s) [g]"
    curves = [line for line in ax.get_lines() if line.get_linestyle() == "-"]
    np.testing.assert_allclose(curves[0].get_ydata(), 2.0 * np.asarray(ds.pga_scaled[0]) / G)
    assert plot.ida(ds, im="pgv").get_ylabel() == "PGV [m/s]"
    frag = fragility(ds, n_boot=0)
    ax = plot.fragility(frag, ds=ds)
    assert ax.get_xlabel() == "$S_a$(0.5 s) [g]"
    assert any(f"{frag.median_g:.3g} g" in t for t in _legend_texts(ax))
    assert plot.fragility(fragility(ds, "pga", n_boot=0)).get_xlabel() == "PGA [g]"


def _capacity(theta_blocks=None):
    d_over_b = jnp.linspace(0.0, 1.0, 101)
    lam = jnp.where(d_over_b < 0.05, 2.0 * d_over_b, 0.1 * (1.0 - d_over_b))
    return rj.Capacity(
        load_multiplier=lam,
        d_over_b=d_over_b,
        theta=0.1 * d_over_b,
        lambda_rigid=jnp.asarray(0.1),
        b=jnp.asarray(0.25),
        h=jnp.asarray(2.5),
        overburden=jnp.asarray(0.0),
        t=jnp.arange(101.0),
        theta_blocks=theta_blocks,
    )


def test_pushover_curve_rigid_block_and_fit(tmp_path):
    cap = _capacity()
    law = rj.ThreeBranchLaw(lambda_0=0.1, Delta_1=0.01, Delta_2=0.05, Delta_u=1.0)
    ax = plot.pushover(cap, law, title="capacity")
    labels = [line.get_label() for line in ax.get_lines()]
    assert labels[0] == "DEM pushover" and labels[1].startswith("rigid block")
    assert any(label.startswith("three-branch") for label in labels)
    fit_line = next(line for line in ax.get_lines() if line.get_label().startswith("three"))
    np.testing.assert_allclose(fit_line.get_ydata()[-1], 0.0, atol=1e-12)  # zero at Delta_u
    assert "[-]" in ax.get_xlabel() and "a/g" in ax.get_ylabel()
    ax.figure.savefig(tmp_path / "pushover.png")
    ax = plot.pushover(_capacity(jnp.zeros((101, 2))), x="theta")
    assert "[rad]" in ax.get_xlabel()
    assert any(line.get_label().startswith("rigid collapse") for line in ax.get_lines())
    with pytest.raises(ValueError, match="x must be one of"):
        plot.pushover(cap, x="d")
    with pytest.raises(ValueError, match="fit must be a rockjax.ThreeBranchFit"):
        plot.pushover(cap, fit=0.1)


def test_spectrum_lines_per_floor():
    spec = rj.spectra.Spectrum(
        periods=jnp.linspace(0.0, 2.0, 5),
        damping=jnp.asarray(0.05),
        sd=jnp.ones((3, 5)),
        sa=G * jnp.ones((3, 5)),
    )
    ax = plot.spectrum(spec)
    assert [line.get_label() for line in ax.get_lines()] == ["floor 1", "floor 2", "floor 3"]
    np.testing.assert_allclose(ax.get_lines()[0].get_ydata(), 1.0)  # Sa in g
    assert "5 % damping" in ax.get_ylabel() and ax.get_xlabel() == "period T [s]"
    with pytest.raises(ValueError, match="one label per motion: 3"):
        plot.spectrum(spec, labels=["a"])
