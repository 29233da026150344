#!/usr/bin/env python3
"""A third evaluation set, for programs nobody tuned on: the kinds of
make_set.py (chord circles, one-block circles, spirals, polygons, zigzags,
helical bores, arcs in all planes in inch, pockets with arcs, R arcs in G91,
rasters) with other sizes, start angles, directions and feeds, and what CAM
programs of those kinds also have and sets a and b lack:

* one-block circles in G18 and G19, a full circle of three turns (P3), small
  circles (D5 one block, D6 as 24 chords: pieces of 0.8 mm), a circle from a
  start angle that is no quarter point (37 degrees), clockwise chord circles;
* a 60-gon, a zigzag with a 0.2 mm step-over, a helix of 8 turns, a helix
  in G91 (G17 arcs with a Z move), a pocket with arcs in G91;
* inch programs (G20) with arcs in G17, G18 and G19, and R arcs;
* a program in the work offset G55 with a tool-length offset (G43 H1): the
  set-up bench/eval/setup_c.toml gives G55 and tool 1 (run.py passes it to
  `volcomp compensate` and `volcomp time`, and its offsets to judge.py);
* programs that change the feed (a finishing pass at half the feed, small
  circles at a third of it), as CAM programs do.

Every program is in the work frame G54 (except the G55 one) with the
offsets of setup_c.toml: machine X 200-300, Y 150-250, Z 125-160 mm, inside
every map of run.py.

Usage: make_set_c.py OUT_DIR [FEED_MM_PER_MIN]   (default F6000)
Writes OUT_DIR/<kind>.<mode>.ngc and prints their names.
"""
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import make_set  # noqa: E402
from make_set import fmt, polygon, raster_surface, spiral_lines, zigzag  # noqa: E402


def ffmt(feed):
    """A feed word's number: whole numbers without decimals."""
    return f"{feed:g}" if feed == int(feed) else f"{feed:.1f}"


def chord_circle_cw(r, n, start_deg, feed):
    """A circle of n chords, clockwise (sets a and b only go counter-clockwise)."""
    a0 = math.radians(start_deg)
    pts = [(r * math.cos(a0 - 2 * math.pi * k / n), r * math.sin(a0 - 2 * math.pi * k / n)) for k in range(n + 1)]
    out = ["G0 Z5.0000", f"G0 X{fmt(pts[0][0])} Y{fmt(pts[0][1])}", f"G1 Z0.0000 F{ffmt(feed)}"]
    out += [f"G1 X{fmt(x)} Y{fmt(y)}" for x, y in pts[1:]]
    out.append("G0 Z5.0000")
    return out


def small_circles(feed):
    """A D6 circle as 24 chords (pieces of 0.78 mm), then a D5 one-block G3
    circle beside it, both at a third of the feed (as a CAM program slows
    down for small features)."""
    f = feed / 3
    r, n, a0 = 3.0, 24, math.radians(45.0)
    pts = [(r * math.cos(a0 + 2 * math.pi * k / n), r * math.sin(a0 + 2 * math.pi * k / n)) for k in range(n + 1)]
    out = ["G0 Z5.0000", f"G0 X{fmt(pts[0][0])} Y{fmt(pts[0][1])}", f"G1 Z-0.5000 F{ffmt(f)}"]
    out += [f"G1 X{fmt(x)} Y{fmt(y)}" for x, y in pts[1:]]
    out += ["G0 Z5.0000", "G0 X12.5000 Y0.0000", "G1 Z-0.5000", "G3 X12.5000 Y0.0000 I-2.5000 J0.0000",
            "G0 Z5.0000"]
    return out


def one_block(code, r, start_deg, feed, turns=1):
    a0 = math.radians(start_deg)
    x, y = r * math.cos(a0), r * math.sin(a0)
    p = f" P{turns}" if turns > 1 else ""
    return ["G0 Z5.0000", f"G0 X{fmt(x)} Y{fmt(y)}", f"G1 Z0.0000 F{ffmt(feed)}",
            f"{code} X{fmt(x)} Y{fmt(y)} I{fmt(-x)} J{fmt(-y)}{p}", "G0 Z5.0000"]


def circle_g18(r, start_deg, feed):
    """A full circle in the XZ plane (G18), counter-clockwise as G18 sees it
    (looking along -Y), centred at X0 Z-r-1."""
    a0 = math.radians(start_deg)
    cz = -r - 1.0
    # G18: first axis Z, second X (LinuxCNC's plane order Z, X).
    z, x = cz + r * math.cos(a0), r * math.sin(a0)
    return ["G0 Z5.0000", f"G0 X{fmt(x)} Y0.0000", f"G1 Z{fmt(z)} F{ffmt(feed)}",
            f"G18 G3 X{fmt(x)} Z{fmt(z)} I{fmt(-x)} K{fmt(cz - z)}", "G17 G0 Z5.0000"]


def circle_g19(r, start_deg, feed):
    """A full circle in the YZ plane (G19), clockwise, centred at Y0 Z-r-1."""
    a0 = math.radians(start_deg)
    cz = -r - 1.0
    y, z = r * math.cos(a0), cz + r * math.sin(a0)
    return ["G0 Z5.0000", f"G0 X0.0000 Y{fmt(y)}", f"G1 Z{fmt(z)} F{ffmt(feed)}",
            f"G19 G2 Y{fmt(y)} Z{fmt(z)} J{fmt(-y)} K{fmt(cz - z)}", "G17 G0 Z5.0000"]


def helix_many(r, pitch, turns, feed):
    out = ["G0 Z5.0000", f"G0 X0.0000 Y{fmt(-r)}", f"G1 Z0.0000 F{ffmt(feed)}"]
    for k in range(1, turns + 1):
        out.append(f"G3 X0.0000 Y{fmt(-r)} Z{fmt(-pitch * k)} I0.0000 J{fmt(r)}")
    out.append(f"G3 X0.0000 Y{fmt(-r)} I0.0000 J{fmt(r)}")
    out.append("G0 Z5.0000")
    return out


def helix_g91(r, pitch, turns, feed):
    """Clockwise helix in G91: every turn `G2 X0 Y0 Z-pitch I.. J..`, then a
    flat turn and a half turn out, incremental."""
    out = ["G0 Z5.0000", f"G0 X{fmt(r)} Y0.0000", f"G1 Z0.0000 F{ffmt(feed)}", "G91"]
    out += [f"G2 X0.0000 Y0.0000 Z{fmt(-pitch)} I{fmt(-r)} J0.0000"] * turns
    out += [f"G2 X0.0000 Y0.0000 I{fmt(-r)} J0.0000", f"G2 X{fmt(-2 * r)} Y0.0000 Z0.2000 I{fmt(-r)} J0.0000"]
    out += ["G90", "G0 Z5.0000"]
    return out


def pocket_g91(w, h, rc, step, levels, feed):
    """A pocket with corner arcs written in G91 (every move incremental),
    counter-clockwise, `levels` offsets inwards."""
    out = ["G0 Z5.0000"]
    for k in range(levels):
        ww, hh, rr = w - 2 * step * k, h - 2 * step * k, rc - step * k * 0.5
        x0, y0 = -ww / 2, -hh / 2
        out += ["G90", f"G0 X{fmt(x0 + rr)} Y{fmt(y0)}", f"G1 Z-0.8000 F{ffmt(feed)}", "G91",
                f"G1 X{fmt(ww - 2 * rr)}", f"G3 X{fmt(rr)} Y{fmt(rr)} I0.0000 J{fmt(rr)}",
                f"G1 Y{fmt(hh - 2 * rr)}", f"G3 X{fmt(-rr)} Y{fmt(rr)} I{fmt(-rr)} J0.0000",
                f"G1 X{fmt(-(ww - 2 * rr))}", f"G3 X{fmt(-rr)} Y{fmt(-rr)} I0.0000 J{fmt(-rr)}",
                f"G1 Y{fmt(-(hh - 2 * rr))}", f"G3 X{fmt(rr)} Y{fmt(-rr)} I{fmt(rr)} J0.0000",
                "G90", "G0 Z5.0000"]
    return out


def inch_pocket(feed_mm):
    """G20: a 1.6 x 1.0 in pocket with R0.25 corners, clockwise (G2), then a
    one-block circle D0.9 in from 60 degrees."""
    f = feed_mm / 25.4
    w, h, r = 1.6, 1.0, 0.25
    x0, y0, x1, y1 = -w / 2, -h / 2, w / 2, h / 2
    out = ["G0 Z0.2000", f"G0 X{x0 + r:.4f} Y{y0:.4f}", f"G1 Z-0.0200 F{f:.1f}",
           f"G2 X{x0:.4f} Y{y0 + r:.4f} I0.0000 J{r:.4f}", f"G1 Y{y1 - r:.4f}",
           f"G2 X{x0 + r:.4f} Y{y1:.4f} I{r:.4f} J0.0000", f"G1 X{x1 - r:.4f}",
           f"G2 X{x1:.4f} Y{y1 - r:.4f} I0.0000 J{-r:.4f}", f"G1 Y{y0 + r:.4f}",
           f"G2 X{x1 - r:.4f} Y{y0:.4f} I{-r:.4f} J0.0000", f"G1 X{x0 + r:.4f}", "G0 Z0.2000"]
    a = math.radians(60.0)
    cx, cy = 0.45 * math.cos(a), 0.45 * math.sin(a)
    out += [f"G0 X{cx:.4f} Y{cy:.4f}", "G1 Z-0.0200", f"G3 X{cx:.4f} Y{cy:.4f} I{-cx:.4f} J{-cy:.4f}", "G0 Z0.2000"]
    return out


def inch_arcs_r(feed_mm):
    """G20: R arcs in G17 (one over 180 degrees, R < 0), then a G19 arc over
    Y and Z and a G18 R arc, inch."""
    f = feed_mm / 25.4
    return ["G0 Z0.2000", "G0 X-0.9000 Y-0.3000", f"G1 Z0.0000 F{f:.1f}",
            "G2 X-0.3000 Y-0.3000 R0.4000", "G3 X0.3000 Y-0.3000 R0.3200",
            "G2 X0.9000 Y-0.3000 R-0.3500", "G1 Y0.3000",
            "G19 G3 Y0.7000 Z0.0000 J0.2000 K0.0000", "G2 Y0.3000 Z0.0000 R0.2500",
            "G18 G2 X0.4000 Z-0.1000 R0.3000", "G3 X-0.4000 Z-0.1000 R0.6000",
            "G17 G0 Z0.2000"]


def g55_tool(feed):
    """In G55 with tool 1's length offset (G43 H1): a 16-chord circle D26
    from 20 degrees, then a G2 half circle and a G3 quarter; G49 and G54 at
    the end."""
    a0 = math.radians(20.0)
    r, n = 13.0, 16
    pts = [(r * math.cos(a0 + 2 * math.pi * k / n), r * math.sin(a0 + 2 * math.pi * k / n)) for k in range(n + 1)]
    out = ["G55 G43 H1", "G0 Z5.0000", f"G0 X{fmt(pts[0][0])} Y{fmt(pts[0][1])}", f"G1 Z0.0000 F{ffmt(feed)}"]
    out += [f"G1 X{fmt(x)} Y{fmt(y)}" for x, y in pts[1:]]
    out += ["G1 X8.0000 Y0.0000", "G2 X-8.0000 Y0.0000 I-8.0000 J0.0000", "G3 X0.0000 Y-8.0000 I8.0000 J0.0000",
            "G0 Z5.0000", "G49 G54"]
    return out


def r_arcs_g91_small(feed):
    """R arcs in G91: a wave of R2.5 arcs, a long R-12 arc back (over 180
    degrees), then a wave along Y of R4 arcs."""
    out = ["G0 Z5.0000", "G0 X-15.0000 Y-12.0000", f"G1 Z-0.4000 F{ffmt(feed)}", "G91"]
    for k in range(6):
        out.append(f"{'G3' if k % 2 == 0 else 'G2'} X4.0000 Y1.0000 R2.5000")
    out.append("G2 X-12.0000 Y4.0000 R-12.0000")
    for k in range(4):
        out.append(f"{'G2' if k % 2 == 0 else 'G3'} X-1.0000 Y5.0000 R4.0000")
    out += ["G90", "G0 Z5.0000"]
    return out


def raster_y(w, h, step, feed):
    """A raster along Y (X steps), 16 points a pass on a surface, the second
    half at half the feed (a finishing pass)."""
    out = ["G0 Z5.0000", f"G0 X{fmt(-w / 2)} Y{fmt(-h / 2)}", f"G1 Z0.0000 F{ffmt(feed)}"]
    x, k, slowed = -w / 2, 0, False
    while x <= w / 2 + 1e-9:
        ys = [-h / 2 + h * i / 15 for i in range(16)]
        if k % 2:
            ys.reverse()
        if x > 1e-9 and not slowed:
            out.append(f"F{ffmt(feed / 2)}")
            slowed = True
        for y in ys:
            z = 1.2 * math.cos(x / 6.0) * math.sin(y / 8.0)
            out.append(f"G1 X{fmt(x)} Y{fmt(y)} Z{fmt(z)}")
        x += step
        k += 1
    out.append("G0 Z5.0000")
    return out


def spiral_lines_in_cw(r0, r1, turns, seg_per_turn, feed):
    """A spiral inwards, clockwise, as chords."""
    n = turns * seg_per_turn
    pts = []
    for k in range(n + 1):
        a = math.radians(15.0) - 2 * math.pi * k / seg_per_turn
        r = r0 + (r1 - r0) * k / n
        pts.append((r * math.cos(a), r * math.sin(a)))
    out = ["G0 Z5.0000", f"G0 X{fmt(pts[0][0])} Y{fmt(pts[0][1])}", f"G1 Z0.0000 F{ffmt(feed)}"]
    out += [f"G1 X{fmt(x)} Y{fmt(y)}" for x, y in pts[1:]]
    out.append("G0 Z5.0000")
    return out


def spiral_arcs_g3(r0, dr, halves, feed):
    """G3 half circles about alternating centres, growing by dr/2 a half
    turn, starting on the Y axis (the arcs begin and end at quarter points
    of Y, not X)."""
    out = ["G0 Z5.0000", f"G0 X0.0000 Y{fmt(-r0)}", f"G1 Z0.0000 F{ffmt(feed)}"]
    y = -r0
    for k in range(halves):
        r = r0 + k * dr / 2
        j = r if k % 2 == 0 else -r
        y = y + 2 * j
        out.append(f"G3 X0.0000 Y{fmt(y)} I0.0000 J{fmt(j)}")
    out.append("G0 Z5.0000")
    return out


def programs(feed):
    return {
        "chords20_cw": ("circle D28 as 20 chords, clockwise from 13 degrees", chord_circle_cw(14.0, 20, 13.0, feed), False),
        "small_circles": ("circle D6 as 24 chords and a D5 G3 circle, F/3", small_circles(feed), False),
        "g2_d32_37": ("circle D32 as one G2 from 37 degrees", one_block("G2", 16.0, 37.0, feed), False),
        "g3_d12_p3": ("circle D12 as one G3 of three turns, P3", one_block("G3", 6.0, 135.0, feed, 3), False),
        "g18_d20": ("circle D20 in G18, XZ, as one G3 from 30 degrees", circle_g18(10.0, 30.0, feed), False),
        "g19_d16": ("circle D16 in G19, YZ, as one G2 from 0 degrees", circle_g19(8.0, 0.0, feed), False),
        "polygon60": ("60-gon D40", polygon(20.0, 60, feed), False),
        "zigzag_fine": ("zigzag pocket 12 x 4, 0.2 mm step", zigzag(12.0, 4.0, 0.2, feed), False),
        "helix_8": ("helical bore D14, 8 turns of 1.5 mm", helix_many(7.0, 1.5, 8, feed), False),
        "helix_g91": ("helix D18 clockwise in G91, 4 turns of 1 mm", helix_g91(9.0, 1.0, 4, feed), False),
        "pocket_g91": ("pocket 40 x 26 with R5 corners in G91, 2 offsets", pocket_g91(40.0, 26.0, 5.0, 4.0, 2, feed), False),
        "inch_pocket": ("pocket 1.6 x 1.0 in with R0.25 corners clockwise, and a D0.9 in circle, inch", inch_pocket(feed), True),
        "inch_arcs_r": ("R arcs in G17, G19 and G18, inch", inch_arcs_r(feed), True),
        "g55_tool": ("G55 with G43 H1: chords, half and quarter circles", g55_tool(feed), False),
        "r_arcs_g91_b": ("R arcs in G91: R2.5 wave, R-12 back, R4 wave along Y", r_arcs_g91_small(feed), False),
        "raster_y": ("raster along Y 30 x 32, 2.5 mm step, finishing half at F/2", raster_y(30.0, 32.0, 2.5, feed), False),
        "spiral_in_cw": ("spiral D30 to D6 inwards, clockwise, 60 chords a turn", spiral_lines_in_cw(15.0, 3.0, 3, 60, feed), False),
        "spiral_arcs_g3": ("spiral of G3 half circles along Y, 10", spiral_arcs_g3(2.5, 2.5, 10, feed), False),
    }


if __name__ == "__main__":
    make_set.main(programs)
