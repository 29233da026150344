#!/usr/bin/env python3
"""How LinuxCNC 2.9's planner will join the feed moves of a program: which
joins it takes as tangent (no stop, no blend), and which segments it runs
below their feed because they are shorter than the feed covers in a servo
period.

The rule is tpSetupTangent's (src/emc/tp/tp.c): with v the slower of the
two segments' target velocities (F, capped by the segment's length per
servo period T, tcClampVelocityByLength in tc.c, and the machine's maximum),
a_inst = v/T + A, and the change of the unit tangent between the segments
t2 - t1, the join is tangent when max_i a_inst |t2_i - t1_i| / A_i is below
ARC_BLEND_KINK_RATIO (0.1 by default), that ratio doubled when an arc takes
part (BLEND_ACC_RATIO_TANGENTIAL 0.5). Anything else stops under G61 and is
blended under G64. G61.1 stops at every block end.

Usage: joins.py PROGRAM [--accel 1000] [--vmax 166.7] [--period 0.001] [--work-offset X,Y,Z]
Prints JSON: joins, tangent, corners (not tangent), short (segments below
their feed), and for each corner and short segment the line.
"""
import argparse
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import judge  # noqa: E402


def unit(v):
    n = judge.norm(v)
    return [x / n for x in v] if n > 0 else [0.0, 0.0, 0.0]


def tangent(m, at_end):
    if m["kind"] != "arc":
        return unit(judge.sub(m["end"], m["start"]))
    # derivative of arc_point at t = 0 or 1
    t = 1.0 if at_end else 0.0
    h = 1e-7
    a = judge.arc_point(m, max(0.0, t - h) if at_end else t)
    b = judge.arc_point(m, t if at_end else min(1.0, t + h))
    return unit(judge.sub(b, a))


def length(m):
    return judge.arc_length(m) if m["kind"] == "arc" else judge.norm(judge.sub(m["end"], m["start"]))


def analyse(moves, accel, vmax, period, kink_ratio=0.1):
    feeds = [m for m in moves if m["kind"] != "rapid" and length(m) > 1e-12]
    out = {"joins": 0, "tangent": 0, "corners": 0, "short": 0, "corner_lines": [], "short_lines": []}
    def vel(m):
        return min(m["feed"] / 60.0, length(m) / period, vmax)
    for m in feeds:
        if length(m) / period < min(m["feed"] / 60.0, vmax) - 1e-9:
            out["short"] += 1
            out["short_lines"].append(m["line"])
    for a, b in zip(feeds, feeds[1:]):
        if judge.norm(judge.sub(b["start"], a["end"])) > 1e-9:
            continue  # a rapid or another move between them
        out["joins"] += 1
        v = min(vel(a), vel(b))
        a_inst = v / period + accel
        t1, t2 = tangent(a, True), tangent(b, False)
        scale = max(a_inst * abs(t2[i] - t1[i]) / accel for i in range(3))
        if a["kind"] == "arc" or b["kind"] == "arc":
            scale /= 0.5
        if scale < kink_ratio:
            out["tangent"] += 1
        else:
            out["corners"] += 1
            out["corner_lines"].append(b["line"])
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("program")
    ap.add_argument("--accel", type=float, default=1000.0)
    ap.add_argument("--vmax", type=float, default=166.7)
    ap.add_argument("--period", type=float, default=0.001)
    ap.add_argument("--work-offset", default="0,0,0")
    args = ap.parse_args()
    moves = judge.read_program(args.program, [float(x) for x in args.work_offset.split(",")])
    json.dump(analyse(moves, args.accel, args.vmax, args.period), sys.stdout)
    print()


if __name__ == "__main__":
    main()
