#!/usr/bin/env bash
# Cycle time of compensated programs against their originals on LinuxCNC
# 2.9's trajectory planner (README.md in this folder). Needs linuxcnc-uspace.
#   bench/cycle_time/run.sh [VOLCOMP]    (default: target/release/volcomp)
# Work folder: $BENCH_DIR, or a new temporary one. First the hand check
# (check.py: single moves against the closed-form trapezoid), then the table
# (run.py). Any failure stops the script with a non-zero status.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
vc=${1:-$here/../../target/release/volcomp}
work=${BENCH_DIR:-$(mktemp -d /tmp/cycle-time-XXXXXX)}
mkdir -p "$work"
echo "cycle_time: work folder $work" >&2
/usr/bin/python3 "$here/check.py" "$work/check"
/usr/bin/python3 "$here/run.py" "$vc" "$work"
