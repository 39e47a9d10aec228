#!/bin/bash
# The estimators of issue 12 side by side, for BENCHMARKS.md: every scene rendered at the given
# samples with the defaults (the trial's choice, `auto`), and with each fixed setting: light
# sampling on or off, roulette below 0.5 or 0.3 (the candidates of `auto`), and off with roulette
# below 1 (the `--no-nee` of before issue 12, which the issue measures against). One CSV row a run:
#   scene,setting,spp,seconds,relmse_estimate,relmse_x_seconds,estimator
#   tools/estimators.sh CLPT OUT.csv SCENE:SPP[:W:H] ...
# CLPT is the binary; the device comes from $CLPT_DEVICE. SETTINGS="auto off:0.3 ..." runs only
# those settings; SEED=N renders with seed N (default 1). With BEFORE=OLD_CLPT set, each scene
# also gets a row `before-off:1`: OLD_CLPT with light sampling off and roulette below 1 (the
# `--no-nee` that the issue measures against, rendered by the binary of that time). EXTRA="..."
# adds flags to every run of CLPT (for example EXTRA="--launch-ms 1600").
set -euo pipefail
clpt=$1 out=$2
shift 2
tmp=$(mktemp -d)
echo "scene,setting,spp,seconds,relmse_estimate,relmse_x_seconds,estimator" > "$out"
for entry in "$@"; do
  IFS=: read -r file spp w h <<< "$entry"
  size=()
  [ -n "${w:-}" ] && size=(--width "$w" --height "$h")
  read -r -a settings <<< "${SETTINGS:-auto off:1 on:0.5 on:0.3 off:0.5 off:0.3}"
  [ -n "${BEFORE:-}" ] && settings+=(before-off:1)
  for setting in "${settings[@]}"; do
    bin=$clpt
    if [ "$setting" = auto ]; then
      flags=()
    elif [ "$setting" = before-off:1 ]; then
      bin=$BEFORE flags=(--no-nee --rr-threshold 1)
    else
      flags=(--light-sampling "${setting%:*}" --rr-threshold "${setting#*:}")
    fi
    [ "$bin" = "$clpt" ] && read -r -a extra <<< "${EXTRA:-}" || extra=()
    "$bin" render "$file" "${size[@]}" --spp "$spp" --seed "${SEED:-1}" -q "${flags[@]}" "${extra[@]}" \
      -o "$tmp/image.pfm" --report "$tmp/report.csv" 2> "$tmp/log" || { cat "$tmp/log"; exit 1; }
    estimator=$(sed -n 's/^# estimator: //p' "$tmp/report.csv" | tr ',' ';')
    last=$(tail -1 "$tmp/report.csv")
    seconds=$(cut -d, -f2 <<< "$last")
    relmse=$(cut -d, -f6 <<< "$last")
    product=$(awk -v a="$relmse" -v b="$seconds" 'BEGIN { printf "%.4e", a * b }')
    echo "$(basename "$file"),$setting,$spp,$seconds,$relmse,$product,$estimator" | tee -a "$out"
  done
done
rm -rf "$tmp"
