#!/usr/bin/env bash
# Checks that a change keeps every machining-time estimate: runs two volcomp
# binaries on the planner fixtures, bench/cycle_time's programs, the real
# programs of tests/corpus, the benchmark programs (shortened) and random
# programs (bench/gen_random_moves.py, half of them with parameters and
# expressions, half with feeds per revolution), under four set-ups (no
# [limits]; the benchmark machine's limits; the same with arc blends off;
# slow axes with a slow blend ramp), and compares
#   * `volcomp time --json` of each program (every figure it prints, times
#     to the ms, counts of moves and waits), also with no set-up at all;
#   * the estimates of both programs in the summary of `volcomp compensate`
#     run as a user runs it (the original's and the compensated program's
#     machining times, as printed), with the exit code and the rest of the
#     summary;
#   * `volcomp time --json` of the compensated program beside the original
#     (`--reference`), which `volcomp compensate` must agree with.
#
# usage: bench/same_estimates.sh BEFORE_BINARY [AFTER_BINARY]
#   AFTER_BINARY defaults to ./target/release/volcomp. Prints the cases whose
#   estimates differ and exits 1 if any does. Environment: RANDOM_PROGRAMS
#   (default 64), BENCH_DIR (scratch directory).
set -uo pipefail
cd "$(dirname "$0")/.."
before=$(realpath "$1")
after=$(realpath "${2:-target/release/volcomp}")
work=${BENCH_DIR:-$(mktemp -d)}
mkdir -p "$work/programs"
n_random=${RANDOM_PROGRAMS:-64}

"$before" demo --out-dir "$work/demo" > /dev/null
map="$work/demo/example_map.csv"

# Set-ups: all with the benchmark machine's start and G54 (the programs are
# written for it, and the example map covers them there).
head_toml='units = "mm"
start = [0, 0, 0]
[work_offsets]
G54 = [250.0, 200.0, 150.0]'
printf '%s\n' "$head_toml" > "$work/no-limits.toml"
printf '%s\n[limits]\nmax_velocity = [166.7, 166.7, 166.7]\nmax_acceleration = [1000, 1000, 1000]\ntraj_max_velocity = 166.7\nservo_period = 0.001\n' \
  "$head_toml" > "$work/limits.toml"
printf '%s\n[limits]\nmax_velocity = [166.7, 166.7, 166.7]\nmax_acceleration = [1000, 1000, 1000]\ntraj_max_velocity = 166.7\nservo_period = 0.001\narc_blend_enable = false\n' \
  "$head_toml" > "$work/no-blends.toml"
printf '%s\n[limits]\nmax_velocity = [50, 30, 20]\nmax_acceleration = [300, 200, 100]\ntraj_max_velocity = 60\nservo_period = 0.001\narc_blend_ramp_freq = 20\nmax_feed_override = 1.5\n' \
  "$head_toml" > "$work/slow.toml"
setups=(no-limits limits no-blends slow)

# Programs.
p=$work/programs
cp crates/volcomp-core/tests/fixtures/planner/programs/*.ngc "$p/"
cp bench/cycle_time/programs/*.ngc bench/cycle_time/planner_programs/*.ngc "$p/"
for f in tests/corpus/*.nc tests/corpus/*.ngc tests/corpus/*.NC tests/corpus/*.gcode; do
  cp "$f" "$p/corpus.$(basename "$f")"
done
python3 bench/gen_program.py 20000 > "$p/raster.ngc"
python3 bench/gen_cam.py 30000 > "$p/cam.nc"
python3 bench/gen_loop.py 20000 > "$p/loop.ngc"
for s in $(seq 1 "$n_random"); do
  # Every other one with expressions, every fourth with G95.
  opts=()
  [ $((s % 2)) = 0 ] && opts+=(--expressions)
  [ $((s % 4)) -ge 2 ] && opts+=(--per-rev)
  python3 bench/gen_random_moves.py "$s" 400 "${opts[@]}" > "$p/random$s.ngc"
done

# One case per line: NAME<TAB>KIND<TAB>PROGRAM<TAB>SETUP ("" for none).
cases() {
  local f n s extra
  for f in "$p"/*; do
    n=$(basename "$f")
    printf '%s\t%s\t%s\t%s\n' "$n.time" time "$f" ""
    for s in "${setups[@]}"; do
      printf '%s\t%s\t%s\t%s\n' "$n.time.$s" time "$f" "$work/$s.toml"
      printf '%s\t%s\t%s\t%s\n' "$n.comp.$s" comp "$f" "$work/$s.toml"
    done
  done
}

manifest() { # BINARY -> one line per case on stdout
  local bin=$1 name kind prog setup out=$work/out.ngc extra
  while IFS=$'\t' read -r name kind prog setup; do
    extra=""
    case $prog in *BOTTLE.NC) extra="--absolute-arc-centers" ;; esac
    case $kind in
      time)
        # shellcheck disable=SC2086
        "$bin" --quiet time "$prog" ${setup:+--setup "$setup"} $extra --json \
          > "$work/stdout" 2> "$work/stderr"
        printf '%s rc=%s %s err=%s\n' "$name" "$?" "$(tr -d '\n' < "$work/stdout")" \
          "$(sed "s#$bin#BIN#g" "$work/stderr" | sha256sum | cut -c1-16)"
        ;;
      comp)
        rm -f "$out"
        # shellcheck disable=SC2086
        "$bin" compensate "$prog" --map "$map" --setup "$setup" $extra -o "$out" \
          > /dev/null 2> "$work/stderr"
        local rc=$?
        printf '%s rc=%s %s err=%s\n' "$name" "$rc" \
          "$(grep '^volcomp: machining time' "$work/stderr" | tr -d '\n')" \
          "$(sed "s#$bin#BIN#g" "$work/stderr" | sha256sum | cut -c1-16)"
        if [ -e "$out" ]; then
          # shellcheck disable=SC2086
          "$bin" --quiet time "$out" --reference "$prog" --setup "$setup" $extra --json \
            > "$work/stdout" 2> /dev/null
          printf '%s.reference rc=%s %s\n' "$name" "$?" "$(tr -d '\n' < "$work/stdout")"
        fi
        ;;
    esac
  done < <(cases)
}

manifest "$before" > "$work/before.txt"
manifest "$after" > "$work/after.txt"
echo "$(wc -l < "$work/before.txt") estimates ($(grep -c 'rc=0' "$work/before.txt") exit 0); manifests in $work/before.txt, $work/after.txt"
if diff "$work/before.txt" "$work/after.txt"; then
  echo "same estimates"
else
  echo "ESTIMATES DIFFER"
  exit 1
fi
