"""Tests for rockjax.records: the PEER AT2 and CSV readers, the AT2 writer and rotation.

References: docs/verification.md, "PEER .AT2 record files" (the AT2 header variants, whose
header lines are quoted here verbatim) and "FEMA P695 record sets" (the rotation formula and
its Nahanni example). The sample files are
written here, each in its variant's own number format.
"""

import math

import numpy as np
import pytest

import rockjax as rj
from rockjax import records
from rockjax.constants import G

# 7 significant digits (E14.6 and the PEA .dddddddE format) round to half a unit in the
# 7th digit, i.e. a relative 5e-7 at most; the 1e-12 covers the float64 g conversion.
RTOL_7_DIGITS = 5e-7 + 1e-12
# 17 significant digits print a float64 exactly; converting to g and back costs 2 ulp.
RTOL_17_DIGITS = 4.5e-16


def _samples_g(n):
    """A deterministic record in g with both signs, small and zero values."""
    k = np.arange(n)
    y = 0.3 * np.sin(0.05 * k) + 0.01 * np.cos(0.3 * k)
    y[0] = 0.0
    return y


def _e14_6(values):  # NGA-West2: '  3.654112E-04'
    return [f"{v:14.6E}" for v in values]


def _pea_e(v):  # PEER-SMD / PEA: '  -.4524259E-02', mantissa in [0.1, 1), no leading zero
    if v == 0.0:
        return "   .0000000E+00"
    exp = math.floor(math.log10(abs(v))) + 1
    digits = round(abs(v) / 10.0**exp * 1e7)
    if digits >= 10**7:
        digits, exp = digits // 10, exp + 1
    return f"{'  -' if v < 0 else '   '}.{digits:07d}E{exp:+03d}"


def _write(path, header, cells, per_line=5, newline="\n", tail=""):
    rows = ["".join(cells[i : i + per_line]) for i in range(0, len(cells), per_line)]
    path.write_bytes((newline.join([*header, *rows]) + newline + tail).encode("ascii"))
    return path


def _assert_printed(actual, expected_g, rtol=RTOL_7_DIGITS):
    expected = np.asarray(expected_g) * G
    err = np.abs(np.asarray(actual) - expected)
    assert np.all(err <= rtol * np.abs(expected)), float(
        np.max(err / np.maximum(1e-300, np.abs(expected)))
    )


# ------------------------------------------------------------------ AT2 header variants
def test_nga_west2(tmp_path):
    """AT2 variant 1: NGA-West2 header, trailing comma, E14.6 data 5 per line."""
    y = _samples_g(7814)
    y[:2] = [3.654112e-04, 3.647600e-04]
    header = [
        "PEER NGA STRONG MOTION DATABASE RECORD",
        "Northern Calif-03, 12/21/1954, Ferndale City Hall, 44",
        "ACCELERATION TIME SERIES IN UNITS OF G",
        "NPTS=  7814, DT= .0050 SEC,",
    ]
    gm = records.read_at2(_write(tmp_path / "RSN36_NCALIF.FH_FRN044.AT2", header, _e14_6(y)))
    assert gm.n == 7814 and gm.dt == 0.005 and gm.name == "RSN36_NCALIF.FH_FRN044"
    assert np.asarray(gm.ag).dtype == np.float64
    _assert_printed(gm.ag, y)
    assert gm.ag[0] == 3.654112e-04 * G
    assert gm.metadata["event"] == "Northern Calif-03"
    assert gm.metadata["date"] == "12/21/1954"
    assert gm.metadata["station"] == "Ferndale City Hall"
    assert gm.metadata["component"] == "44"
    assert gm.metadata["units"] == "G"
    assert gm.metadata["title"] == "PEER NGA STRONG MOTION DATABASE RECORD"


def test_peer_smd_2000(tmp_path):
    """AT2 variant 2: PEER-SMD 2000 header with filter text, '-.4524259E-02' data."""
    y = _samples_g(7802)
    y[:2] = [-0.4524259e-02, -0.5453609e-02]
    header = [
        "PEER STRONG MOTION DATABASE RECORD. PROCESSING BY PACIFIC ENGINEERING.",
        "IMPERIAL VALLEY 10/15/79 2316, EL CENTRO ARRAY #12, 140 (USGS STATION 931)",
        "ACCELERATION TIME HISTORY IN UNITS OF G. FILTER POINTS: HP=0.1 Hz LP=40.0 Hz",
        "NPTS=  7802, DT= .00500 SEC",
    ]
    cells = [_pea_e(v) for v in y]
    assert "".join(cells[:2]) == "  -.4524259E-02  -.5453609E-02"  # the quoted data line
    gm = records.read_at2(_write(tmp_path / "H-E12140.AT2", header, cells))
    assert gm.n == 7802 and gm.dt == 0.005
    _assert_printed(gm.ag, y)
    assert gm.ag[0] == -0.4524259e-02 * G
    assert gm.metadata["event"] == "IMPERIAL VALLEY"
    assert gm.metadata["date"] == "10/15/79 2316"
    assert gm.metadata["station"] == "EL CENTRO ARRAY #12"
    assert gm.metadata["component"] == "140 (USGS STATION 931)"


def test_nga_west1_numbers_first(tmp_path):
    """AT2 variant 3: line 4 '4164    0.0100    NPTS, DT'."""
    y = _samples_g(4164)
    header = [
        "PEER NGA STRONG MOTION DATABASE RECORD",
        "Imperial Valley-06, 10/15/1979, El Centro Array #12, 140",
        "ACCELERATION TIME HISTORY IN UNITS OF G",
        "4164    0.0100    NPTS, DT",
    ]
    gm = records.read_at2(_write(tmp_path / "PUL164.AT2", header, _e14_6(y)))
    assert gm.n == 4164 and gm.dt == 0.01
    _assert_printed(gm.ag, y)


def test_older_pea(tmp_path):
    """AT2 variant 4: 'PACIFIC ENGINEERING AND ANALYSIS STRONG-MOTION DATA'."""
    y = _samples_g(3930)
    header = [
        "PACIFIC ENGINEERING AND ANALYSIS STRONG-MOTION DATA",
        "LOMA PRIETA 10/18/89 00:05, CAPITOLA, 000 (CDMG STATION 47125)",
        "ACCELERATION TIME HISTORY IN UNITS OF G",
        "NPTS=  3930, DT= .00500 SEC",
    ]
    gm = records.read_at2(_write(tmp_path / "CAP000.AT2", header, [_pea_e(v) for v in y]))
    assert gm.n == 3930 and gm.dt == 0.005
    _assert_printed(gm.ag, y)
    assert gm.metadata["station"] == "CAPITOLA"


def test_hand_edited_no_sec_one_per_line(tmp_path):
    """AT2 variant 5: 'NPTS=  8000, DT= .0050' (no SEC), one value per line."""
    y = _samples_g(8000)
    header = [
        "PEER NGA STRONG MOTION DATABASE RECORD",
        "Northridge-01, 1/17/1994, Rinaldi Receiving Sta, 228",
        "ACCELERATION TIME SERIES IN UNITS OF G",
        "NPTS=  8000, DT= .0050",
    ]
    cells = [f"{v:.7f}" for v in y]  # hand edits often leave plain decimals
    gm = records.read_at2(_write(tmp_path / "GM11.AT2", header, cells, per_line=1))
    assert gm.n == 8000 and gm.dt == 0.005
    np.testing.assert_allclose(gm.ag, np.round(y, 7) * G, rtol=1e-15, atol=0)


def test_trailing_filter_text_crlf_short_last_line_and_blank_lines(tmp_path):
    """AT2 variant 5 and the parser rules: text after 'SEC,', CRLF, ragged end."""
    y = _samples_g(13)  # 13 = 2 full lines + a short line of 3
    header = [
        "PEER NGA STRONG MOTION DATABASE RECORD",
        "Northern Calif-03, 12/21/1954, Ferndale City Hall, 44",
        "ACCELERATION TIME SERIES IN UNITS OF G",
        "NPTS=    13, DT= .0050 SEC, 0 POLE @ 30.00000 HZ, 0 POLE @ 0.10000 HZ",
    ]
    path = _write(tmp_path / "filt.AT2", header, _e14_6(y), newline="\r\n", tail="\r\n   \r\n")
    gm = records.read_at2(path)
    assert gm.n == 13 and gm.dt == 0.005
    _assert_printed(gm.ag, y)


@pytest.mark.parametrize("dt_text", [".0050", "0.005", "5.0E-03", "5.0e-3", "5.0D-03", "5.D-3"])
def test_dt_forms(tmp_path, dt_text):
    """AT2 parser rules (docs/verification.md): '.0050', '0.005', '5.0E-03' and Fortran 'D' exponents."""
    header = [
        "T",
        "x",
        "ACCELERATION TIME SERIES IN UNITS OF G",
        f"NPTS=     6, DT= {dt_text} SEC,",
    ]
    cells = ["  1.0D-02", "  -2.5D-03", "  0.0", "  3.0E-2", "  .5", "  -1."]
    gm = records.read_at2(_write(tmp_path / "dt.AT2", header, cells))
    assert gm.dt == 0.005
    np.testing.assert_allclose(gm.ag, np.array([1e-2, -2.5e-3, 0.0, 3e-2, 0.5, -1.0]) * G, rtol=0)


@pytest.mark.parametrize(
    "units_line, factor",
    [
        ("ACCELERATION TIME SERIES IN UNITS OF G", G),
        ("ACCELERATION TIME SERIES IN UNITS OF CM/S^2", 0.01),
        ("ACCELERATION TIME SERIES IN UNITS OF CM/SEC/SEC", 0.01),
        ("ACCELERATION TIME HISTORY IN UNITS OF CM/S/S.", 0.01),
        ("ACCELERATION TIME SERIES IN UNITS OF M/S^2", 1.0),
    ],
)
def test_units_from_line_3(tmp_path, units_line, factor):
    """AT2 format (docs/verification.md): the units come from line 3; cm/s^2 and m/s^2 are converted to m/s^2."""
    header = ["T", "x", units_line, "NPTS=     3, DT= .0100 SEC,"]
    gm = records.read_at2(_write(tmp_path / "u.AT2", header, ["  1.0", "  -2.0", "  0.5"]))
    np.testing.assert_allclose(gm.ag, np.array([1.0, -2.0, 0.5]) * factor, rtol=1e-15)


def test_custom_g_and_assumed_units(tmp_path):
    header = ["T", "x", "NPTS=     2, DT= .0100 SEC,"]  # no units line
    gm = records.read_at2(_write(tmp_path / "g.AT2", header, ["  1.0", "  -1.0"]), g=9.81)
    np.testing.assert_allclose(gm.ag, [9.81, -9.81], rtol=1e-15)
    assert gm.metadata["units"].startswith("G (assumed")


# ------------------------------------------------------------------ refusals and malformed files
HEADER = ["PEER NGA STRONG MOTION DATABASE RECORD", "x", "ACCELERATION TIME SERIES IN UNITS OF G"]


@pytest.mark.parametrize("suffix, kind", [(".VT2", "velocity"), (".DT2", "displacement")])
def test_velocity_and_displacement_files_are_refused(tmp_path, suffix, kind):
    path = _write(tmp_path / f"rec{suffix}", [*HEADER, "NPTS=     2, DT= .0050 SEC,"], ["1", "2"])
    with pytest.raises(ValueError, match=rf"rec\{suffix}.*{kind}.*\.AT2 file"):
        records.read_at2(path)


def test_velocity_header_in_at2_file_is_refused(tmp_path):
    header = ["T", "x", "VELOCITY TIME SERIES IN UNITS OF CM/S", "NPTS=     2, DT= .0050 SEC,"]
    with pytest.raises(ValueError, match=r"v\.AT2, line 3: .*velocity time series"):
        records.read_at2(_write(tmp_path / "v.AT2", header, ["1", "2"]))


@pytest.mark.parametrize(
    "npts_line, cells, match",
    [
        ("NPTS=     3, DT= 0.0 SEC,", ["1", "2", "3"], r"bad\.AT2, line 4: DT=0\.0 s.*positive"),
        ("NPTS=     3, DT= -.005 SEC,", ["1", "2", "3"], r"line 4: DT=-\.005 s.*positive"),
        ("NPTS=     3, SEC", ["1", "2", "3"], r"line 4: cannot read DT from 'NPTS=     3, SEC'"),
        (
            "NPTS=    12, DT= .0050 SEC,",
            ["  1.0"] * 10,
            r"line 4: NPTS=12 but 10 values were found \(lines 5-6\).*truncated",
        ),
        (
            "NPTS=     4, DT= .0050 SEC,",
            ["  1.0"] * 6,
            r"line 4: NPTS=4 but 6 values were found.*extra values",
        ),
        ("NPTS=     3, DT= .0050 SEC,", [], r"NPTS=3 but 0 values were found"),
        ("NPTS=     1, DT= .0050 SEC,", ["  1.0"], r"line 4: NPTS=1; a record needs at least 2"),
        (
            "NPTS=     7, DT= .0050 SEC,",
            ["  1.0"] * 6 + ["  0.1x"],
            r"line 6: '0\.1x' is not a number",
        ),
        (
            "NPTS=     3, DT= .0050 SEC,",
            ["  1.0", "  NaN", "  2.0"],
            r"line 5: non-finite sample 'NaN'",
        ),
        (
            "NPTS=     3, DT= .0050 SEC,",
            ["  1.0", "  1.0E999", "  2.0"],
            r"line 5: '1\.0E999' overflows",
        ),
    ],
)
def test_malformed_files_name_the_line(tmp_path, npts_line, cells, match):
    """Malformed files raise ValueError naming the file, the line and what is wrong."""
    path = _write(tmp_path / "bad.AT2", [*HEADER, npts_line], cells)
    with pytest.raises(ValueError, match=match):
        records.read_at2(path)


def test_empty_no_header_and_unknown_units(tmp_path):
    empty = tmp_path / "empty.AT2"
    empty.write_text("\n  \n")
    with pytest.raises(ValueError, match=r"empty\.AT2: the file is empty"):
        records.read_at2(empty)
    bare = _write(tmp_path / "bare.AT2", [], ["  1.0"] * 10)
    with pytest.raises(ValueError, match=r"bare\.AT2: no NPTS/DT line found in its 2 lines"):
        records.read_at2(bare)
    header = ["T", "x", "ACCELERATION IN UNITS OF IN/S^2", "NPTS=     2, DT= .0050 SEC,"]
    with pytest.raises(ValueError, match=r"line 3: unknown units 'IN/S\^2'"):
        records.read_at2(_write(tmp_path / "in.AT2", header, ["1", "2"]))


# ------------------------------------------------------------------ writer: round trip
def test_write_read_round_trip(tmp_path):
    """write_at2 -> read_at2 keeps every sample to the printed precision, dt and metadata."""
    y = _samples_g(1003)
    y[5], y[6] = 1.234567891e-120, -9.87654321e-150  # 3-digit exponents must not touch
    gm = rj.GroundMotion(ag=y * G, dt=1.0 / 300.0, name="RSN1063_NORTHR_RRS228").with_metadata(
        event="Northridge-01", date="1/17/1994", station="Rinaldi Receiving Sta", component="228"
    )
    path = tmp_path / f"{gm.name}.AT2"
    records.write_at2(path, gm)
    lines = path.read_text().splitlines()
    assert lines[1] == "Northridge-01, 1/17/1994, Rinaldi Receiving Sta, 228"
    assert lines[3].startswith("NPTS=  1003, DT= ") and lines[3].endswith(" SEC,")
    assert lines[4].startswith("  0.000000E+00  ") and len(lines[4].split()) == 5  # E14.6 x 5
    back = records.read_at2(path)
    assert back.n == gm.n and back.dt == gm.dt and back.name == gm.name
    _assert_printed(back.ag, y)
    for key in ("event", "date", "station", "component"):
        assert back.metadata[key] == gm.metadata[key]

    records.write_at2(path, gm, significant_digits=17)
    back = records.read_at2(path)
    np.testing.assert_allclose(back.ag, gm.ag, rtol=RTOL_17_DIGITS, atol=0)


def test_write_refuses_vertical_and_bad_digits(tmp_path):
    gm = rj.GroundMotion(ag=np.ones(4), dt=0.01, ag_v=np.zeros(4))
    with pytest.raises(ValueError, match="vertical component"):
        records.write_at2(tmp_path / "v.AT2", gm)
    with pytest.raises(ValueError, match="significant_digits"):
        records.write_at2(
            tmp_path / "v.AT2", rj.GroundMotion(ag=np.ones(4), dt=0.01), significant_digits=0
        )


# ------------------------------------------------------------------ CSV
def test_read_csv_two_columns_with_header(tmp_path):
    t = 0.25 + 0.01 * np.arange(50)
    a = np.sin(t)
    text = "# exported record\ntime_s,acc_g\n" + "".join(
        f"{ti:.2f},{ai:.17g}\r\n" for ti, ai in zip(t, a)
    )
    path = tmp_path / "rec.csv"
    path.write_text(text)
    # `acc_g` states no unit (a_g is the ground acceleration's symbol): the units must be given
    with pytest.raises(ValueError, match=r"units of the acceleration column 1 \('acc_g'\) are not"):
        records.read_csv(path)
    gm = records.read_csv(path, units="g")
    assert gm.n == 50 and math.isclose(gm.dt, 0.01, rel_tol=1e-12) and gm.name == "rec"
    np.testing.assert_allclose(gm.ag, a * G, rtol=1e-15)
    assert gm.metadata["header"] == "time_s,acc_g" and gm.metadata["t_start"] == "0.25"
    assert gm.metadata["units"] == "g" and gm.metadata["units_from"] == "units="
    gm = records.read_csv(path, units="m/s2", name="x")
    np.testing.assert_allclose(gm.ag, a, rtol=1e-15)
    assert gm.name == "x"


def test_read_csv_one_column(tmp_path):
    path = tmp_path / "a.txt"
    path.write_text("acc\n1.0\n-2.0\n\n0.5\n")
    gm = records.read_csv(path, units="cm/s2", time_column=False, dt=0.02)
    np.testing.assert_allclose(gm.ag, [0.01, -0.02, 0.005], rtol=1e-15)
    assert gm.dt == 0.02
    path.write_text("1.0;2.0\n")
    with pytest.raises(ValueError, match=r"a\.txt, line 1: 2 values, expected 1"):
        records.read_csv(path, time_column=False, dt=0.02)
    with pytest.raises(ValueError, match="needs its sampling step"):
        records.read_csv(path, time_column=False)
    with pytest.raises(ValueError, match="Pass dt only with time_column=False"):
        records.read_csv(path, dt=0.01)


def test_read_csv_errors_name_the_line(tmp_path):
    path = tmp_path / "b.csv"
    path.write_text("t,a\n0.0,1.0\n0.01,abc\n")
    with pytest.raises(ValueError, match=r"b\.csv, line 3: 'abc' is not a number"):
        records.read_csv(path)
    path.write_text("0.0,1.0\n0.01,nan\n")
    with pytest.raises(ValueError, match=r"line 2: non-finite sample 'nan'"):
        records.read_csv(path)
    path.write_text("0.0 1.0\n0.01 2.0\n0.03 0.0\n")
    with pytest.raises(ValueError, match="not uniformly sampled"):
        records.read_csv(path, units="m/s2")
    path.write_text("0.0|1.0\n0.01|2.0\n")
    np.testing.assert_allclose(records.read_csv(path, delimiter="|", units="m/s2").ag, [1.0, 2.0])


# ------------------------------------------------------------------ rotation
# Rotation by an orthogonal matrix is exact; float64 products and sums cost a few ulp.
RTOL_ROTATION = 1e-13


def _pair():
    t = np.arange(500) * 0.01
    a = rj.GroundMotion(ag=np.sin(3.0 * t) * np.exp(-0.2 * t), dt=0.01, name="S1_070")
    b = rj.GroundMotion(ag=0.7 * np.cos(5.0 * t + 0.3), dt=0.01, name="S1_160")
    return a.with_metadata(event="Nahanni", component="070"), b.with_metadata(event="Nahanni")


def test_rotate_to_own_azimuths_and_nahanni_example():
    """FEMA P695 facts (docs/verification.md): a(phi) = a_A cos(phi - theta_A) + a_B sin(phi - theta_A), theta_B = theta_A + 90."""
    a, b = _pair()
    np.testing.assert_array_equal(records.rotate(a, b, 70, 160, 70).ag, a.ag)
    np.testing.assert_array_equal(records.rotate(a, b, 70, 160, 160).ag, b.ag)
    r280 = records.rotate(a, b, 70, 160, 280)
    # docs/verification.md: "Nahanni 280: a = -0.8660 a_070 - 0.5 a_160"
    np.testing.assert_allclose(
        r280.ag, -math.sqrt(3) / 2 * a.ag - 0.5 * b.ag, rtol=RTOL_ROTATION, atol=1e-15
    )
    assert r280.metadata["azimuth_deg"] == "280" and r280.metadata["event"] == "Nahanni"
    assert "component" not in r280.metadata  # not shared by both inputs
    assert r280.name == "S1_070_rot280" and r280.dt == a.dt


def test_rotate_preserves_energy_and_accepts_either_order():
    """Rotation is orthogonal: a(phi)^2 + a(phi + 90)^2 = a_A^2 + a_B^2 at every sample."""
    a, b = _pair()
    for phi in (0.0, 37.0, 123.4, 280.0, -45.0):
        p = np.asarray(records.rotate(a, b, 70, 160, phi).ag)
        q = np.asarray(records.rotate(a, b, 70, 160, phi + 90.0).ag)
        np.testing.assert_allclose(p**2 + q**2, a.ag**2 + b.ag**2, rtol=RTOL_ROTATION, atol=1e-15)
        # b at theta_A - 90 (mod 360): the same projection with the components swapped
        swapped = records.rotate(b, a, 160, 70 + 360, phi).ag
        np.testing.assert_allclose(swapped, p, rtol=RTOL_ROTATION, atol=1e-15)


def test_rotate_refuses_bad_pairs():
    a, b = _pair()
    with pytest.raises(ValueError, match="must be orthogonal.*100 deg apart"):
        records.rotate(a, b, 70, 170, 0)
    with pytest.raises(ValueError, match="share dt and length"):
        records.rotate(a, rj.GroundMotion(ag=np.asarray(b.ag), dt=0.02), 70, 160, 0)
    with pytest.raises(ValueError, match="share dt and length"):
        records.rotate(a, rj.GroundMotion(ag=np.asarray(b.ag)[:-1], dt=0.01), 70, 160, 0)
    with pytest.raises(ValueError, match="different vertical components"):
        av = rj.GroundMotion(ag=a.ag, dt=a.dt, ag_v=np.zeros(a.n))
        records.rotate(av, b, 70, 160, 0)


# ----------------------------------------------------------------------------- records.load


def test_load_files_folders_and_errors_name_the_entry(tmp_path):
    """Files and folders in the order given (a folder's .AT2 files by name, any suffix case);
    an unknown entry or an empty folder raises naming it."""
    folder = tmp_path / "set"
    folder.mkdir()
    header = [*HEADER, "NPTS=     3, DT= .0100 SEC,"]
    _write(folder / "b.at2", header, ["  1.0", "  -2.0", "  0.5"])
    _write(folder / "a.AT2", header, ["  0.5", "  -1.0", "  0.25"])
    (folder / "notes.txt").write_text("not a record")
    single = _write(tmp_path / "c.AT2", header, ["  0.1", "  0.2", "  0.3"])
    motions = records.load([single, str(folder)])
    assert [m.name for m in motions] == ["c", "a", "b"]
    np.testing.assert_allclose(motions[1].ag, np.array([0.5, -1.0, 0.25]) * G, rtol=1e-12)
    assert [m.name for m in records.load(single)] == ["c"]  # one entry alone
    with pytest.raises(ValueError, match=r"nope\.AT2: no such file or folder, and not a record"):
        records.load([single, tmp_path / "nope.AT2"])
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ValueError, match=r"empty: the folder holds no \.AT2 files"):
        records.load([empty])


# ------------------------------------------------------------------ CSV: recorders, columns, steps
# OpenSees prints 6 significant digits by default (`recorder ... -precision 6`): a relative
# half-unit of the 6th digit
RTOL_6_DIGITS = 5e-6 + 1e-15


def _opensees_file(path, t, columns, fmt="%.6g"):
    """A Node recorder file written as OpenSees writes it with `-time`: no header, blanks
    between fields, the time first, then one column per node and DOF."""
    np.savetxt(path, np.column_stack([t, *columns]), fmt=fmt, delimiter=" ")


def test_read_csv_opensees_recorder_several_dofs(tmp_path):
    """`recorder Node -file a.out -time -node 3 4 -dof 1 2 accel`: 4 DOF columns after the time;
    the first row is the end of the first step, t = dt."""
    dt = 0.005
    t = dt * np.arange(1, 401)
    cols = [np.sin(2 * np.pi * f * t) * (k + 1) for k, f in enumerate((1.0, 2.0, 3.0, 5.0))]
    path = tmp_path / "floor.out"
    _opensees_file(path, t, cols)
    with pytest.raises(ValueError, match=r"floor\.out, line 1: 5 values.*Pass column="):
        records.read_csv(path, units="m/s2")
    for k in range(4):
        gm = records.read_csv(path, column=k + 1, units="m/s2")
        assert gm.n == t.size and gm.dt == dt
        np.testing.assert_allclose(gm.ag, cols[k], rtol=RTOL_6_DIGITS, atol=1e-6 * (k + 1))
        assert gm.metadata["t_start"] == "0.005" and gm.metadata["column"] == str(k + 1)
    # the last column counted from the end, as a Python index
    np.testing.assert_array_equal(
        records.read_csv(path, column=-1, units="m/s2").ag,
        records.read_csv(path, column=4, units="m/s2").ag,
    )
    # a recorder in kip-inch-second units
    gm = records.read_csv(path, column=1, units="in/s2")
    np.testing.assert_allclose(gm.ag, 0.0254 * cols[0], rtol=RTOL_6_DIGITS, atol=1e-7)
    with pytest.raises(ValueError, match=r"column=7 is out of range: the file has 5 columns"):
        records.read_csv(path, column=7)
    with pytest.raises(ValueError, match=r"column=0 is also the time column"):
        records.read_csv(path, column=0)


def test_read_csv_columns_by_name(tmp_path):
    path = tmp_path / "export.csv"
    t = 0.01 * np.arange(20)
    rows = "".join(f"{a:.2f},{1.0 + a},{-a},{2 * a:.3f}\n" for a in t)
    path.write_text("acc_x [g],time [s],acc_y [g],acc_z [g]\n" + rows)
    gm = records.read_csv(path, column="acc_y [g]", time_column="time [s]")
    np.testing.assert_allclose(gm.ag, -t * G, rtol=1e-15)
    assert math.isclose(gm.dt, 0.01, rel_tol=1e-12) and gm.metadata["t_start"] == "1.0"
    assert gm.metadata["column"] == "acc_y [g]" and gm.metadata["time_column"] == "time [s]"
    gm = records.read_csv(path, column="ACC_Z [G]", time_column=1)  # case-insensitive
    np.testing.assert_allclose(gm.ag, 2 * t * G, rtol=1e-15)
    with pytest.raises(ValueError, match=r"column='acc' is not a column name.*1 \('time \[s\]'\)"):
        records.read_csv(path, column="acc", time_column=1)
    # a tab-separated export with blanks inside the names
    path = tmp_path / "tabs.txt"
    path.write_text("t [s]\ta [m/s2]\n0\t0.5\n0.02\t-0.5\n")
    gm = records.read_csv(path, column="a [m/s2]", time_column="t [s]", units="m/s2")
    np.testing.assert_allclose(gm.ag, [0.5, -0.5]) and gm.dt == 0.02
    # without a header a name cannot be resolved
    path.write_text("0\t0.5\n0.02\t-0.5\n")
    with pytest.raises(ValueError, match=r"column='a' names a column, but the file has no header"):
        records.read_csv(path, column="a")


@pytest.mark.parametrize(
    ("text", "encoding"),
    [
        ("0.0,0.1\n0.01,0.2\n0.02,0.3\n", "utf-8-sig"),  # Excel "CSV UTF-8": a byte order mark
        ("0.0\t0.1\n0.01\t0.2\n0.02\t0.3\n", "utf-16"),  # Excel "Unicode text"
        ("# exported\n0.0,0.1 # start\n0.01,0.2\n\n# pause\n0.02,0.3#end\n", "utf-8"),
        ("t,a\n0.0,0.1,\n0.01,0.2,\n0.02,0.3,\n", "utf-8"),  # one trailing separator per row
        ("0.0;0.1\r\n0.01;0.2\r\n0.02;0.3\r\n", "utf-8"),
    ],
    ids=["utf8-bom", "utf16-bom", "comments", "trailing-separator", "semicolons-crlf"],
)
def test_read_csv_keeps_every_row(tmp_path, text, encoding):
    """Every data row is read, whatever wraps it (before, a BOM or a trailing comment on the first
    row made it a header, silently dropped)."""
    path = tmp_path / "rec.csv"
    path.write_bytes(text.encode(encoding))
    gm = records.read_csv(path, units="m/s2")
    np.testing.assert_array_equal(np.asarray(gm.ag), [0.1, 0.2, 0.3])
    assert math.isclose(gm.dt, 0.01, rel_tol=1e-12)


def test_read_csv_refuses_what_it_cannot_read(tmp_path):
    path = tmp_path / "bad.csv"
    cases = [
        # a first line that mixes text and numbers is data that does not parse, not a header
        ("Node 3 DOF 1\n0 0\n0.01 1\n", {}, r"line 1: 'Node' is not a number.*header=True"),
        ("0,,1\n0.01,2,3\n", {}, r"line 1: field 1 is empty"),
        ("0 0\n0.01 1 2\n", {}, r"line 2: 3 values, expected 2 as on line 1"),
        ("0;0,1\n0,01;0,2\n", {}, r"line 1: '0,1' is not a number.*decimal comma.*decimal=','"),
        ("0.1\n0.2\n", {}, r"line 1: 1 value, expected 2.*time_column=False and dt="),
        (
            "0 0\n0.01 1\n0.005 3\n",
            {"units": "m/s2"},
            r"line 3: .*must increase.*follows t = 0\.01 s on line 2",
        ),
        ("0 0\n0.01 294\n", {"units": "g"}, r"peaks at 294 g read with units='g'.*units='cm/s2'"),
        ("0 0\n0.01 1\n", {"column": True}, r"column must be a 0-based column index"),
        (
            "0 0\n0.01 1\n",
            {"resample": 0.5, "units": "g"},
            r"resample=0\.5 s is longer than the record",
        ),
    ]
    for text, kw, message in cases:
        path.write_text(text)
        with pytest.raises(ValueError, match=message):
            records.read_csv(path, **kw)
    # a header with a number in it, declared
    path.write_text("Node 3 DOF 1\n0 0\n0.01 1\n")
    gm = records.read_csv(path, header=True, units="m/s2")
    assert gm.metadata["header"] == "Node 3 DOF 1" and gm.n == 2
    # a NaN in a column not read is no error (OpenSees writes -nan for a diverged DOF)
    path.write_text("0 0 -nan\n0.01 1 -nan\n")
    np.testing.assert_array_equal(records.read_csv(path, column=1, units="m/s2").ag, [0.0, 1.0])
    with pytest.raises(ValueError, match=r"line 1: non-finite sample '-nan' in column 2"):
        records.read_csv(path, column=2)


def test_read_csv_variable_step_says_how_and_resamples(tmp_path):
    """A variable-step analysis (steps halved around t = 0.5 s): the error quantifies the spread
    and proposes resample=; resample interpolates linearly.

    Reference: a record linear in t is reproduced exactly by linear interpolation; a sine is
    within the interpolation bound h^2/8 max|a''| of its closed form (h the file's largest
    step)."""
    t = np.concatenate([np.arange(0.0, 0.5, 0.01), np.arange(0.5, 0.6, 0.0025), [0.6, 0.61]])
    t = np.concatenate([t, np.arange(0.62, 1.0001, 0.01)])
    path = tmp_path / "variable.out"
    _opensees_file(path, t, [0.3 + 0.7 * t], fmt="%.17g")
    message = (
        r"variable\.out: the time column t of record 'variable' is not uniformly sampled: the "
        r"steps range from 0\.0025 to 0\.01 s .* differ from the mean by more than rtol=1e-06; "
        r"the worst, line \d+ .* Pass resample=0\.01 to interpolate"
    )
    with pytest.raises(ValueError, match=message):
        records.read_csv(path, units="m/s2")
    gm = records.read_csv(path, units="m/s2", resample=0.004)
    t_new = 0.004 * np.arange(gm.n)
    assert gm.dt == 0.004 and gm.n == 251 and t_new[-1] <= t[-1]
    # exact for a linear record, up to round-off
    np.testing.assert_allclose(gm.ag, 0.3 + 0.7 * t_new, rtol=0, atol=1e-14)
    assert "linear interpolation of" in gm.metadata["resampled"]

    omega = 2 * np.pi * 1.5
    _opensees_file(path, t, [np.sin(omega * t)], fmt="%.17g")
    gm = records.read_csv(path, units="m/s2", resample=0.004)
    bound = 0.01**2 / 8 * omega**2  # h^2/8 max|a''|
    err = np.max(np.abs(np.asarray(gm.ag) - np.sin(omega * t_new)))
    assert 0 < err <= bound
    # a uniform file resamples too, like GroundMotion.resampled
    uniform = tmp_path / "u.csv"
    _opensees_file(uniform, 0.01 * np.arange(101), [np.sin(omega * 0.01 * np.arange(101))])
    gm = records.read_csv(uniform, units="m/s2", resample=0.005)
    assert gm.n == 201 and "step 0.01 s" in gm.metadata["resampled"]
    bare = tmp_path / "bare.txt"
    bare.write_text("0.0\n1.0\n2.0\n")
    gm = records.read_csv(bare, time_column=False, dt=0.01, resample=0.005, units="m/s2")
    np.testing.assert_allclose(gm.ag, [0.0, 0.5, 1.0, 1.5, 2.0], rtol=0, atol=1e-15)


# ------------------------------------------------------------------ CSV: units, stated or refused
# Factors to m/s^2 written out here, not read from records.CSV_UNITS: 1 gal = 1 cm/s^2 = 0.01
# m/s^2, 1 in = 0.0254 m (exact by definition), g = 9.80665 m/s^2 (standard gravity).
HEADER_UNITS = [
    ("acc [m/s2]", 1.0),
    ("acc [m/s^2]", 1.0),
    ("acc (m/s**2)", 1.0),
    ("acc [m/sec/sec]", 1.0),
    ("acc [m s-2]", 1.0),
    ("acc [m·s⁻²]", 1.0),
    ("acc [m/s²]", 1.0),
    ("accel (g)", 9.80665),
    ("ag [G]", 9.80665),
    ("a (cm/s2)", 0.01),
    ("a [gal]", 0.01),
    ("a [cm/sec^2]", 0.01),
    ("a [mm/s2]", 0.001),
    ("a [in/s2]", 0.0254),
]


@pytest.mark.parametrize(("name", "factor"), HEADER_UNITS, ids=[n for n, _ in HEADER_UNITS])
def test_read_csv_takes_the_unit_from_the_header(tmp_path, name, factor):
    path = tmp_path / "rec.csv"
    path.write_text(f"t [s],{name}\n0,0.5\n0.01,-0.25\n0.02,0\n", encoding="utf-8")
    gm = records.read_csv(path)
    np.testing.assert_allclose(gm.ag, np.array([0.5, -0.25, 0.0]) * factor, rtol=1e-15)
    assert gm.metadata["units_from"] == "header"
    # the same unit passed again is no contradiction
    again = records.read_csv(path, units=gm.metadata["units"])
    np.testing.assert_array_equal(again.ag, gm.ag)


def test_read_csv_refuses_missing_or_contradicting_units(tmp_path):
    path = tmp_path / "rec.csv"
    # an OpenSees recorder file: no header, so no unit
    path.write_text("0.01 0.5\n0.02 -0.25\n")
    with pytest.raises(
        ValueError,
        match=r"rec\.csv: the units .* not stated: the file has no "
        r"header.*units='m/s2' \(an OpenSees model in N, m, s\)",
    ):
        records.read_csv(path)
    # a header in m/s^2 read as g would be 9.81 times too strong
    path.write_text("t [s],acc [m/s2]\n0,0.5\n0.01,-0.25\n")
    with pytest.raises(ValueError, match=r"units='g' contradicts the header.*'m/s2'.*Drop units="):
        records.read_csv(path, units="g")
    # an unknown unit in the header is named, with the accepted ones
    path.write_text("t,acc [ft/s2]\n0,0.5\n0.01,-0.25\n")
    with pytest.raises(ValueError, match=r"header's unit 'ft/s2' is not one read_csv reads"):
        records.read_csv(path)
    # ... and passing the units settles it (the header's text is no known unit)
    np.testing.assert_allclose(records.read_csv(path, units="m/s2").ag, [0.5, -0.25])
    # a velocity or displacement column is no acceleration, whatever units= says
    for col, kind in (("vel [m/s]", "velocity"), ("disp (cm)", "displacement")):
        path.write_text(f"t,{col}\n0,0.5\n0.01,-0.25\n")
        with pytest.raises(ValueError, match=rf"holds a {kind} by its header.*column="):
            records.read_csv(path, units="m/s2")
    # a header in g with values in cm/s^2: the plausibility limit says to correct the header
    path.write_text("t [s],acc [g]\n0,0\n0.01,294\n")
    with pytest.raises(
        ValueError,
        match=r"peaks at 294 g read with the header's unit \(g\).*"
        r"Correct the unit in the header \(cm/s2 or mm/s2\)",
    ):
        records.read_csv(path)


def test_read_csv_times_in_milliseconds(tmp_path):
    """Times in ms: converted where the header or time_units= says so, refused where a step
    longer than MAX_PLAUSIBLE_STEP would be read as seconds."""
    path = tmp_path / "ms.csv"
    rows = "".join(f"{5 * k},{a}\n" for k, a in enumerate((0.0, 0.1, -0.2, 0.05)))
    path.write_text(rows)
    with pytest.raises(ValueError, match=r"steps by 5 \(median\).*milliseconds.*time_units='ms'"):
        records.read_csv(path, units="g")
    gm = records.read_csv(path, units="g", time_units="ms")
    assert gm.dt == 0.005 and gm.n == 4 and "ms" in gm.metadata["time_units"]
    # a step of 5 s is taken when it is said to be one
    assert records.read_csv(path, units="g", time_units="s").dt == 5.0
    for head in ("t [ms]", "time (ms)", "time_ms", "Time (msec)"):
        path.write_text(f"{head},a [g]\n" + rows)
        gm = records.read_csv(path)
        assert gm.dt == 0.005, head
        with pytest.raises(ValueError, match=r"time_units='s' contradicts the header"):
            records.read_csv(path, time_units="s")
    # a header in seconds: the plausibility rule is not needed, the step is what it says
    path.write_text("t [s],a [g]\n" + rows)
    assert records.read_csv(path).dt == 5.0
    with pytest.raises(ValueError, match=r"time_units='ms' was given but time_column=False"):
        records.read_csv(path, time_column=False, dt=0.01, time_units="ms", units="g")


def test_read_csv_decimal_commas(tmp_path):
    """A spreadsheet in a European locale: decimal commas, semicolons between the columns."""
    path = tmp_path / "eu.csv"
    path.write_text("t [s];a [m/s2]\n0,00;0,5\n0,01;-1,25E-1\n0,02;0\n")
    with pytest.raises(ValueError, match=r"line 2: '0,00' is not a number.*decimal=','"):
        records.read_csv(path)
    gm = records.read_csv(path, decimal=",")
    np.testing.assert_array_equal(np.asarray(gm.ag), [0.5, -0.125, 0.0])
    assert gm.dt == 0.01
    # blanks between the columns too
    path.write_text("0,00 0,5\n0,01 -0,25\n")
    np.testing.assert_array_equal(
        records.read_csv(path, decimal=",", units="m/s2").ag, [0.5, -0.25]
    )
    with pytest.raises(ValueError, match=r'delimiter=";"'):
        records.read_csv(path, decimal=",", delimiter=",", units="m/s2")
