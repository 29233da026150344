#!/usr/bin/env python3
"""Hand check of the cycle-time harness: single straight moves from rest,
whose time on a trapezoidal velocity profile is known in closed form, run on
the benchmark machine (config/); each measured time must agree within 3
servo cycles (3 ms). run.sh runs this before any measurement.

A move of length L at speed v with acceleration a from rest to rest
accelerates for v/a (covering v^2/(2a)), cruises, and decelerates likewise:

    t = L/v + v/a            if L >= v^2/a   (the speed v is reached)
    t = 2 sqrt(L/a)          otherwise       (triangular profile)

The machine's limits (config/machine.ini): 166.7 mm/s and 1000 mm/s^2 per
axis. What the planner uses (LinuxCNC 2.9, src/emc/task/emccanon.cc and
src/emc/tp/tc.c):
  * the path acceleration of a straight move is the largest one under which
    no axis exceeds its own: a = min over moving axes of a_axis L / |d_axis|
    (1414.2 mm/s^2 on a 45-degree XY diagonal);
  * G0 runs at the axes' MAX_VELOCITY (here also [TRAJ]MAX_LINEAR_VELOCITY);
  * under G64 (LinuxCNC's default) every segment is "parabolic-blend
    terminated" and tcGetOverallMaxAccel() halves its acceleration, even for
    the last move of a program, which stops; under G61 (exact path) it is
    not halved. So `G1 X100 F6000` takes 1.2 s under G64 and 1.1 s under G61.

Usage: check.py [WORK_DIR]  (default: a new temporary folder)
"""

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import lcnc  # noqa: E402

SERVO_PERIOD_S = 0.001
TOLERANCE_S = 3 * SERVO_PERIOD_S
AXIS_MAX_VEL_MM_S = 166.7
AXIS_MAX_ACC_MM_S2 = 1000.0


def trapezoid_time_s(length_mm, speed_mm_s, accel_mm_s2):
    """Time of a rest-to-rest move on a trapezoidal (or triangular) profile."""
    if length_mm >= speed_mm_s**2 / accel_mm_s2:
        return length_mm / speed_mm_s + speed_mm_s / accel_mm_s2
    return 2.0 * math.sqrt(length_mm / accel_mm_s2)


def path_accel_mm_s2(deltas_mm):
    """Largest path acceleration of a straight move keeping every axis
    within AXIS_MAX_ACC_MM_S2."""
    length = math.sqrt(sum(d * d for d in deltas_mm))
    return min(AXIS_MAX_ACC_MM_S2 * length / abs(d) for d in deltas_mm if d != 0.0)


# (name, program body, length mm, speed mm/s, acceleration mm/s^2, feed?)
CASES = [
    ("G61 G1 X100 F6000", "G61 G1 X100 F6000", 100.0, 100.0, 1000.0, True),
    ("G64 G1 X100 F6000 (default blending)", "G1 X100 F6000", 100.0, 100.0, 500.0, True),
    ("G61 G1 X100 F3000", "G61 G1 X100 F3000", 100.0, 50.0, 1000.0, True),
    (
        "G61 G1 X100 Y100 F6000",
        "G61 G1 X100 Y100 F6000",
        math.hypot(100.0, 100.0),
        100.0,
        path_accel_mm_s2([100.0, 100.0]),
        True,
    ),
    ("G61 G0 X100", "G61 G0 X100", 100.0, AXIS_MAX_VEL_MM_S, 1000.0, False),
    ("G61 G1 X5 F6000 (triangular)", "G61 G1 X5 F6000", 5.0, 100.0, 1000.0, True),
]


def main():
    work = lcnc.work_dir("ct-check-")
    print("Hand check: single moves from rest (G91, mm), expected from the")
    print("trapezoidal profile t = L/v + v/a (triangular 2 sqrt(L/a) when v is not reached).")
    print()
    print("| move | L mm | v mm/s | a mm/s² | expected s | measured s | diff ms | feed s |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    failures = []
    for i, (name, body, length, speed, accel, feed) in enumerate(CASES):
        expected = trapezoid_time_s(length, speed, accel)
        text = f"(cycle-time hand check: {body})\nG21 G91\n{body}\nM2\n"
        r = lcnc.run_text(text, os.path.join(work, f"check{i}.ngc"), work)
        measured = r["moving_s"]
        diff = measured - expected
        expected_feed = measured if feed else 0.0
        print(
            f"| `{name}` | {length:.3f} | {speed:.1f} | {accel:.1f} | {expected:.4f} "
            f"| {measured:.4f} | {diff * 1000:+.1f} | {r['feed_s']:.4f} |"
        )
        if abs(diff) > TOLERANCE_S:
            failures.append(f"{name}: measured {measured:.4f} s, expected {expected:.4f} s")
        if abs(r["feed_s"] - expected_feed) > TOLERANCE_S:
            failures.append(f"{name}: feed time {r['feed_s']:.4f} s, expected {expected_feed:.4f} s")
    print()
    if failures:
        print("HAND CHECK FAILED (tolerance 3 servo cycles):", file=sys.stderr)
        for f in failures:
            print("  " + f, file=sys.stderr)
        return 1
    print(f"Hand check passed: every move within {TOLERANCE_S * 1000:.0f} ms (3 servo cycles).")
    return 0


if __name__ == "__main__":
    lcnc.exit_with(main, "check.py")
