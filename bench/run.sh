#!/usr/bin/env bash
# Reproduces the figures in BENCHMARKS.md: volcomp against LinuxCNC's rs274
# on the same 1,000,000-line program, side by side in one hyperfine run.
# Needs: hyperfine, rs274 (Debian: linuxcnc-uspace), a release build.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q
work=${BENCH_DIR:-$(mktemp -d)}
mkdir -p "$work"
python3 bench/gen_program.py 1000000 > "$work/big.ngc"
for i in $(seq 1 99); do echo "T$i P$i Z0 D0"; done > "$work/tools.tbl"
./target/release/volcomp demo --out-dir "$work/demo" > /dev/null
vc=./target/release/volcomp
hyperfine --warmup 1 --runs ${RUNS:-5} --export-markdown "$work/moves.md" \
  -n "rs274 -g" "rs274 -g -t $work/tools.tbl $work/big.ngc $work/rs274.out < /dev/null" \
  -n "volcomp moves" "$vc moves $work/big.ngc > $work/moves.csv" \
  -n "volcomp compensate (1 mm)" "$vc compensate $work/big.ngc --map $work/demo/example_map.csv --work-offset 250,200,150 --segment-length 1 -o $work/big.comp.ngc"
cat "$work/moves.md"
for cmd in "moves $work/big.ngc" "compensate $work/big.ngc --map $work/demo/example_map.csv --work-offset 250,200,150 --segment-length 1 -o $work/big.comp.ngc"; do
  /usr/bin/time -f "max RSS %M KiB: volcomp ${cmd%% *}" $vc $cmd > /dev/null 2> "$work/time.txt" || true
  tail -1 "$work/time.txt"
done
# Control flow: a 16-line program whose while-loop executes 1,000,000 feed
# moves (bench/gen_loop.py), read by both interpreters.
python3 bench/gen_loop.py 1000000 > "$work/loop.ngc"
hyperfine --warmup 1 --runs ${RUNS:-5} --export-markdown "$work/loop.md" \
  -n "rs274 -g (loop)" "rs274 -g -t $work/tools.tbl $work/loop.ngc $work/rs274-loop.out < /dev/null" \
  -n "volcomp moves (loop)" "$vc moves $work/loop.ngc > $work/loop.csv"
cat "$work/loop.md"
/usr/bin/time -f "max RSS %M KiB: volcomp moves (loop)" $vc moves "$work/loop.ngc" > /dev/null 2> "$work/time.txt" || true
tail -1 "$work/time.txt"
