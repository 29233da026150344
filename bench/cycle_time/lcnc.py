"""Run one G-code program on LinuxCNC 2.9's simulated machine (config/) and
return its simulated machining time. Used by check.py and run.py.

One LinuxCNC at a time: LinuxCNC keeps one lock file (/tmp/linuxcnc.lock)
and one set of shared-memory segments per machine, and its start-up script
stops any other running instance, so a run refuses to start while another
LinuxCNC is up rather than stop it. A lock file that no LinuxCNC process
stands behind (a run killed, or a machine started from a disk image taken
while a run was up) is stale: LinuxCNC's own script clears it ("No display,
no tty, trying to clean up other instance automatically", then its
`Cleanup other`: HAL stopped and unloaded, the lock removed; scripts/linuxcnc.in
in LinuxCNC 2.9), so a run goes ahead and says so on standard error.
"""

import json
import os
import shutil
import subprocess
import tempfile
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
CONFIG = os.path.join(HERE, "config")
LOCKFILE = "/tmp/linuxcnc.lock"
# A lock file younger than this, with no LinuxCNC process yet, may belong to
# a LinuxCNC that is starting (its script touches the lock before it starts
# the real-time host): wait and look again before calling it stale.
STALE_LOCK_AGE_S = 10.0


class LinuxCncError(Exception):
    pass


def linuxcnc_running():
    """Processes of a running LinuxCNC (its real-time host, task, server)."""
    found = []
    for name in ("rtapi_app", "milltask", "linuxcncsvr"):
        r = subprocess.run(["pidof", name], capture_output=True, text=True)
        if r.returncode == 0:
            found.append(f"{name} ({r.stdout.strip()})")
    return found


def linuxcnc_version():
    """The installed LinuxCNC package's version (Debian), or the script's."""
    r = subprocess.run(
        ["dpkg-query", "-W", "-f", "${Version}", "linuxcnc-uspace"],
        capture_output=True,
        text=True,
    )
    if r.returncode == 0 and r.stdout.strip():
        return f"linuxcnc-uspace {r.stdout.strip()}"
    return "(version unknown: not a Debian package)"


def check_installed():
    for tool in ("linuxcnc", "halcmd"):
        if shutil.which(tool) is None:
            raise LinuxCncError(
                f"`{tool}` not found: install LinuxCNC 2.9 (Debian 12: "
                "apt-get install linuxcnc-uspace)"
            )
    r = subprocess.run(
        ["/usr/bin/python3", "-c", "import linuxcnc, hal"], capture_output=True
    )
    if r.returncode != 0:
        raise LinuxCncError(
            "/usr/bin/python3 cannot import the `linuxcnc` and `hal` modules "
            "(they come with linuxcnc-uspace)"
        )


MOTION_TIMEOUT = "motion controller timed out (host overloaded)"
USRMOT_TIMEOUT = "USRMOT: ERROR: command timeout"

# Failures of the machine's start-up (before the program is opened) that a
# loaded machine shows now and then ("timed out after 10 s waiting for
# machine on", "home all: command not completed"): the run is started again,
# at most START_RETRIES more times. A program's own error is never retried.
# A run whose motion controller missed a command's deadline (LinuxCNC's
# usrmotintf.cc prints "USRMOT: ERROR: command timeout" when the real-time
# thread did not answer in time: a host too loaded for its servo thread) is
# started again too: the error is the host's, not the program's.
START_FAILURES = ("waiting for machine on", "waiting for estop reset",
                  "waiting for task status", "home all", "waiting for all joints homed",
                  "Must be in MDI mode", "joint mode: command not completed",
                  "manual mode: command not completed", MOTION_TIMEOUT)
START_RETRIES = 2


def work_dir(prefix):
    """The folder a script works in: its first argument, else a new
    temporary folder named `prefix`...; LinuxCNC is checked installed."""
    work = sys.argv[1] if len(sys.argv) > 1 else tempfile.mkdtemp(prefix=prefix)
    os.makedirs(work, exist_ok=True)
    check_installed()
    return work


def run_text(text, program, work_dir):
    """Writes the program `text` to the file `program` and runs it
    (`run_program`)."""
    with open(program, "w") as f:
        f.write(text)
    return run_program(program, work_dir)


def exit_with(main, script):
    """Exits with what `main()` returns; a LinuxCncError is told as
    `script: error` on standard error, with exit status 1."""
    try:
        sys.exit(main())
    except LinuxCncError as err:
        print(f"{script}: {err}", file=sys.stderr)
        sys.exit(1)


def run_program(program, work_dir, timeout_s=None):
    """`run_once`, started again where the machine failed to start up
    (START_FAILURES; at most START_RETRIES more times)."""
    for attempt in range(START_RETRIES + 1):
        try:
            return run_once(program, work_dir, timeout_s)
        except LinuxCncError as err:
            text = str(err).split("\n", 1)[0]
            if attempt == START_RETRIES or not any(f in text for f in START_FAILURES):
                raise
            print(f"lcnc: start-up failed ({text[-80:]}); starting again", file=sys.stderr)


def lock_age_s():
    """Age of LinuxCNC's lock file in seconds, or None where there is none."""
    try:
        return time.time() - os.stat(LOCKFILE).st_mtime
    except FileNotFoundError:
        return None


def check_no_other_linuxcnc():
    """Raises LinuxCncError while another LinuxCNC runs on this machine.

    A lock file with no LinuxCNC process behind it is stale once it is
    STALE_LOCK_AGE_S old (waited for where it is younger): the run goes
    ahead, LinuxCNC's script clears it, and standard error says so.
    """
    running = linuxcnc_running()
    age = lock_age_s()
    if not running and age is not None and age < STALE_LOCK_AGE_S:
        time.sleep(STALE_LOCK_AGE_S - age)
        running = linuxcnc_running()
        age = lock_age_s()
    if running or (age is not None and age < STALE_LOCK_AGE_S):
        raise LinuxCncError(
            f"another LinuxCNC is running ({', '.join(running) or LOCKFILE + ' just written'}): "
            "wait for it to end, or stop it yourself if it is yours"
        )
    if age is not None:
        print(
            f"lcnc: {LOCKFILE} is {age:.0f} s old and no LinuxCNC process runs: "
            "a stale lock, which LinuxCNC's start-up script clears",
            file=sys.stderr,
        )


def run_once(program, work_dir, timeout_s=None):
    """Runs `program` once on a fresh copy of config/ under `work_dir`.

    Returns the display's result: moving_s (simulated time from the first
    motion to the end of the last, s), feed_s (time with a G1/G2/G3 active,
    s), end_machine_mm, wall_s. Raises LinuxCncError, with LinuxCNC's own
    log, when the run fails or takes longer than `timeout_s` (wall clock;
    default CT_TIMEOUT_S from the environment, else 600 s: a loaded machine
    runs the simulation slower than real time, the figures stay exact).
    """
    if timeout_s is None:
        timeout_s = float(os.environ.get("CT_TIMEOUT_S", "600"))
    program = os.path.abspath(program)
    if not os.path.isfile(program):
        raise LinuxCncError(f"{program}: no such program")
    check_no_other_linuxcnc()
    os.makedirs(work_dir, exist_ok=True)
    run_dir = tempfile.mkdtemp(prefix="run-", dir=work_dir)
    machine = os.path.join(run_dir, "machine")
    shutil.copytree(CONFIG, machine)
    result_path = os.path.join(run_dir, "result.jsonl")
    env = dict(os.environ)
    env.update(
        CT_RESULT=result_path,
        CT_LOG=os.path.join(run_dir, "display.log"),
        CT_RUN_TIMEOUT_S=str(timeout_s),
        # LinuxCNC copies its logs to $HOME when it fails: keep them here.
        HOME=run_dir,
    )
    if os.geteuid() == 0:
        # uspace rtapi_app refuses to run as root unless given a user to
        # fall back to (src/rtapi/uspace_rtapi_app.cc); it then creates its
        # socket as that user, so the socket's folder (and every folder above
        # it) must be open to them: a folder of its own under /tmp.
        uid = int(env.get("RTAPI_UID", "65534"))
        fifo_dir = tempfile.mkdtemp(prefix="ct-rtapi-", dir="/tmp")
        os.chown(fifo_dir, uid, -1)
        env["RTAPI_UID"] = str(uid)
        env["RTAPI_FIFO_PATH"] = os.path.join(fifo_dir, "rtapi_fifo")
    else:
        fifo_dir = None
    cmd = ["linuxcnc", os.path.join(machine, "machine.ini"), program]
    t0 = time.monotonic()
    try:
        proc = subprocess.run(
            cmd,
            env=env,
            cwd=run_dir,
            stdin=subprocess.DEVNULL,
            capture_output=True,
            text=True,
            timeout=timeout_s + 60.0,
        )
    except subprocess.TimeoutExpired:
        raise LinuxCncError(
            f"{program}: LinuxCNC did not finish within {timeout_s + 60.0:.0f} s "
            f"(logs in {run_dir})"
        )
    finally:
        if fifo_dir is not None:
            shutil.rmtree(fifo_dir, ignore_errors=True)
    results = []
    if os.path.exists(result_path):
        with open(result_path) as f:
            results = [json.loads(line) for line in f if line.strip()]
    if proc.returncode != 0 or len(results) != 1 or "error" in results[0]:
        detail = results[0].get("error") if results else "no result written"
        printed = os.path.join(run_dir, "linuxcnc_print.txt")
        if os.path.exists(printed):
            with open(printed) as f:
                if USRMOT_TIMEOUT in f.read():
                    detail = f"{MOTION_TIMEOUT}: {detail}"
        logs = ""
        for name in ("linuxcnc_debug.txt", "display.log"):
            p = os.path.join(run_dir, name)
            if os.path.exists(p):
                with open(p) as f:
                    # rtapi_app says this once per module loaded: noise here.
                    kept = [x for x in f if not x.startswith("Running with fallback_uid")]
                logs += f"\n--- {name} (end) ---\n" + "".join(kept[-20:])
        raise LinuxCncError(
            f"{program}: LinuxCNC run failed (exit {proc.returncode}): {detail}"
            f"{logs}\n(run folder {run_dir})"
        )
    result = results[0]
    result["run_wall_s"] = round(time.monotonic() - t0, 3)
    result["run_dir"] = run_dir
    return result
