#!/usr/bin/env bash
# Ingest throughput in KNOWN_POSES mode: starts a fresh semmapd, streams a TUM dataset at max
# rate with its ground-truth poses (client reading files, gRPC over loopback, server decoding,
# keyframe selection, SQLite commits), and prints frames/s and the server's peak RSS.
#   bench/ingest_bench.sh [DATASET_DIR] [REPEATS]
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build/release}
DATASET=${1:-../shared/data/tum_fr3_teddy_200}
REPEATS=${2:-3}
[ -d "$DATASET" ] || DATASET=data/samples/tum_fr3_teddy_80
SEMMAPD="$BUILD_DIR/server/semmapd"
SEMMAP="$BUILD_DIR/client/cli/semmap"
work=$(mktemp -d -t semmap-bench-XXXXXX)
trap 'kill -KILL $pid 2>/dev/null || true; rm -rf "$work"' EXIT

"$SEMMAPD" --listen 127.0.0.1:0 --data-dir "$work" >"$work/out" 2>"$work/log" &
pid=$!
for _ in $(seq 1 100); do
  addr=$(sed -n 's/^semmapd: listening on //p' "$work/out" | head -n1)
  [ -n "$addr" ] && break
  sleep 0.1
done
[ -n "$addr" ] || { echo "bench: semmapd did not start" >&2; cat "$work/log" >&2; exit 1; }

echo "dataset: $DATASET"
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
rss_before=$(awk '/VmRSS/ {print $2}' /proc/$pid/status)
for i in $(seq 1 "$REPEATS"); do
  json=$("$SEMMAP" --server "$addr" --json ingest "$DATASET" --poses groundtruth.txt \
           --map bench --session "run$i")
  jq -r '"run \(.session): \(.frames_stored) frames, \(.keyframes) keyframes, " +
         "\(.seconds * 100 | round / 100) s, \(.frames_per_second * 10 | round / 10) frames/s"' \
    <<<"$json"
done
peak_kb=$(awk '/VmHWM/ {print $2}' /proc/$pid/status)
rss_kb=$(awk '/VmRSS/ {print $2}' /proc/$pid/status)
kill -TERM $pid; wait $pid || true
db_bytes=$(stat -c %s "$work/semmap.db")
echo "server RSS at start: $((rss_before / 1024)) MiB, after: $((rss_kb / 1024)) MiB, peak: $((peak_kb / 1024)) MiB"
echo "database: $((db_bytes / 1024 / 1024)) MiB for $REPEATS sessions"
