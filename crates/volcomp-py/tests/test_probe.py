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
