#!/usr/bin/env bash
# Checks that a speed change keeps every output byte for byte: runs two
# volcomp binaries on the real programs of tests/corpus and the benchmark
# programs (moves, simulate, compensate three ways, with a map with and one
# without backlash, the machining-time estimate) and compares the hashes of
# everything they write (standard output, standard error, the compensated
# programs but for their `(date …)` header line, exit codes). Every command runs
# with --quiet but those whose arguments start with `LOUD ` (compensate as a
# user runs it: the summary and the machining times on standard error).
#
# usage: bench/same_output.sh BEFORE_BINARY [AFTER_BINARY]
#   AFTER_BINARY defaults to ./target/release/volcomp. Prints the commands
#   whose outputs differ and exits 1 if any does.
set -uo pipefail
cd "$(dirname "$0")/.."
before=$(realpath "$1")
after=$(realpath "${2:-target/release/volcomp}")
work=${BENCH_DIR:-$(mktemp -d)}
mkdir -p "$work"
python3 bench/ripple_map.py > "$work/ripple.csv"
{ echo 'units = "mm"'; echo; echo '[work_offsets]'; echo 'G54 = [0, 0, 0]'; echo; echo '[tools]'
  for i in $(seq 1 99); do echo "$i = 0"; done; } > "$work/setup.toml"
"$before" demo --out-dir "$work/demo" > /dev/null
python3 bench/gen_program.py 100000 > "$work/raster.ngc"
python3 bench/gen_cam.py 130000 > "$work/cam.nc"
python3 bench/gen_loop.py 100000 > "$work/loop.ngc"

# One command per line: NAME<TAB>ARGS (OUT stands for the output file).
cases() {
  local ripple=(--map "$work/ripple.csv" --setup "$work/setup.toml")
  for p in tests/corpus/*.nc tests/corpus/*.ngc tests/corpus/*.NC tests/corpus/*.gcode; do
    local n extra=""
    n=$(basename "$p")
    case $n in *BOTTLE.NC) extra="--absolute-arc-centers" ;; esac
    printf '%s\t%s\n' "$n.moves" "moves $p --setup $work/setup.toml $extra"
    printf '%s\t%s\n' "$n.moves-json" "moves $p --setup $work/setup.toml $extra --format json --extra-axes"
    printf '%s\t%s\n' "$n.simulate" "simulate $p ${ripple[*]} $extra --json"
    printf '%s\t%s\n' "$n.comp" "compensate $p ${ripple[*]} $extra -o OUT"
    printf '%s\t%s\n' "$n.comp-fixed" "compensate $p ${ripple[*]} $extra --segment-length 1 --arcs-as-lines -o OUT"
    printf '%s\t%s\n' "$n.comp-example" "compensate $p --map $work/demo/example_map.csv --setup $work/setup.toml --work-offset 250,200,150 $extra -o OUT"
    printf '%s\t%s\n' "$n.time" "time $p --setup $work/setup.toml $extra"
    printf '%s\t%s\n' "$n.comp-loud" "LOUD compensate $p ${ripple[*]} $extra -o OUT"
  done
  for p in "$work/raster.ngc" "$work/cam.nc" "$work/loop.ngc"; do
    local n
    n=$(basename "$p")
    printf '%s\t%s\n' "$n.moves" "moves $p"
    printf '%s\t%s\n' "$n.comp" "compensate $p --map $work/demo/example_map.csv --work-offset 250,200,150 -o OUT"
    printf '%s\t%s\n' "$n.comp-1mm" "compensate $p --map $work/demo/example_map.csv --work-offset 250,200,150 --segment-length 1 -o OUT"
    printf '%s\t%s\n' "$n.comp-ripple" "compensate $p ${ripple[*]} -o OUT"
    printf '%s\t%s\n' "$n.time" "time $p"
    printf '%s\t%s\n' "$n.comp-loud" "LOUD compensate $p --map $work/demo/example_map.csv --work-offset 250,200,150 -o OUT"
    printf '%s\t%s\n' "$n.comp-loud-stdout" "LOUD compensate $p --map $work/demo/example_map.csv --work-offset 250,200,150 -o -"
  done
}

manifest() { # BINARY -> hashes on stdout
  local bin=$1 name args out
  while IFS=$'\t' read -r name args; do
    out="$work/out.ngc"
    rm -f "$out"
    local quiet=--quiet
    [[ $args == "LOUD "* ]] && quiet="" && args=${args#LOUD }
    # shellcheck disable=SC2086
    "$bin" $quiet ${args//OUT/$out} > "$work/stdout" 2> "$work/stderr"
    local rc=$?
    printf '%s rc=%s out=%s err=%s file=%s\n' "$name" "$rc" \
      "$(grep -v '^(date ' "$work/stdout" | sha256sum | cut -c1-16)" \
      "$(sed "s#$bin#BIN#g" "$work/stderr" | sha256sum | cut -c1-16)" \
      "$( [ -e "$out" ] && grep -v '^(date ' "$out" | sha256sum | cut -c1-16 || echo none)"
  done < <(cases)
}

manifest "$before" > "$work/before.txt"
manifest "$after" > "$work/after.txt"
echo "$(wc -l < "$work/before.txt") commands; manifests in $work/before.txt, $work/after.txt"
if diff "$work/before.txt" "$work/after.txt"; then
  echo "same output"
else
  echo "OUTPUT DIFFERS"
  exit 1
fi
