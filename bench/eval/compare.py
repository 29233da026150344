#!/usr/bin/env python3
"""Compare bench/eval/run.py tables: what changed, what breaks the merge
rules, and where the issue's targets are missed.

  compare.py BASE.md NEW.md            rows that differ (base -> new)
  compare.py --rules BASE.md NEW.md    rows that break a merge rule, and a
                                       count of better / worse rows
  compare.py --misses TABLE.md...      per mode and map: rows that miss the
                                       targets below

A row is keyed by (program, mode, map). The columns read are the ones
run.py prints: blocks in -> out, stops/blends added, the cutting-time
change Δ, and the band reading's RMS reduction, maximum and maximum away
from reversals.

Merge rules (what a change may not do; `--rules`):
  g61   a maximum that rises past 0.5 um, an RMS reduction that falls under
        99 % where it was above;
  g64p  a maximum past 5 um, a time change past +3 %;
  g64   a time change past +3 % where the base was within;
  any   a time change worse by more than one point.
Targets (`--misses`): the goals each path mode is evaluated against
(docs/compensation.md, "Reversals by path-control mode", says what each
mode promises; BENCHMARKS.md holds the figures):
  g61   time <= +5 % (one-block circles; +1 % elsewhere is stricter and not
        told apart here), RMS reduction >= 99 %, maximum <= 0.5 um;
  g64p  time <= +3 %, maximum <= 5 um;
  g64   time <= +3 %, RMS reduction >= 97 %, <= 0.5 um away from reversals.
"""
import argparse
import collections
import sys

MODES = ("g61", "g64p", "g64")


def load(path):
    """Rows of one table: {(program, mode, map): {column: value}}."""
    rows = {}
    with open(path, encoding="utf-8") as f:
        for line in f:
            if not line.startswith("| ") or line.startswith("| program"):
                continue
            c = [x.strip() for x in line.strip().strip("|").split("|")]
            if len(c) < 12 or c[1] not in MODES:
                continue
            try:
                rows[(c[0], c[1], c[2])] = {
                    "blocks": c[3],
                    "added": c[4],
                    "d": float(c[7].split()[0]),
                    "rms": float(c[8]),
                    "max": float(c[9]),
                    "away": float(c[11]),
                }
            except ValueError:
                print(f"{path}: row {c[:3]} not read (a column is not a number)", file=sys.stderr)
    return rows


def differences(base, new):
    shown = ("d", "rms", "max", "away", "blocks", "added")
    same = 0
    for key, old in base.items():
        row = new.get(key)
        if row is None:
            print("missing in new:", " | ".join(key))
            continue
        if all(old[x] == row[x] for x in shown):
            same += 1
            continue
        changes = "; ".join(f"{x}: {old[x]} -> {row[x]}" for x in shown if old[x] != row[x])
        print(" | ".join(key), " || ", changes)
    for key in new:
        if key not in base:
            print("new only:", " | ".join(key))
    print(f"{same} of {len(base)} rows identical")


def rule_breaks(old, row, mode):
    msg = []
    if mode == "g61":
        if row["max"] > 0.5 and row["max"] > old["max"]:
            msg.append(f"max {old['max']} -> {row['max']} um")
        if row["rms"] < 99 and row["rms"] < old["rms"]:
            msg.append(f"RMS {old['rms']} -> {row['rms']} %")
    elif mode == "g64p":
        if row["max"] > 5:
            msg.append(f"max {row['max']} um")
        if row["d"] > 3:
            msg.append(f"time {row['d']:+} %")
    elif row["d"] > 3 and old["d"] <= 3:
        msg.append(f"time {old['d']:+} -> {row['d']:+} %")
    if row["d"] > old["d"] + 1.0:
        msg.append(f"time worse {old['d']:+} -> {row['d']:+} %")
    return msg


def rules(base, new):
    better = worse = broken = same = 0
    for key, row in new.items():
        old = base.get(key)
        if old is None:
            print("new only:", " | ".join(key))
            continue
        if old == row:
            same += 1
            continue
        msg = rule_breaks(old, row, key[1])
        better += row["d"] < old["d"] - 0.05 or row["rms"] > old["rms"] + 0.05
        worse += row["d"] > old["d"] + 0.05 or row["rms"] < old["rms"] - 0.05
        if msg:
            broken += 1
            print("RULE", " | ".join(key), ": " + "; ".join(msg))
    print(f"rows {len(new)}: identical {same}, some better {better}, some worse {worse}, rule breaks {broken}")


def misses(tables):
    total = collections.Counter()
    missed = collections.Counter()
    for path in tables:
        for (_, mode, map_name), r in load(path).items():
            total[(mode, map_name)] += 1
            checks = {
                "g61": [("time", r["d"] > 5), ("rms", r["rms"] < 99), ("max", r["max"] > 0.5)],
                "g64p": [("time", r["d"] > 3), ("max", r["max"] > 5)],
                "g64": [("time", r["d"] > 3), ("rms", r["rms"] < 97), ("away", r["away"] > 0.5)],
            }[mode]
            for name, miss in checks:
                missed[(mode, map_name, name)] += miss
    print("| mode | map | rows | time | rms | max | away |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for mode, map_name in sorted(total):
        cells = [str(missed[(mode, map_name, n)]) if (mode, map_name, n) in missed else "–"
                 for n in ("time", "rms", "max", "away")]
        print(f"| {mode} | {map_name} | {total[(mode, map_name)]} | " + " | ".join(cells) + " |")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--rules", action="store_true", help="merge-rule breaks of NEW against BASE")
    p.add_argument("--misses", action="store_true", help="target misses per mode and map of every TABLE")
    p.add_argument("tables", nargs="+")
    a = p.parse_args()
    if a.misses:
        misses(a.tables)
        return 0
    if len(a.tables) != 2:
        p.error("BASE.md NEW.md expected")
    base, new = load(a.tables[0]), load(a.tables[1])
    if a.rules:
        rules(base, new)
    else:
        differences(base, new)
    return 0


if __name__ == "__main__":
    sys.exit(main())
