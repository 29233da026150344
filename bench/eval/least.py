#!/usr/bin/env python3
"""The least cutting time the dead band costs a program under G61, by the
closed form of docs/compensation.md ("The least time a smooth reversal
costs"), computed apart from volcomp from the original program and the map.

Where an axis reverses on a corner, the machine stops there anyway under
G61. If the axis stood still along the move before the corner, its motor
crosses the band during that move with the tool on the path: free. If it
moved there, the tool stands at the corner while the axis' motor crosses
its band `b` from rest to rest, at best `2·√(b/A)` (half the way at `+A`,
half at `−A`). Where it reverses on a smooth path (an arc's
quarter point inside the arc, or a tangent join of two arcs), the tool
stays within `tol` of the path only while the path stays within a band of
`2·tol` of its tangent there: `2·√(R·tol)` along the path on each side of
the point. Across that window the reversing axis must move its band `b`
relative to the path, at rest relative to it at both ends, at no more than
the axis' acceleration `A`: the feed through the point is at most
`v* = 2·√(A·R·tol / (b + 4·tol))`, and slowing from `v` to `v*` and back at
the path acceleration (taken as `A`, so the figure stays a lower bound)
costs `(v − v*)² / (A·v)`. At a tangent join of radii `R1`, `R2` the window
is `2·√(R1·tol) + 2·√(R2·tol)`, the symmetric window of
`R = ((√R1 + √R2)/2)²`. A join of an arc with a line costs nothing: the
reversing axis stands still along the line, where the band is crossed with
the tool on the path. `v` is the programmed feed, capped where the arc
itself is slower on LinuxCNC's planner (`√(a_n·R)`, a_n = A·√3/2:
tp.c/blendmath.c `pmCircleActualMaxVel`).

`b` is the reversing axis' own reversal value at the point (its forward and
reverse tables' own component, design.md's axis-table map; the same reading
as compensate/arcs.rs `window_at`); a negative band (the axis' reverse
table lies ahead of it) needs no take-up.

Usage: least.py ORIGINAL --map MAP.csv --work-offset X,Y,Z [--tol-um 0.5] [--accel 1000]
Prints JSON: seconds, the number of reversals that cost time (smooth ones
and corners the reversing axis runs into), and each one.
"""
import argparse
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import judge  # noqa: E402

# Two directions within this angle are one tangent (rad); LinuxCNC's
# tangency test is looser at the feed (tp.c `tpSetupTangent`), a corner
# stops under G61 either way.
TANGENT_RAD = 1e-3
# The accuracy goal under G61 (issue: max ≤ 0.5 µm): the bound at it.
GOAL_TOL_MM = 0.5e-3


def least_speed_mm_s(r_mm, b_mm, tol_mm, a_mm_s2):
    """The highest feed that takes up `b` at a quarter point of radius `r`
    with the tool within `tol` of the path (docs/compensation.md)."""
    return 2.0 * math.sqrt(a_mm_s2 * r_mm * tol_mm / (b_mm + 4.0 * tol_mm))


def least_cost_s(v_mm_s, r_mm, b_mm, tol_mm, a_mm_s2):
    vs = least_speed_mm_s(r_mm, b_mm, tol_mm, a_mm_s2)
    return 0.0 if vs >= v_mm_s else (v_mm_s - vs) ** 2 / (a_mm_s2 * v_mm_s)


def corner_cost_s(b_mm, a_mm_s2):
    """The least time an axis' motor takes to cross its band `b` from rest
    to rest at acceleration `A`, the tool standing: `2·√(b/A)`."""
    return 2.0 * math.sqrt(b_mm / a_mm_s2)


def arc_radius(m):
    u, v, _ = m["plane"]
    c, s = m["centre"], m["start"]
    return math.hypot(s[u] - c[u], s[v] - c[v])


def tangent(m, t):
    """The unit direction of motion of move `m` at parameter `t`."""
    if m["kind"] != "arc":
        d = judge.sub(m["end"], m["start"])
        n = judge.norm(d)
        return [x / n for x in d] if n > 0 else [0.0, 0.0, 0.0]
    eps = 1e-6
    p0 = judge.arc_point(m, max(0.0, t - eps))
    p1 = judge.arc_point(m, min(1.0, t + eps))
    d = judge.sub(p1, p0)
    n = judge.norm(d)
    return [x / n for x in d] if n > 0 else [0.0, 0.0, 0.0]


def band_mm(emap, p, axis, new_dir, s):
    """The reversing axis' band at `p` when it turns to `new_dir` (+1/−1),
    the other axes in direction state `s`."""
    s_old, s_new = list(s), list(s)
    s_old[axis] = 0 if new_dir < 0 else 1
    s_new[axis] = 0 if new_dir > 0 else 1
    e_old = emap.error_mm(p, s_old)
    e_new = emap.error_mm(p, s_new)
    return (e_old[axis] - e_new[axis]) * new_dir


def quarter_points(m):
    """Parameters t in (0, 1) where an axis of the arc's plane reverses, with
    that axis and its new direction."""
    u, v, _ = m["plane"]
    c, s = m["centre"], m["start"]
    a0 = math.atan2(s[v] - c[v], s[u] - c[u])
    sweep = m["sweep"]
    out = []
    k0 = math.floor(min(a0, a0 + sweep) / (math.pi / 2)) - 1
    k1 = math.ceil(max(a0, a0 + sweep) / (math.pi / 2)) + 1
    for k in range(k0, k1 + 1):
        ang = k * math.pi / 2
        t = (ang - a0) / sweep
        if 1e-9 < t < 1 - 1e-9:
            # At angle 0 or π the u coordinate is extreme (u reverses), at
            # ±π/2 the v coordinate.
            axis = u if k % 2 == 0 else v
            d = tangent(m, min(1.0, t + 1e-4))[axis]
            if d != 0.0:
                out.append((t, axis, 1 if d > 0 else -1))
    return sorted(out)


def least_time(moves, emap, tol_mm, a_mm_s2):
    feed = [m for m in moves if m["kind"] != "rapid"]
    a_n = a_mm_s2 * math.sqrt(3.0) / 2.0
    state = [0, 0, 0]  # 0 forward, 1 reverse: the commanded direction last moved
    total, found = 0.0, []
    prev = None
    for m in moves:
        if m["kind"] == "rapid":
            d = judge.sub(m["end"], m["start"])
            for a in range(3):
                if abs(d[a]) > 1e-12:
                    state[a] = 0 if d[a] > 0 else 1
            prev = None
            continue
        v = m["feed"] / 60.0
        # A join with the move before: an axis that reverses there.
        t0 = tangent(m, 0.0)
        if prev is not None and m is not feed[0]:
            tp = tangent(prev, 1.0)
            cos = sum(x * y for x, y in zip(tp, t0))
            smooth = cos > math.cos(TANGENT_RAD)
            for a in range(3):
                if abs(t0[a]) < 1e-12:
                    continue
                new = 1 if t0[a] > 0 else -1
                if state[a] == (0 if new > 0 else 1):
                    continue
                # The axis reverses here.
                if not smooth and abs(tp[a]) > 1e-12:
                    # A corner the axis runs into: the take-up at the stop.
                    b = band_mm(emap, m["start"], a, new, state)
                    if b > 0:
                        c = corner_cost_s(b, a_mm_s2)
                        total += c
                        found.append({"line": m["line"], "at": "corner", "axis": "XYZ"[a],
                                      "band_um": b * 1e3, "cost_s": c})
                elif smooth and prev["kind"] == "arc" and m["kind"] == "arc":
                    r = ((math.sqrt(arc_radius(prev)) + math.sqrt(arc_radius(m))) / 2.0) ** 2
                    b = band_mm(emap, m["start"], a, new, state)
                    vj = min(v, math.sqrt(a_n * min(arc_radius(prev), arc_radius(m))))
                    if b > 0:
                        c = least_cost_s(vj, r, b, tol_mm, a_mm_s2)
                        total += c
                        found.append({"line": m["line"], "at": "join", "axis": "XYZ"[a], "r_mm": r,
                                      "band_um": b * 1e3, "v_mm_s": vj, "cost_s": c})
                state[a] = 0 if new > 0 else 1
        for a in range(3):
            if abs(t0[a]) > 1e-12:
                state[a] = 0 if t0[a] > 0 else 1
        # Quarter points inside an arc.
        if m["kind"] == "arc":
            r = arc_radius(m)
            vj = min(v, math.sqrt(a_n * r))
            for t, a, new in quarter_points(m):
                p = judge.arc_point(m, t)
                b = band_mm(emap, p, a, new, state)
                if b > 0:
                    c = least_cost_s(vj, r, b, tol_mm, a_mm_s2)
                    total += c
                    found.append({"line": m["line"], "at": round(t, 6), "axis": "XYZ"[a], "r_mm": r,
                                  "band_um": b * 1e3, "v_mm_s": vj, "cost_s": c})
                state[a] = 0 if new > 0 else 1
        # The directions at the move's end.
        te = tangent(m, 1.0)
        for a in range(3):
            if abs(te[a]) > 1e-9:
                state[a] = 0 if te[a] > 0 else 1
        prev = m
    return total, found


def check():
    """The worked example of docs/compensation.md: R 25 mm, b 4 µm, tol
    0.1 µm, A 1,000 mm/s², F6000: v* = 47.7 mm/s, 27 ms."""
    vs = least_speed_mm_s(25.0, 0.004, 0.0001, 1000.0)
    c = least_cost_s(100.0, 25.0, 0.004, 0.0001, 1000.0)
    assert abs(vs - 47.7) < 0.05 and abs(c - 0.0273) < 0.0005, (vs, c)
    # 4 µm from rest to rest at 1,000 mm/s²: 2 µm in √(0.004 mm / 1000) s each way.
    assert abs(corner_cost_s(0.004, 1000.0) - 0.004) < 1e-12


def main():
    check()
    ap = argparse.ArgumentParser()
    ap.add_argument("program")
    ap.add_argument("--map", required=True)
    ap.add_argument("--work-offset", default="250,200,150")
    ap.add_argument("--tol-um", type=float, default=0.5)
    ap.add_argument("--accel", type=float, default=1000.0)
    args = ap.parse_args()
    offset = [float(x) for x in args.work_offset.split(",")]
    moves = judge.read_program(args.program, offset)
    total, found = least_time(moves, judge.AxisTableMap(args.map), args.tol_um * 1e-3, args.accel)
    print(json.dumps({"least_s": total, "costly_reversals": len(found), "reversals": found}, indent=1))


if __name__ == "__main__":
    main()
