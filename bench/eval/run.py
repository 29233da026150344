#!/usr/bin/env python3
"""The evaluation set, compensated and judged: per program (make_set.py's
kinds, or with --set b make_set_b.py's other sizes and shapes, or with
--set c make_set_c.py's held-out kinds: G18/G19 circles, P turns, small
circles, a 60-gon, a 0.2 mm zigzag, helices in G90 and G91, a pocket in G91,
inch arcs, G55 with G43 H1, feed changes; each in G61, G64 P0.005 and G64)
and map (the example map of `volcomp demo`, the ripple map of
bench/ripple_map.py, the shop map of bench/shop_map.py: bands of 2.5-7 um
and straightness that jumps at reversals; the held-out maps fine
(bench/fine_map.py: reversals of 1-2 um, a table every 5 mm) and coarse
(bench/coarse_map.py: reversals of 10-15 um, a table every 25 mm,
squareness, straightness that switches with the direction on every axis),
chosen with --maps), the compensated
program's size, how LinuxCNC's planner will join its moves (joins.py: the
joins it stops at or blends that were tangent in the original, the segments
below their feed), and its accuracy under both dead-band readings
(judge.py: RMS reduction, maximum, maximum at reversals and elsewhere).
Under G61, the least time the dead band costs the original at the 0.5 µm
goal (least.py: smooth reversals, and corners whose reversing axis moved
into them, the take-up at the stop; a corner after a move in which the axis
stood still is free), as a share of its cutting time: how close the compensated program comes to the physics.

With --planner VOLCOMP_WITH_TIME (a volcomp that has `volcomp time`, the
machining-time estimate on a model of LinuxCNC 2.9's planner), the cutting
time of the original and the compensated program, on the cycle-time
benchmark's machine (bench/cycle_time/setup.toml: 1,000 mm/s², 1 ms).

Set c runs with the set-up bench/eval/setup_c.toml (G54 as --work-offset,
G55 and tool 1 for its g55_tool program) for compensate and time, and the
judge reads the same offsets.

Usage: run.py VOLCOMP [--work DIR] [--feed 6000] [--set a|b|c]
              [--maps example,ripple,shop,fine,coarse]
              [--only SUBSTRING[,SUBSTRING...]] [--planner BIN] [-- EXTRA COMPENSATE ARGS]
Prints a markdown table and writes DIR/results.json.
"""
import argparse
import json
import tomllib
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import joins  # noqa: E402
import least  # noqa: E402
import judge  # noqa: E402

OFFSET = [250.0, 200.0, 150.0]


def blocks(path):
    n = 0
    for line in open(path):
        text = judge.strip_comments(line).strip()
        if text and text != "%":
            n += 1
    return n


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("volcomp")
    ap.add_argument("--work", default="/tmp/volcomp-eval")
    ap.add_argument("--feed", default="6000")
    ap.add_argument("--only", default="")
    ap.add_argument("--maps", default="example,ripple")
    ap.add_argument("--planner", default="")
    ap.add_argument("--set", default="a", choices=["a", "b", "c"],
                    help="a: make_set.py; b: make_set_b.py (other sizes and shapes); "
                         "c: make_set_c.py (held-out kinds, with setup_c.toml)")
    ap.add_argument("extra", nargs="*")
    args = ap.parse_args()
    work = args.work
    os.makedirs(work, exist_ok=True)
    maker = {"a": "make_set.py", "b": "make_set_b.py", "c": "make_set_c.py"}[args.set]
    setup = os.path.join(HERE, "..", "cycle_time", "setup.toml")
    setup_args, work_offsets, tools = [], None, None
    if args.set == "c":
        setup = os.path.join(HERE, "setup_c.toml")
        setup_args = ["--setup", setup]
        with open(setup, "rb") as f:
            s = tomllib.load(f)
        work_offsets = {k: [float(v) for v in vs] for k, vs in s["work_offsets"].items()}
        tools = {int(k): float(v) for k, v in s["tools"].items()}
    progs = subprocess.run([sys.executable, os.path.join(HERE, maker), os.path.join(work, "programs"), args.feed],
                           check=True, capture_output=True, text=True).stdout.split()
    maps = {}
    if "example" in args.maps:
        subprocess.run([args.volcomp, "demo", "--out-dir", os.path.join(work, "demo"), "--quiet"], check=True,
                       capture_output=True)
        maps["example"] = os.path.join(work, "demo", "example_map.csv")
    if "ripple" in args.maps:
        ripple = os.path.join(work, "ripple.csv")
        with open(ripple, "w") as f:
            subprocess.run([sys.executable, os.path.join(HERE, "..", "ripple_map.py")], check=True, stdout=f)
        maps["ripple"] = ripple
    if "shop" in args.maps:
        shop = os.path.join(work, "shop.csv")
        with open(shop, "w") as f:
            subprocess.run([sys.executable, os.path.join(HERE, "..", "shop_map.py")], check=True, stdout=f)
        maps["shop"] = shop
    for name in ("fine", "coarse"):
        if name in args.maps.split(","):
            path = os.path.join(work, f"{name}.csv")
            with open(path, "w") as f:
                subprocess.run([sys.executable, os.path.join(HERE, "..", f"{name}_map.py")], check=True, stdout=f)
            maps[name] = path
    env = dict(os.environ, SOURCE_DATE_EPOCH="0")
    rows = []
    print("| program | mode | map | blocks in → out | stops/blends added | short | cutting s | Δ | band: RMS red. % | max µm | max at rev. | max away | instant: RMS red. % | max µm | max away | least Δ |")
    print("|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for prog in progs:
        if args.only and not any(o in prog for o in args.only.split(",")):
            continue
        kind, mode = os.path.basename(prog).split(".")[:2]
        orig_moves = judge.read_program(prog, OFFSET, work_offsets, tools)
        j0 = joins.analyse(orig_moves, 1000.0, 166.7, 0.001)
        for map_name, map_path in maps.items():
            out = os.path.join(work, f"{kind}.{mode}.{map_name}.ngc")
            r = subprocess.run([args.volcomp, "compensate", prog, "--map", map_path, "--work-offset",
                                ",".join(str(x) for x in OFFSET), "-o", out, "--quiet"] + setup_args + args.extra,
                               capture_output=True, text=True, env=env)
            if r.returncode != 0:
                print(f"| {kind} | {mode} | {map_name} | refused: {r.stderr.strip()[:80]} |")
                continue
            comp_moves = judge.read_program(out, OFFSET, work_offsets, tools)
            j1 = joins.analyse(comp_moves, 1000.0, 166.7, 0.001)
            emap = judge.AxisTableMap(map_path)
            res = {"program": kind, "mode": mode, "map": map_name, "blocks_in": blocks(prog),
                   "blocks_out": blocks(out), "corners_added": j1["corners"] - j0["corners"],
                   "short": j1["short"]}
            for reading in ("band", "instant"):
                before = judge.simulate(orig_moves, emap, judge.Nominal(orig_moves), reading)
                after = judge.simulate(comp_moves, emap, judge.Nominal(orig_moves), reading)
                res[reading] = {"before": before, "after": after,
                                "reduction_pct": 100.0 * (1 - after["rms_um"] / before["rms_um"])}
            time_text = " | "
            if args.planner:
                t = subprocess.run([args.planner, "time", out, "--reference", prog, "--setup", setup, "--json",
                                    "--quiet"], capture_output=True, text=True)
                if t.returncode == 0:
                    d = json.loads(t.stdout)
                    c0 = d["original"]["motion"]["cutting_s"]
                    c1 = d["program"]["motion"]["cutting_s"]
                    res["cutting_s"] = [c0, c1]
                    time_text = f"{c0:.3f} → {c1:.3f} | {100 * (c1 / c0 - 1):+.1f} %"
            least_text = ""
            if mode == "g61" and "cutting_s" in res:
                least_s, found = least.least_time(orig_moves, emap, least.GOAL_TOL_MM, 1000.0)
                res["least_s"] = least_s
                least_text = f"{100 * least_s / res['cutting_s'][0]:+.1f} % ({len(found)})"
            rows.append(res)
            b, i = res["band"], res["instant"]
            print(f"| {kind} | {mode} | {map_name} | {res['blocks_in']} → {res['blocks_out']} | "
                  f"{res['corners_added']} | {res['short']} | {time_text} | {b['reduction_pct']:.2f} | {b['after']['max_um']:.3f} | "
                  f"{b['after']['max_at_reversal_um']:.3f} | {b['after']['max_away_um']:.3f} | "
                  f"{i['reduction_pct']:.2f} | {i['after']['max_um']:.3f} | {i['after']['max_away_um']:.3f} | {least_text} |",
                  flush=True)
    with open(os.path.join(work, "results.json"), "w") as f:
        json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
