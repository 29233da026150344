#!/usr/bin/env bash
# Reproduces the speed figures in BENCHMARKS.md: volcomp against LinuxCNC's
# rs274 on the same programs, side by side in one alternating run
# (bench/alternate.py: every round runs each command once, the order
# rotating, so a change of load falls on all alike; medians, CPU time and
# peak memory per command).
#
# Programs: a real CAM program (bench/gen_cam.py: CAMotics' tiger.nc
# repeated to 1,011,376 lines), the generated raster (bench/gen_program.py,
# 1,000,020 lines) and the while-loop (bench/gen_loop.py, 1,000,000 moves).
# `moves` reads ten times as many lines (MOVES_LINES, default 10,000,000:
# 1 M lines take it 0.1-0.2 s, too short for a few rounds to tell builds
# apart), side by side with `rs274 -g` on the same files; both write to
# /dev/null (the CSV would be ~0.5 GB), and GNU time's peak is the memory
# at 10 M lines.
#
# Needs: rs274 (Debian: linuxcnc-uspace), GNU time, python3, a release build.
# Environment: ROUNDS (default 5); MOVES_LINES (default 10000000); VOLCOMP (a volcomp binary instead of
# this checkout's release build); BASE (a second volcomp binary, e.g. the
# previous release, timed in the same rounds); MEM_10M=1 also measures peak
# memory on the 10-million-line programs.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ -z "${VOLCOMP:-}" ]; then
  cargo build --release -q
  VOLCOMP=./target/release/volcomp
fi
vc=$(realpath "$VOLCOMP")
work=${BENCH_DIR:-$(mktemp -d)}
mkdir -p "$work"
rounds=${ROUNDS:-5}
python3 bench/gen_cam.py 1000000 > "$work/cam.nc"
python3 bench/gen_program.py 1000000 > "$work/raster.ngc"
python3 bench/gen_loop.py 1000000 > "$work/loop.ngc"
for i in $(seq 1 99); do echo "T$i P$i Z0 D0"; done > "$work/tools.tbl"
"$vc" demo --out-dir "$work/demo" > /dev/null
map="--map $work/demo/example_map.csv --work-offset 250,200,150"

# NAME=COMMAND arguments for one program: rs274 first (the reference), then
# each volcomp binary's compensate: the defaults as a user runs them (the
# summary on standard error with the machining-time estimate of both
# programs), with --quiet (no estimate), and with 1 mm segments.
commands() {
  local p=$1 n
  n=$(basename "$p")
  echo "rs274 -g=rs274 -g -t $work/tools.tbl $p $work/rs274.out < /dev/null > /dev/null"
  for b in ${BASE:+base=$(realpath "$BASE")} "new=$vc"; do
    local tag=${b%%=*} bin=${b#*=}
    echo "compensate ($tag)=$bin compensate $p $map -o $work/$n.$tag.comp.ngc 2> /dev/null"
    echo "compensate --quiet ($tag)=$bin --quiet compensate $p $map -o $work/$n.$tag.comp.ngc"
    echo "compensate 1 mm ($tag)=$bin --quiet compensate $p $map --segment-length 1 -o $work/$n.$tag.1mm.ngc"
  done
}

for p in "$work/cam.nc" "$work/raster.ngc"; do
  echo "## $(basename "$p"): $(wc -l < "$p") lines (load: $(cut -d' ' -f1-3 /proc/loadavg))"
  mapfile -t cmds < <(commands "$p")
  python3 bench/alternate.py --rounds "$rounds" "${cmds[@]}"
done

# `moves` at MOVES_LINES lines: rs274 and each binary, output to /dev/null.
moves_lines=${MOVES_LINES:-10000000}
python3 bench/gen_cam.py "$moves_lines" > "$work/cam_moves.nc"
python3 bench/gen_program.py "$moves_lines" > "$work/raster_moves.ngc"
for p in "$work/cam_moves.nc" "$work/raster_moves.ngc"; do
  echo "## moves, $(basename "$p"): $(wc -l < "$p") lines (load: $(cut -d' ' -f1-3 /proc/loadavg))"
  cmds=("rs274 -g=rs274 -g -t $work/tools.tbl $p /dev/null < /dev/null > /dev/null")
  [ -n "${BASE:-}" ] && cmds+=("moves (base)=$(realpath "$BASE") moves $p > /dev/null")
  cmds+=("moves (new)=$vc moves $p > /dev/null")
  python3 bench/alternate.py --rounds "$rounds" "${cmds[@]}"
done
rm -f "$work/cam_moves.nc" "$work/raster_moves.ngc"

echo "## loop.ngc: a while-loop of 1,000,000 moves (load: $(cut -d' ' -f1-3 /proc/loadavg))"
loop=("rs274 -g=rs274 -g -t $work/tools.tbl $work/loop.ngc $work/rs274.out < /dev/null > /dev/null")
[ -n "${BASE:-}" ] && loop+=("moves (base)=$(realpath "$BASE") moves $work/loop.ngc > $work/loop.base.csv")
loop+=("moves (new)=$vc moves $work/loop.ngc > $work/loop.new.csv")
python3 bench/alternate.py --rounds "$rounds" "${loop[@]}"

if [ "${MEM_10M:-}" = 1 ]; then
  echo "## peak memory at 10 M lines"
  python3 bench/gen_cam.py 10000000 > "$work/cam10.nc"
  python3 bench/gen_program.py 10000000 > "$work/raster10.ngc"
  for p in "$work/cam10.nc" "$work/raster10.ngc"; do
    for cmd in "moves $p" "compensate $p $map --max-output-size none -o $work/out10.ngc"; do
      # shellcheck disable=SC2086
      /usr/bin/time -f "%M KiB peak, %e s: volcomp ${cmd%% *} $(basename "$p") ($(wc -l < "$p") lines)" \
        "$vc" --quiet $cmd > /dev/null
    done
  done
  rm -f "$work/cam10.nc" "$work/raster10.ngc" "$work/out10.ngc"
fi
