#!/usr/bin/env python3
"""What a take-up and a split cost on LinuxCNC's planner, in isolation.

Small G91 programs on the benchmark machine (config/), each against the
same path without the feature:

* a take-up: a 30 mm X line at F with a 4 µm Y move in its middle (a take-up
  block of the size volcomp writes). LinuxCNC 2.9 caps a segment's speed at
  its length per servo cycle (src/emc/tp/tc.c, tcClampVelocityByLength:
  4 µm / 1 ms = 4 mm/s), so the machine must nearly stop there: about v/a
  more than the plain line (50 ms at F3000, 100 ms at F6000);
* a split next to a corner: two 15 mm lines meeting at 36° (a 10-gon's
  corner) at F6000, the second split, in line, 0.5 mm or 5 mm after the
  corner, or the first 0.5 mm before it. A blend arc may use at most half of
  each neighbouring segment (src/emc/tp/blendmath.c, BLEND_DIST_FRACTION =
  0.5), so a short piece next to a corner makes the blend tighter and the
  corner slower.

Usage: mechanisms.py [WORK_DIR]
"""

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import lcnc  # noqa: E402


def corner(pieces_before_mm, pieces_after_mm, feed):
    c, s = math.cos(math.radians(36.0)), math.sin(math.radians(36.0))
    lines = [f"G1 X{d:.4f} F{feed}" for d in pieces_before_mm]
    lines += [f"X{d * c:.4f} Y{d * s:.4f}" for d in pieces_after_mm]
    return lines


CASES = []
for feed in (3000, 6000):
    CASES.append((f"30 mm line, F{feed}", None, [f"G1 X30 F{feed}"]))
    CASES.append((f"same with a 4 µm Y take-up at 15 mm, F{feed}", "previous",
                  [f"G1 X15 F{feed}", "Y0.004", "X15"]))
CASES += [
    ("36° corner, 15 + 15 mm, F6000", None, corner([15.0], [15.0], 6000)),
    ("same, second line split 0.5 mm after the corner", 4, corner([15.0], [0.5, 14.5], 6000)),
    ("same, second line split 5 mm after the corner", 4, corner([15.0], [5.0, 10.0], 6000)),
    ("same, first line split 0.5 mm before the corner", 4, corner([14.5, 0.5], [15.0], 6000)),
]


def main():
    work = lcnc.work_dir("ct-mech-")
    print("| program (G91, mm, default G64) | s | more than the plain one |")
    print("|---|---:|---:|")
    times = []
    for i, (name, base, body) in enumerate(CASES):
        if base == "previous":
            base = i - 1
        text = "G21 G91\n" + "\n".join(body) + "\nM2\n"
        t = lcnc.run_text(text, os.path.join(work, f"mech{i}.ngc"), work)["moving_s"]
        times.append(t)
        more = "" if base is None else f"{(t - times[base]) * 1000:+.0f} ms"
        print(f"| {name} | {t:.3f} | {more} |")
    return 0


if __name__ == "__main__":
    lcnc.exit_with(main, "mechanisms.py")
