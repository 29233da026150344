#!/usr/bin/env python3
"""Evaluation programs of the kinds a compensation is judged on, each in
the three path-control modes (a first line G61, G64 P0.005 or G64).

Kinds: circles of 10-30 chords, one-block circles (G2/G3, full turns), a
helical bore, arcs in all three planes in inch, a pocket with arcs, R arcs
in G91, a raster surface, spirals (G1 chords and G2/G3 arcs), polygons and
a zigzag pocket. The geometry differs from the bundled demo and
bench/cycle_time programs (other diameters, chord counts, start angles),
so a rule tuned on those is tested on new cases. Programs are in the work
frame G54; the cycle-time machine and the example map use G54 = (250, 200,
150) mm, inside both maps.

Usage: make_set.py OUT_DIR [FEED_MM_PER_MIN]   (default F6000)
Writes OUT_DIR/<kind>.<mode>.ngc and prints their names.
"""
import math
import os
import sys

MODES = {"g61": "G61", "g64p": "G64 P0.005", "g64": "G64"}


def fmt(v):
    s = f"{v:.4f}"
    return "0.0000" if s == "-0.0000" else s


def header(title, mode, inch=False):
    return [f"({title})", ("G20" if inch else "G21") + " G17 G90 G94 G54", mode]


def chord_circle(r, n, start_deg, z=0.0, feed=6000):
    a0 = math.radians(start_deg)
    pts = [(r * math.cos(a0 + 2 * math.pi * k / n), r * math.sin(a0 + 2 * math.pi * k / n)) for k in range(n + 1)]
    out = ["G0 Z5.0000", f"G0 X{fmt(pts[0][0])} Y{fmt(pts[0][1])}", f"G1 Z{fmt(z)} F{feed}"]
    out += [f"G1 X{fmt(x)} Y{fmt(y)}" for x, y in pts[1:]]
    out += ["G0 Z5.0000"]
    return out


def one_block_circle(r, start_deg, cw, turns=1, feed=6000):
    a0 = math.radians(start_deg)
    x, y = r * math.cos(a0), r * math.sin(a0)
    code = "G2" if cw else "G3"
    p = f" P{turns}" if turns > 1 else ""
    return ["G0 Z5.0000", f"G0 X{fmt(x)} Y{fmt(y)}", f"G1 Z0.0000 F{feed}",
            f"{code} X{fmt(x)} Y{fmt(y)} I{fmt(-x)} J{fmt(-y)}{p}", "G0 Z5.0000"]


def helical_bore(r, depth, turns, feed):
    out = ["G0 Z5.0000", f"G0 X{fmt(r)} Y0.0000", f"G1 Z0.0000 F{feed}"]
    for k in range(1, turns + 1):
        out.append(f"G3 X{fmt(r)} Y0.0000 Z{fmt(-depth * k / turns)} I{fmt(-r)} J0.0000")
    out.append(f"G3 X{fmt(r)} Y0.0000 I{fmt(-r)} J0.0000")
    out.append("G0 Z5.0000")
    return out


def arcs_all_planes_inch(feed_mm):
    f = feed_mm / 25.4
    out = ["G0 Z0.2000", "G0 X0.8000 Y0.0000", f"G1 Z0.0000 F{f:.1f}"]
    # G17: a half circle and back by a quarter
    out += ["G17 G3 X-0.8000 Y0.0000 I-0.8000 J0.0000", "G2 X0.0000 Y-0.8000 I0.8000 J0.0000"]
    # G18 (XZ): a bump over X
    out += ["G18 G2 X0.6000 Z0.0000 I0.3000 K0.0000", "G3 X0.8000 Z-0.2000 I0.0000 K-0.2000"]
    # G19 (YZ)
    out += ["G19 G2 Y0.0000 Z-0.2000 J0.4000 K0.0000", "G3 Y0.6000 Z-0.2000 J0.3000 K0.0000"]
    out += ["G17 G0 Z0.2000"]
    return out


def pocket_with_arcs(w, h, rc, step, levels, feed):
    out = ["G0 Z5.0000"]
    for k in range(levels):
        ww, hh, rr = w - 2 * step * k, h - 2 * step * k, max(rc - step * k, 1.0)
        if ww <= 2 * rr or hh <= 2 * rr:
            break
        x0, y0, x1, y1 = -ww / 2, -hh / 2, ww / 2, hh / 2
        out += [f"G0 X{fmt(x0 + rr)} Y{fmt(y0)}", f"G1 Z-1.0000 F{feed}",
                f"G1 X{fmt(x1 - rr)}", f"G3 X{fmt(x1)} Y{fmt(y0 + rr)} I0.0000 J{fmt(rr)}",
                f"G1 Y{fmt(y1 - rr)}", f"G3 X{fmt(x1 - rr)} Y{fmt(y1)} I{fmt(-rr)} J0.0000",
                f"G1 X{fmt(x0 + rr)}", f"G3 X{fmt(x0)} Y{fmt(y1 - rr)} I0.0000 J{fmt(-rr)}",
                f"G1 Y{fmt(y0 + rr)}", f"G3 X{fmt(x0 + rr)} Y{fmt(y0)} I{fmt(rr)} J0.0000",
                "G0 Z5.0000"]
    return out


def r_arcs_g91(feed):
    out = ["G0 Z5.0000", "G0 X-20.0000 Y-10.0000", f"G1 Z0.0000 F{feed}", "G91"]
    # a wave of R arcs, alternating direction, then back with a long R arc
    for k in range(6):
        code = "G2" if k % 2 == 0 else "G3"
        out.append(f"{code} X6.0000 Y0.0000 R3.5000")
    out.append("G2 X-36.0000 Y0.0000 R-25.0000")
    out += ["G90", "G0 Z5.0000"]
    return out


def raster_surface(w, h, step, feed):
    out = ["G0 Z5.0000", f"G0 X{fmt(-w / 2)} Y{fmt(-h / 2)}", f"G1 Z0.0000 F{feed}"]
    y = -h / 2
    k = 0
    while y <= h / 2 + 1e-9:
        xs = [-w / 2 + w * i / 20 for i in range(21)]
        if k % 2:
            xs.reverse()
        for x in xs:
            z = 1.5 * math.sin(x / 9.0) * math.cos(y / 7.0)
            out.append(f"G1 X{fmt(x)} Y{fmt(y)} Z{fmt(z)}")
        y += step
        k += 1
    out.append("G0 Z5.0000")
    return out


def spiral_lines(r0, r1, turns, seg_per_turn, feed):
    n = turns * seg_per_turn
    pts = []
    for k in range(n + 1):
        a = 2 * math.pi * k / seg_per_turn
        r = r0 + (r1 - r0) * k / n
        pts.append((r * math.cos(a), r * math.sin(a)))
    out = ["G0 Z5.0000", f"G0 X{fmt(pts[0][0])} Y{fmt(pts[0][1])}", f"G1 Z0.0000 F{feed}"]
    out += [f"G1 X{fmt(x)} Y{fmt(y)}" for x, y in pts[1:]]
    out.append("G0 Z5.0000")
    return out


def spiral_arcs(r0, dr, halves, feed):
    """G2 half circles about alternating centres, the radius growing by
    dr/2 every half turn: a spiral of arcs."""
    out = ["G0 Z5.0000", f"G0 X{fmt(r0)} Y0.0000", f"G1 Z0.0000 F{feed}"]
    x = r0
    for k in range(halves):
        r = r0 + k * dr / 2
        i = -r if k % 2 == 0 else r
        x = x + 2 * i
        out.append(f"G2 X{fmt(x)} Y0.0000 I{fmt(i)} J0.0000")
    out.append("G0 Z5.0000")
    return out


def polygon(r, n, feed):
    return chord_circle(r, n, 90.0 / n, feed=feed)


def zigzag(w, h, step, feed):
    out = ["G0 Z5.0000", f"G0 X{fmt(-w / 2)} Y{fmt(-h / 2)}", f"G1 Z-0.5000 F{feed}"]
    y, k = -h / 2, 0
    while y <= h / 2 + 1e-9:
        x = w / 2 if k % 2 == 0 else -w / 2
        out.append(f"G1 X{fmt(x)}")
        if y + step <= h / 2 + 1e-9:
            out.append(f"G1 Y{fmt(y + step)}")
        y += step
        k += 1
    out.append("G0 Z5.0000")
    return out


def programs(feed):
    return {
        "chords12_d36": ("circle D36 as 12 chords", chord_circle(18.0, 12, 7.0, feed=feed), False),
        "chords17_d24": ("circle D24 as 17 chords", chord_circle(12.0, 17, 33.0, feed=feed), False),
        "chords25_d44": ("circle D44 as 25 chords", chord_circle(22.0, 25, 0.0, feed=feed), False),
        "g2_d40": ("circle D40 as one G2 from 30 degrees", one_block_circle(20.0, 30.0, True, feed=feed), False),
        "g3_d30_x2": ("circle D30 as one G3 of two turns", one_block_circle(15.0, 0.0, False, 2, feed), False),
        "helix_d24": ("helical bore D24, 4 turns, 8 mm deep", helical_bore(12.0, 8.0, 4, feed), False),
        "planes_inch": ("arcs in G17, G18, G19, inch", arcs_all_planes_inch(feed), True),
        "pocket_arcs": ("pocket 44 x 28 with R6 corners, 3 offsets", pocket_with_arcs(44.0, 28.0, 6.0, 3.0, 3, feed), False),
        "r_arcs_g91": ("R arcs in G91", r_arcs_g91(feed), False),
        "raster": ("raster surface 36 x 24", raster_surface(36.0, 24.0, 3.0, feed), False),
        "spiral_lines": ("spiral D8 to D34 as 48 chords a turn", spiral_lines(4.0, 17.0, 3, 48, feed), False),
        "spiral_arcs": ("spiral of G2 half circles", spiral_arcs(3.0, 2.0, 8, feed), False),
        "hexagon": ("hexagon D30", polygon(15.0, 6, feed), False),
        "zigzag": ("zigzag pocket 30 x 20, 2.5 mm step", zigzag(30.0, 20.0, 2.5, feed), False),
    }


def main(programs_at=programs):
    """Writes the set `programs_at(feed)` (this file's, or another set's)."""
    usage = sys.modules["__main__"].__doc__ or __doc__
    if len(sys.argv) < 2 or sys.argv[1].startswith("-"):
        # `--help` or no argument: print the usage and write nothing (a
        # directory named `--help` was once written and committed).
        asked = len(sys.argv) > 1 and sys.argv[1] in ("-h", "--help")
        print(usage, file=sys.stderr)
        sys.exit(0 if asked else 2)
    out_dir = sys.argv[1]
    feed = float(sys.argv[2]) if len(sys.argv) > 2 else 6000.0
    feed = int(feed) if feed == int(feed) else feed
    os.makedirs(out_dir, exist_ok=True)
    for kind, (title, body, inch) in programs_at(feed).items():
        for tag, mode in MODES.items():
            path = os.path.join(out_dir, f"{kind}.{tag}.ngc")
            lines = ["%"] + header(f"{title}, {mode}", mode, inch) + body + ["M2", "%"]
            with open(path, "w") as f:
                f.write("\n".join(lines) + "\n")
            print(path)


if __name__ == "__main__":
    main()
