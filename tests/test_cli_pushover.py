"""`rockjax pushover` end to end through `main(argv)`: the curve in its CSV is
`rj.pushover`'s for the same block or stack, the law in its JSON is `rj.fit_three_branch`'s
of that curve (printed too), and `rockjax simulate --model three-branch --law pushover.json`
runs Housner with that law. Bad options are one ``error: ...`` line (exit status 2).

Short curves (60 samples) of the 0.2 x 1.5 m block: the pushover compiles once per body."""

import json

import numpy as np
import pandas as pd
import pytest
from helpers import assert_refused, assert_same_table, run_cli

import rockjax as rj
from rockjax.constants import G

CSV_RTOL = 1e-9  # the CSV holds 12 significant digits of the same computation
CSV_ATOL = 1e-12  # [the column's unit]: the curve's first sample is zero up to round-off
LAW_RTOL = 1e-9  # the JSON's law is the fit of the same curve
B, H, N_OUT = 0.2, 1.5, 60
LAW = ("lambda_0", "Delta_1", "Delta_2", "Delta_u")


@pytest.fixture(scope="module")
def block_pushover(tmp_path_factory):
    out = tmp_path_factory.mktemp("pushover") / "out"
    argv = ["pushover", "--b", B, "--h", H, "--n-out", N_OUT, "--out", out]
    rc, stdout, stderr = run_cli(argv)
    cap = rj.pushover(rj.Block(b=B, h=H), n_out=N_OUT)
    return rc, out, stdout, stderr, cap


def test_block_curve_and_fit(block_pushover):
    rc, out, stdout, stderr, cap = block_pushover
    assert rc == 0, stderr
    assert sorted(p.name for p in out.iterdir()) == [
        "pushover.csv",
        "pushover.json",
        "pushover.png",
    ]
    assert (out / "pushover.png").stat().st_size > 10_000
    assert_same_table(
        pd.read_csv(out / "pushover.csv", index_col=0), cap.to_dataframe(), CSV_RTOL, CSV_ATOL
    )
    with open(out / "pushover.json") as f:
        res = json.load(f)
    fit = rj.fit_three_branch(cap)
    for key in LAW:
        assert res["law"][key] == pytest.approx(float(getattr(fit.law, key)), rel=LAW_RTOL)
    assert res["fitted"] is True and res["fit_rmse"] == pytest.approx(float(fit.rmse), rel=1e-6)
    assert res["lambda_rigid"] == pytest.approx(B / H, rel=1e-12)
    lam = np.asarray(cap.load_multiplier)
    assert res["lambda_max"] == pytest.approx(float(lam.max()), rel=1e-12)
    assert f"Delta_u {float(fit.law.Delta_u):.4g}" in stdout
    assert f"peak lambda    = {float(lam.max()):.4g}" in stdout


def test_simulate_reads_the_law_of_pushover(block_pushover, tmp_path):
    _, out, _, _, cap = block_pushover
    sim = tmp_path / "sim"
    argv = ["simulate", "--b", B, "--h", H, "--pulse", "MH", "--pga-g", 0.2]
    argv += ["--pulse-period", 0.4, "--model", "three-branch", "--law", out / "pushover.json"]
    rc, stdout, stderr = run_cli([*argv, "--duration", 2.2, "--out", sim])
    assert rc == 0, stderr
    df = pd.read_csv(sim / "simulate.csv", index_col=0)
    gm = rj.pulses.pulse("MH", 0.2 * G, 0.4)
    law = rj.fit_three_branch(cap).law
    ref = rj.simulate_housner(rj.Block(b=B, h=H), gm, law=law).to_dataframe()
    np.testing.assert_allclose(df["theta [rad]"], ref["theta [rad]"], rtol=1e-8, atol=1e-12)


def test_stack_restrained(tmp_path):
    out = tmp_path / "out"
    argv = ["pushover", "--b", B, "--h", H, "--blocks", 2, "--top", "restrained"]
    rc, stdout, stderr = run_cli([*argv, "--n-out", N_OUT, "--fix-lambda0", "--out", out])
    assert rc == 0, stderr
    stack = rj.Assembly.stack([rj.Block(b=B, h=H / 2)] * 2, top="restrained")
    cap = rj.pushover(stack, n_out=N_OUT)
    df = pd.read_csv(out / "pushover.csv", index_col=0)
    assert_same_table(df, cap.to_dataframe(), CSV_RTOL, CSV_ATOL)
    assert {"theta_0 [rad]", "theta_1 [rad]"} <= set(df.columns)
    with open(out / "pushover.json") as f:
        res = json.load(f)
    assert res["n_blocks"] == 2 and res["top"] == "restrained"
    # --fix-lambda0: the rigid line through the mechanism's multiplier (limit analysis)
    assert res["fitted"] is True and res["lambda_0_fixed"] is True
    assert res["law"]["lambda_0"] == pytest.approx(float(cap.lambda_rigid), rel=1e-12)
    fit = rj.fit_three_branch(cap, lambda_0=float(cap.lambda_rigid))
    for key in LAW:
        assert res["law"][key] == pytest.approx(float(getattr(fit.law, key)), rel=LAW_RTOL)
    assert "(fixed)" in stdout


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--d-over-b", 50], r"--d-over-b is the top displacement .* not percent"),
        (["--top", "restrained"], "--top is a stack's top restraint"),
        (["--n-out", 3], "--n-out .samples of the curve. must be an integer >= 6"),
        (["--blocks", 2, "--mode", "one_sided"], "--mode one_sided / --gap: a stack"),
        (["--beta", -1], r"--beta .DEM damping. must be >= 0, in s"),
        (["--joint", "two"], "--joint is the DEM joint"),
        (["--mode", "two_sided", "--gap", 0.001], "--mode two_sided --gap 0.001 .metres."),
    ],
)
def test_bad_options_are_one_error_line(tmp_path, args, match):
    out = tmp_path / "out"
    assert_refused(["pushover", *args], match, out)
