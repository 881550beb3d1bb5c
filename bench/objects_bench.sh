#!/usr/bin/env bash
# Object recognition benchmark (issue 6), through semmapd on TUM fr3/teddy in RGBD mode:
#   - tracking latency and frames/s with 0, 1 and 50 object types registered (recognition runs
#     on the map's own thread: tracking must not slow down), recognition cost per keyframe;
#   - the teddy (registered from data/samples/objects/teddy.png, a crop of the first frame):
#     instances found and the distance to its true position (the median of the first frame's
#     depth points inside the crop nearer than 1.3 m, in the map frame = the first camera's);
#   - the café sequence (no teddy in it): teddy instances must be 0;
#   - object-location query latency with 10,000 instances (object_query_bench).
# The 49 other types are the generator's object photos for 13 scene seeds.
#
#   bench/objects_bench.sh [--out DIR] [--data DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build/release}
SEMMAPD="$BUILD_DIR/server/semmapd"
SEMMAP="$BUILD_DIR/client/cli/semmap"
SYNTH="$BUILD_DIR/tools/semmap-synth"
source scripts/semmapd_lib.sh

OUT=""; DATA=../shared/data
while [ $# -gt 0 ]; do
  case "$1" in
    --out) OUT=$2; shift 2 ;;
    --data) DATA=$2; shift 2 ;;
    -h|--help) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "objects_bench: unknown option $1" >&2; exit 2 ;;
  esac
done
TEDDY="$DATA/tum_fr3_teddy_200"
CAFE="$DATA/kinect_cafe_391_nogt"
[ -d "$TEDDY" ] || { echo "objects_bench: needs $TEDDY (skipped)"; exit 0; }
bench_setup objects-bench "$SEMMAPD" "$SEMMAP" "$SYNTH"

photos=()
for seed in $(seq 1 13); do
  "$SYNTH" "$WORK/seed$seed" --frames 1 --seed "$seed" --quiet >/dev/null
  for p in "$WORK/seed$seed"/objects/*.png; do photos+=("$p"); done
done

# run NAME TYPES: fresh server, TYPES object types (the teddy first), teddy ingested.
run() {
  local name=$1 types=$2 db="$WORK/db-$1"
  mkdir -p "$db"
  start_semmapd "$SEMMAPD" "$db"
  local S=("$SEMMAP" --server "$SEMMAPD_ADDR")
  if [ "$types" -ge 1 ]; then
    "${S[@]}" objects add teddy data/samples/objects/teddy.png >/dev/null
    local i=0
    for p in "${photos[@]}"; do
      [ $((i + 1)) -ge "$types" ] && break
      "${S[@]}" objects add "other_$i" "$p" >/dev/null
      i=$((i + 1))
    done
  fi
  "${S[@]}" --json ingest "$TEDDY" --map teddy >"$OUT/$name-ingest.json"
  "${S[@]}" --json where teddy --map teddy >"$OUT/$name-where.json"
  "${S[@]}" --json where --map teddy >"$OUT/$name-where-all.json"
  if [ "$name" = "teddy1" ] && [ -d "$CAFE" ]; then
    "${S[@]}" --json ingest "$CAFE" --map cafe >/dev/null
    "${S[@]}" --json where teddy --map cafe >"$OUT/cafe-where.json"
  fi
  stop_semmapd
  cp "$db/semmapd.log" "$OUT/$name-semmapd.log"
}

st() { jq -r ".stages.$2.$3 // 0" "$OUT/$1-ingest.json"; }
echo "semmap objects bench: $(date -u +%FT%TZ), $(nproc) cores"
printf '\n== tracking with object recognition on the map thread (teddy, 200 frames)\n'
printf '  %-8s %14s %14s %10s %22s\n' types "tracking p50" "tracking p95" frames/s "recognise p50 / p95"
for n in 0 1 50; do
  run "teddy$n" "$n"
  printf '  %-8s %11.2f ms %11.2f ms %10.1f %12.1f / %.1f ms\n' "$n" "$(st "teddy$n" tracking p50_ms)" \
    "$(st "teddy$n" tracking p95_ms)" "$(jq .frames_per_second "$OUT/teddy$n-ingest.json")" \
    "$(st "teddy$n" recognise p50_ms)" "$(st "teddy$n" recognise p95_ms)"
done

printf '\n== the teddy (registered from one crop)\n'
for n in 1 50; do
  jq -r --arg n "$n" '"  \($n) types: \(.objects | length) teddy instance(s)" +
    (if (.objects | length) > 0 then ", at (\(.objects[0].position.x | . * 1000 | round / 1000), \(.objects[0].position.y | . * 1000 | round / 1000), \(.objects[0].position.z | . * 1000 | round / 1000)) m, seen \(.objects[0].observations) times, confidence \(.objects[0].confidence | . * 100 | round / 100)" else "" end)' \
    "$OUT/teddy$n-where.json"
  jq -r '"    other labels found on teddy: " + ([.objects[] | select(.label != "teddy") | .label] | tostring)' \
    "$OUT/teddy$n-where-all.json"
done
echo "  truth (tests/e2e/objects_test.cc, TeddyTruth): (0.050, -0.074, 0.867) m, the front-surface median"
if [ -f "$OUT/cafe-where.json" ]; then
  printf '\n== café (391 frames, no teddy in it): %s teddy instance(s)\n' "$(jq '.objects | length' "$OUT/cafe-where.json")"
fi
grep -h "objects:" "$OUT"/teddy*-semmapd.log | sed 's/^/  /'

printf '\n== object-location queries, 10,000 instances of 50 types\n'
if [ -x "$BUILD_DIR/bench/object_query_bench" ]; then
  "$BUILD_DIR/bench/object_query_bench" 2>/dev/null | grep BM_ | sed 's/^/  /'
fi
echo
echo "outputs in $OUT"
