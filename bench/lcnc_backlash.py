#!/usr/bin/env python3
"""What LinuxCNC 2.9's motion controller applies from [JOINT_n] BACKLASH
beside a COMP_FILE, measured on its real motion controller (headless sim of
bench/cycle_time/config/): joint 0 has BACKLASH = 0.004 and a type-1 comp file
(trims +0.001 forward, -0.003 reverse), joint 1 has BACKLASH = 0.004 alone.

compute_screw_comp (src/emc/motion/control.c, 2.9 commit f1270d6ed7) uses the
comp file's trim for the direction of travel when the joint has a table, and
+-BACKLASH/2 only when it has none; volcomp's INI reader models the same
(docs/controllers.md, "LinuxCNC"). The script runs one program ending on
forward travel and one ending on reverse travel, reads each joint's
backlash-corr pin at the end, and exits 1 when a value differs from that rule
by more than 1 nm.

Run it under the LinuxCNC lock (one LinuxCNC on the machine at a time):

    flock /tmp/volcomp-linuxcnc.lock python3 bench/lcnc_backlash.py
"""

import os
import shutil
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "cycle_time"))
import lcnc  # noqa: E402

# Expected backlash-corr (mm) at the end of each program, by joint.
EXPECTED = {
    "fwd": {0: 0.001, 1: 0.002},  # comp file's forward trim; +B/2
    "rev": {0: -0.003, 1: -0.002},  # comp file's reverse trim; -B/2
}
PROGRAMS = {
    "fwd": "G21 G90\nG0 X100 Y100\nM2\n",
    "rev": "G21 G90\nG0 X100 Y100\nG0 X50 Y50\nM2\n",
}


def machine(folder):
    """bench/cycle_time/config with the joints' BACKLASH and comp file."""
    shutil.copytree(lcnc.CONFIG, folder)
    ini = os.path.join(folder, "machine.ini")
    with open(ini) as f:
        text = f.read()
    for joint, keys in (
        (0, "BACKLASH = 0.004\nCOMP_FILE = x.comp\nCOMP_FILE_TYPE = 1\n"),
        (1, "BACKLASH = 0.004\n"),
    ):
        head = f"[JOINT_{joint}]\nTYPE = LINEAR\n"
        if text.count(head) != 1:
            raise SystemExit(f"{ini}: no single '{head.strip()}' to add to")
        text = text.replace(head, head + keys)
    with open(ini, "w") as f:
        f.write(text)
    with open(os.path.join(folder, "x.comp"), "w") as f:
        f.write("-2000 0.001 -0.003\n2000 0.001 -0.003\n")


def main():
    lcnc.check_installed()
    # VOLCOMP_LCNC_WORK: a folder to keep the machine in (the test
    # crates/volcomp-cli/tests/linuxcnc_backlash.rs reads its machine.ini
    # with volcomp's reader); otherwise a temporary one, removed.
    keep = os.environ.get("VOLCOMP_LCNC_WORK")
    work = keep or tempfile.mkdtemp(prefix="volcomp-lcnc-backlash-")
    config = os.path.join(work, "config")
    machine(config)
    lcnc.CONFIG = config
    os.environ["CT_PINS"] = " ".join(f"joint.{j}.backlash-corr" for j in (0, 1))
    worst = 0.0
    for name, text in PROGRAMS.items():
        program = os.path.join(work, f"{name}.ngc")
        with open(program, "w") as f:
            f.write(text)
        pins = lcnc.run_program(program, os.path.join(work, "runs"), 120.0)["pins"]
        for joint, want in EXPECTED[name].items():
            got = pins[f"joint.{joint}.backlash-corr"]
            worst = max(worst, abs(got - want))
            print(f"{name}: joint {joint} backlash-corr {got:+.9f} mm (expected {want:+.3f})")
    print(f"largest difference {worst * 1e6:.3f} nm")
    if not keep:
        shutil.rmtree(work, ignore_errors=True)
    return 0 if worst <= 1e-6 else 1


if __name__ == "__main__":
    sys.exit(main())
