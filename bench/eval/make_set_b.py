#!/usr/bin/env python3
"""A second, held-out-like evaluation set: the kinds of make_set.py with
other sizes, counts, start angles and directions, plus shapes the first set
lacks (a zigzag along Y, a rotated rectangle, an octagon, a pentagon)."""
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import make_set  # noqa: E402
from make_set import (chord_circle, fmt, one_block_circle, pocket_with_arcs,  # noqa: E402
                      polygon, raster_surface, spiral_arcs, spiral_lines)


def helix_cw(r, depth, turns, feed):
    out = ["G0 Z5.0000", f"G0 X{fmt(-r)} Y0.0000", f"G1 Z0.0000 F{feed}"]
    for k in range(1, turns + 1):
        out.append(f"G2 X{fmt(-r)} Y0.0000 Z{fmt(-depth * k / turns)} I{fmt(r)} J0.0000")
    out.append(f"G2 X{fmt(-r)} Y0.0000 I{fmt(r)} J0.0000")
    out.append("G0 Z5.0000")
    return out


def zigzag_y(w, h, step, feed):
    out = ["G0 Z5.0000", f"G0 X{fmt(-w / 2)} Y{fmt(-h / 2)}", f"G1 Z-0.3000 F{feed}"]
    x, k = -w / 2, 0
    while x <= w / 2 + 1e-9:
        y = h / 2 if k % 2 == 0 else -h / 2
        out.append(f"G1 Y{fmt(y)}")
        if x + step <= w / 2 + 1e-9:
            out.append(f"G1 X{fmt(x + step)}")
        x += step
        k += 1
    out.append("G0 Z5.0000")
    return out


def rotated_rect(w, h, deg, feed):
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    pts = [(-w / 2, -h / 2), (w / 2, -h / 2), (w / 2, h / 2), (-w / 2, h / 2), (-w / 2, -h / 2)]
    pts = [(x * c - y * s, x * s + y * c) for x, y in pts]
    out = ["G0 Z5.0000", f"G0 X{fmt(pts[0][0])} Y{fmt(pts[0][1])}", f"G1 Z-0.2000 F{feed}"]
    out += [f"G1 X{fmt(x)} Y{fmt(y)}" for x, y in pts[1:]]
    out.append("G0 Z5.0000")
    return out


def r_arcs_mixed(feed):
    out = ["G0 Z5.0000", "G0 X-24.0000 Y5.0000", f"G1 Z-0.5000 F{feed}", "G91"]
    for k in range(5):
        code = "G3" if k % 2 == 0 else "G2"
        out.append(f"{code} X8.0000 Y-2.0000 R5.0000")
    out.append("G3 X-40.0000 Y10.0000 R-30.0000")
    out += ["G90", "G0 Z5.0000"]
    return out


def programs(feed):
    return {
        "chords10_d50": ("circle D50 as 10 chords", chord_circle(25.0, 10, 3.0, feed=feed), False),
        "chords30_d20": ("circle D20 as 30 chords", chord_circle(10.0, 30, 51.0, feed=feed), False),
        "g3_d16": ("circle D16 as one G3 from 200 degrees", one_block_circle(8.0, 200.0, False, feed=feed), False),
        "g2_d60": ("circle D60 as one G2 from 0 degrees", one_block_circle(30.0, 0.0, True, feed=feed), False),
        "helix_cw_d10": ("helical bore D10 clockwise, 3 turns", helix_cw(5.0, 6.0, 3, feed), False),
        "pocket_r4": ("pocket 60 x 40 with R4 corners, 2 offsets", pocket_with_arcs(60.0, 40.0, 4.0, 4.0, 2, feed), False),
        "r_arcs_mixed": ("R arcs in G91, mixed", r_arcs_mixed(feed), False),
        "raster_2": ("raster surface 48 x 30, 2 mm step", raster_surface(48.0, 30.0, 2.0, feed), False),
        "spiral_lines36": ("spiral D6 to D40 as 36 chords a turn", spiral_lines(3.0, 20.0, 4, 36, feed), False),
        "spiral_arcs12": ("spiral of G2 half circles, 12", spiral_arcs(4.0, 1.5, 12, feed), False),
        "octagon": ("octagon D40", polygon(20.0, 8, feed), False),
        "pentagon": ("pentagon D36", polygon(18.0, 5, feed), False),
        "zigzag_y": ("zigzag along Y 24 x 36, 3 mm step", zigzag_y(24.0, 36.0, 3.0, feed), False),
        "rect_rot30": ("rectangle 40 x 20 rotated 30 degrees", rotated_rect(40.0, 20.0, 30.0, feed), False),
    }


if __name__ == "__main__":
    make_set.main(programs)
