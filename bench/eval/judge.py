#!/usr/bin/env python3
"""An independent judge of compensated programs: two dead-band readings.

Written apart from volcomp's own simulator (crates/volcomp-core/src/simulate)
so that an accuracy figure is checked by a second method. It reads the
programs itself (a subset of LinuxCNC G-code: G0 G1 G2 G3, G17 G18 G19,
G20 G21, G90 G91, G90.1 G91.1, I J K R P, comments; one work offset given
on the command line), evaluates an axis-table map (docs/design.md, "The
axis-table map": per axis and direction, linear interpolation, the vector
sum of the three axes' contributions), and runs the compensated program's
commands through one of two readings of the same tables:

  band     a dead band per axis: when an axis' command reverses, the jump of
           the tables that axis' switch makes (its own reversal value and
           what its straightness tables change across) is carried as a lag
           that fades as that axis' command travels across its band (its
           own component shrinks by the travel, the others in proportion);
           it stays while the axis stands still, vanishes at once when the
           axis moves away from it or has no reversal value of its own.
  instant  the tables switch when the command does (design.md's model
           without a dead band): the tool jumps at a reversal.

The actual tool path is sampled every 0.05 mm or closer along every feed
command; each sample's contour error is its distance to the nearest feed
move of the original program (lines and arcs, helices included). Printed
(JSON): RMS over path length, maximum, the maximum within 1 mm of path after
a reversal of the compensated commands (`max_at_reversal_um`) and elsewhere
(`max_away_um`), for the original program (`before`, same reading) and the
compensated one, and the RMS reduction.

Usage: judge.py ORIGINAL COMPENSATED --map MAP.csv --work-offset X,Y,Z
                [--reading band|instant|both]
"""
import argparse
import bisect
import json
import math
import re
import sys

SPACING_MM = 0.05
REVERSAL_ZONE_MM = 1.0
# JUDGE_DEBUG_UM=x prints every sample whose error passes x µm (stderr).
DEBUG_UM = float(__import__("os").environ.get("JUDGE_DEBUG_UM", "0"))


# ---------------------------------------------------------------- the map
class AxisTableMap:
    def __init__(self, path):
        self.tables = {}  # (axis, direction) -> (positions, [ex, ey, ez] lists)
        rows = {}
        header = None
        for raw in open(path):
            line = raw.strip()
            if not line or line.startswith("#"):
                continue
            cells = [c.strip() for c in line.split(",")]
            if header is None:
                header = cells
                continue
            r = dict(zip(header, cells))
            axis = "XYZ".index(r["axis"].upper())
            dirs = {"forward": [0], "reverse": [1], "both": [0, 1]}[r["direction"].lower()]
            for d in dirs:
                rows.setdefault((axis, d), []).append(
                    (float(r["position_mm"]), [float(r["ex_um"]), float(r["ey_um"]), float(r["ez_um"])])
                )
        for key, rs in rows.items():
            rs.sort()
            self.tables[key] = ([p for p, _ in rs], [e for _, e in rs])

    def contribution_um(self, axis, direction, x):
        pos, err = self.tables[(axis, direction)]
        if x <= pos[0]:
            return list(err[0])
        if x >= pos[-1]:
            return list(err[-1])
        i = bisect.bisect_right(pos, x) - 1
        t = (x - pos[i]) / (pos[i + 1] - pos[i])
        return [err[i][k] + t * (err[i + 1][k] - err[i][k]) for k in range(3)]

    def error_mm(self, q, s):
        """e(q, s) in mm; s[a] = 0 forward, 1 reverse."""
        e = [0.0, 0.0, 0.0]
        for a in range(3):
            c = self.contribution_um(a, s[a], q[a])
            for k in range(3):
                e[k] += c[k] * 1e-3
        return e


# ---------------------------------------------------------------- G-code
WORD = re.compile(r"([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")


def strip_comments(line):
    out, depth = [], 0
    for ch in line:
        if ch == "(":
            depth += 1
        elif ch == ")" and depth:
            depth -= 1
        elif ch == ";" and not depth:
            break
        elif not depth:
            out.append(ch)
    return "".join(out).upper()


def read_program(path, offset_mm, work_offsets=None, tools=None):
    """Feed and rapid moves in the axis frame (mm): dicts with kind
    ('rapid', 'line', 'arc'), start, end and for arcs centre (axis frame),
    plane axes (u, v, w) and signed sweep (rad). `offset_mm` is the work
    offset in use at the start (G54); `work_offsets` ({"G55": [x, y, z]}, mm)
    the ones a G55 ... G59 selects, `tools` ({1: length_mm}) the lengths a
    G43 H adds to Z until G49, as LinuxCNC's canon does (docs/gcode.md,
    "Frames")."""
    offset_mm = list(offset_mm)
    frames = {"G54": list(offset_mm)}
    frames.update(work_offsets or {})
    tool_mm = 0.0
    pos = None  # program coordinates, program units
    absolute, arc_abs, mm_per_unit, plane = True, False, 1.0, (0, 1, 2)
    motion = None
    feed = 0.0
    moves = []
    for n, raw in enumerate(open(path), 1):
        text = strip_comments(raw).strip()
        if not text or text == "%":
            continue
        words = [(l, float(v)) for l, v in WORD.findall(text)]
        g = [v for l, v in words if l == "G"]
        val = {l: v for l, v in words if l != "G"}
        for code in g:
            if code == 20:
                mm_per_unit = 25.4
            elif code == 21:
                mm_per_unit = 1.0
            elif code == 90:
                absolute = True
            elif code == 91:
                absolute = False
            elif abs(code - 90.1) < 1e-9:
                arc_abs = True
            elif abs(code - 91.1) < 1e-9:
                arc_abs = False
            elif code == 17:
                plane = (0, 1, 2)
            elif code == 18:
                plane = (2, 0, 1)
            elif code == 19:
                plane = (1, 2, 0)
            elif code in (0, 1, 2, 3):
                motion = int(code)
            elif code in (54, 55, 56, 57, 58, 59):
                name = f"G{int(code)}"
                if name not in frames:
                    raise ValueError(f"{path}:{n}: {name} without its offset")
                shift = [frames[name][a] - offset_mm[a] for a in range(3)]
                offset_mm = list(frames[name])
                if pos is not None:  # the position stays; its program coordinates change
                    pos = [pos[a] - shift[a] / mm_per_unit for a in range(3)]
            elif code == 43:
                new_tool = (tools or {})[int(val["H"])]
                if pos is not None:
                    pos[2] -= (new_tool - tool_mm) / mm_per_unit
                tool_mm = new_tool
            elif code == 49:
                if pos is not None:
                    pos[2] += tool_mm / mm_per_unit
                tool_mm = 0.0
        if "F" in val:
            feed = val["F"] * mm_per_unit
        axes = [k for k in "XYZ" if k in val]
        if not axes or motion is None:
            continue
        start = list(pos) if pos is not None else [0.0, 0.0, 0.0]
        end = list(start)
        for k in axes:
            a = "XYZ".index(k)
            end[a] = val[k] if absolute else start[a] + val[k]
        pos = end
        to_axis = lambda p: [p[a] * mm_per_unit + offset_mm[a] + (tool_mm if a == 2 else 0.0) for a in range(3)]
        s_ax, e_ax = to_axis(start), to_axis(end)
        if motion in (0, 1):
            moves.append({"kind": "rapid" if motion == 0 else "line", "start": s_ax, "end": e_ax, "line": n,
                          "feed": feed})
            continue
        u, v, w = plane
        cw = motion == 2
        if "R" in val:
            r = val["R"] * mm_per_unit
            du, dv = e_ax[u] - s_ax[u], e_ax[v] - s_ax[v]
            d = math.hypot(du, dv)
            h = math.sqrt(max(r * r - d * d / 4.0, 0.0))
            # LinuxCNC (arc_data_r): the centre left of the chord for a
            # counter-clockwise arc with R > 0.
            sign = (1.0 if not cw else -1.0) * (1.0 if r > 0 else -1.0)
            cu = s_ax[u] + du / 2 - sign * h * dv / d
            cv = s_ax[v] + dv / 2 + sign * h * du / d
        else:
            ij = {0: "I", 1: "J", 2: "K"}
            off_u = val.get(ij[u], 0.0) * mm_per_unit
            off_v = val.get(ij[v], 0.0) * mm_per_unit
            if arc_abs:
                cu = off_u + offset_mm[u]
                cv = off_v + offset_mm[v]
            else:
                cu, cv = s_ax[u] + off_u, s_ax[v] + off_v
        a0 = math.atan2(s_ax[v] - cv, s_ax[u] - cu)
        a1 = math.atan2(e_ax[v] - cv, e_ax[u] - cu)
        turns = int(val.get("P", 1))
        if cw:
            sweep = a1 - a0
            while sweep >= -1e-12:
                sweep -= 2 * math.pi
            sweep -= 2 * math.pi * (turns - 1)
        else:
            sweep = a1 - a0
            while sweep <= 1e-12:
                sweep += 2 * math.pi
            sweep += 2 * math.pi * (turns - 1)
        centre = list(s_ax)
        centre[u], centre[v] = cu, cv
        moves.append({"kind": "arc", "start": s_ax, "end": e_ax, "centre": centre,
                      "plane": plane, "sweep": sweep, "line": n, "feed": feed})
    return moves


def arc_point(m, t):
    u, v, w = m["plane"]
    c, s, e = m["centre"], m["start"], m["end"]
    r0 = math.hypot(s[u] - c[u], s[v] - c[v])
    r1 = math.hypot(e[u] - c[u], e[v] - c[v])
    a0 = math.atan2(s[v] - c[v], s[u] - c[u])
    a = a0 + m["sweep"] * t
    r = r0 + (r1 - r0) * t
    p = [0.0, 0.0, 0.0]
    p[u] = c[u] + r * math.cos(a)
    p[v] = c[v] + r * math.sin(a)
    p[w] = s[w] + (e[w] - s[w]) * t
    return p


def arc_length(m):
    u, v, w = m["plane"]
    c, s, e = m["centre"], m["start"], m["end"]
    r = 0.5 * (math.hypot(s[u] - c[u], s[v] - c[v]) + math.hypot(e[u] - c[u], e[v] - c[v]))
    return math.hypot(r * m["sweep"], e[w] - s[w])


def pieces(m, chord_mm=1e-5):
    """The points a move is run through: its end for a line, chord ends
    within `chord_mm` for an arc (as a controller interpolates it)."""
    if m["kind"] != "arc":
        return [m["end"]]
    u, v, w = m["plane"]
    c, s = m["centre"], m["start"]
    r = max(math.hypot(s[u] - c[u], s[v] - c[v]), 1e-9)
    step = 2 * math.acos(max(-1.0, 1 - chord_mm / r)) if r > chord_mm else math.pi
    n = max(1, int(math.ceil(abs(m["sweep"]) / max(step, 1e-9))))
    return [arc_point(m, k / n) for k in range(1, n + 1)]


# ---------------------------------------------------------------- distance
def sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def norm(a):
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


def dist_line(p, a, b):
    ab = sub(b, a)
    l2 = ab[0] ** 2 + ab[1] ** 2 + ab[2] ** 2
    t = 0.0 if l2 == 0 else max(0.0, min(1.0, sum((p[k] - a[k]) * ab[k] for k in range(3)) / l2))
    return norm(sub(p, [a[k] + t * ab[k] for k in range(3)]))


def dist_arc(p, m):
    u, v, w = m["plane"]
    c, s = m["centre"], m["start"]
    a0 = math.atan2(s[v] - c[v], s[u] - c[u])
    ap = math.atan2(p[v] - c[v], p[u] - c[u])
    sw = m["sweep"]
    # Parameter of the point's angle, every turn that lies in the sweep.
    cands = [0.0, 1.0]
    base = (ap - a0) / sw
    period = 2 * math.pi / abs(sw)
    k0 = math.floor(-base / period) - 1
    for k in range(int(k0), int(k0) + int(abs(sw) / (2 * math.pi)) + 4):
        t = base + k * period
        if 0.0 <= t <= 1.0:
            cands.append(t)
    best = min(cands, key=lambda t: norm(sub(p, arc_point(m, t))))
    # Refine (helix: the closest point lies slightly off the angle).
    h = 1e-3 / max(arc_length(m), 1e-9)
    for _ in range(30):
        f0 = norm(sub(p, arc_point(m, best)))
        lo, hi = max(0.0, best - h), min(1.0, best + h)
        fl, fh = norm(sub(p, arc_point(m, lo))), norm(sub(p, arc_point(m, hi)))
        if fl < f0 and fl <= fh:
            best = lo
        elif fh < f0:
            best = hi
        else:
            h *= 0.5
    return norm(sub(p, arc_point(m, best)))


def distance(p, m):
    return dist_arc(p, m) if m["kind"] == "arc" else dist_line(p, m["start"], m["end"])


class Nominal:
    """The original program's feed moves; the distance to the nearest one,
    found through a grid of cells (each move listed in every cell its
    bounding box, grown by 0.2 mm, touches)."""

    CELL_MM = 2.0

    def __init__(self, moves):
        self.moves = [m for m in moves if m["kind"] != "rapid"]
        self.grid = {}
        for i, m in enumerate(self.moves):
            pts = [m["start"], m["end"]]
            if m["kind"] == "arc":
                pts += [arc_point(m, k / 64) for k in range(65)]
            lo = [min(p[k] for p in pts) - 0.2 for k in range(3)]
            hi = [max(p[k] for p in pts) + 0.2 for k in range(3)]
            c0 = [int(math.floor(lo[k] / self.CELL_MM)) for k in range(3)]
            c1 = [int(math.floor(hi[k] / self.CELL_MM)) for k in range(3)]
            for x in range(c0[0], c1[0] + 1):
                for y in range(c0[1], c1[1] + 1):
                    for z in range(c0[2], c1[2] + 1):
                        self.grid.setdefault((x, y, z), []).append(i)

    def distance_mm(self, p):
        cell = tuple(int(math.floor(p[k] / self.CELL_MM)) for k in range(3))
        near = self.grid.get(cell) or range(len(self.moves))
        return min(distance(p, self.moves[i]) for i in near)


# ---------------------------------------------------------------- readings
def simulate(moves, emap, nominal, reading, debug=False):
    s = [0, 0, 0]
    q = None
    lags = [[0.0, 0.0, 0.0] for _ in range(3)]
    last_sign = [0, 0, 0]
    sum_sq = weight = 0.0
    mx = mx_rev = mx_away = 0.0
    since_rev = float("inf")
    for m in moves:
        if q is None:
            q = list(m["start"])
        feed = m["kind"] != "rapid"
        for b in pieces(m):
            dq = sub(b, q)
            length = norm(dq)
            if length == 0.0:
                continue
            s_new = list(s)
            reversed_any = False
            for a in range(3):
                if dq[a] > 0:
                    s_new[a] = 0
                elif dq[a] < 0:
                    s_new[a] = 1
                sign = (dq[a] > 0) - (dq[a] < 0)
                if sign and last_sign[a] and sign != last_sign[a]:
                    reversed_any = True
                if sign:
                    last_sign[a] = sign
            if reversed_any:
                since_rev = 0.0
            if reading == "band":
                cur = list(s)
                for a in range(3):
                    if s_new[a] != cur[a]:
                        before = emap.error_mm(q, cur)
                        cur[a] = s_new[a]
                        after = emap.error_mm(q, cur)
                        for k in range(3):
                            lags[a][k] += before[k] - after[k]
            bands = []
            for a in range(3):
                own = lags[a][a]
                if own == 0.0 or own * dq[a] < 0:
                    bands.append(None)
                else:
                    bands.append((abs(own), abs(dq[a])))

            def left(a, lam):
                if bands[a] is None:
                    return 0.0
                own, travel = bands[a]
                return max(0.0, (own - travel * lam) / own)

            n = max(1, int(math.ceil(length / SPACING_MM)))
            for i in range(1, n + 1):
                lam = i / n
                qq = [q[k] + dq[k] * lam for k in range(3)]
                e = emap.error_mm(qq, s_new)
                actual = [qq[k] + e[k] for k in range(3)]
                if reading == "band":
                    for a in range(3):
                        f = left(a, lam)
                        if f:
                            for k in range(3):
                                actual[k] += lags[a][k] * f
                if feed:
                    d_um = nominal.distance_mm(actual) * 1e3
                    if debug and DEBUG_UM and d_um > DEBUG_UM:
                        print(f"line {m['line']} {reading}: {d_um:.3f} um at {[round(x, 5) for x in actual]}", file=sys.stderr)
                    wgt = length / n
                    sum_sq += d_um * d_um * wgt
                    weight += wgt
                    mx = max(mx, d_um)
                    at_rev = since_rev + length * lam <= REVERSAL_ZONE_MM
                    if at_rev:
                        mx_rev = max(mx_rev, d_um)
                    else:
                        mx_away = max(mx_away, d_um)
            if reading == "band":
                for a in range(3):
                    f = left(a, 1.0)
                    lags[a] = [x * f for x in lags[a]]
            since_rev += length
            s = s_new
            q = b
    rms = math.sqrt(sum_sq / weight) if weight else 0.0
    return {"rms_um": rms, "max_um": mx, "max_at_reversal_um": mx_rev, "max_away_um": mx_away,
            "length_mm": weight}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("original")
    ap.add_argument("compensated")
    ap.add_argument("--map", required=True)
    ap.add_argument("--work-offset", default="0,0,0")
    ap.add_argument("--reading", default="both", choices=["band", "instant", "both"])
    args = ap.parse_args()
    offset = [float(x) for x in args.work_offset.split(",")]
    emap = AxisTableMap(args.map)
    orig = read_program(args.original, offset)
    comp = read_program(args.compensated, offset)
    out = {}
    for reading in (["band", "instant"] if args.reading == "both" else [args.reading]):
        before = simulate(orig, emap, Nominal(orig), reading)
        after = simulate(comp, emap, Nominal(orig), reading, debug=True)
        out[reading] = {
            "before": before,
            "after": after,
            "reduction_pct": 100.0 * (1 - after["rms_um"] / before["rms_um"]) if before["rms_um"] else 0.0,
        }
    json.dump(out, sys.stdout, indent=1)
    print()


if __name__ == "__main__":
    main()
