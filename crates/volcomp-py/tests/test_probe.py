"""volcomp.probe_fit: the example probing campaign (examples/data/probing,
docs/probing.md) identified as `volcomp probe fit` identifies it, the
parameters one probe length cannot see reported as such, bad input named
by file and option."""

import io
import os
import pathlib
import subprocess

import pytest

import volcomp

DATA = pathlib.Path(__file__).resolve().parents[3] / "examples" / "data" / "probing"
NAMES = ("reference", "plate", "gauge")
RANGES = [(0, 600), (0, 400), (0, 300)]


def fit(**options):
    arts = [DATA / f"{n}.toml" for n in NAMES]
    logs = [DATA / f"{n}.log" for n in NAMES]
    return volcomp.probe_fit(arts, logs, ranges_mm=RANGES, **options)


def test_the_example_campaign_gives_the_clis_result(tmp_path):
    model, found = fit()
    params = {p["name"]: p for p in found["params"]}
    assert sum(p["status"] == "identified" for p in params.values()) == 25
    # One probe length: the angles acting through the tool alone (docs/probing.md).
    unseen = sorted(n for n, p in params.items() if p["status"] == "not seen")
    assert unseen == sorted(f"{c}.P{k}" for c in ("ECY", "EAZ", "EBZ", "ECZ") for k in (1, 2))
    assert all(params[n]["value"] is None for n in unseen)
    assert any("one probe length" in n for n in found["notes"])
    assert all(r is not None and r["std"] > 0 for r in found["reversal_um"])
    assert 0.3 < found["sigma0_um"] < 0.5  # the example's probing noise is 0.4 µm
    assert "kinematic" in repr(model)
    exe = os.environ.get("VOLCOMP_BIN")
    if exe:
        args = [exe, "probe", "fit", "--ranges-mm", "0:600,0:400,0:300", "-o", str(tmp_path / "m.toml")]
        for n in NAMES:
            args += ["--artifact", str(DATA / f"{n}.toml"), "--log", str(DATA / f"{n}.log")]
        out = subprocess.run(args, check=True, capture_output=True, text=True)
        cli = out.stdout.splitlines()
        for line in found["summary"]:
            assert line in cli, line


def test_bad_input_is_named():
    with pytest.raises(volcomp.BadInputError, match="ranges_mm"):
        volcomp.probe_fit([DATA / "plate.toml"], [DATA / "plate.log"])
    bad = io.StringIO('artifact = "spheres"\nname = 3\n')
    bad.name = "bad.toml"
    with pytest.raises(volcomp.BadInputError, match="bad.toml"):
        volcomp.probe_fit([bad], [DATA / "plate.log"], ranges_mm=RANGES)


def test_a_plan_is_the_clis_program_and_states_its_time(tmp_path):
    art, setup = DATA / "plate.toml", DATA / "setup.toml"
    program, plan = volcomp.probe_plan(str(art), str(setup), tip_diameter_mm=2, probe_tool=9)
    # The example's log of this plate has one line per touch; each touch is
    # a fast and a slow probe move.
    logged = sum(line.startswith("touch ") for line in (DATA / "plate.log").read_text().splitlines())
    assert plan["touches"] == logged == sum(p["touches"] for p in plan["placements"])
    assert program.count("G38.2") == 2 * plan["touches"]
    assert [p["name"] for p in plan["placements"]][0] == "low"
    assert abs(sum(p["time_s"] for p in plan["placements"]) - plan["time_s"]) < 1e-9
    assert 600 < plan["time_s"] < 1800
    exe = os.environ.get("VOLCOMP_BIN")
    if exe:
        out = tmp_path / "plate.ngc"
        args = [exe, "probe", "plan", str(art), "--setup", str(setup), "--probe-tool", "9", "--tip-diameter-mm", "2", "-o", str(out)]
        said = subprocess.run(args, check=True, capture_output=True, text=True).stdout
        assert out.read_text() == program
        assert f"{plan['touches']} touches" in said


def test_a_plan_names_its_bad_option():
    with pytest.raises(volcomp.BadInputError, match="tip_diameter_mm"):
        volcomp.probe_plan(DATA / "plate.toml")
    with pytest.raises(volcomp.BadInputError, match="work_system"):
        volcomp.probe_plan(DATA / "plate.toml", tip_diameter_mm=2, work_system="G60")
