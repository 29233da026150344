#!/usr/bin/env bash
# Size and accuracy of compensated programs (BENCHMARKS.md, "Compact
# compensated programs"): per program, output blocks / input blocks and the
# dense contour error (volcomp simulate --reference) for
#   fixed : --segment-length 1 --arcs-as-lines (1 mm segments, arcs as G1
#           chords within 0.1 µm: the former default)
#   lines : --arcs-as-lines (adaptive lines, arcs still linearised)
#   arcs  : the defaults (adaptive lines, arcs as arcs)
# with the ripple map of bench/ripple_map.py (3 µm / 1 µm waves, 5 mm table).
# Usage: bench/compact.sh PROGRAM...   (needs a release build)
# Programs posted for absolute arc centres without G90.1 are read with
# --absolute-arc-centers: their base names in ABSOLUTE_CENTRES (space
# separated; default the corpus' BOTTLE.NC).
set -uo pipefail
cd "$(dirname "$0")/.."
vc=./target/release/volcomp
work=${BENCH_DIR:-$(mktemp -d)}
mkdir -p "$work"
python3 bench/ripple_map.py > "$work/ripple.csv"
# Work offsets zero, tools 1 … 99 of length 0 (the map is defined over ±20 m).
{ echo 'units = "mm"'; echo; echo '[work_offsets]'; echo 'G54 = [0, 0, 0]'; echo; echo '[tools]'
  for i in $(seq 1 99); do echo "$i = 0"; done; } > "$work/setup.toml"
absolute=" ${ABSOLUTE_CENTRES:-MaestroFusion360__easy_gcode_plot__BOTTLE.NC} "
echo "| program | blocks in | fixed ×| lines × | arcs × | contour RMS before µm | RMS fixed / lines / arcs µm | max fixed / lines / arcs µm | reduction (arcs) |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|"
for p in "$@"; do
  name=$(basename "$p")
  common=(--map "$work/ripple.csv" --setup "$work/setup.toml")
  case "$absolute" in *" $name "*) common+=(--absolute-arc-centers) ;; esac
  in=$(python3 bench/blocks.py "$p" | cut -d' ' -f1)
  before=$($vc simulate "$p" "${common[@]}" --json 2>/dev/null) || { echo "| $name | $in | refused by simulate | | | | | | |"; continue; }
  rms0=$(echo "$before" | python3 -c 'import json,sys; print("%.3f" % json.load(sys.stdin)["contour_rms_um"])')
  ratios=(); rms=(); max=()
  for cfg in fixed lines arcs; do
    case $cfg in
      fixed) extra=(--segment-length 1 --arcs-as-lines) ;;
      lines) extra=(--arcs-as-lines) ;;
      arcs) extra=() ;;
    esac
    out="$work/$name.$cfg.ngc"
    if ! $vc compensate "$p" "${common[@]}" "${extra[@]}" --max-output-size none -o "$out" 2> "$work/$name.$cfg.err"; then
      ratios+=("refused"); rms+=("-"); max+=("-"); continue
    fi
    n=$(python3 bench/blocks.py "$out" | cut -d' ' -f1)
    ratios+=("$(python3 -c "print('%.2f' % ($n/$in))")")
    j=$($vc simulate "$out" --reference "$p" "${common[@]}" --json 2>/dev/null)
    rms+=("$(echo "$j" | python3 -c 'import json,sys; print("%.3f" % json.load(sys.stdin)["contour_rms_um"])')")
    max+=("$(echo "$j" | python3 -c 'import json,sys; print("%.3f" % json.load(sys.stdin)["contour_max_um"])')")
  done
  red=$(python3 -c "print('%.1f %%' % (100*(1-${rms[2]:-0}/$rms0)))" 2>/dev/null || echo -)
  echo "| $name | $in | ${ratios[0]} | ${ratios[1]} | ${ratios[2]} | $rms0 | ${rms[0]} / ${rms[1]} / ${rms[2]} | ${max[0]} / ${max[1]} / ${max[2]} | $red |"
done
