"""`rockjax calibrate` end to end on the paper's 0.25 x 3 m parapet: the default command fits a
beta inside the reachable range whose DEM restitution matches the target, writes the figure and
a plain JSON, and an unreachable target is one `error: ...` line naming the range, exit 2.
A facade (`--mode one_sided`) is calibrated to its measured bounces by default, and the exit
status and JSON tell whether they were met.

One parapet and one facade, one release each, so the DEM compiles once per geometry.
"""

import json
import re

import numpy as np
import pytest
from helpers import run_cli

import rockjax as rj

E_TARGET = 0.975
E_TOL = 2e-3  # the DEM's effective e against the target (the fit reaches ~1e-4)


_run = run_cli


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    out = tmp_path_factory.mktemp("calibrate") / "out"
    rc, stdout, stderr = _run(["calibrate", "--b", 0.25, "--h", 3, "--e", E_TARGET, "--out", out])
    return rc, out, stdout, stderr


def test_calibrate_fits_beta_and_writes_json_and_figure(calibrated):
    rc, out, stdout, stderr = calibrated
    assert rc == 0, stderr
    assert sorted(p.name for p in out.iterdir()) == ["calibration.json", "calibration.png"]
    assert (out / "calibration.png").stat().st_size > 10_000
    with open(out / "calibration.json") as f:
        res = json.load(f)
    parapet = rj.Block(b=0.25, h=3.0)
    assert res["block"]["b_m"] == 0.25 and res["block"]["h_m"] == 3.0
    assert res["mode"] == "two_sided" and res["target"] == "e" and res["method"] == "lbfgs"
    assert res["e_target"] == pytest.approx(E_TARGET)
    e_lo, e_hi = res["e_range"]
    assert e_lo < E_TARGET < e_hi
    assert 0.0 < res["beta_s"] <= res["beta_max_s"]
    np.testing.assert_allclose(res["beta_max_s"], 2.0 * float(rj.beta_dejong(parapet)))
    np.testing.assert_allclose(
        res["beta_over_beta_dejong"], res["beta_s"] / float(rj.beta_dejong(parapet))
    )
    assert abs(res["e_effective"] - E_TARGET) < E_TOL
    assert len(res["e_exp"]) == 3 and all(abs(v - E_TARGET) < 5 * E_TOL for v in res["e_exp"])
    assert res["converged"] is True and res["dem_status"] == 0
    assert res["n_simulations"] >= res["n_iterations"] >= 1
    assert len(res["history"]["beta"]) == len(res["history"]["loss"]) >= 2
    assert res["loss"] < 1e-4 and res["seconds"] > 0
    assert res["command"].startswith("rockjax calibrate --b 0.25 --h 3 --e 0.975")
    # the printout gives beta in s and in beta_DeJong, e_effective and the reachable range
    beta_line = re.search(r"beta\s+= (\S+) s\s+\((\S+) beta_DeJong\)", stdout)
    assert beta_line and float(beta_line[1]) == pytest.approx(res["beta_s"], rel=1e-5)
    assert f"e_effective  = {res['e_effective']:.5f}" in stdout
    assert f"reachable e  = {e_lo:.4f}" in stdout


def test_unreachable_e_is_one_error_line_naming_the_range(tmp_path):
    out = tmp_path / "out"
    rc, stdout, stderr = _run(["calibrate", "--b", 0.25, "--h", 3, "--e", 0.5, "--out", out])
    assert rc == 2
    assert stderr.startswith("error: ") and stderr.count("\n") == 1
    assert "not reachable" in stderr
    assert re.search(r"spans e = 0\.\d+ \(beta = \S+ s\) to [01]\.\d+ \(beta = 0", stderr)
    assert "Traceback" not in stderr
    assert not out.exists()


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--n-sub", "1"], "--n-sub is the DEM joint"),
        (["--theta0", "1.2"], "--theta0"),
        (["--e", "1.5"], "--e (restitution"),
        (["--target", "bounces", "--mode", "two_sided"], "--mode one_sided"),
        (["--target", "bounces", "--e", "0.9"], "takes no --e"),
        (["--mode", "one_sided", "--e", "0.45"], "add --target e"),
        (["--mode", "one_sided", "--target", "e", "--e", "0.1"], "target='bounces'"),
        (["--b", "-1"], "b must be a positive"),
    ],
)
def test_bad_input_exits_2_before_any_run(tmp_path, args, match):
    argv = ["calibrate", "--b", 0.25, "--h", 3, "--out", tmp_path / "out", *args]
    rc, _, stderr = _run(argv)
    assert rc == 2
    assert stderr.startswith("error: ") and match in stderr
    assert not (tmp_path / "out").exists()


def test_b_and_h_are_required():
    rc, _, stderr = _run(["calibrate", "--b", 0.25])
    assert rc == 2 and "--h" in stderr


def test_help_lists_every_option():
    rc, stdout, _ = _run(["calibrate", "--help"])
    assert rc == 0
    for flag in ("--b", "--h", "--e", "--mode", "--target", "--theta0", "--E", "--rho"):
        assert flag in stdout
    assert "--beta-max" in stdout and "--method" in stdout and "calibration_out" in stdout
    assert "--loss" in stdout and "history" in stdout and "--n-sub" in stdout
    assert "%%" not in stdout


# measured e_exp of bounces 1 and 2 as fractions of |e_ISR| (the paper, Sect. 2.2); bounce 3:
# the band the project states for "similar to e_ISR" (docs/verification.md, Calibration)
BANDS = ((0.64, 0.72), (0.74, 0.86), rj.calibration.BOUNCE_BANDS[2])


@pytest.mark.slow  # 25-31 s: a whole facade fit through the CLI; ./test.sh -m slow
def test_one_sided_default_calibrates_to_the_bounce_targets(tmp_path):
    """`--mode one_sided` alone fits the bounce targets (it used to fit Housner's e = |e_ISR|
    and report converged with loss 0): the best match, exit status 0 when it converged;
    whether every e_exp is in its measured band is `target_met` (measured here from the JSON's
    e_exp), printed with what was missed."""
    out = tmp_path / "out"
    argv = ["calibrate", "--b", 0.2, "--h", 1.5, "--mode", "one_sided"]
    rc, stdout, stderr = _run([*argv, "--out", out])
    assert rc == 0, stderr
    with open(out / "calibration.json") as f:
        res = json.load(f)
    e_isr = abs(float(rj.e_isr(rj.Block(b=0.2, h=1.5))))
    assert res["target"] == "bounces" and res["e_target"] is None
    np.testing.assert_allclose(res["bounce_targets"], np.array([0.68, 0.80, 1.00]) * e_isr)
    ratio = np.array([np.nan if v is None else v for v in res["e_exp"]], float) / e_isr
    met = all(lo <= r <= hi for r, (lo, hi) in zip(ratio, BANDS))
    assert res["converged"] is True and res["reason"] == ""
    assert res["target_met"] is met and (res["target_missed"] == "") is met
    line = re.search(r"target met\s+= (.*)", stdout)
    assert line and line[1].startswith("yes" if met else "no, the best match: bounce ")


def test_unwritable_out_fails_before_the_fit(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    rc, stdout, stderr = run_cli(["calibrate", "--b", 0.25, "--h", 3, "--out", blocker / "sub"])
    assert rc == 2 and "--out: cannot write into" in stderr, stderr
    assert "beta =" not in stdout


def test_every_output_is_checked_before_the_fit(tmp_path):
    """A folder where calibration.json goes stops the command before the fit, not after."""
    out = tmp_path / "c"
    (out / "calibration.json").mkdir(parents=True)
    rc, stdout, stderr = run_cli(["calibrate", "--b", 0.25, "--h", 3, "--out", out])
    assert rc == 2 and stderr.count("\n") == 1, stderr
    assert "calibration.json is a folder, where the command writes a file" in stderr, stderr
    assert "beta =" not in stdout
