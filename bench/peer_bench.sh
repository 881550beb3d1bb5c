#!/usr/bin/env bash
# semmap and ORB-SLAM2 side by side (issue 14): both systems on every RGB-D sequence with ground
# truth held here, in one run on this machine, the same evaluator for both. Per sequence and
# system: ATE RMSE (rigid alignment, `semmap eval ate` on each system's trajectory), frames
# tracked, per-frame tracking time (p50), end-to-end frames/s, peak RSS; then semmap / ORB-SLAM2
# ratios and semmap's back-end share. Medians over --runs runs (ORB-SLAM2 is multi-threaded and
# not deterministic). Also writes OUT/peer_bench.json.
#
#   bench/peer_bench.sh [--runs N] [--only NAMES] [--out DIR] [--semmapd-args A]
#     --runs N      runs per system and sequence (default 3)
#     --only NAMES  comma-separated subset of: teddy, redkitchen, icl, synth-lap, synth-fast
#     --out DIR     where every run's files and the report go (default: a new temp dir, kept)
#     --semmapd-args A  extra semmapd flags, one string (e.g. "--final-ba off")
#
# Sequences: teddy (../shared/data), 7-Scenes redkitchen and ICL-NUIM kt2 ($SEMMAP_EXTRA_DATA,
# default ~/.cache/semmap/data; rebuild with ../shared/data/extra/README.md); each is skipped
# with a message when absent. Two synthetic ones rendered by semmap-synth into OUT/data (seed 2,
# motion blur, Kinect-like depth noise, colour noise; about a minute each, kept for a rerun with
# the same --out): synth-lap, one 300-frame lap of the room at 30 Hz that closes a loop;
# synth-fast, 300 frames of fast hand-held motion (about 2 m/s and 150 deg/s) at 60 Hz.
# ORB-SLAM2 comes from ../shared/peers/orbslam2 (build.sh, README):
# its column is skipped with a message when it is not built ($ORBSLAM2_ROOT, default
# ~/.cache/semmap/peers/orbslam2). Its settings file is generated from the sequence's own
# camera.yaml (intrinsics, depth scale) with ORB-SLAM2's TUM defaults for everything else.
#
# Not the same thing measured, said plainly: ORB-SLAM2's tracking time is TrackRGBD (decode
# excluded, local mapping on its own thread); semmap's is the server's tracking stage (decode
# excluded, back end on its own thread). Frames/s: ORB-SLAM2's over its feed loop (reading
# images from disk in the same process, each TrackRGBD call; its shutdown excluded); semmap's
# client reads the files and streams them over loopback gRPC to semmapd, and its "streaming"
# figure runs until the last frame's pose came back (the same span), printed beside the figure
# that includes closing the session (final bundle adjustment, the layers' last rebuild). The
# ratio is on the streaming figure.
# ORB-SLAM2's ATE covers the frames it tracked; semmap's every stored frame (lost ones included).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
BUILD_DIR=${BUILD_DIR:-build/release}
SEMMAP="$BUILD_DIR/client/cli/semmap"
PEER="$ROOT/../shared/peers/orbslam2"
ORBSLAM2_ROOT=${ORBSLAM2_ROOT:-$HOME/.cache/semmap/peers/orbslam2}
export ORBSLAM2_ROOT
EXTRA=${SEMMAP_EXTRA_DATA:-$HOME/.cache/semmap/data}
SHARED_DATA="$ROOT/../shared/data"

usage() { sed -n '2,30p' "$0" | sed 's/^# \{0,1\}//'; exit "${1:-2}"; }
RUNS=3; ONLY=""; OUT=""; SEMMAPD_ARGS=""
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) RUNS=$2; shift 2 ;;
    --only) ONLY=",$2,"; shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    --semmapd-args) SEMMAPD_ARGS=$2; shift 2 ;;
    -h|--help) usage 0 ;;
    *) echo "peer_bench: unknown option $1" >&2; usage ;;
  esac
done
[[ $RUNS =~ ^[1-9][0-9]*$ ]] || { echo "peer_bench: --runs wants a positive integer" >&2; exit 2; }
[ -x "$SEMMAP" ] || { echo "peer_bench: $SEMMAP missing; run 'make build'" >&2; exit 1; }
command -v jq >/dev/null || { echo "peer_bench: needs jq" >&2; exit 1; }
OUT=${OUT:-$(mktemp -d -t semmap-peer-bench-XXXXXX)}
mkdir -p "$OUT"; OUT=$(cd "$OUT" && pwd)

PEER_OK=1
if [ ! -x "$ORBSLAM2_ROOT/src/Examples/RGB-D/rgbd_tum" ]; then
  PEER_OK=0
  echo "ORB-SLAM2 not built under $ORBSLAM2_ROOT: its column is skipped (build it: fetch"
  echo "github:raulmur/ORB_SLAM2, then ORBSLAM2_MIRROR=<that dir> bash ../shared/peers/orbslam2/build.sh)"
fi

#        name        folder
SEQS=("teddy       $SHARED_DATA/tum_fr3_teddy_200"
      "redkitchen  $EXTRA/7scenes_redkitchen_tsdfpy"
      "icl         $EXTRA/icl_livingroom_kt2_cmu16833"
      "synth-lap   $OUT/data/synth-lap"
      "synth-fast  $OUT/data/synth-fast")
SYNTH="$BUILD_DIR/tools/semmap-synth"
SYNTH_NOISE=(--seed 2 --frames 300 --blur --depth-noise --colour-noise --quiet --no-templates)
declare -A SYNTH_ARGS=([synth-lap]="--trajectory circle --rate 30"
                       [synth-fast]="--trajectory fast --rate 60")

# render_synth NAME DIR: renders a synthetic sequence unless DIR already holds it.
render_synth() {
  [ -f "$2/groundtruth.txt" ] && return 0
  [ -x "$SYNTH" ] || { echo "  skipped: $SYNTH missing (make build)"; return 1; }
  echo "  rendering $1 (semmap-synth ${SYNTH_ARGS[$1]} ${SYNTH_NOISE[*]})"
  rm -rf "$2"; mkdir -p "$(dirname "$2")"
  # shellcheck disable=SC2086  # the arguments are words
  "$SYNTH" "$2" ${SYNTH_ARGS[$1]} "${SYNTH_NOISE[@]}" >"$2.log" 2>&1 ||
    { echo "  skipped: semmap-synth failed: $2.log"; tail -3 "$2.log"; return 1; }
}

# orb_settings CAMERA_YAML: an ORB-SLAM2 settings file for that camera (semmap's camera.yaml
# keys: fx fy cx cy width height depth_scale distortion), ORB-SLAM2's TUM defaults otherwise.
orb_settings() {
  awk -F': *' '
    /^[a-z_]+:/ { sub(/ *#.*/, "", $2); v[$1] = $2 }
    END {
      d = v["distortion"]; gsub(/[][ ]/, "", d); n = split(d, k, ",")
      for (i = 1; i <= 5; i++) if (i > n) k[i] = 0
      if (v["depth_scale"] + 0 <= 0) { print "camera.yaml has no depth_scale" > "/dev/stderr"; exit 1 }
      print "%YAML:1.0"
      printf "Camera.fx: %s\nCamera.fy: %s\nCamera.cx: %s\nCamera.cy: %s\n", v["fx"], v["fy"], v["cx"], v["cy"]
      printf "Camera.k1: %s\nCamera.k2: %s\nCamera.p1: %s\nCamera.p2: %s\nCamera.k3: %s\n", k[1], k[2], k[3], k[4], k[5]
      printf "Camera.width: %s\nCamera.height: %s\n", v["width"], v["height"]
      print "Camera.fps: 30.0\nCamera.bf: 40.0\nCamera.RGB: 1\nThDepth: 40.0"
      printf "DepthMapFactor: %s\n", v["depth_scale"]
      print "ORBextractor.nFeatures: 1000\nORBextractor.scaleFactor: 1.2\nORBextractor.nLevels: 8"
      print "ORBextractor.iniThFAST: 20\nORBextractor.minThFAST: 7"
    }' "$1"
}


# run_semmap NAME DIR RUN_DIR: one semmap run (bench/run_dataset.sh); prints a JSON object.
run_semmap() {
  local dir=$2 out=$3
  bash bench/run_dataset.sh "$dir" --out "$out" --semmapd-args "$SEMMAPD_ARGS" >"$out.log" 2>&1 ||
    { echo "  semmap run failed: $out.log" >&2; tail -5 "$out.log" >&2; echo null; return; }
  jq -c '{ate_m: .ate.rmse, ate_max_m: .ate.max, frames: .ingest.frames_sent,
          tracked: (.ingest.frames_stored - .ingest.lost_frames), lost: .ingest.lost_frames,
          keyframes: .ingest.keyframes, loops: .ingest.loop_closures,
          tracking_p50_ms: .ingest.stages.tracking.p50_ms, decode_p50_ms: .ingest.stages.decode.p50_ms,
          extract_p50_ms: .ingest.stages.tracking_extract.p50_ms,
          match_p50_ms: .ingest.stages.tracking_match.p50_ms,
          pose_p50_ms: .ingest.stages.tracking_pose.p50_ms,
          backend_keyframe_p50_ms: .ingest.stages.backend_keyframe.p50_ms,
          backend_keyframe_p95_ms: .ingest.stages.backend_keyframe.p95_ms,
          map_insert_p50_ms: .ingest.stages.map_insert.p50_ms,
          fps: .ingest.frames_per_second, streaming_fps: .ingest.streaming_frames_per_second,
          close_s: (.ingest.seconds - .ingest.streaming_seconds), peak_rss_mb: (.server_peak_rss_kb / 1024)}' "$out/report.json"
}

# run_orb DIR SETTINGS RUN_DIR: one ORB-SLAM2 run (peers/orbslam2/run.sh); prints a JSON object.
run_orb() {
  local dir=$1 settings=$2 out=$3
  bash "$PEER/run.sh" "$dir" "$settings" "$out" >"$out.log" 2>&1 ||
    { echo "  ORB-SLAM2 run failed: $out.log" >&2; tail -5 "$out.log" >&2; echo null; return; }
  local s="$out/summary.txt" ate=null
  get() { awk -v k="$1" '$1 == k { print $2 }' "$s"; }
  if [ -s "$out/CameraTrajectory.txt" ] && [ -e "$dir/groundtruth.txt" ]; then
    ate=$("$SEMMAP" --json eval ate "$dir/groundtruth.txt" "$out/CameraTrajectory.txt")
  fi
  jq -nc --argjson ate "$ate" --arg fed "$(get frames_fed)" --arg ok "$(get tracked_ok)" \
     --arg lost "$(get lost)" --arg kfs "$(get keyframes)" --arg med "$(get median_track_ms)" \
     --arg feed "$(get feed_s)" --arg rss "$(get peak_rss_mb)" --arg tum "$(get ate_rmse_m)" '
    {ate_m: $ate.rmse, ate_max_m: $ate.max, ate_tum_script_m: ($tum | tonumber? // null),
     frames: ($fed | tonumber), tracked: ($ok | tonumber), lost: ($lost | tonumber),
     keyframes: ($kfs | tonumber), tracking_p50_ms: ($med | tonumber),
     fps: (($fed | tonumber) / ($feed | tonumber)), peak_rss_mb: ($rss | tonumber)}'
}

# summarise RUNS_JSON_ARRAY: the per-key median over the runs (nulls dropped).
summarise() {
  jq -c 'map(select(. != null)) as $r | if ($r | length) == 0 then null else
    ($r[0] | keys) as $k | reduce $k[] as $key ({runs: ($r | length)};
      . + {($key): ([$r[][$key] | select(. != null)] | sort |
             if length == 0 then null elif length % 2 == 1 then .[(length - 1) / 2]
             else (.[length / 2 - 1] + .[length / 2]) / 2 end)}) end'
}

echo "peer_bench: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)," \
     "commit $(git rev-parse --short HEAD 2>/dev/null || echo '?'), $RUNS run(s) each," \
     "semmapd ${SEMMAPD_ARGS:-(defaults)}, out $OUT"
echo '{}' >"$OUT/peer_bench.json"
T0=$(date +%s)
for entry in "${SEQS[@]}"; do
  read -r name dir <<<"$entry"
  [ -z "$ONLY" ] || [[ $ONLY == *",$name,"* ]] || continue
  printf '\n== %s (%s)\n' "$name" "$dir"
  if [[ $name == synth-* ]]; then render_synth "$name" "$dir" || continue; fi
  if [ ! -f "$dir/rgb.txt" ] || [ ! -f "$dir/groundtruth.txt" ]; then
    echo "  skipped: $dir absent (see ../shared/data/README.md and ../shared/data/extra/README.md)"
    continue
  fi
  mkdir -p "$OUT/$name"
  settings="$OUT/$name/orbslam2.yaml"
  orb_settings "$dir/camera.yaml" >"$settings"
  sem_runs=(); orb_runs=()
  for r in $(seq 1 "$RUNS"); do
    # Alternate the order so neither system always runs on a warmer page cache.
    if [ $((r % 2)) -eq 1 ]; then
      sem_runs+=("$(run_semmap "$name" "$dir" "$OUT/$name/semmap-$r")")
      [ "$PEER_OK" -eq 1 ] && orb_runs+=("$(run_orb "$dir" "$settings" "$OUT/$name/orbslam2-$r")")
    else
      [ "$PEER_OK" -eq 1 ] && orb_runs+=("$(run_orb "$dir" "$settings" "$OUT/$name/orbslam2-$r")")
      sem_runs+=("$(run_semmap "$name" "$dir" "$OUT/$name/semmap-$r")")
    fi
    echo "  run $r: semmap ATE $(jq -r '.ate_m // "n/a"' <<<"${sem_runs[-1]}")" \
         "$([ "$PEER_OK" -eq 1 ] && echo "| ORB-SLAM2 ATE $(jq -r '.ate_m // "n/a"' <<<"${orb_runs[-1]}")")"
  done
  sem=$(printf '%s\n' "${sem_runs[@]}" | jq -s . | summarise)
  orb=null
  [ "$PEER_OK" -eq 1 ] && orb=$(printf '%s\n' "${orb_runs[@]}" | jq -s . | summarise)
  row=$(jq -nc --argjson s "$sem" --argjson o "$orb" --argjson sem_all "$(printf '%s\n' "${sem_runs[@]}" | jq -s .)" \
          --argjson orb_all "$([ "$PEER_OK" -eq 1 ] && printf '%s\n' "${orb_runs[@]}" | jq -s . || echo null)" '
    def ratio(a; b): if a == null or b == null or b == 0 then null else a / b end;
    {semmap: $s, orbslam2: $o, semmap_runs: $sem_all, orbslam2_runs: $orb_all,
     ratio: (if $s == null or $o == null then null else
       {ate: ratio($s.ate_m; $o.ate_m), tracking_p50: ratio($s.tracking_p50_ms; $o.tracking_p50_ms),
        fps: ratio($s.streaming_fps; $o.fps), fps_with_close: ratio($s.fps; $o.fps),
        peak_rss: ratio($s.peak_rss_mb; $o.peak_rss_mb)} end)}')
  jq --arg n "$name" --argjson v "$row" '.[$n] = $v' "$OUT/peer_bench.json" >"$OUT/tmp.json" &&
    mv "$OUT/tmp.json" "$OUT/peer_bench.json"
  jq -r '
    def f(x; d): if x == null then "n/a" else (x * pow(10; d) | round / pow(10; d) | tostring) end;
    def line(n; r): if r == null then "  \(n): n/a" else
      "  \(n): ATE \(f(r.ate_m * 1000; 1)) mm (max \(f(r.ate_max_m * 1000; 0)) mm), tracked \(r.tracked)/\(r.frames), keyframes \(r.keyframes), tracking p50 \(f(r.tracking_p50_ms; 1)) ms, \(if r.streaming_fps != null then "\(f(r.streaming_fps; 1)) frames/s streaming, \(f(r.fps; 1)) with the session close (\(f(r.close_s; 2)) s)" else "\(f(r.fps; 1)) frames/s (feed loop)" end), peak RSS \(f(r.peak_rss_mb; 0)) MB" end;
    line("semmap   "; .semmap), line("ORB-SLAM2"; .orbslam2),
    (if .semmap != null then "  semmap tracking p50 by part: extraction \(f(.semmap.extract_p50_ms; 1)) ms, matching \(f(.semmap.match_p50_ms; 1)) ms, pose \(f(.semmap.pose_p50_ms; 1)) ms" else empty end),
    (if .semmap != null then "  semmap back end: keyframe p50 \(f(.semmap.backend_keyframe_p50_ms; 1)) ms / p95 \(f(.semmap.backend_keyframe_p95_ms; 1)) ms, map layer insert p50 \(f(.semmap.map_insert_p50_ms; 1)) ms, decode p50 \(f(.semmap.decode_p50_ms; 1)) ms; loops \(.semmap.loops)" else empty end),
    (if .ratio != null then "  semmap / ORB-SLAM2: ATE \(f(.ratio.ate; 2)), tracking p50 \(f(.ratio.tracking_p50; 2)), frames/s \(f(.ratio.fps; 2)) streaming (\(f(.ratio.fps_with_close; 2)) with the close), peak RSS \(f(.ratio.peak_rss; 2))" else empty end)' <<<"$row"
done
jq --argjson s "$(( $(date +%s) - T0 ))" --arg c "$(git rev-parse HEAD 2>/dev/null || true)" \
   '. + {seconds: $s, commit: $c}' "$OUT/peer_bench.json" >"$OUT/tmp.json" && mv "$OUT/tmp.json" "$OUT/peer_bench.json"
printf '\nrun time: %d s; report: %s\n' "$(( $(date +%s) - T0 ))" "$OUT/peer_bench.json"
