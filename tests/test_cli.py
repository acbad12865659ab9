"""`rockjax demo` end to end: it writes its files, and the numbers in them are physically sane.

References: Housner's free rocking keeps e_exp (Eq. 6) equal to the e it was given, up to the
small-angle error of Eq. 6 (O(eta^2)); the DEM's e falls as beta grows (the paper's Eq. 3 trend).
"""

import contextlib
import csv
import io
import json
from pathlib import Path

import jax
import numpy as np
import pytest

import rockjax as rj
from rockjax.cli import DEMO_FILES, main

E_EXP_RTOL = 2e-3  # Eq. 6 inverts the small-angle solution: O(eta^2) ~ 1e-3 relative off Housner
E_MAX = 1.01  # a nearly elastic DEM impact (beta = 0) may read e slightly above 1

EXPECTED_FILES = set(DEMO_FILES)  # what the demo declares, checked before it runs


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo") / "out"
    stdout = io.StringIO()
    with contextlib.redirect_stdout(stdout):
        rc = main(["demo", "--quick", "--out", out])
    with open(out / "results.json") as f:
        results = json.load(f)
    return rc, out, results, stdout.getvalue()


def _finite(values):
    return [v for v in values if v is not None]


def test_demo_writes_every_file(demo):
    rc, out, results, stdout = demo
    assert rc == 0
    assert {p.name for p in out.iterdir()} == EXPECTED_FILES
    assert set(results["files"]) == EXPECTED_FILES
    assert all((out / name).stat().st_size > 0 for name in EXPECTED_FILES)
    assert "[6/6]" in stdout and "wrote 15 files" in stdout


def test_demo_calibrates_beta_to_e_h_and_runs_an_ida(demo):
    """The main job's calibration lands on e_H (within the calibration tolerance 2e-3, measured on the DEM's own
    peaks) and its IDA Datasets hold every (pulse, scale) run with a valid status."""
    import xarray as xr

    _, out, results, _ = demo
    cal = results["calibration"]
    assert abs(cal["e_effective"] - cal["target_e"]) < 2e-3
    assert cal["converged"] and 0.0 < cal["beta_s"] < results["parapet"]["beta_dejong_s"]
    for name in ("housner", "dem"):
        ds = xr.load_dataset(out / f"ida_pulses_{name}.nc")
        assert ds.sizes["record"] == len(results["ida"]["records"])
        assert (ds["status"] == 0).all()
        # the pulses overturn the parapet at the top of the scale range, not at the bottom
        assert ds["collapse"].isel(scale=-1).any() and not ds["collapse"].isel(scale=0).any()


def test_demo_records_versions_and_inputs(demo):
    _, _, results, _ = demo
    assert results["versions"]["jax"] == jax.__version__
    assert results["rockjax_version"] == rj.__version__
    assert results["quick"] is True
    parapet = rj.Block(b=0.25, h=3.0)
    assert results["parapet"]["b_m"] == 0.25 and results["parapet"]["h_m"] == 3.0
    np.testing.assert_allclose(results["parapet"]["e_H"], float(rj.e_housner(parapet)))
    np.testing.assert_allclose(results["parapet"]["beta_dejong_s"], float(rj.beta_dejong(parapet)))
    assert results["wall_s"]["total"] > 0


def test_demo_runs_are_valid(demo):
    _, _, results, _ = demo
    for section in ("parapet_free_rocking", "facade_free_rocking", "parapet_ricker"):
        for key, run in results[section]["runs"].items():
            assert run["status"] == 0, (section, key)
            assert not run["overturned"], (section, key)
            assert 0.0 < run["theta_max_over_eta"] < 1.0, (section, key)


def test_demo_free_rocking_e_values_are_sane(demo):
    _, _, results, _ = demo
    runs = results["parapet_free_rocking"]["runs"]
    for key in ("dem_beta0", "dem_beta_dejong", "housner_e_H"):
        e = _finite(runs[key]["e_exp"])
        assert len(e) == 3, key
        assert all(0.0 < v < E_MAX for v in e), (key, e)
    # damping lowers e
    assert np.mean(runs["dem_beta0"]["e_exp"]) > np.mean(runs["dem_beta_dejong"]["e_exp"])
    np.testing.assert_allclose(
        runs["housner_e_H"]["e_exp"], runs["housner_e_H"]["e"], rtol=E_EXP_RTOL
    )
    facade = results["facade_free_rocking"]["runs"]
    np.testing.assert_allclose(
        facade["housner_e_1sr"]["e_exp"], results["facade"]["e_1sr"], rtol=E_EXP_RTOL
    )
    assert all(0.0 < v < E_MAX for v in _finite(facade["dem_beta_1sr"]["e_exp"]))


def test_demo_sweep_e_falls_with_beta(demo):
    _, out, results, _ = demo
    sweep = results["e_beta_sweep"]
    betas = np.asarray(sweep["beta_s"])
    assert betas[0] == 0.0 and np.any(np.isclose(betas, results["parapet"]["beta_dejong_s"]))
    e_mean = np.asarray(sweep["e_exp_mean"]["closed"], dtype=float)
    assert e_mean.shape == betas.shape and np.all(np.isfinite(e_mean))
    assert np.all(np.diff(e_mean) < 0)
    assert np.all((e_mean > 0) & (e_mean < E_MAX))
    with open(out / "e_beta.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == betas.size
    np.testing.assert_allclose([float(r["e_exp_mean"]) for r in rows], e_mean, rtol=1e-5)


def test_demo_time_history_csv(demo):
    _, out, results, _ = demo
    data = np.genfromtxt(out / "parapet_free_rocking.csv", delimiter=",", names=True)
    assert data.dtype.names == (
        "t_s",
        "theta_dem_beta0_rad",
        "theta_dem_beta_dejong_rad",
        "theta_housner_e_H_rad",
    )
    eta = results["parapet"]["eta_rad"]
    for name in data.dtype.names[1:]:
        np.testing.assert_allclose(data[name][0], 0.5 * eta, rtol=1e-6)
    np.testing.assert_allclose(data["t_s"][-1], results["parapet_free_rocking"]["duration_s"])


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--b", "-1"], "b must be a positive"),
        (["--h", "0"], "h must be a positive"),
        (["--n-beta", "1"], "--n-beta must be an integer >= 2"),
    ],
)
def test_bad_input_is_one_clean_error_line(tmp_path, capsys, args, match):
    out = tmp_path / "out"
    rc = main(["demo", "--out", str(out), *args])
    err = capsys.readouterr().err
    assert rc == 2
    assert err.startswith("error: ") and match in err
    assert err.count("\n") == 1
    assert not out.exists()


def test_calibrate_squat_block_asks_for_e(tmp_path, capsys):
    """A squat block (h/b = 0.5): Eq. 2 gives e_H = 1 - 1.5 sin^2(eta) = 1 - 1.5 * 0.8 = -0.2,
    no restitution coefficient; the command asks for --e instead of passing it on."""
    rc = main(["calibrate", "--b", "1", "--h", "0.5", "--out", str(tmp_path / "c")])
    err = capsys.readouterr().err
    assert rc == 2 and err.startswith("error: ") and err.count("\n") == 1
    assert "e_H (Eq. 2) = -0.2" in err and "--e" in err, err
    assert not (tmp_path / "c").exists()


def test_out_must_be_a_folder(tmp_path, capsys):
    target = tmp_path / "a_file"
    target.write_text("")
    assert main(["demo", "--out", str(target)]) == 2
    assert "is not a folder" in capsys.readouterr().err


def test_unwritable_out_is_one_line_before_any_run(tmp_path, capsys):
    """A folder that cannot be made (inside a file) or a file the demo writes that is a folder:
    one `error:` line, exit 2, before the first run (was a traceback after the mkdir)."""
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    assert main(["demo", "--out", str(blocker / "out")]) == 2
    captured = capsys.readouterr()
    assert captured.err.startswith("error: --out: cannot write into") and captured.out == ""
    assert captured.err.count("\n") == 1
    out = tmp_path / "out"
    (out / "e_beta.csv").mkdir(parents=True)
    assert main(["demo", "--out", str(out)]) == 2
    captured = capsys.readouterr()
    assert "e_beta.csv is a folder" in captured.err and captured.out == ""


def test_usage_errors_exit_2(capsys):
    with pytest.raises(SystemExit) as info:
        main([])
    assert info.value.code == 2
    with pytest.raises(SystemExit) as info:
        main(["demo", "--b", "thick"])
    assert info.value.code == 2


def test_version(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out.strip() == f"rockjax {rj.__version__}"


def test_readme_python_snippet_runs():
    """The README's quick-start block runs as written (the docs must match the code)."""
    readme = (Path(__file__).parents[1] / "README.md").read_text()
    start = readme.index("```python\n") + len("```python\n")
    code = readme[start : readme.index("```", start)]
    namespace: dict = {}
    with contextlib.redirect_stdout(io.StringIO()):
        exec(compile(code, "README.md", "exec"), namespace)
    for name in ("h", "d", "free"):
        resp = namespace[name]
        assert isinstance(resp, rj.Response) and int(resp.status) == 0
        assert resp.theta.dtype == np.float64
