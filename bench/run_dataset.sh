#!/usr/bin/env bash
# Dataset benchmark harness: a fresh semmapd on loopback, one dataset ingested at max rate, and
# every figure we are judged by: frames, keyframes, end-to-end frames/s, per-stage server
# latency (p50/p95/max), server peak RSS, database size and, with ground truth, ATE and RPE
# plus a trajectory plot. Also writes all figures as JSON.
#
#   bench/run_dataset.sh DIR [--poses GT] [--gt GT] [--out OUT_DIR] [--mono] [--semmapd-args A]
#     --poses GT  stream in KNOWN_POSES mode with these poses (e.g. groundtruth.txt)
#     --gt GT     ground truth to evaluate against (default: DIR/groundtruth.txt if present)
#     --out DIR   where report.json, the estimate, the plots and semmapd.log go (default: a
#                 temp dir)
#     --semmapd-args A  extra semmapd flags, one string (e.g. "--final-ba off")
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build/release}
SEMMAPD="$BUILD_DIR/server/semmapd"
SEMMAP="$BUILD_DIR/client/cli/semmap"

usage() { sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 2; }
[ $# -ge 1 ] || usage
DATASET=$1; shift
POSES=""; GT=""; OUT=""; MODE_ARGS=(); SERVER_ARGS=()
while [ $# -gt 0 ]; do
  case "$1" in
    --poses) POSES=$2; shift 2 ;;
    --gt) GT=$2; shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    --mono) MODE_ARGS+=(--mono); shift ;;
    --semmapd-args) read -r -a SERVER_ARGS <<<"$2"; shift 2 ;;
    -h|--help) usage ;;
    *) echo "run_dataset: unknown option $1" >&2; usage ;;
  esac
done
[ -d "$DATASET" ] || { echo "run_dataset: no dataset directory $DATASET" >&2; exit 1; }
for bin in "$SEMMAPD" "$SEMMAP"; do
  [ -x "$bin" ] || { echo "run_dataset: $bin missing; run 'make build'" >&2; exit 1; }
done
[ -n "$POSES" ] && [ ! -e "$POSES" ] && [ -e "$DATASET/$POSES" ] && POSES="$DATASET/$POSES"
[ -z "$GT" ] && [ -e "$DATASET/groundtruth.txt" ] && GT="$DATASET/groundtruth.txt"
OUT=${OUT:-$(mktemp -d -t semmap-bench-XXXXXX)}
mkdir -p "$OUT"
data_dir=$(mktemp -d -t semmap-bench-db-XXXXXX)
pid=""
trap '{ [ -n "$pid" ] && kill -KILL $pid 2>/dev/null; } || true; rm -rf "$data_dir"' EXIT
source scripts/semmapd_lib.sh
start_semmapd "$SEMMAPD" "$data_dir" "${SERVER_ARGS[@]}"
pid=$SEMMAPD_PID
addr=$SEMMAPD_ADDR

ingest_args=(--server "$addr" --json ingest "$DATASET" --map bench --session run
             --trajectory-out "$OUT/estimate.txt" "${MODE_ARGS[@]}")
[ -n "$POSES" ] && ingest_args+=(--poses "$POSES")
echo "dataset: $DATASET ($(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs))"
echo "ingesting at max rate ..."
ingest=$("$SEMMAP" "${ingest_args[@]}")
echo "$ingest" >"$OUT/ingest.json"
peak_kb=$(awk '/VmHWM/ {print $2}' /proc/$pid/status)
kill -TERM $pid; wait $pid || true
db_bytes=$(stat -c %s "$data_dir/semmap.db")
cp "$data_dir/semmapd.log" "$OUT/semmapd.log"

keyframes=$(jq .keyframes <<<"$ingest")
printf 'frames: %s stored of %s sent, keyframes: %s\n' "$(jq .frames_stored <<<"$ingest")" \
  "$(jq .frames_sent <<<"$ingest")" "$keyframes"
printf 'end-to-end: %.1f frames/s (%.2f s, client file reading + gRPC + server, session close included)\n' \
  "$(jq .frames_per_second <<<"$ingest")" "$(jq .seconds <<<"$ingest")"
printf 'streaming: %.1f frames/s (%.2f s until the last pose came back; then %.2f s to close the session)\n' \
  "$(jq .streaming_frames_per_second <<<"$ingest")" "$(jq .streaming_seconds <<<"$ingest")" \
  "$(jq '.seconds - .streaming_seconds' <<<"$ingest")"
echo "server latency (ms)     p50      p95      max"
jq -r '.stages | to_entries[] | select(.value.count > 0) |
       "  \(.key)\t\(.value.p50_ms)\t\(.value.p95_ms)\t\(.value.max_ms)"' <<<"$ingest" |
  awk -F'\t' '{printf "%-20s %8.2f %8.2f %8.2f\n", $1, $2, $3, $4}'
awk -v kb="$peak_kb" 'BEGIN { printf "server peak RSS: %.1f MiB\n", kb / 1024 }'
# The SLAM back end's account of the session (keyframes culled, loops, BA, map points).
grep -o 'map back end: .*' "$OUT/semmapd.log" | tail -1 || true
awk -v b="$db_bytes" -v k="$keyframes" \
  'BEGIN { printf "database: %.2f MiB (%.0f bytes per keyframe)\n", b / 1048576, b / (k > 0 ? k : 1) }'

ate='null'; rpe='null'
if [ -n "$GT" ]; then
  ate=$("$SEMMAP" --json eval ate "$GT" "$OUT/estimate.txt" --plot "$OUT/trajectory.png" \
          --plot-errors "$OUT/ate_errors.png")
  rpe=$("$SEMMAP" --json eval rpe "$GT" "$OUT/estimate.txt" --delta 1 --delta-unit s)
  jq -r '"ATE (m): rmse \(.rmse) mean \(.mean) median \(.median) max \(.max) over \(.pairs) pairs"' <<<"$ate"
  jq -r '"RPE (1 s): translation rmse \(.translation_m.rmse) m, rotation rmse " +
         "\(.rotation_deg.rmse) deg over \(.pairs) pairs"' <<<"$rpe"
  echo "plots: $OUT/trajectory.png $OUT/ate_errors.png"
else
  echo "no ground truth: ATE/RPE skipped"
fi
jq -n --argjson ingest "$ingest" --argjson ate "$ate" --argjson rpe "$rpe" \
  --arg dataset "$DATASET" --argjson peak_rss_kb "$peak_kb" --argjson db_bytes "$db_bytes" \
  '{dataset: $dataset, ingest: $ingest, server_peak_rss_kb: $peak_rss_kb,
    database_bytes: $db_bytes, ate: $ate, rpe: $rpe}' >"$OUT/report.json"
echo "report: $OUT/report.json"
