#!/usr/bin/env bash
# Canned cycles kept as cycles (docs/compensation.md, "Canned cycles"): per
# program, output blocks / input blocks of `volcomp compensate` with the
# ripple map of bench/ripple_map.py at the default contour tolerance (0.1 µm)
# and at 1 µm and 3 µm, and how many holes were kept as cycles / written as
# moves; with BEFORE=<binary>, that binary's ratio at the default too.
# Usage: [BEFORE=old/volcomp] bench/cycle_blocks.sh VOLCOMP PROGRAM...
set -uo pipefail
vc=$1; shift
here=$(cd "$(dirname "$0")" && pwd)
work=${BENCH_DIR:-$(mktemp -d)}
mkdir -p "$work"
python3 "$here/ripple_map.py" > "$work/ripple.csv"
# Work offsets zero, tools 1 … 99 of length 0 (as bench/compact.sh).
{ printf 'units = "mm"\n[work_offsets]\nG54 = [0, 0, 0]\n[tools]\n'
  for i in $(seq 1 99); do echo "$i = 0"; done; } > "$work/setup.toml"
blocks() { python3 "$here/blocks.py" "$1" | cut -d' ' -f1; }
ratio() { python3 -c "print('x%.2f' % ($1 / $2))"; }
echo "| program | blocks in | before | 0.1 µm | 1 µm | 3 µm | holes kept / written as moves (0.1 / 1 / 3 µm) |"
echo "|---|---:|---:|---:|---:|---:|---|"
for p in "$@"; do
  in=$(blocks "$p")
  before=-
  if [ -n "${BEFORE:-}" ]; then
    rm -f "$work/before.ngc"
    "$BEFORE" compensate "$p" --map "$work/ripple.csv" --setup "$work/setup.toml" \
      -o "$work/before.ngc" --max-output-size none >/dev/null 2>&1 &&
      before=$(ratio "$(blocks "$work/before.ngc")" "$in")
  fi
  row="| $(basename "$p") | $in | $before"; holes=""
  for tol in 0.1 1 3; do
    out="$work/after-$tol.ngc"; rm -f "$out"
    if "$vc" compensate "$p" --map "$work/ripple.csv" --setup "$work/setup.toml" \
        -o "$out" --max-output-size none --contour-tolerance-um "$tol" >/dev/null 2>&1; then
      row="$row | $(ratio "$(blocks "$out")" "$in")"
      kept=$(grep -cE '^[^(;]*G(73|8[1-35-9])([^0-9]|$)' "$out")
      holes="$holes $kept/$(grep -c 'cycle expanded' "$out")"
    else
      row="$row | refused"; holes="$holes -"
    fi
  done
  echo "$row |$holes |"
done
