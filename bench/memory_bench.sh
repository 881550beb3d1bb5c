#!/usr/bin/env bash
# Server memory per keyframe (issue 12): a synthetic room tour with depth, streamed into semmapd
# as an RGBD session with a low keyframe threshold, so nearly every frame is a keyframe that
# reaches the back end, the 3D layers and the object mapper. semmapd's resident memory is sampled
# every 0.2 s; the bench prints RSS before, at each quarter of the stream, at its end, and after
# the map's pipeline was released (--max-idle-maps 0), and the growth per 1000 keyframes, with the
# map layers on and off. All figures also go to OUT/memory_bench.json.
#
#   bench/memory_bench.sh [--frames N] [--size WxH] [--cloud-budget-mb MB] [--out DIR]
#     --frames N            frames of the tour (default 1200)
#     --size WxH            image size (default 640x480)
#     --cloud-budget-mb MB  semmapd's --map-cloud-budget-mb (default: semmapd's, 64)
#     --out DIR             where memory_bench.json goes (default: a new temp dir, kept)
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build/release}
SEMMAPD="$BUILD_DIR/server/semmapd"
SEMMAP="$BUILD_DIR/client/cli/semmap"
SYNTH="$BUILD_DIR/tools/semmap-synth"
source scripts/semmapd_lib.sh

usage() { sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'; exit "${1:-2}"; }
OUT=""; FRAMES=1200; SIZE=640x480; BUDGET_ARGS=()
while [ $# -gt 0 ]; do
  case "$1" in
    --frames) FRAMES=$2; shift 2 ;;
    --size) SIZE=$2; shift 2 ;;
    --cloud-budget-mb) BUDGET_ARGS=(--map-cloud-budget-mb "$2"); shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    -h|--help) usage 0 ;;
    *) echo "memory_bench: unknown option $1" >&2; usage ;;
  esac
done
[[ "$SIZE" =~ ^([0-9]+)x([0-9]+)$ ]] || { echo "memory_bench: --size takes WxH" >&2; exit 2; }
WIDTH=${BASH_REMATCH[1]}; HEIGHT=${BASH_REMATCH[2]}
bench_setup memory-bench "$SEMMAPD" "$SEMMAP" "$SYNTH"
REPORT="$OUT/memory_bench.json"
echo '{}' >"$REPORT"
report_set() { jq --argjson v "$2" "$1 = \$v" "$REPORT" >"$REPORT.tmp" && mv "$REPORT.tmp" "$REPORT"; }

SEQ="$WORK/tour"
echo "memory_bench: rendering a ${FRAMES}-frame ${WIDTH}x${HEIGHT} tour"
"$SYNTH" "$SEQ" --trajectory tour --frames "$FRAMES" --width "$WIDTH" --height "$HEIGHT" \
  --depth-noise --quiet

rss_kb() { awk '/^VmRSS:/ { print $2 }' "/proc/$1/status" 2>/dev/null || echo 0; }
mb() { awk -v k="$1" 'BEGIN { printf "%.1f", k / 1024 }'; }

# run LAYERS: one server, one stream, RSS samples in $WORK/rss-LAYERS.txt ("seconds kB").
run() {
  local layers=$1 data="$WORK/db-$1" samples="$WORK/rss-$1.txt"
  mkdir -p "$data"
  start_semmapd "$SEMMAPD" "$data" --map-layers "$layers" --max-idle-maps 0 --log-level warning \
    "${BUDGET_ARGS[@]}"
  local pid=$SEMMAPD_PID
  sleep 0.5
  local before; before=$(rss_kb "$pid")
  ( t0=$(date +%s.%N)
    while kill -0 "$pid" 2>/dev/null; do
      echo "$(awk -v a="$(date +%s.%N)" -v b="$t0" 'BEGIN { printf "%.2f", a - b }') $(rss_kb "$pid")"
      sleep 0.2
    done ) >"$samples" &
  local sampler=$!
  "$SEMMAP" --server "$SEMMAPD_ADDR" --json ingest "$SEQ" --map tour \
    --keyframe-min-motion 0.02 >"$WORK/ingest-$layers.json"
  local at_end; at_end=$(rss_kb "$pid")
  # The session has ended and --max-idle-maps 0 released the map's pipeline when it did; one
  # more session on another map lets the manager evict it for sure, then memory settles.
  "$SEMMAP" --server "$SEMMAPD_ADDR" --json ingest "$SEQ" --map other --poses groundtruth.txt \
    --keyframe-min-motion 100 >/dev/null 2>&1 || true
  sleep 2
  local released; released=$(rss_kb "$pid")
  stop_semmapd
  kill "$sampler" 2>/dev/null || true
  wait "$sampler" 2>/dev/null || true
  local keyframes frames peak
  keyframes=$(jq -r '.keyframes // 0' "$WORK/ingest-$layers.json")
  frames=$(jq -r '.frames_stored // 0' "$WORK/ingest-$layers.json")
  peak=$(awk 'BEGIN { m = 0 } { if ($2 > m) m = $2 } END { print m }' "$samples")
  local quarters; quarters=$(awk -v n="$(wc -l <"$samples")" \
    'NR == int(n / 4) || NR == int(n / 2) || NR == int(3 * n / 4) { printf "%s%.1f", s, $2 / 1024; s = " " }' "$samples")
  local per_1000; per_1000=$(awk -v a="$at_end" -v b="$before" -v k="$keyframes" \
    'BEGIN { if (k > 0) printf "%.1f", (a - b) / 1024 / k * 1000; else print "nan" }')
  printf '  layers %-3s  %5d frames, %5d keyframes  RSS MB: start %s, quarters %s, end %s, peak %s, released %s  growth %s MB per 1000 keyframes\n' \
    "$layers" "$frames" "$keyframes" "$(mb "$before")" "$quarters" "$(mb "$at_end")" "$(mb "$peak")" \
    "$(mb "$released")" "$per_1000"
  report_set ".layers_$layers" "{\"frames\": $frames, \"keyframes\": $keyframes, \"rss_start_mb\": $(mb "$before"), \"rss_end_mb\": $(mb "$at_end"), \"rss_peak_mb\": $(mb "$peak"), \"rss_released_mb\": $(mb "$released"), \"mb_per_1000_keyframes\": $per_1000}"
}

echo "== semmapd memory, ${FRAMES} frames ${WIDTH}x${HEIGHT}, RGBD, keyframe threshold 0.02 ${BUDGET_ARGS[*]}"
run on
run off
echo "memory_bench: report in $REPORT"
