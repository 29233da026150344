#!/usr/bin/env python3
"""Times measured on LinuxCNC 2.9's trajectory planner for the planner
model's test (crates/volcomp-core/tests/planner_linuxcnc.rs): the programs
and their simulated times, written as fixtures.

    planner_fixtures.py VOLCOMP FIXTURE_DIR [NAME_FILTER]

1. The programs of the cycle-time benchmark (run.py: the demo's originals,
   programs/*.ngc, examples/data/part.ngc), each at F3000 and F6000 (every
   F word rewritten), in three path modes: as written (LinuxCNC's default
   G64), with `G61` and with `G64 P0.005` added after the program's first
   block; each compensated with `VOLCOMP compensate` (the demo's map,
   setup.toml, default options) in the default mode and under G61.
2. planner_programs/*.ngc as written (corners, arcs in every plane, short
   pieces, a 628-chord circle, inverse time).
3. Every program runs once on the benchmark machine (config/, lcnc.py);
   FIXTURE_DIR/programs/NAME.ngc gets the program, FIXTURE_DIR/times.csv
   its times: `moving_s` (first motion to the end of the last) and
   `cutting_s` (a G1/G2/G3 active), simulated servo-thread time, exact to
   the servo period (1 ms).

NAME_FILTER (a substring) measures only the programs whose name has it,
and adds them to an existing times.csv. The script holds an exclusive lock
on /tmp/volcomp-linuxcnc.lock for its whole run (one LinuxCNC at a time).
"""

import csv
import fcntl
import glob
import os
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
import lcnc  # noqa: E402
from run import BenchError, run, set_feed  # noqa: E402

LOCK = "/tmp/volcomp-linuxcnc.lock"
FEEDS_MM_MIN = (3000, 6000)
MODES = [("g64", None), ("g61", "G61"), ("g64p0.005", "G64 P0.005")]
COMPENSATED_MODES = ("g64", "g61")


def with_mode(text, word):
    """`text` with a line `word` after its first block (a line with a G
    or M word that is not a comment)."""
    if word is None:
        return text
    lines = text.splitlines(keepends=True)
    for i, line in enumerate(lines):
        code = line.split("(")[0].split(";")[0].strip()
        if code and code != "%":
            lines.insert(i + 1, f"{word}\n")
            return "".join(lines)
    raise BenchError("no block to put the path mode after")


def originals(volcomp, work):
    demo = os.path.join(work, "demo")
    run([volcomp, "demo", "--out-dir", demo, "--quiet"], "volcomp demo")
    progs = sorted(
        p for p in glob.glob(os.path.join(demo, "*.ngc"))
        if "." not in os.path.basename(p)[: -len(".ngc")]
    )
    progs += sorted(glob.glob(os.path.join(HERE, "programs", "*.ngc")))
    progs.append(os.path.join(REPO, "examples", "data", "part.ngc"))
    return progs, os.path.join(demo, "example_map.csv")


def main():
    if len(sys.argv) not in (3, 4):
        print(__doc__, file=sys.stderr)
        return 2
    volcomp, out = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    only = sys.argv[3] if len(sys.argv) == 4 else None
    lcnc.check_installed()
    work = os.path.join(out, "work")
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    prog_dir = os.path.join(out, "programs")
    os.makedirs(prog_dir, exist_ok=True)
    setup = os.path.join(HERE, "setup.toml")
    sources, map_csv = originals(volcomp, work)
    # (name, text) of every program to measure.
    todo = []
    for src in sources:
        stem = os.path.basename(src)[: -len(".ngc")]
        with open(src) as f:
            text = f.read()
        for feed in FEEDS_MM_MIN:
            fed = set_feed(text, feed, src)
            for tag, word in MODES:
                name = f"{stem}.F{feed}.{tag}"
                todo.append((name, with_mode(fed, word)))
                if tag not in COMPENSATED_MODES:
                    continue
                plain = os.path.join(work, name + ".ngc")
                comp = os.path.join(work, name + ".comp.ngc")
                with open(plain, "w") as f:
                    f.write(with_mode(fed, word))
                run([volcomp, "compensate", plain, "--map", map_csv, "--setup", setup,
                     "--quiet", "-o", comp], "volcomp compensate")
                with open(comp) as f:
                    todo.append((name + ".comp", f.read()))
    for src in sorted(glob.glob(os.path.join(HERE, "planner_programs", "*.ngc"))):
        with open(src) as f:
            todo.append((os.path.basename(src)[: -len(".ngc")], f.read()))
    if only:
        todo = [t for t in todo if only in t[0]]
    times_path = os.path.join(out, "times.csv")
    rows = {}
    if only and os.path.exists(times_path):
        with open(times_path) as f:
            rows = {r["program"]: r for r in csv.DictReader(f)}
    version = lcnc.linuxcnc_version()
    with open(LOCK, "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        for i, (name, text) in enumerate(todo, 1):
            path = os.path.join(prog_dir, name + ".ngc")
            with open(path, "w") as f:
                f.write(text)
            r = lcnc.run_program(path, os.path.join(work, "runs"))
            rows[name] = {
                "program": name,
                "moving_s": f"{r['moving_s']:.3f}",
                "cutting_s": f"{r['feed_s']:.3f}",
                "linuxcnc": version,
            }
            print(f"[{i}/{len(todo)}] {name}: {rows[name]['moving_s']} s, "
                  f"cutting {rows[name]['cutting_s']} s", file=sys.stderr)
    with open(times_path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["program", "moving_s", "cutting_s", "linuxcnc"])
        w.writeheader()
        for name in sorted(rows):
            w.writerow(rows[name])
    shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except (BenchError, lcnc.LinuxCncError, subprocess.CalledProcessError) as err:
        print(f"planner_fixtures.py: {err}", file=sys.stderr)
        sys.exit(1)
