#!/usr/bin/python3
"""Headless "display" of the probing simulation (machine.ini): runs one
probing program on LinuxCNC and writes one JSON line with the simulated
time it took.

LinuxCNC's `linuxcnc` script starts it as `probe_display.py -ini INIFILE
PROGRAM` and shuts LinuxCNC down when it exits. It takes the steps an
operator takes, through LinuxCNC's Python interface (linuxcnc.stat /
command / error_channel, "Python Interface" chapter of the LinuxCNC 2.9
manual): estop reset, machine on, home all, MDI the work offset (G10 L2 P1
from PROBE_G54, "x,y,z" mm), load the probe (T M6, tool PROBE_TOOL, 1 by
default), auto, open, run, wait until the program has
ended; any error message from LinuxCNC (e.g. "G38.2 move finished without
making contact") fails the run. The result goes to the file named by
PROBE_RESULT: {"moving_s": simulated time out of position, "wall_s": ...}
or {"error": ...}.
"""

import json
import os
import sys
import time

import hal
import linuxcnc

POLL_S = 0.005


class RunError(Exception):
    pass


def program_of(argv):
    program = None
    i = 1
    while i < len(argv):
        if argv[i] == "-ini":
            i += 2
            continue
        program = argv[i]
        i += 1
    if program is None:
        raise RunError("no program given")
    return os.path.abspath(program)


class Session:
    def __init__(self):
        self.s = linuxcnc.stat()
        self.c = linuxcnc.command()
        self.e = linuxcnc.error_channel()

    def check_errors(self):
        while True:
            msg = self.e.poll()
            if not msg:
                return
            kind, text = msg
            if kind in (linuxcnc.NML_ERROR, linuxcnc.OPERATOR_ERROR):
                raise RunError("LinuxCNC error: " + text)

    def wait_for(self, what, predicate, timeout_s, hold_s=0.0):
        """Waits until `predicate` holds (for `hold_s` without a break)."""
        deadline = time.monotonic() + timeout_s
        since = None
        while True:
            self.s.poll()
            self.check_errors()
            if predicate(self.s):
                now = time.monotonic()
                since = now if since is None else since
                if now - since >= hold_s:
                    return
            else:
                since = None
            if time.monotonic() > deadline:
                raise RunError("timed out after %s s waiting for %s" % (timeout_s, what))
            time.sleep(POLL_S)

    def done(self, what):
        r = self.c.wait_complete(10.0)
        if r == -1 or r == linuxcnc.RCS_ERROR:
            self.check_errors()
            raise RunError(what + ": command not completed")
        self.check_errors()


def run(program, g54, probe_tool, timeout_s):
    comp = hal.component("probe-display")
    comp.ready()
    x = Session()
    x.wait_for("task status", lambda s: True, 10)
    x.c.state(linuxcnc.STATE_ESTOP_RESET)
    x.wait_for("estop reset", lambda s: s.task_state == linuxcnc.STATE_ESTOP_RESET, 10)
    x.c.state(linuxcnc.STATE_ON)
    x.wait_for("machine on", lambda s: s.task_state == linuxcnc.STATE_ON, 10)
    x.c.mode(linuxcnc.MODE_MANUAL)
    x.done("manual mode")
    x.c.teleop_enable(0)
    x.done("joint mode")
    x.c.home(-1)
    x.done("home all")
    x.wait_for("homed", lambda s: all(s.homed[j] for j in range(s.joints)), 10)
    x.c.mode(linuxcnc.MODE_MDI)
    x.done("MDI mode")
    x.c.mdi("G10 L2 P1 X%.6f Y%.6f Z%.6f" % g54)
    x.done("MDI G10")
    x.wait_for("MDI G10", lambda s: s.interp_state == linuxcnc.INTERP_IDLE, 10)
    x.c.mdi("T%d M6" % probe_tool)
    x.done("MDI M6")
    x.wait_for(
        "the probe in the spindle",
        lambda s: s.tool_in_spindle == probe_tool and s.interp_state == linuxcnc.INTERP_IDLE,
        10,
    )
    x.c.mode(linuxcnc.MODE_AUTO)
    x.done("auto mode")
    x.c.program_open(program)
    x.done("program open")
    moving0 = float(hal.get_value("time-moving.out"))
    wall0 = time.monotonic()
    x.c.auto(linuxcnc.AUTO_RUN, 0)

    def finished(s):
        return (
            s.interp_state == linuxcnc.INTERP_IDLE
            and s.queue == 0
            and s.inpos
            and float(hal.get_value("time-moving.out")) > moving0
        )

    # Between a probe move and the next line the task can read as idle for
    # a moment (it synchronises with motion): the end is idle for 1 s.
    x.wait_for("program end", finished, timeout_s, hold_s=1.0)
    result = {
        "moving_s": round(float(hal.get_value("time-moving.out")) - moving0, 4),
        "wall_s": round(time.monotonic() - wall0, 3),
    }
    x.c.abort()
    x.done("abort")
    return result


def main():
    path = os.environ.get("PROBE_RESULT")
    if not path:
        print("probe_display.py: PROBE_RESULT not set", file=sys.stderr)
        return 2
    try:
        g54 = tuple(float(v) for v in os.environ.get("PROBE_G54", "0,0,0").split(","))
        probe_tool = int(os.environ.get("PROBE_TOOL", "1"))
        result = run(
            program_of(sys.argv), g54, probe_tool, float(os.environ.get("PROBE_TIMEOUT_S", "150"))
        )
        status = 0
    except Exception as err:  # every failure is reported
        result = {"error": "%s: %s" % (type(err).__name__, err)}
        status = 1
    with open(path, "a") as f:
        f.write(json.dumps(result) + "\n")
    return status


if __name__ == "__main__":
    sys.exit(main())
