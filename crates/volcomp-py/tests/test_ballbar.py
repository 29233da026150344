"""volcomp.ballbar_predict and ballbar_fit: the CLI's figures, the example
machine's causes within three standard uncertainties of their truth
(examples/data/README.md), bad input named by line and column."""

import io
import json
import os
import pathlib
import subprocess

import pytest

import volcomp

DATA = pathlib.Path(__file__).resolve().parents[3] / "examples" / "data"


def test_predict_gives_the_cli_figures():
    p = volcomp.ballbar_predict(DATA / "map.csv", centre_mm=(300, 200, 150), step_deg=1.0)
    assert set(p) == {"figures", "trace", "program"}
    assert len(p["trace"]["runs"]) == 2 and len(p["trace"]["runs"][0]["deviation_um"]) == 360
    assert p["program"].startswith("(volcomp ballbar test")
    exe = os.environ.get("VOLCOMP_BIN")
    if exe:
        out = subprocess.run(
            [exe, "ballbar", "predict", str(DATA / "map.csv"), "--centre-mm", "300,200,150", "--step-deg", "1", "--json"],
            check=True, capture_output=True, text=True,
        )
        cli = json.loads(out.stdout)
        for k in ("g_um", "g_ccw_um", "g_cw_um", "h_um", "f_max_um", "f_min_um"):
            assert cli[k] == pytest.approx(p["figures"][k], abs=1e-9), k


def test_fit_finds_the_example_machine():
    f = volcomp.ballbar_fit(DATA / "ballbar" / "xy.csv", pitch_mm=(10, 10, 10))
    causes = {c["id"]: c for c in f["causes"]}
    # The truth of examples/data/README.md.
    for cid, want in [("squareness_XY", 20.0), ("scale_mismatch_XY", 16.0), ("backlash_X+", 3.0),
                      ("backlash_Y-", 4.0), ("lateral_play_X", 0.8), ("cyclic_X_sin", 0.3)]:
        c = causes[cid]
        assert abs(c["value"] - want) <= 3 * c["std"], (cid, c)


def test_a_bad_trace_is_located():
    with pytest.raises(volcomp.BadInputError, match="2:3"):
        volcomp.ballbar_fit(io.StringIO("direction,angle_deg,deviation_um\nccw,0,x\n"),
                            trace_plane="XY", trace_radius_mm=100)
    with pytest.raises(volcomp.BadInputError, match="step_deg"):
        volcomp.ballbar_predict(DATA / "map.csv", centre_mm=(300, 200, 150), step_deg=7)
