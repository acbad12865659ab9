"""`rockjax spectrum` end to end through `main(argv)`: the spectra in its CSV are those of
`rj.response_spectrum` (and `rj.floor_spectra` in a building) for the same record, its figure
and JSON are written, and bad options are one ``error: ...`` line (exit status 2)."""

import json

import numpy as np
import pandas as pd
import pytest
from helpers import assert_refused, assert_same_table, run_cli

import rockjax as rj
from rockjax.constants import G

CSV_RTOL = 1e-9  # the CSV holds 12 significant digits of the same computation
CSV_ATOL = 1e-14  # [the column's unit]: Sd and Sv are 0 at T = 0


def test_spectrum_of_a_pulse(tmp_path):
    out = tmp_path / "out"
    argv = ["spectrum", "--pulse", "AR", "--pga-g", 0.3, "--pulse-period", 0.5]
    argv += ["--periods", "0:2:41", "--damping", 0.02, "--out", out]
    rc, stdout, stderr = run_cli(argv)
    assert rc == 0, stderr
    assert sorted(p.name for p in out.iterdir()) == [
        "spectrum.csv",
        "spectrum.json",
        "spectrum.png",
    ]
    df = pd.read_csv(out / "spectrum.csv", index_col=0)
    gm = rj.pulses.pulse("AR", 0.3 * G, 0.5)
    spec = rj.response_spectrum(gm, np.linspace(0.0, 2.0, 41), 0.02)
    assert_same_table(df, spec.to_dataframe(), CSV_RTOL, CSV_ATOL)
    with open(out / "spectrum.json") as f:
        res = json.load(f)
    sa = np.asarray(spec.sa)
    k = int(np.argmax(sa))
    (peak,) = res["peaks"]
    assert peak["sa_max_g"] == pytest.approx(sa[k] / G, rel=1e-12)
    assert peak["t_at_sa_max_s"] == pytest.approx(0.05 * k, rel=1e-12)
    assert peak["pga_g"] == pytest.approx(float(gm.pga_g), rel=1e-12)
    assert f"peak Sa = {sa[k] / G:.4g} g" in stdout


def test_floor_spectra_of_a_csv_record(tmp_path):
    dt = 0.01
    t = np.arange(401) * dt
    acc = 2.0 * np.sin(2 * np.pi * t / 0.3) * np.exp(-t)
    path = tmp_path / "rec.csv"
    np.savetxt(path, np.column_stack([t, acc]), delimiter=",", header="t [s],a [m/s2]", comments="")
    out = tmp_path / "out"
    argv = ["spectrum", "--record", path, "--periods", "0,0.1,0.2,0.5,1"]
    argv += ["--storeys", 3, "--building-period", 0.3, "--storey-height", 3.5, "--out", out]
    rc, stdout, stderr = run_cli(argv)
    assert rc == 0, stderr
    df = pd.read_csv(out / "spectrum.csv", index_col=0)
    gm = rj.read_csv(path)
    periods = [0.0, 0.1, 0.2, 0.5, 1.0]
    bldg = rj.ShearBuilding.uniform(3, 3.5, 0.3)
    floors = rj.floor_spectra(bldg, gm, periods)
    ground = rj.response_spectrum(gm, periods)
    expect = pd.concat(
        [
            ground.to_dataframe().add_suffix(" ground"),
            floors.to_dataframe([f"floor {k}" for k in (1, 2, 3)]),
        ],
        axis=1,
    )
    assert_same_table(df, expect, CSV_RTOL, CSV_ATOL)
    assert stdout.count("peak Sa") == 4


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--periods", "0:2"], r"--periods '0:2' cannot be read; give START:STOP:N"),
        (["--periods", "1,0.5"], r"--periods '1,0.5' must give increasing values >= 0, in s"),
        (["--damping", 1.5], r"--damping is a damping ratio .dimensionless. in \[0, 1\)"),
        (["--building-period", 0.3], "--building-period describes the host building"),
        (["--storeys", 0, "--building-period", 0.3], "--storeys .the building's storeys."),
        (["--storeys", 2, "--building-period", -1], "--building-period must be positive, in s"),
    ],
)
def test_bad_options_are_one_error_line(tmp_path, args, match):
    out = tmp_path / "out"
    argv = ["spectrum", "--pulse", "MH", "--pga-g", 0.3, "--pulse-period", 0.4, *args]
    assert_refused(argv, match, out)


def test_a_record_or_a_pulse_is_required(tmp_path):
    rc, _, stderr = run_cli(["spectrum", "--out", tmp_path / "out"])
    assert rc == 2 and "one of the arguments --record --pulse is required" in stderr
