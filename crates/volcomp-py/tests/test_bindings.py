"""Tests of the Python bindings: numbers checked by hand and against the
`volcomp` command on the same inputs (examples/data of the repository)."""

import csv
import inspect
import io
import json
import math
import os
import pathlib
import shutil
import subprocess
import warnings

import numpy as np
import pytest

import volcomp

REPO = pathlib.Path(__file__).resolve().parents[3]
DATA = REPO / "examples" / "data"
EPOCH = 1_700_000_000  # 2023-11-14T22:13:20Z
EPOCH_ISO = "2023-11-14T22:13:20Z"


@pytest.fixture(scope="session")
def cli():
    """The `volcomp` binary of this repository: $VOLCOMP_BIN, or
    target/{debug,release}/volcomp, built with cargo when missing."""
    env = os.environ.get("VOLCOMP_BIN")
    if env:
        return env
    for profile in ("debug", "release"):
        p = REPO / "target" / profile / "volcomp"
        if p.exists():
            return str(p)
    subprocess.run(
        ["cargo", "build", "-q", "-p", "volcomp-cli"], cwd=REPO, check=True
    )
    return str(REPO / "target" / "debug" / "volcomp")


@pytest.fixture()
def data(tmp_path):
    """A copy of examples/data (nothing is written into the repository)."""
    d = tmp_path / "data"
    shutil.copytree(DATA, d)
    return d


def run(cli, *args, cwd):
    env = dict(os.environ, SOURCE_DATE_EPOCH=str(EPOCH))
    r = subprocess.run(
        [cli, *map(str, args)], cwd=cwd, env=env, capture_output=True, check=True
    )
    return r.stdout.decode()


# A map whose errors are written down by hand: X moves 10 µm along X and
# 2 µm along Y per 100 mm, Y moves −4 µm along Z per 200 mm, Z is exact.
HAND_CSV = """axis,direction,position_mm,ex_um,ey_um,ez_um
X,both,0,0,0,0
X,both,100,10,2,0
Y,both,0,0,0,0
Y,both,200,0,0,-4
Z,both,0,0,0,0
Z,both,100,0,0,0
"""


def hand_tables():
    return dict(
        x=([0.0, 100.0], [[0, 0, 0], [10, 2, 0]]),
        y=([0.0, 200.0], [[0, 0, 0], [0, 0, -4]]),
        z=([0.0, 100.0], [[0, 0, 0], [0, 0, 0]]),
    )


def test_axis_table_deviation_by_hand():
    # e(50, 100, 30) = X's table at 50 (5, 1, 0) + Y's at 100 (0, 0, −2).
    for model in (volcomp.Model.from_csv(HAND_CSV), volcomp.Model.from_axis_tables(**hand_tables())):
        e = model.deviation_um([[50.0, 100.0, 30.0], [25.0, 50.0, 0.0]])
        assert e.shape == (2, 3)
        np.testing.assert_allclose(e[0], [5.0, 1.0, -2.0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(e[1], [2.5, 0.5, -1.0], rtol=0, atol=1e-12)
        assert model.kind == "axis-table"
        np.testing.assert_array_equal(model.range_mm, [[0, 100], [0, 200], [0, 100]])
        # Only E_XX, E_YY, E_ZZ: the 5 µm along X of the X table.
        pos = model.deviation_um([50.0, 100.0, 30.0], positioning_only=True)
        np.testing.assert_allclose(pos[0], [5.0, 0.0, 0.0], atol=1e-12)


def test_direction_chooses_the_table():
    t = hand_tables()
    # Reverse table of X: 3 µm more along X everywhere (a backlash of 3 µm).
    x_rev = ([0.0, 100.0], [[3, 0, 0], [13, 2, 0]])
    m = volcomp.Model.from_axis_tables(
        {"forward": t["x"], "reverse": x_rev}, t["y"], t["z"]
    )
    q = [[50.0, 0.0, 0.0]] * 2
    e = m.deviation_um(q, directions=[[1, 1, 1], [-1, 1, 1]])
    np.testing.assert_allclose(e[:, 0], [5.0, 8.0], atol=1e-12)
    with pytest.raises(volcomp.BadInputError, match="give \\+1"):
        m.deviation_um(q, directions=[0, 1, 1])


def test_out_of_range_raises_with_the_row_or_gives_nan():
    m = volcomp.Model.from_csv(HAND_CSV)
    q = np.array([[10.0, 10.0, 10.0], [150.0, 10.0, 10.0]])
    with pytest.raises(volcomp.BadInputError, match="row 1: axis X = 150 mm"):
        m.deviation_um(q)
    e = m.deviation_um(q, outside="nan")
    assert np.isfinite(e[0]).all() and np.isnan(e[1]).all()
    clamped = volcomp.Model.from_csv(HAND_CSV, clamp=True).deviation_um(q)
    # Held at X = 100: 10 µm along X, 2 along Y; Y at 10 gives −0.2 along Z.
    np.testing.assert_allclose(clamped[1], [10.0, 2.0, -0.2], atol=1e-12)


def test_bad_arrays_are_refused_clearly():
    t = hand_tables()
    with pytest.raises(volcomp.BadInputError, match="does not increase"):
        volcomp.Model.from_axis_tables(([0.0, 0.0], [[0, 0, 0]] * 2), t["y"], t["z"])
    with pytest.raises(volcomp.BadInputError, match="at least two points"):
        volcomp.Model.from_axis_tables(([0.0], [[0, 0, 0]]), t["y"], t["z"])
    with pytest.raises(volcomp.BadInputError, match="shape"):
        volcomp.Model.from_csv(HAND_CSV).deviation_um(np.zeros((4, 2)))


def test_csv_error_carries_file_row_and_column():
    bad = HAND_CSV.replace("X,both,100,10,2,0", "X,both,abc,10,2,0")
    with pytest.raises(volcomp.BadInputError) as info:
        volcomp.Model.from_csv(bad, name="m.csv")
    e = info.value
    assert (e.file, e.line, e.column) == ("m.csv", 3, 3)
    assert "m.csv:3:3" in e.message
    assert isinstance(e, volcomp.VolcompError)


def test_load_error_names_the_file(tmp_path):
    with pytest.raises(volcomp.VolcompIOError) as info:
        volcomp.Model.load(tmp_path / "missing.csv")
    assert info.value.file.endswith("missing.csv")


def test_program_text_given_as_a_path_says_how_to_pass_text(tmp_path):
    # A str is always a path; G-code text in one is not read as a program
    # but refused with the way to pass text.
    m = volcomp.Model.from_csv(HAND_CSV)
    for fn in (volcomp.compensate, volcomp.simulate):
        with pytest.raises(volcomp.VolcompIOError, match=r"program: a str names a file.*text of 2 lines.*io\.StringIO\(text\)"):
            fn("G0 X1\nM2\n", m, work_offset_mm=[0, 0, 0])
    with pytest.raises(volcomp.VolcompIOError, match=r"io\.StringIO"):
        volcomp.moves("G0 X1\nM2\n", work_offset_mm=[0, 0, 0])


def test_compensate_by_hand():
    # Target (50, 10, 10). X slope 10 µm / 100 mm: q_x + 1e-4·q_x = 50 →
    # q_x = 49.99500 (4 decimals: 49.995). X at q_x also moves the tool
    # 2e-2·q_x = 0.9999 µm along Y: q_y = 10 − 0.0009999 → 9.9990. Y at
    # q_y moves it −4/200·q_y = −0.19998 µm along Z: q_z = 10.0002.
    m = volcomp.Model.from_csv(HAND_CSV)
    r = volcomp.compensate(
        io.StringIO("G21 G90\nG0 X0 Y10 Z10\nG1 X50 F100\nM2\n"), m, work_offset_mm=[0, 0, 0], no_split=True
    )
    def words(prefix):
        line = [l for l in r.text.splitlines() if l.startswith(prefix)][0]
        return dict((w[0], float(w[1:])) for w in line.split("(")[0].split() if w[0] in "XYZ")

    # The rapid to (0, 10, 10) already carries Z's correction (Y at 10:
    # −0.2 µm along Z); Z is modal, so the feed line repeats only X and Y.
    assert words("G0") == {"X": 0.0, "Y": 10.0, "Z": 10.0002}
    assert words("G1") == {"X": 49.995, "Y": 9.999}
    assert r.points >= 1 and r.lines_in == 4
    assert r.max_correction_um == pytest.approx(math.sqrt(5.0**2 + 1.0**2 + 0.2**2), abs=2e-3)


def test_refused_program_carries_its_line():
    m = volcomp.Model.from_csv(HAND_CSV)
    with pytest.raises(volcomp.RefusedProgramError) as info:
        volcomp.compensate(io.StringIO("G21 G90\nG0 X1 Y1 Z1\nG1 X2 Y1 Q F100\nM2\n"), m, work_offset_mm=[0, 0, 0], name="p.ngc")
    assert info.value.file == "p.ngc"
    assert info.value.line == 3


def test_out_of_range_program_names_the_missing_work_offset():
    m = volcomp.Model.from_csv(HAND_CSV)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", volcomp.VolcompWarning)
        with pytest.raises(volcomp.RefusedProgramError, match="no work offset was given") as info:
            volcomp.compensate(io.StringIO("G21 G90\nG0 X-10 Y1 Z1\nG1 X2 F100\nM2\n"), m)
    assert info.value.line == 2


def test_compensate_matches_the_cli(cli, data):
    run(cli, "compensate", "part.ngc", "--map", "map.csv", "--setup", "machine.toml", "-o", "cli.ngc", cwd=data)
    expected = (data / "cli.ngc").read_text()
    model = volcomp.Model.load(data / "map.csv")
    r = volcomp.compensate(data / "part.ngc", model, setup=data / "machine.toml", date_utc=EPOCH_ISO)
    assert r.text == expected
    # The same program given as a path in a str, or as content in a file
    # object, gives the same output.
    assert volcomp.compensate(str(data / "part.ngc"), model, setup=data / "machine.toml", date_utc=EPOCH_ISO).text == expected
    r2 = volcomp.compensate(io.StringIO((data / "part.ngc").read_text()), model, setup=data / "machine.toml", date_utc=EPOCH_ISO)
    assert r2.text == expected


def test_compensate_options_match_the_cli(cli, data):
    run(
        cli, "compensate", "part.ngc", "--map", "map.csv", "--work-offset", "250,200,150",
        "--method", "ilc", "--gain", "0.5", "--max-iterations", "20", "--segments", "20",
        "--decimals", "5", "--no-trace", "--report", "report.csv", "-o", "out.ngc", cwd=data,
    )
    expected = (data / "out.ngc").read_text()
    model = volcomp.Model.load(data / "map.csv")
    r = volcomp.compensate(
        data / "part.ngc", model, work_offset_mm=(250, 200, 150), method="ilc", gain=0.5,
        max_iterations=20, segments=20, decimals=5, trace=False, point_records=True, date_utc=EPOCH_ISO,
    )
    # The header names where G54 came from in each front end's words.
    strip = lambda t: [l for l in t.splitlines() if "G54 from" not in l]
    assert strip(r.text) == strip(expected)
    rows = list(csv.DictReader(io.StringIO((data / "report.csv").read_text())))
    pr = r.point_records
    assert len(rows) == len(pr["line"]) == r.points
    for k in (0, len(rows) // 2, len(rows) - 1):
        assert int(rows[k]["line"]) == pr["line"][k]
        assert float(rows[k]["command_x_mm"]) == pytest.approx(pr["command_mm"][k, 0], abs=5e-7)
        assert float(rows[k]["residual_um"]) == pytest.approx(pr["residual_um"][k], abs=5e-7)


def test_simulate_matches_the_cli(cli, data):
    for args, kwargs in (
        ([], {}),
        (["--reference", "part.ngc"], {"reference": None}),
    ):
        prog = "part.ngc"
        if args:
            run(cli, "compensate", "part.ngc", "--map", "map.csv", "--setup", "machine.toml", "-o", "comp.ngc", cwd=data)
            prog = "comp.ngc"
            kwargs = {"reference": data / "part.ngc"}
        out = run(cli, "simulate", prog, "--map", "map.csv", "--setup", "machine.toml", "--json", *args, cwd=data)
        expected = json.loads(out)
        r = volcomp.simulate(data / prog, volcomp.Model.load(data / "map.csv"), setup=data / "machine.toml", **kwargs)
        got = r.as_dict()
        for k, v in expected.items():
            assert got[k] == (pytest.approx(v, rel=1e-12) if isinstance(v, float) else v), k


def test_machining_time_by_hand_and_against_the_cli(cli, data, tmp_path):
    # G61: from rest to rest at 50 mm/s; the path accelerates at
    # 500 · L / 60 (X, the axis moving furthest, at its 500 mm/s²):
    # L/50 + 50/a (the planner counts whole 1 ms periods).
    setup = tmp_path / "s.toml"
    setup.write_text('units = "mm"\n[limits]\nmax_velocity = 200\nmax_acceleration = 500\n')
    program = io.StringIO("G21 G90 G61\nG1 X60 Y10 Z10 F3000\nM2\n")
    t = volcomp.machining_time(program, setup=setup)
    assert t["limits_from_setup"] is True
    assert t["original"] is None
    length = math.sqrt(60**2 + 10**2 + 10**2)
    a = 500 * length / 60
    assert t["program"]["motion"]["total_s"] == pytest.approx(length / 50 + 50 / a, abs=2e-3)
    # simulate and compensate carry it too, as the CLI gives it.
    model = volcomp.Model.load(data / "map.csv")
    c = volcomp.compensate(data / "part.ngc", model, setup=data / "machine.toml", date_utc=EPOCH_ISO)
    (data / "py.ngc").write_bytes(c.data)
    out = json.loads(run(cli, "time", "py.ngc", "--reference", "part.ngc", "--setup", "machine.toml", "--json", cwd=data))
    assert c.machining_time == out
    assert c.summary()["machining_time"]["original"]["motion"]["total_s"] > 0
    s = volcomp.simulate(data / "py.ngc", model, setup=data / "machine.toml", reference=data / "part.ngc")
    assert s.machining_time == out
    assert volcomp.machining_time(data / "py.ngc", setup=data / "machine.toml", reference=data / "part.ngc") == out


def test_simulate_segments_against_the_errors_csv(cli, data):
    run(cli, "simulate", "part.ngc", "--map", "map.csv", "--setup", "machine.toml", "--errors-csv", "e.csv", cwd=data)
    rows = list(csv.DictReader(io.StringIO((data / "e.csv").read_text())))
    model = volcomp.Model.load(data / "map.csv")
    r = volcomp.simulate(data / "part.ngc", model, setup=data / "machine.toml", segments=True)
    s = r.segments
    assert len(rows) == len(s["line"])
    for k, row in enumerate(rows):
        assert int(row["line"]) == s["line"][k]
        assert float(row["x_mm"]) == pytest.approx(s["command_mm"][k, 0], abs=5e-7)
        assert float(row["contour_max_um"]) == pytest.approx(s["contour_max_um"][k], abs=5e-5)
        if row["point_error_um"]:
            assert float(row["point_error_um"]) == pytest.approx(s["point_um"][k], abs=5e-5)
        else:
            assert math.isnan(s["point_um"][k])
    # Where a point error exists it is |actual − target| (µm), by definition.
    has = ~np.isnan(s["point_um"])
    d = np.linalg.norm(s["actual_mm"][has] - s["target_mm"][has], axis=1) * 1e3
    np.testing.assert_allclose(d, s["point_um"][has], rtol=1e-12, atol=1e-9)
    assert r.point_max_um == pytest.approx(np.nanmax(s["point_um"]), rel=1e-12)


def test_moves_match_the_cli(cli, data):
    out = run(cli, "moves", "part.ngc", "--setup", "machine.toml", "--extra-axes", cwd=data)
    rows = list(csv.DictReader(io.StringIO(out)))
    m = volcomp.moves(data / "part.ngc", setup=data / "machine.toml", extra_axes=True)
    assert len(rows) == len(m["line"]) > 10
    for k, row in enumerate(rows):
        assert int(row["line"]) == m["line"][k]
        assert int(row["column"]) == m["column"][k]
        assert row["kind"] == m["kind"][k] and row["source"] == m["source"][k]
        for c in ("x_mm", "y_mm", "z_mm", "cx_mm", "cy_mm", "cz_mm", "a_deg", "w_mm"):
            if row[c] == "":
                assert math.isnan(m[c][k])
            else:
                assert float(row[c]) == pytest.approx(m[c][k], abs=5e-7), (k, c)


def test_moves_warn_without_units():
    with pytest.warns(volcomp.VolcompWarning):
        volcomp.moves(io.StringIO("G0 X1 Y2 Z3\nM2\n"))


def test_kinematic_model_matches_map_eval(cli, data):
    run(cli, "map", "example", "-o", "models/", cwd=data)
    out = run(cli, "map", "eval", "models/example21.toml", "--at", "100,50,20", "--tool-length", "120", cwd=data)
    htm = next(l for l in out.splitlines() if l.strip().startswith("HTM"))
    expected = [float(v) for v in htm.split()[1:4]]
    model = volcomp.Model.load(data / "models" / "example21.toml")
    assert model.kind == "kinematic-21" and model.uses_tool_offset
    e = model.deviation_um([100.0, 50.0, 20.0], tool_offset_mm=[0.0, 0.0, 120.0])
    np.testing.assert_allclose(e[0], expected, atol=5e-7)
    # The components printed for X at 100 mm: EXX +0.680 µm, EBX −2.00 µrad.
    p, fwd, _ = model.component("EXX")
    assert np.interp(100.0, p, fwd) == pytest.approx(0.680, abs=5e-4)
    p, fwd, _ = model.component("EBX")
    assert np.interp(100.0, p, fwd) == pytest.approx(-2.00, abs=5e-3)
    comps = model.components()
    assert set(comps) == {"X", "Y", "Z", "squareness_urad"}
    assert comps["X"]["forward"]["angular_urad"].shape[1] == 3


def test_iso230_2_by_hand():
    # Two targets, two runs each way (µm):
    #   P=0:   up 1, 3 → x̄↑ 2, s↑ √2;   down 0, 0 → x̄↓ 0, s↓ 0;  B = 2
    #   P=100: up 0, 2 → x̄↑ 1, s↑ √2;   down 4, 6 → x̄↓ 5, s↓ √2; B = −4
    r = volcomp.iso230_2([0.0, 100.0], [[1, 3], [0, 2]], [[0, 0], [4, 6]])
    t, a = r["targets"], r["axis"]
    np.testing.assert_allclose(t["mean_up_um"], [2, 1])
    np.testing.assert_allclose(t["s_up_um"], [math.sqrt(2)] * 2)
    np.testing.assert_allclose(t["reversal_um"], [2, -4])
    assert a["reversal_b_um"] == pytest.approx(4.0)
    assert a["mean_reversal_um"] == pytest.approx(-1.0)
    # R_i = max(2s↑ + 2s↓ + |B_i|, 4s↑, 4s↓): P=100 gives 4√2 + 4.
    assert a["repeatability_um"] == pytest.approx(4 * math.sqrt(2) + 4)
    # E = max(x̄↑, x̄↓) − min(x̄↑, x̄↓) = 5 − 0.
    assert a["systematic_um"] == pytest.approx(5.0)
    assert r["notes"]  # fewer targets and runs than the standard asks for


def test_iso230_2_csv_matches_the_cli(cli, data):
    out = run(cli, "map", "iso230-2", "runs.csv", "--axis", "X", "-o", "x.csv", cwd=data)
    r = volcomp.iso230_2_csv(data / "runs.csv")
    line = next(l for l in out.splitlines() if l.startswith("accuracy"))
    # "accuracy  A↑ = 6.208 µm   A↓ = 6.289 µm   A = 8.787 µm"
    a = float(line.split("A =")[1].split()[0])
    assert r["axis"]["accuracy_um"] == pytest.approx(a, abs=5e-4)
    assert len(r["targets"]["target_mm"]) == 13


def test_errors_form_one_hierarchy():
    for cls in (volcomp.BadInputError, volcomp.RefusedProgramError, volcomp.VolcompIOError):
        assert issubclass(cls, volcomp.VolcompError)
    assert issubclass(volcomp.VolcompError, Exception)


def test_straightness_fit_matches_the_cli(cli, data):
    files = ["runs/x-4800.csv", "runs/x-7200.csv", "runs/x-9600.csv"]
    run(cli, "straightness", "fit", *files, "-o", "straightness.toml", cwd=data)
    out = run(cli, "straightness", "predict", "straightness.toml", "120,35", "100,-10", cwd=data)
    rows = list(csv.DictReader(io.StringIO(out)))
    model, report = volcomp.straightness_fit([data / f for f in files])
    assert model.kind == "straightness"
    e = model.deviation_um([[float(r["x_mm"]), float(r["y_mm"]), 0.0] for r in rows])
    np.testing.assert_allclose(e[:, 2], [float(r["ez_um"]) for r in rows], atol=5e-5)
    np.testing.assert_array_equal(e[:, :2], 0.0)
    # The same runs as arrays give the same model.
    runs = []
    for f in files:
        text = (data / f).read_text()
        feed = float(next(l for l in text.splitlines() if "feed_mm_per_min" in l).split("=")[1])
        rows_ = list(csv.DictReader(l for l in text.splitlines() if not l.startswith("#")))
        xz = np.array([[float(r["position_mm"]), float(r["displacement_um"])] for r in rows_])
        runs.append({"positions_mm": xz[:, 0], "displacement_um": xz[:, 1], "feed_mm_per_min": feed, "axis": "X"})
    model2, report2 = volcomp.straightness_fit(runs)
    assert report2["X"]["harmonics"] == report["X"]["harmonics"]
    np.testing.assert_allclose(model2.deviation_um([[120.0, 35.0, 0.0]]), e[:1], atol=1e-9)


def test_straightness_of_a_pure_slope_by_hand():
    # e_z = 2 µrad · x over 0 … 200 mm, the same at every feed rate: the
    # model is the line made zero-mean over the range, 0.002·(x − 100) µm.
    x = np.linspace(0.0, 200.0, 401)
    runs = [
        {"positions_mm": x, "displacement_um": 0.002 * x, "feed_mm_per_min": f, "axis": "X"}
        for f in (4800.0, 7200.0, 9600.0)
    ]
    model, report = volcomp.straightness_fit(runs)
    e = model.deviation_um([[150.0, 0, 0], [0.0, 0, 0], [200.0, 0, 0]])
    np.testing.assert_allclose(e[:, 2], [0.1, -0.2, 0.2], atol=1e-9)
    assert report["X"]["line_slope_um_per_mm"] == pytest.approx(0.002, abs=1e-12)
    # An uneven grid is refused with the sample that breaks it.
    x2 = x.copy()
    x2[7] += 0.1
    with pytest.raises(volcomp.BadInputError, match="sample 7"):
        volcomp.straightness_fit([dict(runs[0], positions_mm=x2)] + runs[1:])


def test_thermal_fit_and_predict_match_the_cli(cli, data):
    run(cli, "thermal", "example", "-o", "th", cwd=data)
    run(
        cli, "thermal", "fit", "--measurements", "th/measurements_train.csv",
        "--temperatures", "th/temperatures_train.csv", "--artifact", "th/artifact.csv",
        "--ranges-mm", "0:600,0:400,0:300", "-o", "thermal.toml", cwd=data,
    )
    run(cli, "thermal", "predict", "--model", "thermal.toml", "--temperatures", "th/temperatures_check.csv", "-o", "now.toml", cwd=data)
    th = data / "th"
    model, report = volcomp.thermal_fit(
        th / "measurements_train.csv", th / "temperatures_train.csv", th / "artifact.csv",
        ranges_mm=[(0, 600), (0, 400), (0, 300)], bands_samples=50,
    )
    # The fitted model file is the CLI's, byte for byte.
    assert model.to_toml() == (data / "thermal.toml").read_text()
    now = model.predict(th / "temperatures_check.csv")
    assert now.kind == "kinematic-21"
    cli_now = volcomp.Model.load(data / "now.toml")
    q = [[100.0, 50.0, 20.0], [500.0, 350.0, 250.0], [300.0, 200.0, 150.0]]
    # The CLI's file holds the tables rounded as written (µm to 4 decimals).
    np.testing.assert_allclose(now.deviation_um(q), cli_now.deviation_um(q), atol=2e-3)
    # A loaded model predicts the same as the fitted one.
    again = volcomp.ThermalModel.load(data / "thermal.toml").predict(th / "temperatures_check.csv")
    np.testing.assert_array_equal(again.deviation_um(q), now.deviation_um(q))
    bands = report["bands"]
    assert set(bands) == {"X", "Y", "Z"}
    for b in bands.values():
        assert b["points_mm"].shape == b["lo_um"].shape == b["hi_um"].shape
        assert (b["lo_um"] <= b["hi_um"]).all()
    # The compensated program of an in-memory model names its hash.
    r = volcomp.compensate(data / "part.ngc", now, setup=data / "machine.toml")
    assert "(map arrays)" in r.text


def test_mirror_matches_the_cli(cli, data, monkeypatch):
    out = run(
        cli, "surface", "mirror", "--nominal", "face.toml", "--measured", "probes.csv", "--stock", "0.2",
        "--finishing", "finish.ngc", "-o", "finish.comp.ngc", "--tool-radius", "3", "--json", cwd=data,
    )
    expected = json.loads(out)
    # The files are named in the outputs as given: relative, as to the CLI.
    monkeypatch.chdir(data)
    r = volcomp.mirror(
        pathlib.Path("face.toml"), pathlib.Path("probes.csv"), stock_mm=0.2, finishing=pathlib.Path("finish.ngc"),
        tool_radius_mm=3.0, date_utc=EPOCH_ISO,
    )
    assert r["program"] == (data / "finish.comp.ngc").read_text()
    assert r["surface_grid_csv"] == (data / "probes.compensated.csv").read_text()
    assert r["surface_bspline_toml"] == (data / "probes.compensated.toml").read_text()
    got = r["summary"]
    # Everything but the names of the files the CLI wrote.
    for k, v in expected.items():
        if k in ("surface", "finishing"):
            v = {kk: vv for kk, vv in v.items() if kk not in ("grid", "bspline", "output")}
            g = {kk: vv for kk, vv in got[k].items() if kk not in ("grid", "bspline", "output")}
            assert g == v, k
        else:
            assert got[k] == v, k
    # The nominal given as content (a file object) needs its format.
    face = lambda: io.StringIO((data / "face.toml").read_text())
    with pytest.raises(volcomp.BadInputError, match="nominal_format"):
        volcomp.mirror(face(), data / "probes.csv", stock_mm=0.2)
    r2 = volcomp.mirror(face(), data / "probes.csv", stock_mm=0.2, nominal_format="bspline")
    assert r2["summary"]["before"] == expected["before"]


def test_evaluation_releases_the_gil():
    # The main thread wakes from a 20 ms sleep while the worker is inside
    # the evaluation (2 million points: 0.1 s in a release build, seconds
    # in a debug one). Had the evaluation kept the GIL, the main thread could
    # not run again before it returned.
    import threading
    import time

    m = volcomp.Model.from_csv(HAND_CSV)
    q = np.tile([[50.0, 100.0, 30.0]], (2_000_000, 1))
    started = threading.Event()
    out = {}

    def work():
        started.set()
        out["start"] = time.perf_counter()
        out["e"] = m.deviation_um(q)
        out["end"] = time.perf_counter()

    worker = threading.Thread(target=work)
    worker.start()
    started.wait()
    time.sleep(0.02)
    woke = time.perf_counter()
    worker.join()
    np.testing.assert_allclose(out["e"][-1], [5.0, 1.0, -2.0], atol=1e-12)
    assert out["start"] < woke < out["end"], (out["start"], woke, out["end"])


def test_kinematic_model_from_arrays_matches_the_file(cli, data):
    # example21.toml: chain "w X' Y' b Z t", measuring point (300, 200, 150)
    # mm, measuring tool 100 mm, squareness xy 12, yz -8, zx 6 µrad.
    run(cli, "map", "example", "-o", "models/", cwd=data)
    loaded = volcomp.Model.load(data / "models" / "example21.toml")
    c = loaded.components()
    axes = []
    for a in "XYZ":
        d = {}
        for direction in ("forward", "reverse"):
            t = c[a][direction]
            d[direction] = (t["position_mm"], t["linear_um"], t["angular_urad"])
        axes.append(d)
    built = volcomp.Model.from_components(
        *axes, squareness_urad=(12.0, -8.0, 6.0), measuring_point_mm=(300.0, 200.0, 150.0),
        measuring_tool_length_mm=100.0,
    )
    assert built.kind == "kinematic-21"
    q = [[100.0, 50.0, 20.0], [550.0, 10.0, 280.0], [0.0, 400.0, 0.0]]
    for tool in ([0.0, 0.0, 120.0], [0.0, 0.0, 0.0]):
        for dirs in ([1, 1, 1], [-1, 1, -1]):
            np.testing.assert_allclose(
                built.deviation_um(q, tool_offset_mm=tool, directions=dirs),
                loaded.deviation_um(q, tool_offset_mm=tool, directions=dirs), atol=1e-12,
            )
    with pytest.raises(volcomp.BadInputError, match="chain|Chain|topology"):
        volcomp.Model.from_components(*axes, chain="nonsense")


# The same bad value through the CLI and Python: the library's one check,
# its one message, each front end naming the options its own way (flags on
# the command line, keywords in Python).
BAD_OPTIONS = [
    (["--method", "ilc", "--gain", "2"], dict(method="ilc", gain=2), {"--gain": "gain"}),
    (["--segments", "0"], dict(segments=0), {"--segments": "segments"}),
    (["--take-up-tolerance-um", "-2"], dict(take_up_tolerance_um=-2.0), {"--take-up-tolerance-um": "take_up_tolerance_um"}),
    (
        ["--no-take-up", "--separate-take-ups"],
        dict(take_up=False, separate_take_ups=True),
        {"--separate-take-ups": "separate_take_ups=True", "--no-take-up": "take_up=False"},
    ),
    (
        ["--segments", "3", "--no-split"],
        dict(segments=3, no_split=True),
        {"--no-split": "no_split=True", "--segments": "segments"},
    ),
    (["--decimals", "12"], dict(decimals=12), {"--decimals": "decimals"}),
    # An unknown word for a choice, and a count out of range.
    (["--method", "exct"], dict(method="exct"), {"--method": "method"}),
    (["--segments", "100000"], dict(segments=100000), {"--segments": "segments"}),
]


@pytest.mark.parametrize("args,kwargs,spelling", BAD_OPTIONS)
def test_a_bad_option_gets_the_same_message_in_both_front_ends(cli, data, args, kwargs, spelling):
    p = subprocess.run(
        [cli, "compensate", "part.ngc", "--map", "map.csv", "--setup", "machine.toml", "-o", "x.ngc", *args],
        cwd=data, capture_output=True, text=True,
    )
    assert p.returncode == 2, p.stderr
    cli_message = p.stderr.splitlines()[0].removeprefix("error: ")
    model = volcomp.Model.load(data / "map.csv")
    with pytest.raises(volcomp.BadInputError) as info:
        volcomp.compensate(data / "part.ngc", model, setup=data / "machine.toml", **kwargs)
    py_message = str(info.value)
    for flag, keyword in spelling.items():
        cli_message = cli_message.replace(flag, keyword)
    assert cli_message == py_message
    assert not (data / "x.ngc").exists()


# Another job, the straightness fit: options whose ranges the fit checks,
# with the help line that names the option again.
FIT_RUNS = ["runs/x-4800.csv", "runs/x-7200.csv", "runs/x-9600.csv"]
BAD_FIT_OPTIONS = [
    (["--taper", "0.7"], dict(taper_fraction=0.7), {"--taper": "taper_fraction"}),
    (["--harmonics", "0"], dict(harmonics=0), {"--harmonics": "harmonics"}),
    (["--sigma-t", "-1"], dict(sigma_t=-1.0), {"--sigma-t": "sigma_t"}),
]


@pytest.mark.parametrize("args,kwargs,spelling", BAD_FIT_OPTIONS)
def test_a_bad_fit_option_gets_the_same_message_in_both_front_ends(cli, data, args, kwargs, spelling):
    p = subprocess.run(
        [cli, "straightness", "fit", *FIT_RUNS, *args, "-o", "s.toml"],
        cwd=data, capture_output=True, text=True,
    )
    assert p.returncode == 2, p.stderr
    cli_message = p.stderr.removeprefix("error: ").rstrip("\n")
    with pytest.raises(volcomp.BadInputError) as info:
        volcomp.straightness_fit([data / r for r in FIT_RUNS], **kwargs)
    py_message = str(info.value)
    for flag, keyword in spelling.items():
        cli_message = cli_message.replace(flag, keyword)
    assert cli_message == py_message
    assert not (data / "s.toml").exists()


# A third job, the controller export: the vendor's settings, checked once.
BAD_EXPORT_OPTIONS = [
    (["--to", "siemens-eec", "--step", "10", "--axis-names", "X1,Y1"],
     dict(to="siemens-eec", step_mm=10, axis_names="X1,Y1"), {"--axis-names": "axis_names"}),
    (["--to", "fanuc"], dict(to="fanuc"), {"--step": "step_mm"}),
    (["--to", "fanuk"], dict(to="fanuk"), {"--to": "to"}),
    (["--to", "linuxcnc", "--type", "2", "--units", "mm"],
     dict(to="linuxcnc", comp_type=2, units="mm"), {"--type": "comp_type"}),
    (["--to", "fanuc", "--step", "10", "--detection-unit-um", "0"],
     dict(to="fanuc", step_mm=10, detection_unit_um=0), {"--detection-unit-um": "detection_unit_um"}),
]


@pytest.mark.parametrize("args,kwargs,spelling", BAD_EXPORT_OPTIONS)
def test_a_bad_export_option_gets_the_same_message_in_both_front_ends(cli, data, args, kwargs, spelling):
    p = subprocess.run(
        [cli, "map", "export", "map.csv", *args, "-o", "out"], cwd=data, capture_output=True, text=True,
    )
    assert p.returncode == 2, p.stderr
    cli_message = p.stderr.removeprefix("error: ").rstrip("\n")
    with pytest.raises(volcomp.BadInputError) as info:
        volcomp.export(volcomp.Model.load(data / "map.csv"), **kwargs)
    py_message = str(info.value)
    for flag, keyword in spelling.items():
        cli_message = cli_message.replace(flag, keyword)
    assert cli_message == py_message
    assert not (data / "out").exists()


def test_export_gives_the_clis_files(cli, data):
    run(cli, "map", "export", "map.csv", "--to", "heidenhain", "--step", "5", "-o", "tnc", cwd=data)
    out = volcomp.export(volcomp.Model.load(data / "map.csv"), to="heidenhain", step_mm=5)
    assert sorted(out["files"]) == sorted(p.name for p in (data / "tnc").iterdir())
    for name, text in out["files"].items():
        assert (data / "tnc" / name).read_text() == text, name
    assert 0 < out["table_error_um"] <= 1.0


def test_an_unknown_keyword_says_the_option_meant():
    with pytest.raises(TypeError, match=r"there is no option `mehtod` \(did you mean `method`\?\)"):
        volcomp.compensate(io.StringIO("M2\n"), volcomp.Model.from_csv(HAND_CSV), mehtod="ilc")


def test_the_options_are_the_librarys_with_their_help():
    sig = inspect.signature(volcomp.compensate)
    assert sig.parameters["gain"].default == 0.5
    assert sig.parameters["take_up"].default is True
    assert sig.parameters["max_output_bytes"].default == 256 << 20
    assert "ILC gain" in volcomp.compensate.__doc__
    # Help names the other options as Python spells them.
    assert "within chord_tolerance_mm" in volcomp.compensate.__doc__
    assert "--" not in volcomp.compensate.__doc__


def test_a_str_is_a_path_and_text_comes_in_a_file_object(data):
    model = volcomp.Model.load(data / "map.csv")
    with pytest.raises(volcomp.VolcompIOError):
        volcomp.compensate("G0 X1\nM2\n", model, work_offset_mm=[0, 0, 0])
    with pytest.raises(TypeError, match="file object"):
        volcomp.compensate(b"G0 X1\nM2\n", model, work_offset_mm=[0, 0, 0])
