#!/usr/bin/env bash
# 3D map benchmark (issue 5): for teddy and a synthetic loop, streamed into semmapd in RGBD mode:
# map insertion per keyframe (p50/p95), rebuilds after loop closures, tracking latency with the
# map layers on vs off, octree memory per cubic metre, and every export's size and time.
# All figures also go to OUT/map_bench.json.
#
#   bench/map_bench.sh [--out DIR] [--data DIR] [--runs N]
#     --out DIR   where map_bench.json and the exports go (default: a new temp dir, kept)
#     --data DIR  the real datasets (default: ../shared/data)
#     --runs N    ingests per configuration for the on/off comparison (default 2; medians)
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build/release}
SEMMAPD="$BUILD_DIR/server/semmapd"
SEMMAP="$BUILD_DIR/client/cli/semmap"
SYNTH="$BUILD_DIR/tools/semmap-synth"
source scripts/semmapd_lib.sh

usage() { sed -n '2,11p' "$0" | sed 's/^# \{0,1\}//'; exit "${1:-2}"; }
OUT=""; DATA=../shared/data; RUNS=2
while [ $# -gt 0 ]; do
  case "$1" in
    --out) OUT=$2; shift 2 ;;
    --data) DATA=$2; shift 2 ;;
    --runs) RUNS=$2; shift 2 ;;
    -h|--help) usage 0 ;;
    *) echo "map_bench: unknown option $1" >&2; usage ;;
  esac
done
bench_setup map-bench "$SEMMAPD" "$SEMMAP"
REPORT="$OUT/map_bench.json"
echo '{}' >"$REPORT"
report_set() { jq --argjson v "$2" "$1 = \$v" "$REPORT" >"$REPORT.tmp" && mv "$REPORT.tmp" "$REPORT"; }
median() { sort -g | awk '{ v[NR] = $1 } END { if (NR == 0) print "nan"; else if (NR % 2) print v[(NR + 1) / 2]; else print (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }

# ingest NAME DIR LAYERS RUN: fresh server (map layers on|off), one ingest at max rate; leaves the
# CLI's JSON in $WORK/NAME-LAYERS-RUN.json and the server running for exports (stop_semmapd).
ingest() {
  local name=$1 dir=$2 layers=$3 run=$4 data="$WORK/db-$1-$3-$4"
  mkdir -p "$data"
  start_semmapd "$SEMMAPD" "$data" --map-layers "$layers"
  "$SEMMAP" --server "$SEMMAPD_ADDR" --json ingest "$dir" --map "$name" \
    >"$WORK/$name-$layers-$run.json"
  LAST_LOG="$data/semmapd.log"
}
stage() { jq -r ".stages.$2.$3 // 0" "$1"; }

# bench_sequence NAME DIR: the whole section for one sequence.
bench_sequence() {
  local name=$1 dir=$2 run layers
  printf '\n== %s (%s)\n' "$name" "$dir"
  for layers in on off; do
    for run in $(seq 1 "$RUNS"); do
      ingest "$name" "$dir" "$layers" "$run"
      if [ "$layers" = on ] && [ "$run" = 1 ]; then
        export_all "$name"
        cp "$LAST_LOG" "$OUT/$name-semmapd.log"
      fi
      stop_semmapd
    done
  done
  local f=("$WORK/$name"-on-*.json) g=("$WORK/$name"-off-*.json)
  local on_p50 on_p95 off_p50 off_p95 on_fps off_fps
  on_p50=$(for j in "${f[@]}"; do stage "$j" tracking p50_ms; done | median)
  on_p95=$(for j in "${f[@]}"; do stage "$j" tracking p95_ms; done | median)
  off_p50=$(for j in "${g[@]}"; do stage "$j" tracking p50_ms; done | median)
  off_p95=$(for j in "${g[@]}"; do stage "$j" tracking p95_ms; done | median)
  on_fps=$(for j in "${f[@]}"; do jq .frames_per_second "$j"; done | median)
  off_fps=$(for j in "${g[@]}"; do jq .frames_per_second "$j"; done | median)
  local first=${f[0]}
  printf '  frames %s, keyframes %s, loop closures %s\n' "$(jq .frames_stored "$first")" \
    "$(jq .keyframes "$first")" "$(jq .loop_closures "$first")"
  printf '  map insertion per keyframe: p50 %.1f ms, p95 %.1f ms, max %.1f ms (%s keyframes)\n' \
    "$(stage "$first" map_insert p50_ms)" "$(stage "$first" map_insert p95_ms)" \
    "$(stage "$first" map_insert max_ms)" "$(stage "$first" map_insert count)"
  printf '  rebuilds after loop closures: %s, p50 %.0f ms, max %.0f ms\n' \
    "$(stage "$first" map_rebuild count)" "$(stage "$first" map_rebuild p50_ms)" \
    "$(stage "$first" map_rebuild max_ms)"
  printf '  tracking p50 / p95, medians of %s runs: layers on %.2f / %.2f ms, off %.2f / %.2f ms\n' \
    "$RUNS" "$on_p50" "$on_p95" "$off_p50" "$off_p95"
  printf '  end-to-end frames/s: layers on %.1f, off %.1f\n' "$on_fps" "$off_fps"
  # "layers: 30 keyframes (0 restored), 0 rebuilds, octree 1.7 MiB over 12.3 m3 known, ..."
  local line
  line=$(grep "layers:" "$OUT/$name-semmapd.log" | tail -n1 | sed 's/^.* info: //')
  printf '  %s\n' "$line"
  report_set ".$name" "$(jq -n --slurpfile on "$first" --arg line "$line" \
    --argjson on_p50 "$on_p50" --argjson on_p95 "$on_p95" --argjson off_p50 "$off_p50" \
    --argjson off_p95 "$off_p95" --argjson on_fps "$on_fps" --argjson off_fps "$off_fps" \
    --slurpfile exports "$WORK/$name-exports.json" \
    '{frames: $on[0].frames_stored, keyframes: $on[0].keyframes,
      loop_closures: $on[0].loop_closures, map_insert: $on[0].stages.map_insert,
      map_rebuild: $on[0].stages.map_rebuild,
      tracking_ms: {on: {p50: $on_p50, p95: $on_p95}, off: {p50: $off_p50, p95: $off_p95}},
      frames_per_second: {on: $on_fps, off: $off_fps}, layers_log: $line,
      exports: $exports[0]}')"
}

# export_all NAME: every format from the running server; sizes and wall times.
export_all() {
  local name=$1 fmt extra t0 t1 bytes
  echo '[]' >"$WORK/$name-exports.json"
  printf '  exports:'
  for spec in ot bt ply pcd "ply --ascii" png "png --view oblique"; do
    fmt=${spec%% *}; extra=${spec#"$fmt"}
    local file
    file="$OUT/$name$(echo "$extra" | tr -d ' -' | sed 's/^./-&/').$fmt"
    t0=$(date +%s%N)
    # shellcheck disable=SC2086
    "$SEMMAP" --server "$SEMMAPD_ADDR" export --map "$name" --format "$fmt" $extra -o "$file" \
      >/dev/null
    t1=$(date +%s%N)
    bytes=$(stat -c %s "$file")
    printf ' %s%s %s (%d ms);' "$fmt" "$extra" "$(numfmt --to=iec "$bytes")" \
      $(((t1 - t0) / 1000000))
    jq --arg f "$fmt$extra" --argjson b "$bytes" --argjson ms $(((t1 - t0) / 1000000)) \
      '. += [{format: $f, bytes: $b, ms: $ms}]' "$WORK/$name-exports.json" \
      >"$WORK/x.json" && mv "$WORK/x.json" "$WORK/$name-exports.json"
  done
  echo
}

echo "semmap map bench: $(date -u +%FT%TZ), $(nproc) cores, binaries $(stat -c %y "$SEMMAPD" | cut -d. -f1)"
if [ -d "$DATA/tum_fr3_teddy_200" ]; then
  bench_sequence teddy "$DATA/tum_fr3_teddy_200"
else
  echo "teddy: skipped (no $DATA/tum_fr3_teddy_200)"
fi
if [ -x "$SYNTH" ]; then
  "$SYNTH" "$WORK/lap" --trajectory circle --frames 300 --depth-noise --colour-noise --quiet \
    --no-templates
  bench_sequence lap "$WORK/lap"
else
  echo "synthetic loop: skipped (no $SYNTH)"
fi
echo
echo "report: $REPORT; exports and logs in $OUT"
