#!/bin/bash
# Time to relMSE 1e-2 and 1e-3 with light sampling (NEE) and without (pure path tracing), both with
# roulette below 1 (the rule of issue 6), on the
# three scenes of tests/convergence.rs, for BENCHMARKS.md: per scene a reference (NEE, another
# seed), then one run of each strategy against it, and `clpt plot` of their reports.
#   tools/error-vs-time.sh refs  CLPT OUT W H SECONDS          # references only
#   tools/error-vs-time.sh runs  CLPT OUT W H NEE_S PT_S REFS   # runs against REFS/<scene>-ref.*
# CLPT is the binary, OUT the folder for images, reports, tables and plots; the device comes
# from $CLPT_DEVICE. Scene paths are relative to the repository root (or a packed device-run/).
set -euo pipefail
mode=$1 clpt=$2 out=$3 w=$4 h=$5
mkdir -p "$out"
scenes=("room:scenes/room.txt" "smallpt:scenes/smallpt.txt" "small_light:scenes/small_light.txt")
for entry in "${scenes[@]}"; do
  name=${entry%%:*} file=${entry#*:}
  size=(--width "$w" --height "$h" -q)
  if [ "$mode" = refs ]; then
    "$clpt" render "$file" "${size[@]}" --time "$6" --seed 1000 --light-sampling on --rr-threshold 1 -o "$out/$name-ref.pfm" \
      --report "$out/$name-ref.csv"
    echo "$name reference: $(tail -1 "$out/$name-ref.csv")"
  else
    refs=$8
    "$clpt" render "$file" "${size[@]}" --time "$6" --seed 1 --light-sampling on --rr-threshold 1 --reference "$refs/$name-ref.pfm" \
      --report "$out/$name-nee.csv" -o "$out/$name-nee.png"
    "$clpt" render "$file" "${size[@]}" --time "$7" --seed 2 --light-sampling off --rr-threshold 1 \
      --reference "$refs/$name-ref.pfm" --report "$out/$name-pt.csv" -o "$out/$name-pt.png"
    ref_error=$(tail -1 "$refs/$name-ref.csv" | cut -d, -f6)
    echo "## $name, ${w}x$h, reference relMSE $ref_error (subtracted)"
    "$clpt" plot "NEE=$out/$name-nee.csv" "path tracing=$out/$name-pt.csv" \
      --reference-error "$ref_error" -o "$out/$name-efficiency.svg" \
      --title "$name, ${w}x$h: relMSE x seconds, NEE and pure path tracing"
  fi
done
