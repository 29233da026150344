#!/usr/bin/env python3
"""Cycle time of compensated programs against their originals, on LinuxCNC
2.9's own trajectory planner (the simulated machine of config/).

    run.py VOLCOMP WORK_DIR

1. `VOLCOMP demo` writes the demo's map and programs into WORK_DIR/demo;
   the programs are the demo's originals, programs/*.ngc (a G2 full circle,
   a zigzag pocket) and the repository's examples/data/part.ngc.
2. Every program gets an F3000 and an F6000 variant (every F word is
   rewritten; G0 moves stay rapids) in each path-control mode: a line
   `G61`, `G64 P0.005` or `G64` put before its first line (after a leading
   `%`). CT_MODES="G61;G64" keeps only the modes named, CT_FEEDS="6000" the
   feeds named; CT_PROGRAMS="g2;zigzag"
   only the programs whose name contains one of the words; CT_EXTRA=DIR adds
   the programs of DIR (e.g. bench/eval/make_set.py's, one mode each: the
   mode line is added to those too).
3. Each variant is compensated with the demo's map and the machine's set-up
   (setup.toml) with the defaults, or the ways CT_VARIANTS names among
   "defaults", "--take-up-tolerance-um 5" (take-ups folded where they leave
   at most 5 µm), "--no-take-up" and "--no-split --no-take-up"
   (';'-separated; a way whose flag the binary lacks is skipped and said so).
4. Original and compensated programs run one after the other on LinuxCNC;
   two Markdown tables of simulated times (servo-thread timers,
   config/machine.hal) go to standard output and WORK_DIR/table.md, every
   figure to WORK_DIR/results.csv: the cutting time (a G1/G2/G3 segment
   active) and the whole program (first motion to the end of the last,
   with the rapids from home at machine 0, the same in both programs).

Any failure (compensate, LinuxCNC, a run that ends elsewhere than its
original) stops the script with an error; no number is printed for it.
"""

import csv
import glob
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
import lcnc  # noqa: E402

FEEDS_MM_MIN = (3000, 6000)
# CT_FEEDS="6000" keeps only the feeds named (mm/min, ';'-separated).
if os.environ.get("CT_FEEDS"):
    FEEDS_MM_MIN = tuple(int(f) for f in os.environ["CT_FEEDS"].split(";"))
MODES = ["G61", "G64 P0.005", "G64"]
if os.environ.get("CT_MODES"):
    MODES = os.environ["CT_MODES"].split(";")
# (label, extra `compensate` arguments)
VARIANTS = [
    ("defaults", []),
    ("--take-up-tolerance-um 5", ["--take-up-tolerance-um", "5"]),
    ("--no-take-up", ["--no-take-up"]),
    ("--no-split --no-take-up", ["--no-split", "--no-take-up"]),
]
# Only the defaults unless CT_VARIANTS="defaults;--no-take-up" names others
# (labels, ';'-separated).
_keep = os.environ.get("CT_VARIANTS", "defaults").split(";")
VARIANTS = [v for v in VARIANTS if v[0] in _keep]
# A compensated program ends where its original does, within the largest
# correction `compensate` accepts by default (--max-correction 0.1 mm).
END_TOLERANCE_MM = 0.1


class BenchError(Exception):
    pass


def split_comment(line):
    """(code, comment) of one G-code line: parenthesised comments and
    everything after ';' go to the comment part, in order."""
    code, comment = [], []
    depth = 0
    for i, ch in enumerate(line):
        if depth == 0 and ch == ";":
            comment.append(line[i:])
            break
        if ch == "(":
            depth += 1
        if depth > 0:
            comment.append(ch)
            code.append("\0")  # keeps word boundaries around the comment
        else:
            code.append(ch)
        if ch == ")" and depth > 0:
            depth -= 1
    return "".join(code), "".join(comment)


F_WORD = re.compile(r"[Ff]\s*([-+]?(?:\d+\.?\d*|\.\d+))")
F_OTHER = re.compile(r"[Ff]\s*[#\[<]")


def set_feed(text, feed_mm_min, name):
    """`text` with every F word's value replaced by `feed_mm_min`.

    Refuses (BenchError, with the line) an F given by an expression or a
    parameter, inverse-time or per-revolution feed (G93, G95), and a
    program without any F word.
    """
    out = []
    count = 0
    for n, line in enumerate(text.splitlines(keepends=True), start=1):
        code, _ = split_comment(line)
        if re.search(r"[Gg]\s*0*9[35](?![\d.])", code):
            raise BenchError(f"{name}:{n}: G93/G95 feed mode: F is not mm/min there")
        if F_OTHER.search(code):
            raise BenchError(f"{name}:{n}: F given by an expression or parameter")
        if not F_WORD.search(code):
            out.append(line)
            continue
        # `code` is `line` with comments blanked out (same length): the
        # matches are positions in `line` outside comments.
        new = []
        last = 0
        for m in F_WORD.finditer(code):
            new.append(line[last : m.start()])
            new.append(f"F{feed_mm_min}")
            last = m.end()
            count += 1
        new.append(line[last:])
        out.append("".join(new))
    if count == 0:
        raise BenchError(f"{name}: no F word to rewrite")
    return "".join(out)


def with_mode(text, mode):
    """`text` with the line `mode` before its first line, or after a
    leading `%` line (LinuxCNC reads what follows `%` as the program)."""
    lines = text.splitlines(keepends=True)
    at = 1 if lines and lines[0].strip() == "%" else 0
    return "".join(lines[:at] + [f"{mode}\n"] + lines[at:])


def blocks(path):
    """Lines with more than comments (and other than '%')."""
    n = 0
    with open(path) as f:
        for line in f:
            code, _ = split_comment(line)
            code = code.replace("\0", "").strip()
            if code and code != "%":
                n += 1
    return n


SERVO_PERIOD_S = 0.001


def slow_moves(volcomp, path, setup, feed_mm_min):
    """(take-ups, short moves) of a program: take-up blocks (volcomp's
    trace comment `(volcomp Ln take-up)`), and straight feed moves shorter than the
    distance F covers in one servo cycle. LinuxCNC 2.9 caps a segment's
    speed at its length per servo cycle (src/emc/tp/tc.c,
    tcClampVelocityByLength), so the planner must slow below F for each of
    them, whatever the blending."""
    with open(path) as f:
        take_ups = sum(1 for line in f if re.search(r"\(volcomp L\d+ take-up\)", line))
    r = run([volcomp, "moves", path, "--setup", setup, "--quiet"], "volcomp moves")
    rows = list(csv.DictReader(r.stdout.splitlines()))
    limit_mm = feed_mm_min / 60.0 * SERVO_PERIOD_S
    short = 0
    prev = None
    for row in rows:
        p = tuple(float(row[k]) for k in ("x_mm", "y_mm", "z_mm"))
        if prev is not None and row["kind"] == "feed":
            if sum((a - b) ** 2 for a, b in zip(p, prev)) ** 0.5 < limit_mm:
                short += 1
        prev = p
    return take_ups, short


def run(cmd, what):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise BenchError(f"{what} failed (exit {r.returncode}): {' '.join(cmd)}\n{r.stderr}")
    return r


def pct(new, old):
    return f"{(new / old - 1.0) * 100.0:+.1f} %"


def markdown_table(rows, labels, first, per_variant):
    """The lines of a markdown table of `rows`: the `first` columns
    (header, alignment rule, cells of a row), then those of `per_variant`
    for each variant label (header after "label: ", rule, cells of a row
    and a label)."""
    head, rule, cells = first
    v_head, v_rule, v_cells = per_variant
    lines = [head + "".join(f" {label}: {v_head}" for label in labels),
             rule + v_rule * len(labels)]
    for row in rows:
        lines.append(cells(row) + "".join(v_cells(row, label) for label in labels))
    return lines


def main():
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    volcomp, work = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    if not os.access(volcomp, os.X_OK):
        raise BenchError(f"{volcomp}: not an executable volcomp binary")
    lcnc.check_installed()
    os.makedirs(work, exist_ok=True)
    version = run([volcomp, "--version"], "volcomp --version").stdout.strip()
    helptext = run([volcomp, "compensate", "--help"], "volcomp compensate --help").stdout
    variants = []
    for label, args in VARIANTS:
        missing = [a for a in args if a not in helptext]
        if missing:
            print(f"note: {version} has no {' '.join(missing)}: variant '{label}' skipped",
                  file=sys.stderr)
        else:
            variants.append((label, args))

    demo = os.path.join(work, "demo")
    run([volcomp, "demo", "--out-dir", demo, "--quiet"], "volcomp demo")
    map_csv = os.path.join(demo, "example_map.csv")
    if not os.path.isfile(map_csv):
        raise BenchError(f"volcomp demo wrote no {map_csv}")
    originals = sorted(
        p for p in glob.glob(os.path.join(demo, "*.ngc"))
        if "." not in os.path.basename(p)[: -len(".ngc")]
    )
    if not originals:
        raise BenchError(f"volcomp demo wrote no original program into {demo}")
    originals += sorted(glob.glob(os.path.join(HERE, "programs", "*.ngc")))
    originals.append(os.path.join(REPO, "examples", "data", "part.ngc"))
    if os.environ.get("CT_EXTRA"):
        originals += sorted(glob.glob(os.path.join(os.environ["CT_EXTRA"], "*.ngc")))
    if os.environ.get("CT_PROGRAMS"):
        words = os.environ["CT_PROGRAMS"].split(";")
        originals = [p for p in originals if any(w in os.path.basename(p) for w in words)]
    setup = os.path.join(HERE, "setup.toml")

    progs = os.path.join(work, "programs")
    os.makedirs(progs, exist_ok=True)
    runs = os.path.join(work, "runs")
    rows = []
    for original in originals:
        stem = os.path.basename(original)[: -len(".ngc")]
        with open(original) as f:
            text = f.read()
        for mode, feed in [(m, f) for m in MODES for f in FEEDS_MM_MIN]:
            mtag = mode.replace(" ", "").replace(".", "")
            base = os.path.join(progs, f"{stem}.{mtag}.F{feed}.ngc")
            with open(base, "w") as f:
                f.write(with_mode(set_feed(text, feed, original), mode))
            r0 = lcnc.run_program(base, runs)
            row = {
                "program": stem,
                "mode": mode,
                "feed_mm_min": feed,
                "blocks": blocks(base),
                "original_s": r0["moving_s"],
                "original_feed_s": r0["feed_s"],
            }
            for label, args in variants:
                tag = label.replace("--", "").replace(" ", "_")
                out = os.path.join(progs, f"{stem}.{mtag}.F{feed}.{tag}.ngc")
                run(
                    [volcomp, "compensate", base, "--map", map_csv, "--setup", setup,
                     "--quiet", "-o", out] + args,
                    f"volcomp compensate ({label})",
                )
                r = lcnc.run_program(out, runs)
                dev = max(abs(a - b) for a, b in zip(r["end_machine_mm"], r0["end_machine_mm"]))
                if dev > END_TOLERANCE_MM:
                    raise BenchError(
                        f"{out} ended at {r['end_machine_mm']}, its original at "
                        f"{r0['end_machine_mm']} (machine mm): the run did not complete"
                    )
                row[f"{label} blocks"] = blocks(out)
                take_ups, short = slow_moves(volcomp, out, setup, feed)
                row[f"{label} take-ups"] = take_ups
                row[f"{label} short moves"] = short
                row[f"{label} s"] = r["moving_s"]
                row[f"{label} feed_s"] = r["feed_s"]
            rows.append(row)
            print(f"  {stem} {mode} F{feed}: " + ", ".join(
                f"{k} {v}" for k, v in row.items() if k.endswith(" s") or k == "original_s"),
                file=sys.stderr)

    with open(os.path.join(work, "results.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)

    lines = [
        f"Simulated times on {lcnc.linuxcnc_version()}, {version}; "
        "Δ = compensated / original − 1.",
        "",
        "Cutting time (a G1/G2/G3 move active), s; blocks: lines with more than "
        "comments; take-ups: volcomp's take-up blocks; short: feed lines shorter "
        "than F covers in one servo cycle (LinuxCNC caps their speed below F):",
        "",
    ]
    labels = [label for label, _ in variants]
    lines += markdown_table(
        rows, labels,
        ("| program | mode | F mm/min | blocks | original |", "|---|---|---:|---:|---:|",
         lambda row: (f"| {row['program']} | {row['mode']} | {row['feed_mm_min']} | "
                      f"{row['blocks']} | {row['original_feed_s']:.3f} |")),
        ("blocks (take-ups, short) | s | Δ |", "---:|---:|---:|",
         lambda row, label: (f" {row[f'{label} blocks']} ({row[f'{label} take-ups']}, "
                             f"{row[f'{label} short moves']}) | {row[f'{label} feed_s']:.3f} "
                             f"| {pct(row[f'{label} feed_s'], row['original_feed_s'])} |")))
    lines += [
        "",
        "Whole program (first motion to end of the last, with the rapids from "
        "home at machine 0), s:",
        "",
    ]
    lines += markdown_table(
        rows, labels,
        ("| program | mode | F mm/min | original |", "|---|---|---:|---:|",
         lambda row: (f"| {row['program']} | {row['mode']} | {row['feed_mm_min']} | "
                      f"{row['original_s']:.3f} |")),
        ("s | Δ |", "---:|---:|",
         lambda row, label: (f" {row[f'{label} s']:.3f} "
                             f"| {pct(row[f'{label} s'], row['original_s'])} |")))
    table = "\n".join(lines) + "\n"
    with open(os.path.join(work, "table.md"), "w") as f:
        f.write(table)
    print(table)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except (BenchError, lcnc.LinuxCncError) as err:
        print(f"run.py: {err}", file=sys.stderr)
        sys.exit(1)
