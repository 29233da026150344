#!/usr/bin/env python3
"""Times commands side by side, alternating: every round runs each command
once (the order rotates from round to round), so a change of the machine's
load during the run falls on all of them alike. Prints, per command, the
median wall time, the median CPU time (user + system, which other work on
the machine disturbs less), the peak resident memory, and the ratio of
the reference command's median to its own (how many times faster it is).

A command is NAME=SHELL COMMAND; the first is the reference.

usage: alternate.py [--rounds N] [--markdown FILE] NAME=CMD NAME=CMD ...
"""
import statistics
import subprocess
import sys
import tempfile
import time


def run_once(cmd):
    """Wall seconds, CPU seconds and peak RSS (KiB) of one run of `cmd`,
    as GNU time reports them (its small process is what the measured one
    is forked from, so the peak is the program's own)."""
    with tempfile.NamedTemporaryFile("r") as f:
        full = f"/usr/bin/time -f '%U %S %M' -o {f.name} {cmd}"
        start = time.perf_counter()
        status = subprocess.call(["bash", "-c", full])
        wall = time.perf_counter() - start
        if status != 0:
            sys.exit(f"failed ({status}): {cmd}")
        user, system, rss = f.read().split()[-3:]
    return wall, float(user) + float(system), int(rss)


def main():
    args = sys.argv[1:]
    rounds, markdown = 5, None
    while args and args[0].startswith("--"):
        opt = args.pop(0)
        if opt == "--rounds":
            rounds = int(args.pop(0))
        elif opt == "--markdown":
            markdown = args.pop(0)
        else:
            sys.exit(__doc__)
    cmds = [a.split("=", 1) for a in args]
    if not cmds or any(len(c) != 2 for c in cmds):
        sys.exit(__doc__)
    times = {name: [] for name, _ in cmds}
    for r in range(rounds):
        order = cmds[r % len(cmds):] + cmds[: r % len(cmds)]
        for name, cmd in order:
            times[name].append(run_once(cmd))
    ref_wall = statistics.median(t[0] for t in times[cmds[0][0]])
    ref_cpu = max(statistics.median(t[1] for t in times[cmds[0][0]]), 0.005)
    rows = [
        "| command | wall median [s] | wall runs [s] | CPU median [s] | peak RSS [MiB] "
        f"| × faster than {cmds[0][0]} (wall) | (CPU) |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, _ in cmds:
        walls = [t[0] for t in times[name]]
        cpus = [t[1] for t in times[name]]
        rss = max(t[2] for t in times[name]) / 1024
        w, c = statistics.median(walls), max(statistics.median(cpus), 0.005)
        rows.append(
            f"| {name} | {w:.3f} | {', '.join(f'{x:.2f}' for x in walls)} | {c:.3f} "
            f"| {rss:.1f} | {ref_wall / w:.1f} | {ref_cpu / c:.1f} |"
        )
    text = "\n".join(rows) + "\n"
    sys.stdout.write(text)
    if markdown:
        with open(markdown, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
