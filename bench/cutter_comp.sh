#!/usr/bin/env bash
# Size and accuracy of cutter-compensated programs (BENCHMARKS.md,
# "Cutter-compensated programs"): per program, blocks in (of the file,
# bench/blocks.py, and as run: o-word loops and calls unrolled, as
# `compensate` counts them and writes them), output blocks and their ratio
# to the blocks as run for
#   lines : --arcs-as-lines (tool-centre arcs linearised within 0.1 µm)
#   arcs  : the defaults (tool-centre arcs written as arcs)
# whether LinuxCNC's rs274 accepts the output, and the dense contour error
# against the original tool-centre path (volcomp simulate --reference).
# Map: bench/ripple_map.py. Set-up: that of the rs274 tests
# (crates/volcomp-cli/tests/rs274/mod.rs): inch, G54 … G59.3 distinct,
# tool n of length (16 + n)·0.1 in and diameter n·0.05 in, in volcomp's
# set-up and rs274's tool table and parameter file alike.
# Usage: bench/cutter_comp.sh PROGRAM...   (any build; VOLCOMP names it)
set -uo pipefail
cd "$(dirname "$0")/.."
vc=${VOLCOMP:-./target/release/volcomp}
work=${BENCH_DIR:-$(mktemp -d)}
mkdir -p "$work"
python3 bench/ripple_map.py > "$work/ripple.csv"
python3 - "$work" <<'PY'
import sys
w = sys.argv[1]
def h(x):
    s = '-' if x < 0 else ''
    return f"{s}{abs(x) // 100}.{abs(x) % 100:02d}"
systems = ["G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3"]
off = lambda i: [1000 + 150 * i, -600 + 45 * i, -1500 - 20 * i]
s = 'units = "inch"\nstart = [0, 0, 0]\n\n[work_offsets]\n'
s += "".join(f'"{n}" = [{", ".join(h(v) for v in off(i))}]\n' for i, n in enumerate(systems))
s += "\n[tools]\n" + "".join(f"{n} = {h(10 * (16 + n))}\n" for n in range(1, 100))
s += "\n[tool_diameters]\n" + "".join(f"{n} = {h(5 * n)}\n" for n in range(1, 100))
s += "\n[reference]\nG28 = [5.00, 2.50, 1.00]\nG30 = [-3.00, 4.00, 2.00]\n"
open(f"{w}/setup.toml", "w").write(s)
open(f"{w}/tools.tbl", "w").write(
    "".join(f"T{n} P{n} Z{h(10 * (16 + n))} D{h(5 * n)}\n" for n in range(1, 100)))
var = [(5161 + k, h(v)) for k, v in enumerate([500, 250, 100])]
var += [(5181 + k, h(v)) for k, v in enumerate([-300, 400, 200])]
for i in range(9):
    var += [(5221 + 20 * i + k, h(v)) for k, v in enumerate(off(i))]
var.append((5220, "1"))
open(f"{w}/params.var", "w").write("".join(f"{n} {v}\n" for n, v in sorted(var)))
PY
common=(--map "$work/ripple.csv" --setup "$work/setup.toml")
rs274_ok() {  # rs274_ok PROGRAM: "yes (N arcs)" or the refusal
  local d; d=$(mktemp -d "$work/rs.XXXX"); cp "$work/params.var" "$d/"
  local said; said=$(cd "$d" && HOME="$d" rs274 -g -t "$work/tools.tbl" -v "$d/params.var" "$1" "$d/canon.txt" < /dev/null 2>&1 | grep -v '^executing$')
  if [ -z "$said" ]; then echo "yes ($(grep -c ARC_FEED "$d/canon.txt") arcs)"; else echo "NO: $said" | head -1; fi
  rm -rf "$d"
}
echo "| program | blocks in (file / as run) | lines: blocks (×) | arcs: blocks (×) | rs274 accepts arcs | contour RMS lines / arcs µm | max lines / arcs µm |"
echo "|---|---:|---:|---:|---|---:|---:|"
for p in "$@"; do
  name=$(basename "$p")
  file_in=$(python3 bench/blocks.py "$p" | cut -d' ' -f1)
  cells=(); rms=(); max=(); run_in=-
  for cfg in lines arcs; do
    extra=(); [ $cfg = lines ] && extra=(--arcs-as-lines)
    out="$work/$name.$cfg.ngc"
    said=$($vc compensate "$p" "${common[@]}" "${extra[@]}" --max-output-size none -o "$out" 2>&1) || { cells+=("refused"); rms+=("-"); max+=("-"); continue; }
    run_in=$(echo "$said" | sed -n 's/.* bytes, \([0-9]*\) -> \([0-9]*\) blocks.*/\1/p')
    n=$(echo "$said" | sed -n 's/.* bytes, \([0-9]*\) -> \([0-9]*\) blocks.*/\2/p')
    cells+=("$n ($(python3 -c "print('%.2f' % ($n/$run_in))"))")
    j=$($vc simulate "$out" --reference "$p" "${common[@]}" --json 2>/dev/null) || { rms+=("n/a"); max+=("n/a"); continue; }
    rms+=("$(echo "$j" | python3 -c 'import json,sys; print("%.3f" % json.load(sys.stdin)["contour_rms_um"])')")
    max+=("$(echo "$j" | python3 -c 'import json,sys; print("%.3f" % json.load(sys.stdin)["contour_max_um"])')")
  done
  echo "| $name | $file_in / $run_in | ${cells[0]} | ${cells[1]} | $(rs274_ok "$work/$name.arcs.ngc") | ${rms[0]} / ${rms[1]} | ${max[0]} / ${max[1]} |"
done
