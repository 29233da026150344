#!/usr/bin/env python3
"""Runs the ballbar test's program on LinuxCNC 2.9's simulator, headless
(bench/cycle_time/lcnc.py), and checks that it runs to its end: no message
from LinuxCNC, the machine where the program ends (program end + the
simulator's G54, (250, 200, 150) mm), and the feed time of the path the
trace assumes (each run: feed-in, 360°, feed-out at F) within the planner's
accelerations.

    python3 bench/ballbar/check_sim.py [path/to/volcomp]    # default: target/debug/volcomp

Holds an exclusive lock on /tmp/volcomp-linuxcnc.lock for the whole run (one
LinuxCNC on the machine at a time). A check, not a CI test: the simulation
runs in real time (about 20 s plus LinuxCNC's start-up).
"""

import fcntl
import math
import os
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "bench", "cycle_time"))
import lcnc  # noqa: E402

G54 = (250.0, 200.0, 150.0)


def main():
    volcomp = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "target", "debug", "volcomp")
    work = tempfile.mkdtemp(prefix="ballbar-sim-")
    program = os.path.join(work, "bb.ngc")
    # R 50 about (50, 60, 0) in G54, F3000, 90° feed-in and feed-out.
    radius, feed, overshoot, centre = 50.0, 3000.0, 90.0, (50.0, 60.0, 0.0)
    subprocess.run(
        [volcomp, "ballbar", "predict", os.path.join(ROOT, "examples", "data", "map.csv"),
         "--centre-mm", ",".join(str(c) for c in centre), "--radius-mm", str(radius),
         "--overshoot-deg", str(overshoot), "--feed-mm-per-min", str(feed), "--step-deg", "1",
         "--write-program", program],
        check=True, stdout=subprocess.DEVNULL,
    )
    with open("/tmp/volcomp-linuxcnc.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        r = lcnc.run_program(program, os.path.join(work, "runs"), timeout_s=300)
    # The cw run's feed-out ends at 0° − 90° = 270°: (50, 10, 0) in G54.
    end = (centre[0], centre[1] - radius, centre[2])
    want_end = tuple(e + g for e, g in zip(end, G54))
    assert not r["messages"], r["messages"]
    assert all(abs(a - b) < 1e-3 for a, b in zip(r["end_machine_mm"], want_end)), (r, want_end)
    path_mm = 2 * (2 * overshoot + 360.0) / 360.0 * 2 * math.pi * radius
    at_feed_s = path_mm / (feed / 60.0)
    # Accelerating to and from F (1000 mm/s² per axis) adds well under a second.
    assert at_feed_s <= r["feed_s"] <= at_feed_s + 1.0, (r["feed_s"], at_feed_s)
    print(f"ballbar test on LinuxCNC's simulator: ran to {r['end_machine_mm']} (want {want_end}), "
          f"feed time {r['feed_s']:.2f} s for {path_mm:.1f} mm at F{feed:.0f} ({at_feed_s:.2f} s at full feed)")
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
