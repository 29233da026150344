#!/usr/bin/env bash
# Cycle time of compensated programs against their originals on LinuxCNC
# 2.9's trajectory planner (README.md in this folder). Needs linuxcnc-uspace.
#   bench/cycle_time/run.sh [VOLCOMP]    (default: target/release/volcomp)
# Work folder: $BENCH_DIR, or a new temporary one. First the hand check
# (check.py: single moves against the closed-form trapezoid), then the table
# (run.py). Any failure stops the script with a non-zero status.
# One LinuxCNC on the machine at a time: the whole run holds the team's lock
# /tmp/volcomp-linuxcnc.lock (do not wrap this script in another flock on it).
set -euo pipefail
exec 9>/tmp/volcomp-linuxcnc.lock
if ! flock -n 9; then
  echo "cycle_time: waiting for /tmp/volcomp-linuxcnc.lock (another LinuxCNC run)" >&2
  flock 9
fi
here=$(cd "$(dirname "$0")" && pwd)
vc=${1:-$here/../../target/release/volcomp}
work=${BENCH_DIR:-$(mktemp -d /tmp/cycle-time-XXXXXX)}
mkdir -p "$work"
echo "cycle_time: work folder $work" >&2
if [ -z "${CT_SKIP_CHECK:-}" ]; then
  /usr/bin/python3 "$here/check.py" "$work/check"
fi
/usr/bin/python3 "$here/run.py" "$vc" "$work"
