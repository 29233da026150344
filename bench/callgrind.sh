#!/usr/bin/env bash
# Instruction counts (valgrind's callgrind) of the CPU figures BENCHMARKS.md
# quotes as "cam20k", "cam50k" and "time cam50k". Instruction counts repeat
# under load where wall time does not, so two builds can be compared on a
# busy machine; they miss what real cores pay for cache misses and copies, so
# a change that moves data needs `bench/run.sh` on a quiet machine as well.
#
#   bench/callgrind.sh VOLCOMP TAG [OUT_DIR]
#
# Programs (made here, into OUT_DIR, default a new temporary folder):
#   cam20k.nc      bench/gen_cam.py 20000 (67,426 lines of real CAM output, G64)
#   cam20k_g61.nc  the same under G61 (its first block's G64 written G61)
#   cam50k.nc      cam20k's first 50,000 lines and M30
# Map: `volcomp demo`'s example map, work offset 250,200,150.
# Runs:
#   q20k    `--quiet compensate cam20k.nc`
#   q20kg61 `--quiet compensate cam20k_g61.nc`
#   d50k    `compensate cam50k.nc` (the defaults: the machining-time
#           estimates run on threads of their own, counted apart)
#   time    `time cam50k.nc --setup bench/cycle_time/setup.toml --json`
# Prints callgrind's "Collected" line per run (d50k: one per thread); the
# callgrind files stay in OUT_DIR (callgrind_annotate reads them).
# Needs: valgrind, python3.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ $# -lt 2 ]; then
  echo "usage: bench/callgrind.sh VOLCOMP TAG [OUT_DIR]" >&2
  exit 2
fi
vc=$(realpath "$1")
tag=$2
out=${3:-$(mktemp -d)}
mkdir -p "$out"
setup=$(realpath bench/cycle_time/setup.toml)
python3 bench/gen_cam.py 20000 > "$out/cam20k.nc"
sed '1s/G64/G61/' "$out/cam20k.nc" > "$out/cam20k_g61.nc"
{ head -n 50000 "$out/cam20k.nc"; echo M30; } > "$out/cam50k.nc"
"$vc" demo --out-dir "$out/demo" > /dev/null
map=(--map "$out/demo/example_map.csv" --work-offset 250,200,150)
cd "$out"
run() { # NAME ARGS...: one callgrind run, its log beside its profile
  local name=$1
  shift
  valgrind --tool=callgrind --separate-threads=yes --callgrind-out-file="cg.$tag.$name" "$@" \
    > /dev/null 2> "cg.$tag.$name.log"
  grep -H "Collected" "cg.$tag.$name.log" | sed "s#^cg\.##; s#\.log:==[0-9]*==##"
}
run q20k "$vc" --quiet compensate cam20k.nc "${map[@]}" -o "o.$tag.q20k.nc"
run q20kg61 "$vc" --quiet compensate cam20k_g61.nc "${map[@]}" -o "o.$tag.q20kg61.nc"
run d50k "$vc" compensate cam50k.nc "${map[@]}" -o "o.$tag.d50k.nc"
run time "$vc" time cam50k.nc --setup "$setup" --json
echo "profiles and logs: $out" >&2
