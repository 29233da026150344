#!/usr/bin/env python3
"""A random program of G-code moves for comparing machining-time estimates
(bench/same_estimates.sh): lines from 1 um to 100 mm, arcs of chords up
to 20 mm (R and IJ, in the three planes), rapids, every path-control mode
(G61, G61.1, G64, G64 P, G64 P Q), feeds per minute (with --per-rev also
per revolution, G95 with an S word; not inverse time, G93, whose moves
the compensation does not split), dwells, spindle and coolant words, inch
and mm. With --expressions some coordinates and feeds are computed from
parameters (`X[#1+0.25]`, `F[#2/3]`), as CAM post-processors and hand-
written programs do.

Inside X, Y in [-80, 80] mm and Z in [-40, 40] mm of the work offset.

usage: gen_random_moves.py SEED [MOVES] [--expressions] [--per-rev]
"""
import math
import random
import sys


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    expressions = "--expressions" in sys.argv
    per_rev = "--per-rev" in sys.argv
    seed = int(args[0])
    moves = int(args[1]) if len(args) > 1 else 400
    r = random.Random(seed)
    inch = r.random() < 0.15
    unit = 25.4 if inch else 1.0
    out = [f"(random moves, seed {seed})", "G20" if inch else "G21", "G17 G90 G94 G40 G49 G54"]
    x, y, z = 0.0, 0.0, 0.0
    out.append("G0 X0 Y0 Z0")
    if expressions:
        out.append(f"#1 = {r.uniform(-1, 1):.4f}")
        out.append(f"#2 = {r.randint(900, 6000)}")
    feed_mode = "G94"
    for _ in range(moves):
        k = r.random()
        words = []
        if r.random() < 0.06:
            # On a line of its own: a P word on an arc's line is its turns.
            out.append(r.choice(["G61", "G61.1", "G64", f"G64 P{r.choice([0.001, 0.01, 0.05, 0.2]) / unit:.5f}",
                                 f"G64 P{r.choice([0.01, 0.05]) / unit:.5f} Q{r.choice([0.001, 0.01]) / unit:.5f}"]))
        if r.random() < 0.02:
            out.append(r.choice(["M3 S%d" % r.randint(500, 12000), "M8", "M9", "G4 P%.2f" % r.uniform(0, 0.5)]))
        if r.random() < 0.03:
            # Not G93: the compensation refuses to split a G93 move.
            new = r.choice(["G94", "G95"]) if per_rev else "G94"
            if new == "G95":
                out.append("S%d M3" % r.randint(1000, 10000))
            if new != feed_mode:
                words.append(new)
                feed_mode = new
        step = r.choice([0.001, 0.01, 0.1, 0.5, 2, 10, 100]) * r.uniform(0.5, 1)
        dx, dy, dz = (r.uniform(-1, 1) * step for _ in range(3))
        if r.random() < 0.7:
            dz *= 0.05
        nx = min(max(x + dx, -80), 80)
        ny = min(max(y + dy, -80), 80)
        nz = min(max(z + dz, -40), 40)

        def feed():
            if feed_mode == "G93":
                return f"F{r.uniform(5, 500):.2f}"
            if feed_mode == "G95":
                return f"F{r.uniform(0.01, 0.5) / unit:.4f}"
            if expressions and r.random() < 0.2:
                return "F[#2/3]"
            return f"F{r.randint(100, 8000) / unit:.1f}"

        def coord(letter, v):
            if expressions and r.random() < 0.1:
                return f"{letter}[{v / unit - 0.0:.4f}+#1-#1]"
            return f"{letter}{v / unit:.4f}"

        if k < 0.1:
            words += ["G0", coord("X", nx), coord("Y", ny), coord("Z", nz)]
        elif k < 0.75 or step < 0.01 or step > 20:
            # Arcs of chords up to 20 mm: a long way round stays in the map.
            words += ["G1", coord("X", nx), coord("Y", ny), coord("Z", nz), feed()]
        else:
            # An arc in one of the planes, to a point near the chord's end.
            plane = r.choice(["G17", "G17", "G18", "G19"])
            cw = r.choice(["G2", "G3"])
            if plane == "G17":
                u0, v0, u1, v1, lu, lv = x, y, nx, ny, "X", "Y"
                nz = z
            elif plane == "G18":
                u0, v0, u1, v1, lu, lv = z, x, nz, nx, "Z", "X"
                ny = y
            else:
                u0, v0, u1, v1, lu, lv = y, z, ny, nz, "Y", "Z"
                nx = x
            chord = ((u1 - u0) ** 2 + (v1 - v0) ** 2) ** 0.5
            if chord < 1e-3:
                continue
            if r.random() < 0.5:
                radius = chord / 2 * r.uniform(1.01, 3)
                arc = [f"R{radius / unit:.4f}"]
                end = [coord(lu, u1), coord(lv, v1)]
            else:
                # Centre on the chord's bisector; the end on the circle.
                mu, mv = (u0 + u1) / 2, (v0 + v1) / 2
                t = r.uniform(-1, 1)
                cu, cv = mu - (v1 - v0) * t, mv + (u1 - u0) * t
                rad = ((u0 - cu) ** 2 + (v0 - cv) ** 2) ** 0.5
                off = {"G17": ("I", "J"), "G18": ("K", "I"), "G19": ("J", "K")}[plane]
                arc = [f"{off[0]}{(cu - u0) / unit:.4f}", f"{off[1]}{(cv - v0) / unit:.4f}"]
                a1 = math.atan2(v1 - cv, u1 - cu)
                u1, v1 = cu + rad * math.cos(a1), cv + rad * math.sin(a1)
                end = [coord(lu, u1), coord(lv, v1)]
                if plane == "G17":
                    nx, ny = u1, v1
                elif plane == "G18":
                    nz, nx = u1, v1
                else:
                    ny, nz = u1, v1
            words += [plane, cw] + end + arc + [feed()]
            out.append(" ".join(words))
            out.append("G17")
            x, y, z = nx, ny, nz
            continue
        out.append(" ".join(words))
        x, y, z = nx, ny, nz
    out += ["G94 G0 Z50" if not inch else "G94 G0 Z2", "M5 M9", "M2"]
    print("\n".join(out))


if __name__ == "__main__":
    main()
