#!/usr/bin/env bash
# The end-to-end demo: start semmapd on its embedded SQLite store, stream the bundled real
# sample (TUM fr3/teddy, 80 frames) as an RGBD visual SLAM session with the teddy registered as
# an object, compare the trajectory the server estimated with the ground truth, stream it again
# as a MONO session (colour only: the learned VO) with its ATE without scale alignment and its
# scale factor, show what was
# stored, export the 3D map and its picture, print where the teddy is, and stop the server
# cleanly. Run through `make demo` (which installs and builds first).
set -euo pipefail

BUILD_DIR=${BUILD_DIR:-build/release}
SAMPLE=${SAMPLE:-data/samples/tum_fr3_teddy_80}
DATA_DIR=${DATA_DIR:-$(mktemp -d -t semmap-demo-XXXXXX)}
SEMMAPD="$BUILD_DIR/server/semmapd"
SEMMAP="$BUILD_DIR/client/cli/semmap"

for bin in "$SEMMAPD" "$SEMMAP"; do
  [ -x "$bin" ] || { echo "demo: $bin is missing; run 'make build' first" >&2; exit 1; }
done

source "$(dirname "$0")/semmapd_lib.sh"
start_semmapd "$SEMMAPD" "$DATA_DIR"
server_pid=$SEMMAPD_PID
trap 'kill -KILL "$server_pid" 2>/dev/null || true' EXIT
export SEMMAP_SERVER="$SEMMAPD_ADDR"
echo "== semmapd serving on $SEMMAPD_ADDR, data in $DATA_DIR"
"$SEMMAP" health

echo "== registering the object to look for: the teddy, from a crop of the sample's first frame"
"$SEMMAP" objects add teddy "${OBJECT_PHOTO:-data/samples/objects/teddy.png}"

echo "== streaming $SAMPLE (RGBD: the server tracks the camera, maps and recognises objects)"
"$SEMMAP" ingest "$SAMPLE" --map demo --session teddy \
  --trajectory-out "$DATA_DIR/teddy_trajectory.txt"
echo "== accuracy of the estimated trajectory against the sample's ground truth"
"$SEMMAP" eval ate "$SAMPLE/groundtruth.txt" "$DATA_DIR/teddy_trajectory.txt"

if "$SEMMAP" ingest "$SAMPLE" --map demo-mono --session teddy-mono --mono \
  --trajectory-out "$DATA_DIR/teddy_mono_trajectory.txt" >"$DATA_DIR/mono_ingest.txt" 2>&1; then
  echo "== the same sample as MONO (colour only: learned VO, metric scale from the network)"
  tail -n 3 "$DATA_DIR/mono_ingest.txt"
  echo "-- ATE without scale alignment (rigid), then the scale a similarity alignment finds"
  "$SEMMAP" eval ate "$SAMPLE/groundtruth.txt" "$DATA_DIR/teddy_mono_trajectory.txt" |
    grep -E "rmse|pairs"
  "$SEMMAP" eval ate "$SAMPLE/groundtruth.txt" "$DATA_DIR/teddy_mono_trajectory.txt" --scale |
    grep -E "scale"
else
  echo "== MONO skipped: $(tail -n 1 "$DATA_DIR/mono_ingest.txt")"
fi

echo "== maps"
"$SEMMAP" maps
echo "== sessions"
"$SEMMAP" sessions --map demo
echo "== keyframes (where the camera was, T_world_camera, metres)"
"$SEMMAP" trajectory --map demo --session teddy --keyframes | head -n 8
"$SEMMAP" export --map demo --format json -o "$DATA_DIR/demo_map.json"
echo "== the 3D map: OctoMap, coloured cloud, and a picture from above"
"$SEMMAP" export --map demo --format bt -o "$DATA_DIR/demo_map.bt"
"$SEMMAP" export --map demo --format ply -o "$DATA_DIR/demo_map.ply"
"$SEMMAP" export --map demo --format png -o "${DEMO_PNG:-demo-map.png}"
echo "== where is the teddy? (map frame: the first camera's, metres)"
"$SEMMAP" where teddy
"$SEMMAP" --json where teddy
echo "== what is within 2 m of the first camera?"
"$SEMMAP" near 0 0 0 2

kill -TERM "$server_pid"
wait "$server_pid"
trap - EXIT
echo "== semmapd stopped cleanly; the map is in $DATA_DIR/semmap.db"
