#!/usr/bin/python3
"""Headless "display" of the cycle-time benchmark: runs one program on
LinuxCNC and writes its simulated machining time.

LinuxCNC's `linuxcnc` script starts it as `ct_display.py -ini INIFILE
PROGRAM` ([DISPLAY] DISPLAY in machine.ini) once HAL, motion and task are up,
and shuts LinuxCNC down when it exits. It uses the `linuxcnc` Python module
(LinuxCNC's documented Python interface, "Python Interface" chapter of the
LinuxCNC 2.9 manual: linuxcnc.stat / command / error_channel), the same
steps an operator takes: estop reset, machine on, home all, MDI the G54
offset, auto, open, run, wait until the interpreter is idle and motion is
done. The simulated time is read from the servo-thread timers of
machine.hal with the `hal` module (hal.get_value).

The result is one JSON line appended to the file named by the environment
variable CT_RESULT (the `linuxcnc` script sends the display's own standard
output to a temporary log it deletes). On any error (an error message from
LinuxCNC, a state not reached within its time limit) the line holds
"error" and the exit status is 1, which `linuxcnc` passes on.
"""

import json
import os
import sys
import time

import hal
import linuxcnc

# G54 of the benchmark machine, mm (the demo's work offset).
G54_MM = (250.0, 200.0, 150.0)
POLL_S = 0.005
LOG = None


def log(text):
    """One time-stamped line to the file named by CT_LOG (if set)."""
    if LOG:
        with open(LOG, "a") as f:
            f.write(f"{time.strftime('%H:%M:%S')} {text}\n")


class RunError(Exception):
    pass


def parse_args(argv):
    program = None
    i = 1
    while i < len(argv):
        if argv[i] == "-ini":
            i += 2
            continue
        program = argv[i]
        i += 1
    if program is None:
        raise RunError("no program given (linuxcnc machine.ini PROGRAM)")
    return os.path.abspath(program)


def pin_value(pin):
    """A HAL pin's value, as a Python float (the full double)."""
    return float(hal.get_value(pin))


class Session:
    def __init__(self):
        self.s = linuxcnc.stat()
        self.c = linuxcnc.command()
        self.e = linuxcnc.error_channel()
        self.messages = []

    def check_errors(self):
        while True:
            msg = self.e.poll()
            if not msg:
                return
            kind, text = msg
            if kind in (linuxcnc.NML_ERROR, linuxcnc.OPERATOR_ERROR):
                raise RunError(f"LinuxCNC error: {text}")
            self.messages.append(text)

    def wait_for(self, what, predicate, timeout_s):
        log(f"waiting for {what}")
        deadline = time.monotonic() + timeout_s
        next_report = time.monotonic() + 1.0
        s_ = self.s
        while True:
            self.s.poll()
            self.check_errors()
            if predicate(self.s):
                return
            now = time.monotonic()
            if now > next_report:
                next_report = now + 1.0
                log(
                    f"  interp {s_.interp_state} exec {s_.exec_state} queue {s_.queue}"
                    f" inpos {s_.inpos} line {s_.motion_line} pos {s_.position[:3]}"
                )
            if now > deadline:
                raise RunError(f"timed out after {timeout_s} s waiting for {what}")
            time.sleep(POLL_S)

    def command_done(self, what):
        log(f"command: {what}")
        # wait_complete returns -1 on timeout, RCS_ERROR when the command failed.
        r = self.c.wait_complete(10.0)
        if r == -1 or r == linuxcnc.RCS_ERROR:
            self.check_errors()
            raise RunError(f"{what}: command not completed (wait_complete {r})")
        self.check_errors()


def run(program, run_timeout_s):
    # hal.get_value needs this process to be a HAL component (no pins).
    comp = hal.component("ct-display")
    comp.ready()
    x = Session()
    # NML channels are up when the display starts; poll once to be sure.
    x.wait_for("task status", lambda s: True, 10)

    x.c.state(linuxcnc.STATE_ESTOP_RESET)
    x.wait_for("estop reset", lambda s: s.task_state == linuxcnc.STATE_ESTOP_RESET, 10)
    x.c.state(linuxcnc.STATE_ON)
    x.wait_for("machine on", lambda s: s.task_state == linuxcnc.STATE_ON, 10)

    x.c.mode(linuxcnc.MODE_MANUAL)
    x.command_done("manual mode")
    # Homing is per joint: joint mode (teleop off), then home all (-1).
    x.c.teleop_enable(0)
    x.command_done("joint mode")
    x.c.home(-1)
    x.command_done("home all")
    x.wait_for("all joints homed", lambda s: all(s.homed[j] for j in range(s.joints)), 10)

    x.c.mode(linuxcnc.MODE_MDI)
    x.command_done("MDI mode")
    x.c.mdi("G10 L2 P1 X%.4f Y%.4f Z%.4f" % G54_MM)
    x.command_done("MDI G10")
    x.wait_for("MDI G10", lambda s: s.interp_state == linuxcnc.INTERP_IDLE, 10)
    x.s.poll()
    if any(abs(a - b) > 1e-9 for a, b in zip(x.s.g5x_offset[:3], G54_MM)):
        raise RunError(f"G54 not set: {x.s.g5x_offset[:3]}")

    # CT_MDI: a file of MDI lines to run one at a time instead of the
    # program, reading the CT_PINS after each once motion has stopped
    # (crates/volcomp-cli/tests/linuxcnc_backlash.rs samples the joints'
    # compensation at its stops this way).
    mdi_file = os.environ.get("CT_MDI")
    if mdi_file:
        names = os.environ.get("CT_PINS", "").split()
        stops = []
        with open(mdi_file) as f:
            for raw in (l.strip() for l in f):
                if not raw:
                    continue
                # "LINE<TAB>J:V J:V": wait until joint J's pos-cmd is V
                # (status seen just after an MDI may still be the one
                # before its move starts).
                line, _, ends = raw.partition("\t")
                targets = [(int(j), float(v)) for j, v in (e.split(":") for e in ends.split())]
                x.c.mdi(line)
                x.command_done(f"MDI {line}")
                x.wait_for(
                    f"MDI {line}",
                    lambda s: s.interp_state == linuxcnc.INTERP_IDLE
                    and s.queue == 0
                    and s.inpos
                    and all(abs(pin_value(f"joint.{j}.pos-cmd") - v) < 1e-6 for j, v in targets),
                    30,
                )
                stops.append({"mdi": line, "pins": {p: pin_value(p) for p in names}})
        return {"program": program, "stops": stops, "messages": x.messages}

    x.c.mode(linuxcnc.MODE_AUTO)
    x.command_done("auto mode")
    x.c.program_open(program)
    x.command_done("program open")

    moving0_s = pin_value("ct-time-moving.out")
    feed0_s = pin_value("ct-time-feed.out")
    wall0 = time.monotonic()
    # No wait_complete here: the run command completes only with the program.
    x.c.auto(linuxcnc.AUTO_RUN, 0)
    log("command: run")

    def finished(s):
        # Idle interpreter, empty motion queue, in position, and the
        # program has moved (a short program may be over before the first
        # poll, so "was busy once" is not the test).
        return (
            s.interp_state == linuxcnc.INTERP_IDLE
            and s.queue == 0
            and s.inpos
            and pin_value("ct-time-moving.out") > moving0_s
        )

    x.wait_for("program end", finished, run_timeout_s)
    wall_s = time.monotonic() - wall0
    moving_s = pin_value("ct-time-moving.out") - moving0_s
    feed_s = pin_value("ct-time-feed.out") - feed0_s
    x.s.poll()
    end = list(x.s.position[:3])
    if moving_s <= 0.0:
        raise RunError("the program made no motion")
    # CT_PINS: HAL pins to report as they stand at the end (blank-separated;
    # bench/lcnc_backlash.py reads the joints' backlash-corr).
    pins = {p: pin_value(p) for p in os.environ.get("CT_PINS", "").split()}
    x.c.abort()
    x.command_done("abort")
    return {
        "pins": pins,
        "program": program,
        "moving_s": round(moving_s, 6),
        "feed_s": round(feed_s, 6),
        "end_machine_mm": [round(v, 6) for v in end],
        "wall_s": round(wall_s, 3),
        "messages": x.messages,
    }


def main():
    global LOG
    LOG = os.environ.get("CT_LOG")
    result_path = os.environ.get("CT_RESULT")
    if not result_path:
        print("ct_display.py: CT_RESULT (result file) not set", file=sys.stderr)
        return 2
    timeout_s = float(os.environ.get("CT_RUN_TIMEOUT_S", "600"))
    try:
        program = parse_args(sys.argv)
        result = run(program, timeout_s)
        status = 0
    except Exception as err:  # every failure is reported, none is a number
        result = {"error": f"{type(err).__name__}: {err}"}
        status = 1
    log(f"result: {result}")
    with open(result_path, "a") as f:
        f.write(json.dumps(result) + "\n")
    return status


if __name__ == "__main__":
    sys.exit(main())
