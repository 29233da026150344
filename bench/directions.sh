#!/usr/bin/env bash
# Direction handling, measured: the dense-contour RMS after `exact`
# compensation (1 mm segments) with tables chosen by the nominal move
# direction (the papers' way), by the commanded direction without take-up
# moves, and by the commanded direction with take-up moves (volcomp's default).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q
vc=./target/release/volcomp
work=${BENCH_DIR:-$(mktemp -d)}
mkdir -p "$work"
$vc demo --out-dir "$work" > /dev/null
off=250,200,150
printf "%-26s %9s %22s %22s %22s\n" program before "nominal directions" "commanded, no take-up" "commanded + take-up"
for p in "$work"/*seg.ngc; do
  name=$(basename "$p" .ngc)
  before=$($vc simulate "$p" --map "$work/example_map.csv" --work-offset $off --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["contour_rms_um"])')
  row=$(printf "%-26s %9.3f" "$name" "$before")
  for flags in "--nominal-directions" "--no-take-up" ""; do
    $vc compensate "$p" --map "$work/example_map.csv" --work-offset $off $flags -o "$work/d.ngc" 2> /dev/null
    after=$($vc simulate "$work/d.ngc" --reference "$p" --map "$work/example_map.csv" --work-offset $off --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["contour_rms_um"])')
    row="$row $(python3 -c "b=$before; a=$after; print(f'{a:10.3f} ({100*(1-a/b):5.1f} %)'.rjust(22))")"
  done
  echo "$row"
done
