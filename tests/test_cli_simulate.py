"""`rockjax simulate` end to end through `main(argv)`: each model under a pulse, a CSV record,
a PEER .AT2 record or a free release, on the ground or in a host building, writes its CSV,
figure and JSON, and the history in the CSV is the one the Python API gives for the same
inputs (the public simulators called here, with the record padded by the API's own
``duration=``, or by the building's floors of the padded record). Bad options are one
``error: ...`` line naming the option, exit status 2, and nothing written.

The 0.2 x 1.5 m block under short pulses: each model compiles once for the module.
"""

import json

import numpy as np
import pandas as pd
import pytest
from helpers import assert_refused, run_cli

import rockjax as rj
from rockjax.constants import G

CSV_RTOL = 1e-9  # the CSV holds 12 significant digits of the same computation
CSV_ATOL = 1e-12  # [the column's unit]: samples that are zero up to round-off
B, H = 0.2, 1.5
TAIL = 2.0  # [s], simulate's free rocking after a record, by default
FILES = ["simulate.csv", "simulate.json", "simulate.png"]


def _read(out):
    df = pd.read_csv(out / "simulate.csv", index_col=0)
    with open(out / "simulate.json") as f:
        return df, json.load(f)


def _same_history(df, resp):
    """The CLI's CSV holds the API's history, column for column (and the base's ag)."""
    ref = resp.to_dataframe()
    np.testing.assert_allclose(df.index.to_numpy(), ref.index.to_numpy(), rtol=CSV_RTOL)
    for col in ref.columns:
        np.testing.assert_allclose(
            df[col].to_numpy(), ref[col].to_numpy(), rtol=CSV_RTOL, atol=CSV_ATOL, err_msg=col
        )


def _padded(gm, tail=TAIL):
    k = int(round(tail / gm.dt))
    return rj.GroundMotion(ag=np.concatenate([np.asarray(gm.ag), np.zeros(k)]), dt=gm.dt)


def test_dem_under_a_pulse_with_corner_contacts(tmp_path):
    out = tmp_path / "out"
    argv = ["simulate", "--b", B, "--h", H, "--pulse", "MH", "--pga-g", 0.25]
    argv += ["--pulse-period", 0.4, "--joint", "corners", "--out", out]
    rc, stdout, stderr = run_cli(argv)
    assert rc == 0, stderr
    assert sorted(p.name for p in out.iterdir()) == FILES
    assert (out / "simulate.png").stat().st_size > 10_000
    df, res = _read(out)
    block = rj.Block(b=B, h=H)
    gm = rj.pulses.pulse("MH", 0.25 * G, 0.4)
    beta = float(rj.beta_dejong(block))
    resp = rj.simulate_dem(
        block, gm, beta=beta, joint=rj.Joint(n_sub=2), duration=gm.duration + TAIL
    )
    _same_history(df, resp)
    n = gm.n
    np.testing.assert_allclose(df["ag [m/s^2]"].to_numpy()[:n], np.asarray(gm.ag), rtol=CSV_RTOL)
    assert np.all(df["ag [m/s^2]"].to_numpy()[n:] == 0.0)
    assert res["model"] == "dem" and res["beta_s"] == pytest.approx(beta, rel=1e-12)
    assert res["joint"] == {"n_sub": 2, "shear_release": "uniform"}
    ratio = float(resp.theta_max) / float(block.eta)
    assert res["theta_max_over_eta"] == pytest.approx(ratio, rel=1e-12)
    assert res["overturned"] is bool(resp.overturned) and res["status"] == 0
    assert res["dt_step_s"] == pytest.approx(float(resp.extras["dt"]), rel=1e-12)
    assert f"peak |theta|/eta = {ratio:.4f}" in stdout
    assert "overturned       = no" in stdout and "beta_DeJong, uncalibrated" in stdout
    assert res["command"].startswith("rockjax simulate --b 0.2 --h 1.5")


def test_housner_facade_in_a_building_from_a_csv_record(tmp_path):
    """A CSV record without units in its header is read with --units g; the facade stands in
    storey 1 of the building, its return walls moving with it (wall_motion=bldg)."""
    dt = 0.01
    t = np.arange(301) * dt
    acc_g = 0.2 * np.sin(2 * np.pi * t / 0.5) * np.exp(-t)
    path = tmp_path / "rec.csv"
    np.savetxt(path, np.column_stack([t, acc_g]), delimiter=",", header="time,acc", comments="")
    out = tmp_path / "out"
    argv = ["simulate", "--b", B, "--h", H, "--record", path, "--units", "g"]
    argv += ["--model", "housner", "--mode", "one_sided", "--storeys", 2]
    argv += ["--building-period", 0.2, "--duration", 3.0, "--out", out]
    rc, stdout, stderr = run_cli(argv)
    assert rc == 0, stderr
    df, res = _read(out)
    gm = rj.read_csv(path, units="g")
    bldg = rj.ShearBuilding.uniform(2, 3.0, 0.2)
    resp = rj.simulate_housner(rj.Block(b=B, h=H), gm, mode="one_sided", wall_motion=bldg)
    _same_history(df, resp)
    assert res["building"]["storey"] == 1 and res["building"]["n_storeys"] == 2
    assert res["motion"]["pga_g"] == pytest.approx(float(gm.pga_g), rel=1e-12)
    assert "storey 1 (base on the ground)" in stdout


def test_housner_parapet_on_the_roof_from_an_at2_record(tmp_path):
    """A parapet stands on the roof by default: it rocks on the top floor's motion under the
    ground record padded with the free rocking after it (the building keeps moving)."""
    dt = 0.005
    gm = rj.GroundMotion.from_g(0.3 * np.sin(2 * np.pi * np.arange(241) * dt / 0.4), dt)
    path = tmp_path / "REC.AT2"
    rj.write_at2(path, gm)
    out = tmp_path / "out"
    argv = ["simulate", "--b", B, "--h", H, "--record", path, "--model", "housner"]
    argv += ["--storeys", 3, "--building-period", 0.3, "--out", out]
    rc, stdout, stderr = run_cli(argv)
    assert rc == 0, stderr
    df, res = _read(out)
    rec = rj.read_at2(path)
    bldg = rj.ShearBuilding.uniform(3, 3.0, 0.3)
    roof = bldg.floor_motions(_padded(rec))[-1]
    resp = rj.simulate_housner(rj.Block(b=B, h=H), roof)
    _same_history(df, resp)
    np.testing.assert_allclose(df["ag [m/s^2]"].to_numpy(), np.asarray(roof.ag), rtol=CSV_RTOL)
    assert res["building"]["storey"] == 4 and "base on floor 3" in stdout


def test_three_branch_law_given_and_free_rocking(tmp_path):
    """A three-branch law of four numbers under a sine pulse; and a free release."""
    out = tmp_path / "law"
    law = (0.12, 0.004, 0.14, 0.97)
    argv = ["simulate", "--b", B, "--h", H, "--pulse", "SC", "--pga-g", 0.2]
    argv += ["--pulse-period", 0.4, "--model", "three-branch", "--e", 0.9]
    argv += ["--law", ",".join(map(str, law)), "--out", out]
    rc, stdout, stderr = run_cli(argv)
    assert rc == 0, stderr
    df, res = _read(out)
    gm = rj.pulses.pulse("SC", 0.2 * G, 0.4)
    resp = rj.simulate_housner(
        rj.Block(b=B, h=H), gm, e=0.9, law=rj.ThreeBranchLaw(*law), duration=gm.duration + TAIL
    )
    _same_history(df, resp)
    assert res["law"] == dict(zip(("lambda_0", "Delta_1", "Delta_2", "Delta_u"), law))

    out = tmp_path / "free"
    argv = ["simulate", "--b", B, "--h", H, "--model", "housner", "--theta0", 0.5]
    argv += ["--duration", 3, "--out", out]
    rc, stdout, stderr = run_cli(argv)
    assert rc == 0, stderr
    df, res = _read(out)
    block = rj.Block(b=B, h=H)
    resp = rj.simulate_housner(block, theta0=0.5 * float(block.eta), duration=3.0, dt=0.005)
    _same_history(df, resp)
    assert np.all(df["ag [m/s^2]"].to_numpy() == 0.0) and res["motion"] is None


PULSE = ["--pulse", "MH", "--pga-g", 0.3, "--pulse-period", 0.4]


@pytest.mark.parametrize(
    ("args", "match"),
    [
        ([*PULSE, "--e", 0.9], "--e .restitution"),
        (
            [
                *PULSE,
                "--model",
                "housner",
                "--beta",
                1e-3,
            ],
            "--beta .DEM damping, in s",
        ),
        ([*PULSE, "--joint", "1"], "--joint is"),
        (
            [
                *PULSE,
                "--joint",
                "corners",
                "--shear-release",
                "none",
            ],
            "--shear-release is the integrated face joint",
        ),
        (["--pulse", "MH", "--pulse-period", 0.4], "needs --pga-g .in g"),
        (["--pulse", "MH", "--pga-g", -1, "--pulse-period", 0.4], "--pga-g must be positive"),
        (
            [
                *PULSE,
                "--model",
                "housner",
                "--mode",
                "one_sided",
                "--gap",
                0.001,
            ],
            "--gap 0.001 .metres.: Housner",
        ),
        (
            [*PULSE, "--law", "pushover"],
            "--law is the three-branch",
        ),
        (
            [
                *PULSE,
                "--model",
                "three-branch",
                "--law",
                "1,2",
            ],
            "--law '1,2' cannot be read",
        ),
        (
            [*PULSE, "--storeys", 2],
            "--storeys needs --building-period",
        ),
        (
            [
                *PULSE,
                "--storeys",
                2,
                "--building-period",
                0.2,
                "--storey",
                4,
            ],
            "--storey must lie in 1..3",
        ),
        (
            [*PULSE, "--storey", 2],
            "--storey describes the host building",
        ),
        (
            [*PULSE, "--theta0", 1.2],
            "--theta0 is the initial rotation",
        ),
        (["--theta0", 0.5], "give a ground motion"),
        (["--units", "g", "--theta0", 0.5, "--duration", 2], "--units belongs to a CSV --record"),
        (
            [*PULSE, "--b", -0.2],
            "--b -0.2 --h 3 .metres",
        ),
        (["--record", "no_such_file.csv"], "--record no_such_file.csv: no such file"),
    ],
)
def test_bad_options_are_one_error_line(tmp_path, args, match):
    out = tmp_path / "out"
    assert_refused(["simulate", *args], match, out)


def test_csv_record_without_units_names_the_option(tmp_path):
    path = tmp_path / "rec.csv"
    np.savetxt(path, np.column_stack([np.arange(50) * 0.01, np.zeros(50)]), delimiter=",")
    out = tmp_path / "out"
    rc, _, stderr = run_cli(["simulate", "--record", path, "--out", out])
    assert rc == 2 and stderr.startswith(f"error: --record {path}: the units")
    assert "On the command line: --units g or --units m/s2" in stderr
    assert not out.exists()
