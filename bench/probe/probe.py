#!/usr/bin/env python3
"""Hostile-input probe of the volcomp command line (docs/errors.md).

Runs a few hundred generated cases per class against a volcomp binary,
each in a fresh copy of examples/data, with a time limit (10 s) and a
memory limit (1 GiB of address space is not used: the peak resident set
is measured and compared with 1 GiB), and classifies each result:

  clear    refused (exit 2 or 3) with every expected piece in the message:
           the file and row:column that hold the bad value, or the option
  unclear  refused, but without the expected location or option name
  wrong    accepted (exit 0) what must be refused, refused what must be
           accepted, or an input file changed
  hang     not finished within the time limit
  memory   finished, but its peak memory passed the limit
  crash    killed by a signal, exit 1 (internal error) or a panic

Classes: maps (malformed maps, models and measurement files), options,
outputs (output safety, inputs named inside inputs included), bounded
(work and memory), misreads (values read the wrong way).

    python3 bench/probe/probe.py [--bin target/release/volcomp] [--class maps]
        [--seed 1] [--jobs 2] [--list] [--verbose]

Exit status 1 when any case is wrong, hangs, passes the memory limit or
crashes. A new seed draws other rows, columns and values for the cases
that are drawn at random (a held-out run of the same classes).
"""

import argparse
import concurrent.futures
import hashlib
import os
import random
import shutil
import subprocess
import sys
import tempfile
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DATA = os.path.join(ROOT, "examples", "data")
TIME_LIMIT_S = 10.0
MEMORY_LIMIT_KB = 1 << 20  # 1 GiB

COMP = ["compensate", "part.ngc", "--map", "map.csv", "--setup", "machine.toml", "-o", "out.ngc"]


class Case:
    def __init__(self, cls, name, args, expect="refuse", where=(), files=None, prepare=None,
                 stdin=None, timeout=TIME_LIMIT_S):
        self.cls = cls
        self.name = name
        self.args = args
        self.expect = expect  # "refuse" or "ok"
        self.where = list(where)  # substrings the message must hold
        self.files = files or {}  # name -> bytes/str written before the run
        self.prepare = prepare  # callable(dir) run before
        self.stdin = stdin
        self.timeout = timeout


def write(d, name, content):
    path = os.path.join(d, name)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    mode = "wb" if isinstance(content, bytes) else "w"
    with open(path, mode, newline="" if mode == "w" else None) as f:
        f.write(content)


def snapshot(d):
    out = {}
    for base, _, names in os.walk(d):
        for n in names:
            p = os.path.join(base, n)
            if os.path.islink(p) or not os.path.isfile(p):
                continue
            with open(p, "rb") as f:
                out[os.path.relpath(p, d)] = hashlib.sha256(f.read()).hexdigest()
    return out


def run_case(binary, case, keep=False):
    d = tempfile.mkdtemp(prefix="volcomp-probe-")
    try:
        for n in os.listdir(DATA):
            src = os.path.join(DATA, n)
            (shutil.copytree if os.path.isdir(src) else shutil.copy)(src, os.path.join(d, n))
        for n, c in case.files.items():
            write(d, n, c)
        if case.prepare:
            case.prepare(d)
        before = snapshot(d)
        start = time.monotonic()
        stdin = open(os.path.join(d, case.stdin), "rb") if case.stdin else subprocess.DEVNULL
        p = subprocess.Popen([binary] + case.args, cwd=d, stdin=stdin,
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        chunks = []
        reader = threading.Thread(target=lambda: chunks.append(p.stderr.read()))
        reader.start()
        killed = threading.Event()
        def kill():
            killed.set()
            p.kill()
        timer = threading.Timer(case.timeout, kill)
        timer.start()
        # wait4: this child's own peak resident set.
        _, status, usage = os.wait4(p.pid, 0)
        timer.cancel()
        reader.join()
        p.returncode = os.waitstatus_to_exitcode(status)
        hung = killed.is_set()
        err = b"".join(chunks)
        elapsed = time.monotonic() - start
        rss_kb = usage.ru_maxrss
        err = err.decode("utf-8", "replace")
        after = snapshot(d)
        changed = [n for n, h in before.items() if n in after and after[n] != h
                   and n not in ("out.ngc", "report.csv", "errors.csv", "out.toml")]
        verdict = classify(case, p.returncode, err, hung, rss_kb, changed)
        return verdict, err, elapsed, rss_kb
    finally:
        if not keep:
            shutil.rmtree(d, ignore_errors=True)


def classify(case, code, err, hung, rss_kb, changed):
    if hung:
        return "hang"
    if code is None or code < 0 or code == 1 or code == 101 or "panicked" in err:
        return "crash"
    if rss_kb > MEMORY_LIMIT_KB:
        return "memory"
    if changed:
        return "wrong"
    if case.expect == "ok":
        return "ok" if code == 0 else "wrong"
    if code == 0:
        return "wrong"
    if code not in (2, 3):
        return "crash"
    return "clear" if all(w in err for w in case.where) else "unclear"


# ---------------------------------------------------------------- cases

def read_data(name):
    with open(os.path.join(DATA, name), encoding="utf-8") as f:
        return f.read()


def map_cases(rng):
    cases = []
    text = read_data("map.csv")
    lines = text.split("\n")
    rows = [i for i, l in enumerate(lines) if l and i > 0]
    bad_numbers = ["nan", "inf", "-inf", "", "abc", "1,5", "1e999", "0x10", "1 2", "\x1b[31m1", "--1", "1.2.3"]
    columns = ["axis", "direction", "position_mm", "ex_um", "ey_um", "ez_um"]
    for k in range(120):
        r = rng.choice(rows)
        c = rng.randrange(6)
        v = rng.choice(bad_numbers)
        fields = lines[r].split(",")
        if c < 2 and v in ("", "1 2"):
            v = "Q"
        fields[c] = '"' + v + '"' if "," in v else v
        new = lines[:r] + [",".join(fields)] + lines[r + 1:]
        cases.append(Case("maps", f"map cell r{r + 1} c{c + 1} {v!r}", COMP,
                          where=[f"map.csv:{r + 1}:{c + 1}:"], files={"map.csv": "\n".join(new)}))
    # Values that are numbers but cannot be: positions in µm, errors in nm.
    for k in range(20):
        r = rng.choice(rows)
        fields = lines[r].split(",")
        c = rng.choice([2, 3, 4, 5])
        fields[c] = str(float(fields[c] or 0) * 1000 + (200000 if c == 2 else 20000))
        new = lines[:r] + [",".join(fields)] + lines[r + 1:]
        cases.append(Case("maps", f"map value out of range r{r + 1} c{c + 1}", COMP,
                          where=[f"map.csv:{r + 1}:{c + 1}:"], files={"map.csv": "\n".join(new)}))
    # Positions that do not increase.
    for k in range(10):
        r = rng.choice(rows[1:])
        prev = lines[r - 1].split(",")
        fields = lines[r].split(",")
        if prev[0] != fields[0] or prev[1] != fields[1]:
            continue
        fields[2] = prev[2]
        new = lines[:r] + [",".join(fields)] + lines[r + 1:]
        cases.append(Case("maps", f"map position repeats r{r + 1}", COMP,
                          where=[f"map.csv:{r + 1}:3:"], files={"map.csv": "\n".join(new)}))
    # A row with a field too many or too few.
    for k in range(10):
        r = rng.choice(rows)
        extra = rng.random() < 0.5
        fields = lines[r].split(",")
        fields = fields + ["0"] if extra else fields[:-1]
        new = lines[:r] + [",".join(fields)] + lines[r + 1:]
        cases.append(Case("maps", f"map row width r{r + 1} {'+1' if extra else '-1'}", COMP,
                          where=[f"map.csv:{r + 1}:"], files={"map.csv": "\n".join(new)}))
    # Header faults.
    header = lines[0]
    for name, h, at in [
        ("header missing column", header.replace(",ez_um", ""), "map.csv:1:"),
        ("header duplicate column", header.replace("ey_um", "ex_um"), "map.csv:1:"),
        ("header unknown column", header.replace("ez_um", "ez_mm"), "map.csv:1:6:"),
        ("header semicolons", header.replace(",", ";"), "map.csv:1:"),
        ("header without unit", header.replace("position_mm", "position"), "map.csv:1:3:"),
    ]:
        cases.append(Case("maps", name, COMP, where=[at],
                          files={"map.csv": "\n".join([h] + lines[1:])}))
    cases.append(Case("maps", "map not UTF-8", COMP, where=["map.csv:4:"],
                      files={"map.csv": ("\n".join(lines[:3]) + "\nX,forward,\xe9\n").encode("latin-1")}))
    cases.append(Case("maps", "map empty", COMP, where=["map.csv:1:"], files={"map.csv": ""}))
    cases.append(Case("maps", "map header only", COMP, where=["map.csv:"], files={"map.csv": header + "\n"}))
    cases.append(Case("maps", "map with NUL", COMP, where=["map.csv:3:"],
                      files={"map.csv": "\n".join(lines[:2] + ["X,forward,2\x00,0,0,0"] + lines[3:])}))
    cases.append(Case("maps", "map CRLF and BOM", COMP, expect="ok",
                      files={"map.csv": "\ufeff" + text.replace("\n", "\r\n")}))
    # The 21-component model: its TOML and its table.
    def kinematic(d):
        subprocess.run([BINARY, "map", "example", "-o", "."], cwd=d, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    km = COMP[:3] + ["example21.toml"] + COMP[4:]
    def edit(name, old, new):
        def f(d):
            kinematic(d)
            p = os.path.join(d, name)
            with open(p, encoding="utf-8") as fh:
                t = fh.read()
            assert old in t, (name, old)
            with open(p, "w", encoding="utf-8") as fh:
                fh.write(t.replace(old, new, 1))
        return f
    for name, old, new, where in [
        ("measuring point with 4 values", "measuring_point_mm = [", "measuring_point_mm = [1, ", ["example21.toml:", "4 values"]),
        ("squareness nan", "xy = ", "xy = nan #", ["example21.toml:"]),
        ("tables /dev/zero", 'tables = "example21.csv"', 'tables = "/dev/zero"', ["example21.toml:"]),
        ("tables missing", 'tables = "example21.csv"', 'tables = "nothere.csv"', ["example21.toml:", "nothere.csv"]),
        ("chain typo", "chain = \"", "chain = \"q ", ["example21.toml:"]),
        ("unknown key", "chain =", "chian = 1\nchain =", ["example21.toml:", "chian"]),
    ]:
        cases.append(Case("maps", f"kinematic {name}", km, where=where, prepare=edit("example21.toml", old, new)))
    for k in range(20):
        r = rng.randrange(3, 60)
        c = rng.randrange(3, 9)
        v = rng.choice(["nan", "x", "", "1e9"])
        def f(d, r=r, c=c, v=v):
            kinematic(d)
            p = os.path.join(d, "example21.csv")
            with open(p, encoding="utf-8") as fh:
                ls = fh.read().split("\n")
            data = [i for i, l in enumerate(ls) if l and not l.startswith("#")][1:]
            i = data[r % len(data)]
            fs = ls[i].split(",")
            fs[c] = v
            ls[i] = ",".join(fs)
            with open(p, "w", encoding="utf-8") as fh:
                fh.write("\n".join(ls))
            with open(os.path.join(d, "expect"), "w") as fh:
                fh.write(f"example21.csv:{i + 1}:{c + 1}:")
        cases.append(Case("maps", f"kinematic table cell {r},{c} {v!r}", km, where=["example21.csv:"], prepare=f))
    # Set-up files.
    setup = read_data("machine.toml")
    for name, new, where in [
        ("G54 with 4 values", setup.replace("G54 = [250.0, 200.0, 150.0]", "G54 = [250.0, 200.0, 150.0, 1]"), ["machine.toml:"]),
        ("no units", setup.replace('units = "mm"', ""), ["machine.toml:"]),
        ("var file missing", setup.replace('units = "mm"', 'units = "mm"\nvar_file = "none.var"').replace("[work_offsets]\nG54 = [250.0, 200.0, 150.0]\n", "").split("[reference]")[0], ["machine.toml:", "none.var"]),
        ("tool twice", setup.replace("1 = 75.0", "1 = 75.0\nT1 = 80"), ["machine.toml:"]),
        ("G54 nan", setup.replace("G54 = [250.0", "G54 = [nan"), ["machine.toml:"]),
    ]:
        cases.append(Case("maps", f"setup {name}", COMP, where=where, files={"machine.toml": new}))
    # Thermal: temperatures and models.
    def thermal(d):
        subprocess.run([BINARY, "thermal", "example", "-o", "th"], cwd=d, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    fit = ["thermal", "fit", "--measurements", "th/measurements_train.csv", "--temperatures",
           "th/temperatures_train.csv", "--artifact", "th/artifact.csv", "--ranges-mm",
           "0:600,0:400,0:300", "-o", "th.toml"]
    for v in ["2085", "-300", "nan", "1e9"]:
        def f(d, v=v):
            thermal(d)
            p = os.path.join(d, "th/temperatures_train.csv")
            with open(p, encoding="utf-8") as fh:
                ls = fh.read().split("\n")
            data = [i for i, l in enumerate(ls) if l and not l.startswith("#")]
            i = data[3]
            fs = ls[i].split(",")
            fs[2] = v
            ls[i] = ",".join(fs)
            with open(p, "w", encoding="utf-8") as fh:
                fh.write("\n".join(ls))
        cases.append(Case("maps", f"thermal temperature {v}", fit,
                          where=["temperatures_train.csv:", ":3:"], prepare=f))
    def nan_model(d):
        thermal(d)
        subprocess.run([BINARY] + fit, cwd=d, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        p = os.path.join(d, "th.toml")
        with open(p, encoding="utf-8") as fh:
            t = fh.read()
        i = t.index("intercept = ")
        j = t.index("\n", i)
        with open(p, "w", encoding="utf-8") as fh:
            fh.write(t[:i] + "intercept = nan" + t[j:])
    cases.append(Case("maps", "thermal model nan intercept",
                      ["thermal", "predict", "--model", "th.toml", "--temperatures",
                       "th/temperatures_check.csv", "-o", "pred.toml"],
                      where=["th.toml:", "intercept"], prepare=nan_model))
    # Controller files.
    for name, content, where in [
        ("klipper without yz_skew", "[skew_correction m]\nxy_skew = 0.00001\nxz_skew = 0\n", ["skew.cfg:1:", "yz_skew"]),
        ("klipper factor nan", "[skew_correction m]\nxy_skew = nan\nxz_skew = 0\nyz_skew = 0\n", ["skew.cfg:2:"]),
        ("ini missing comp file", "[TRAJ]\nLINEAR_UNITS = mm\n[JOINT_0]\nCOMP_FILE = none.comp\nCOMP_FILE_TYPE = 1\n", ["m.ini:4:", "none.comp"]),
        ("cma missing table", "BEGIN V.CMA\nNR ACTIVE X Y Z\n0 * X.COM Y.COM Z.COM\n[END]\n", ["V.CMA:3:"]),
    ]:
        fname = {"klipper without yz_skew": "skew.cfg", "klipper factor nan": "skew.cfg",
                 "ini missing comp file": "m.ini", "cma missing table": "V.CMA"}[name]
        cases.append(Case("maps", f"controller {name}", COMP + ["--controller", fname],
                          where=where, files={fname: content}))
    # Straightness models.
    def straight(d):
        subprocess.run([BINARY, "straightness", "fit", "runs/x-4800.csv", "runs/x-7200.csv",
                        "runs/x-9600.csv", "-o", "s.toml"], cwd=d, check=False,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    for name, old, new in [
        ("offset nan", "offset_um = ", "offset_um = nan #"),
        ("length negative", "length_mm = ", "length_mm = -"),
        ("harmonics mismatch", "harmonics = ", "harmonics = 1"),
        ("kind", 'kind = "straightness"', 'kind = "other"'),
    ]:
        def f(d, old=old, new=new):
            straight(d)
            p = os.path.join(d, "s.toml")
            with open(p, encoding="utf-8") as fh:
                t = fh.read()
            with open(p, "w", encoding="utf-8") as fh:
                fh.write(t.replace(old, new, 1))
        cases.append(Case("maps", f"straightness model {name}",
                          ["straightness", "table", "s.toml", "-o", "t.csv"], where=["s.toml:"], prepare=f))
    return cases


def option_cases(rng):
    cases = []
    comp = COMP
    bad_any = ["nan", "inf", "-inf", "x", "", "1e400", "0x1"]
    # Every numeric option of compensate with values that cannot be, each
    # refused naming the option.
    numeric = {
        "--gain": (["--method", "ilc"], ["0", "-1", "2", "1.0000001", "-0"]),
        "--max-iterations": (["--method", "ilc"], ["0", "-1", "1e9", "1000000000", "4294967296", "1.5"]),
        "--segments": ([], ["0", "-3", "1e12", "1000000000", "4294967296", "1.5"]),
        "--segment-length": ([], ["0", "-1", "1e-12", "1e-7"]),
        "--chord-tolerance": ([], ["0", "-1", "1e-15", "1e-12", "100"]),
        "--contour-tolerance-um": ([], ["0", "-1", "1e-12", "1e-9"]),
        "--min-segment-length": ([], ["0", "-1", "1e-12", "1e-9"]),
        "--decimals": ([], ["0", "10", "-1", "255", "1.5"]),
        "--max-correction": ([], ["0", "-1"]),
        "--max-residual-um": ([], ["0", "-1"]),
        "--take-up-tolerance-um": ([], ["0", "-1"]),
        "--max-output-size": ([], ["-1", "1Q", "0x10", "1.5.2"]),
    }
    for flag, (pre, values) in numeric.items():
        for v in values + bad_any:
            if flag == "--max-output-size" and v in ("inf",):
                continue
            cases.append(Case("options", f"compensate {flag} {v!r}", comp + pre + [flag, v], where=[flag]))
    # Options that mean nothing with the method chosen.
    cases.append(Case("options", "gain with direct", comp + ["--method", "direct", "--gain", "0.3"], where=["--gain"]))
    cases.append(Case("options", "max-iterations with exact", comp + ["--max-iterations", "5"], where=["--max-iterations"]))
    cases.append(Case("options", "pitch with the controller compensating positioning",
                      comp + ["--method", "pitch", "--controller-compensates", "positioning"], where=["pitch"]))
    # Valid values stay valid.
    for extra in (["--method", "ilc", "--gain", "0.5", "--max-iterations", "50"], ["--segments", "20"],
                  ["--segment-length", "-0"][:0] + ["--segment-length", "0.5"], ["--decimals", "4"],
                  ["--work-offset", "-10,150,100", "--clamp"], ["--chord-tolerance", "0.001"]):
        cases.append(Case("options", f"valid {' '.join(extra)}", comp + extra, expect="ok"))
    for s_ in ["1,2", "a,b,c", "nan,0,0", "1e9,0,0", "", "1,2,3,4", "inf,0,0"]:
        cases.append(Case("options", f"work-offset {s_!r}", ["compensate", "part.ngc", "--map", "map.csv",
                                                              "--work-offset", s_, "-o", "out.ngc"], where=["work-offset"]))
    sim = ["simulate", "part.ngc", "--map", "map.csv", "--setup", "machine.toml"]
    for v in ["0", "-1", "1e-15"] + bad_any:
        cases.append(Case("options", f"simulate --chord-tolerance {v!r}", sim + ["--chord-tolerance", v], where=["--chord-tolerance"]))
    th = ["thermal", "fit", "--measurements", "m.csv", "--temperatures", "t.csv", "--artifact", "a.csv",
          "--ranges-mm", "0:600,0:400,0:300", "-o", "th.toml"]
    for flag, values in [("--table-samples", ["0", "1", "1000000000", "-1"]), ("--order", ["1000", "-1", "11"]),
                         ("--lags", ["100000", "-1"]), ("--threshold", ["0", "2", "-1", "1", "nan"]),
                         ("--probe-length-mm", ["nan", "inf"])]:
        for v in values:
            cases.append(Case("options", f"thermal fit {flag} {v}", th + [flag, v], where=[flag]))
    for v in ["1e9", "0", "5", "-1", "1000000000", "10001"]:
        cases.append(Case("options", f"thermal fit --samples {v}", th + ["--bands", "b.csv", "--samples", v], where=["--samples"]))
    for v in ["1:2", "0:600,0:400", "0:600,0:400,300:0", "a:b,0:1,0:1", "0:nan,0:1,0:1"]:
        cases.append(Case("options", f"thermal fit --ranges-mm {v}", th[:-4] + ["--ranges-mm", v, "-o", "th.toml"], where=["--ranges-mm"]))
    for v in ["-1", "x", "1e3"]:
        cases.append(Case("options", f"thermal predict --cycle {v}",
                          ["thermal", "predict", "--model", "th.toml", "--temperatures", "t.csv", "--cycle", v, "-o", "p.toml"],
                          where=["--cycle"]))
    st = ["straightness", "fit", "runs/x-4800.csv", "runs/x-7200.csv", "runs/x-9600.csv", "-o", "s.toml"]
    for flag, values in [("--sigma-t", ["0", "-1", "nan"]), ("--p-t", ["0", "1", "2", "-1"]),
                         ("--taper", ["-0.1", "0.6", "nan"]), ("--harmonics", ["0", "-1", "100000"])]:
        for v in values:
            cases.append(Case("options", f"straightness fit {flag} {v}", st + [flag, v], where=[flag]))
    for flag, values in [("--step", ["0", "-1", "nan", "1e-9"])]:
        for v in values:
            cases.append(Case("options", f"map export {flag} {v}",
                              ["map", "export", "map.csv", "--to", "heidenhain", "-o", "hh", flag, v], where=[flag]))
    return cases


def output_cases(rng):
    cases = []
    inputs = ["part.ngc", "map.csv", "machine.toml", "./part.ngc", "sub/../map.csv"]
    for flag in ["-o", "--report", "--report-html"]:
        for i in inputs:
            args = COMP[:-2] + (["-o", "x.ngc"] if flag != "-o" else []) + [flag, i]
            cases.append(Case("outputs", f"compensate {flag} {i}", args, where=["refusing to write"],
                              prepare=lambda d: os.makedirs(os.path.join(d, "sub"), exist_ok=True)))
    sim = ["simulate", "part.ngc", "--map", "map.csv", "--setup", "machine.toml"]
    for flag in ["--errors-csv", "--plot", "--report-html"]:
        for i in ["part.ngc", "map.csv", "machine.toml"]:
            cases.append(Case("outputs", f"simulate {flag} {i}", sim + [flag, i], where=["refusing to write"]))
    # Files named inside inputs.
    var_setup = 'units = "mm"\nsubroutine_path = ["subs"]\nvar_file = "sim.var"\n'
    calls = "G21 G90 G17\nG0 X10 Y10 Z5\nG1 Z-1 F300\no<pocket> call\nG0 Z5\nM2\n"
    files = {"var.toml": var_setup, "sim.var": "5220 1\n5221 250\n5222 200\n5223 150\n",
             "subs/pocket.ngc": "o<pocket> sub\nG1 X60 Y40\nG1 X10\no<pocket> endsub\n", "calls.ngc": calls}
    base = ["compensate", "calls.ngc", "--map", "map.csv", "--setup", "var.toml"]
    for flag in ["-o", "--report", "--report-html"]:
        for target in ["sim.var", "subs/pocket.ngc", "./subs/pocket.ngc"]:
            args = base + (["-o", "x.ngc"] if flag != "-o" else []) + [flag, target]
            cases.append(Case("outputs", f"indirect {flag} {target}", args, where=["refusing to write"], files=dict(files)))
    for target in ["sim.var", "subs/pocket.ngc"]:
        cases.append(Case("outputs", f"simulate --errors-csv {target}",
                          ["simulate", "calls.ngc", "--map", "map.csv", "--setup", "var.toml", "--errors-csv", target],
                          where=["refusing to write"], files=dict(files)))
    def export(to, d, extra):
        def f(dd):
            subprocess.run([BINARY, "map", "export", "map.csv", "--to", to, "-o", d] + extra, cwd=dd,
                           check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        return f
    for to, d, ctl, named, extra in [
        ("linuxcnc", "lc", "lc/comp.ini", ["lc/x.comp", "lc/y.comp", "lc/z.comp"], ["--type", "1", "--units", "mm", "--step", "5"]),
        ("heidenhain", "hh", "hh/VOLCOMP.CMA", ["hh/X.COM", "hh/Y.COM", "hh/Z.COM"], ["--step", "5"]),
    ]:
        for n in named:
            for flag in ["-o", "--report"]:
                args = COMP[:-2] + ["--controller", ctl] + (["-o", "x.ngc"] if flag != "-o" else []) + [flag, n]
                cases.append(Case("outputs", f"controller {flag} {n}", args, where=["refusing to write"],
                                  prepare=export(to, d, extra)))
    def kinematic(d):
        subprocess.run([BINARY, "map", "example", "-o", "."], cwd=d, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    for flag in ["-o", "--report"]:
        args = ["compensate", "part.ngc", "--map", "example21.toml", "--setup", "machine.toml"] + \
            (["-o", "x.ngc"] if flag != "-o" else []) + [flag, "example21.csv"]
        cases.append(Case("outputs", f"model table {flag}", args, where=["refusing to write"], prepare=kinematic))
    cases.append(Case("outputs", "stdin program to -o", ["compensate", "-", "--map", "map.csv", "--setup",
                                                          "machine.toml", "-o", "part.ngc"],
                      where=["refusing to write"], stdin="part.ngc"))
    cases.append(Case("outputs", "two outputs one file", COMP + ["--report", "out.ngc"], where=["same file"]))
    return cases


def bounded_cases(rng):
    cases = []
    def big_map(n, name):
        def f(d):
            with open(os.path.join(d, name), "w") as fh:
                fh.write("axis,direction,position_mm,ex_um,ey_um,ez_um\n")
                for a, lo, hi in (("X", 0, 600), ("Y", 0, 400), ("Z", 0, 300)):
                    for i in range(n):
                        fh.write(f"{a},both,{lo + (hi - lo) * i / (n - 1):.6f},{(i % 7) * 0.1:.3f},0,0\n")
        return f
    for n in [200_000, 1_000_000]:
        cases.append(Case("bounded", f"map of {n} points per axis", COMP[:3] + ["dense.csv"] + COMP[4:],
                          expect="ok", prepare=big_map(n, "dense.csv"), timeout=30))
    cases.append(Case("bounded", "map of 2.5 million points per axis (too many rows)", COMP[:3] + ["dense.csv"] + COMP[4:],
                      where=["dense.csv:", "rows"], prepare=big_map(2_500_000, "dense.csv"), timeout=60))
    for dev in ["/dev/zero", "/dev/urandom"]:
        cases.append(Case("bounded", f"--map {dev}", COMP[:3] + [dev] + COMP[4:], where=[dev]))
        cases.append(Case("bounded", f"--setup {dev}", COMP[:5] + [dev] + COMP[6:], where=[dev]))
    def tables_dev(d):
        subprocess.run([BINARY, "map", "example", "-o", "."], cwd=d, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        p = os.path.join(d, "example21.toml")
        with open(p) as fh:
            t = fh.read()
        with open(p, "w") as fh:
            fh.write(t.replace('tables = "example21.csv"', 'tables = "/dev/zero"'))
    cases.append(Case("bounded", "tables = /dev/zero", COMP[:3] + ["example21.toml"] + COMP[4:],
                      where=["example21.toml:", "/dev/zero"], prepare=tables_dev))
    def one_line(mb):
        def f(d):
            with open(os.path.join(d, "line.csv"), "w") as fh:
                fh.write("axis,direction,position_mm,ex_um,ey_um,ez_um\n")
                chunk = "1," * (1 << 20)
                for _ in range(mb // 2):
                    fh.write(chunk)
                fh.write("\n")
        return f
    for mb in [8, 64, 300]:
        cases.append(Case("bounded", f"one-line CSV of {mb} MB", COMP[:3] + ["line.csv"] + COMP[4:],
                          where=["line.csv"], prepare=one_line(mb), timeout=30))
    loops = {
        "while [1] empty": "G21\no1 while [1]\no1 endwhile\nM2\n",
        "while [1] counter": "G21\n#1=0\no1 while [1]\n#1=[#1+1]\no1 endwhile\nM2\n",
        "while [1] motion": "G21 G90\nG0 X0 Y0 Z0\no1 while [1]\nG1 X1 F100\nG1 X0\no1 endwhile\nM2\n",
        "do while [1]": "G21\no1 do\n#1=[#1+1]\no1 while [1]\nM2\n",
        "repeat 1e9": "G21\no1 repeat [1000000000]\n#1=1\no1 endrepeat\nM2\n",
        "recursion": "G21\no<r> sub\no<r> call\no<r> endsub\no<r> call\nM2\n",
    }
    for name, prog in loops.items():
        for cmd in (["moves", "loop.ngc"], ["compensate", "loop.ngc", "--map", "map.csv", "--setup", "machine.toml", "-o", "out.ngc"]):
            cases.append(Case("bounded", f"{cmd[0]} {name}", cmd, where=["loop.ngc:"], files={"loop.ngc": prog}))
    cases.append(Case("bounded", "thermal --samples 1e9", ["thermal", "fit", "--measurements", "m.csv",
                       "--temperatures", "t.csv", "--artifact", "a.csv", "--ranges-mm", "0:600,0:400,0:300",
                       "-o", "th.toml", "--bands", "b.csv", "--samples", "1000000000"], where=["--samples"]))
    cases.append(Case("bounded", "ilc gain 1e-9 1e9 iterations", COMP + ["--method", "ilc", "--gain", "1e-9",
                                                                          "--max-iterations", "1000000000"],
                      where=["max-iterations"]))
    for s in ["--segments", "--segment-length"]:
        v = "1000000" if s == "--segments" else "0.000001"
        cases.append(Case("bounded", f"{s} {v}", COMP + [s, v], where=[s]))
    cases.append(Case("bounded", "chord tolerance 1e-12", COMP + ["--chord-tolerance", "1e-12"], where=["chord-tolerance"]))
    cases.append(Case("bounded", "huge arc", COMP[:1] + ["arc.ngc"] + COMP[2:],
                      where=["arc.ngc:"], files={"arc.ngc": "G21 G90\nG0 X0 Y0 Z0\nG2 X0 Y0 I-1000 J0 Z-10000 P100000 F100\nM2\n"}))
    return cases


def misread_cases(rng):
    cases = []
    # LinuxCNC reads 253 bytes of a line with its ending (rs274 checked):
    # 252 characters before LF, 251 before CR LF.
    for n, eol in [(n, e) for n in range(246, 257) for e in ("\n", "\r\n")]:
        expect = "ok" if n + len(eol) <= 253 else "refuse"
        line = "G1 X1 F100 (" + "a" * (n - 13) + ")"
        prog = "G21" + eol + "G0 X0 Y0 Z0" + eol + line + eol + "M2" + eol
        cases.append(Case("misreads", f"{n}-char line {eol!r}", ["moves", "long.ngc", "--work-offset", "250,200,150"],
                          expect=expect, where=["long.ngc:3:", "Command too long"], files={"long.ngc": prog}))
    # µm positions under position_mm, tables of every length.
    for scale in [1000, 1000.0001]:
        def f(d, scale=scale):
            p = os.path.join(d, "map.csv")
            with open(p) as fh:
                ls = fh.read().split("\n")
            out = [ls[0]]
            for l in ls[1:]:
                if not l:
                    continue
                fs = l.split(",")
                fs[2] = repr(float(fs[2]) * scale)
                out.append(",".join(fs))
            with open(p, "w") as fh:
                fh.write("\n".join(out) + "\n")
        cases.append(Case("misreads", f"positions scaled by {scale}", COMP, where=["map.csv:"], prepare=f))
    # File names with terminal escapes are printed escaped.
    esc = "ma\x1b[2Jp.csv"
    cases.append(Case("misreads", "escape in a file name", COMP[:3] + [esc] + COMP[4:], where=["\\x1b[2J"],
                      prepare=lambda d: shutil.copy(os.path.join(d, "map.csv"), os.path.join(d, esc)),
                      expect="ok"))
    cases.append(Case("misreads", "escape in a missing file name", COMP[:3] + ["no\x1b]0;x\x07.csv"] + COMP[4:],
                      where=["\\x1b]0;x\\x07"]))
    cases.append(Case("misreads", "negative cycle", ["thermal", "predict", "--model", "t.toml", "--temperatures",
                                                      "t.csv", "--cycle", "-1", "-o", "p.toml"], where=["--cycle"]))
    return cases


CLASSES = {
    "maps": map_cases,
    "options": option_cases,
    "outputs": output_cases,
    "bounded": bounded_cases,
    "misreads": misread_cases,
}

BINARY = None


def main():
    global BINARY
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "release", "volcomp"))
    ap.add_argument("--class", dest="cls", action="append", choices=sorted(CLASSES))
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--list", action="store_true")
    ap.add_argument("--verbose", action="store_true")
    a = ap.parse_args()
    BINARY = os.path.abspath(a.bin)
    rng = random.Random(a.seed)
    cases = []
    for name in a.cls or list(CLASSES):
        cases += CLASSES[name](rng)
    if a.list:
        for c in cases:
            print(f"{c.cls:9} {c.expect:6} {c.name}")
        return 0
    results = []
    def one(c):
        return c, run_case(BINARY, c)
    with concurrent.futures.ThreadPoolExecutor(max_workers=a.jobs) as ex:
        for c, (verdict, err, elapsed, rss) in ex.map(one, cases):
            results.append((c, verdict, err, elapsed, rss))
            if a.verbose or verdict not in ("clear", "ok"):
                first = err.strip().split("\n")[0][:200] if err.strip() else "(no message)"
                print(f"{verdict:8} {c.cls:9} {c.name}: {elapsed:.1f} s, {rss // 1024} MB: {first!r}")
    print()
    kinds = ["clear", "ok", "unclear", "wrong", "hang", "memory", "crash"]
    print(f"{'class':10}" + "".join(f"{k:>9}" for k in kinds) + f"{'max s':>8}{'max MB':>8}")
    bad = 0
    for name in a.cls or list(CLASSES):
        rs = [r for r in results if r[0].cls == name]
        counts = {k: sum(1 for r in rs if r[1] == k) for k in kinds}
        bad += counts["wrong"] + counts["hang"] + counts["memory"] + counts["crash"]
        print(f"{name:10}" + "".join(f"{counts[k]:>9}" for k in kinds)
              + f"{max((r[3] for r in rs), default=0):>8.1f}{max((r[4] for r in rs), default=0) // 1024:>8}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
