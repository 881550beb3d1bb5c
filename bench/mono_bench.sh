#!/usr/bin/env bash
# MONO benchmark (issue 13): the learned VO alone (--mono-vo net), the hybrid (feature tracking
# on the network's depth, --mono-vo hybrid) and the classical monocular baseline
# (bench/mono_baseline_vo: five-point + PnP, scale aligned to ground truth: its best case),
# side by side on every sequence with ground truth that training never saw. Prints, per
# sequence and method: ATE RMSE without scale alignment (rigid only), the scale factor and ATE
# of a similarity alignment, RPE per second, frames/s through semmapd; KITTI 07 also t_rel. All
# figures also go to OUT/mono_bench.json. Sequences whose data is absent are skipped with a
# message.
#
#   bench/mono_bench.sh [--out DIR] [--data DIR] [--model FILE] [--only NAME,...]
#     --out DIR     where mono_bench.json and the trajectories go (default: a new temp dir, kept)
#     --data DIR    the real datasets (default: ../shared/data)
#     --model FILE  the VO model (default: models/vo/semmap_vo.onnx)
#     --only NAMES  teddy, synthetic, redkitchen_tail, kitti07
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build/release}
SEMMAPD="$BUILD_DIR/server/semmapd"
SEMMAP="$BUILD_DIR/client/cli/semmap"
SYNTH="$BUILD_DIR/tools/semmap-synth"
BASELINE="$BUILD_DIR/bench/mono_baseline_vo"
source scripts/semmapd_lib.sh

usage() { sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//'; exit "${1:-2}"; }
OUT=""; DATA=../shared/data; MODEL=models/vo/semmap_vo.onnx; ONLY=""
while [ $# -gt 0 ]; do
  case "$1" in
    --out) OUT=$2; shift 2 ;;
    --data) DATA=$2; shift 2 ;;
    --model) MODEL=$2; shift 2 ;;
    --only) ONLY=$2; shift 2 ;;
    -h|--help) usage 0 ;;
    *) echo "mono_bench: unknown option $1" >&2; usage ;;
  esac
done
EXTRA=${SEMMAP_EXTRA_DATA:-$HOME/.cache/semmap/data}
bench_setup mono-bench "$SEMMAPD" "$SEMMAP" "$SYNTH" "$BASELINE"
[ -f "$MODEL" ] || { echo "mono_bench: no VO model at $MODEL (make train-vo)" >&2; exit 1; }
REPORT="$OUT/mono_bench.json"
echo '{}' >"$REPORT"
report_set() { jq --argjson v "$2" "$1 = \$v" "$REPORT" >"$REPORT.tmp" && mv "$REPORT.tmp" "$REPORT"; }
wanted() { [ -z "$ONLY" ] || [[ ",$ONLY," == *",$1,"* ]]; }

# ate GT EST [--scale] -> "rmse scale" (scale 1 without --scale)
ate() {
  local json; json=$("$SEMMAP" --json eval ate "$1" "$2" "${@:3}" 2>/dev/null) || { echo "nan nan"; return; }
  jq -r '"\(.rmse // .ate.rmse // "nan") \(.scale // .alignment.scale // 1)"' <<<"$json"
}
rpe_per_s() {
  "$SEMMAP" --json eval rpe "$1" "$2" --delta 1 --delta-unit s 2>/dev/null |
    jq -r '.translation_m.rmse // "nan"' 2>/dev/null || echo nan
}

# run NAME DIR: every method on one sequence (DIR has groundtruth.txt).
run() {
  local name=$1 dir=$2 gt=$2/groundtruth.txt method
  printf '\n== %s (%s)\n' "$name" "$dir"
  printf '  %-9s %12s %10s %12s %10s %9s\n' method "ATE no-scale" scale "ATE scaled" "RPE/s" "frames/s"
  for method in net hybrid; do
    local data="$WORK/db-$name-$method" est="$OUT/$name-$method.txt"
    mkdir -p "$data"
    start_semmapd "$SEMMAPD" "$data" --vo-model "$MODEL" --mono-vo "$method" --log-level warning
    local json; json=$("$SEMMAP" --server "$SEMMAPD_ADDR" --json ingest "$dir" --map "$name" --mono \
      --trajectory-out "$est")
    stop_semmapd
    local fps; fps=$(jq -r '.frames_per_second' <<<"$json")
    read -r rigid _ <<<"$(ate "$gt" "$est")"
    read -r scaled scale <<<"$(ate "$gt" "$est" --scale)"
    local rpe; rpe=$(rpe_per_s "$gt" "$est")
    printf '  %-9s %10.3f m %10.3f %10.3f m %8.3f m %9.1f\n' "$method" "$rigid" "$scale" "$scaled" "$rpe" "$fps"
    report_set ".\"$name\".$method" "{\"ate_rigid_m\": $rigid, \"scale\": $scale, \"ate_sim3_m\": $scaled, \"rpe_per_s_m\": $rpe, \"frames_per_second\": $fps}"
  done
  local est="$OUT/$name-classical.txt"
  "$BASELINE" "$dir" "$est" >"$OUT/$name-classical.log"
  read -r scaled scale <<<"$(ate "$gt" "$est" --scale)"
  local rpe; rpe=$(rpe_per_s "$gt" "$est")
  printf '  %-9s %12s %10.3f %10.3f m %8s   (scale aligned to ground truth: its best case; %s)\n' \
    classical "-" "$scale" "$scaled" "-" "$(sed 's/^mono_baseline_vo: //' "$OUT/$name-classical.log")"
  report_set ".\"$name\".classical" "{\"scale\": $scale, \"ate_sim3_m\": $scaled, \"rpe_per_s_m\": \"$rpe\"}"
}

# KITTI poses (12 numbers, camera-to-world) + times.txt -> TUM; TUM -> KITTI (quaternions as
# rotation matrices), for the KITTI metric on the same frames.
kitti_to_tum() {
  paste -d' ' "$1/times.txt" "$1/poses.txt" | awk '{
    r00=$2; r01=$3; r02=$4; tx=$5; r10=$6; r11=$7; r12=$8; ty=$9; r20=$10; r21=$11; r22=$12; tz=$13
    tr = r00 + r11 + r22
    if (tr > 0) { s = sqrt(tr + 1) * 2; qw = s / 4; qx = (r21 - r12) / s; qy = (r02 - r20) / s; qz = (r10 - r01) / s }
    else if (r00 > r11 && r00 > r22) { s = sqrt(1 + r00 - r11 - r22) * 2; qw = (r21 - r12) / s; qx = s / 4; qy = (r01 + r10) / s; qz = (r02 + r20) / s }
    else if (r11 > r22) { s = sqrt(1 + r11 - r00 - r22) * 2; qw = (r02 - r20) / s; qx = (r01 + r10) / s; qy = s / 4; qz = (r12 + r21) / s }
    else { s = sqrt(1 + r22 - r00 - r11) * 2; qw = (r10 - r01) / s; qx = (r02 + r20) / s; qy = (r12 + r21) / s; qz = s / 4 }
    printf "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", $1, tx, ty, tz, qx, qy, qz, qw }'
}
tum_to_kitti() {
  grep -v '^#' "$1" | awk '{
    x=$5; y=$6; z=$7; w=$8
    printf "%.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n",
      1-2*(y*y+z*z), 2*(x*y-z*w), 2*(x*z+y*w), $2,
      2*(x*y+z*w), 1-2*(x*x+z*z), 2*(y*z-x*w), $3,
      2*(x*z-y*w), 2*(y*z+x*w), 1-2*(x*x+y*y), $4 }'
}

# tail_of DIR N OUT: a TUM-layout copy of DIR's last N frames (lists filtered, images linked).
tail_of() {
  local dir=$1 n=$2 out=$3 first
  mkdir -p "$out"
  first=$(grep -v '^#' "$dir/rgb.txt" | tail -n "$n" | head -n 1 | awk '{print $1}')
  for list in rgb.txt depth.txt groundtruth.txt; do
    [ -f "$dir/$list" ] && awk -v t="$first" '/^#/ || $1 >= t - 0.02' "$dir/$list" >"$out/$list"
  done
  cp "$dir/camera.yaml" "$out/"
  for sub in rgb depth; do [ -d "$dir/$sub" ] && ln -s "$(cd "$dir/$sub" && pwd)" "$out/$sub"; done
}

if wanted teddy; then
  if [ -f "$DATA/tum_fr3_teddy_200/groundtruth.txt" ]; then run teddy "$DATA/tum_fr3_teddy_200"
  else echo "mono_bench: teddy absent ($DATA/tum_fr3_teddy_200): skipped"; fi
fi
if wanted synthetic; then
  # A loop with a seed and trajectory training never used (training/make_synth.sh: seeds 1-12).
  "$SYNTH" "$WORK/synth_loop" --trajectory figure8 --frames 300 --seed 97 --depth-noise \
    --colour-noise --quiet
  run synthetic_loop "$WORK/synth_loop"
fi
if wanted redkitchen_tail; then
  if [ -f "$EXTRA/7scenes_redkitchen_tsdfpy/groundtruth.txt" ]; then
    # Held back from training: the last 200 of its 1000 frames.
    tail_of "$EXTRA/7scenes_redkitchen_tsdfpy" 200 "$WORK/redkitchen_tail"
    run redkitchen_tail "$WORK/redkitchen_tail"
  else
    echo "mono_bench: 7-Scenes redkitchen absent ($EXTRA; ../shared/data/extra/README.md): skipped"
  fi
fi
if wanted kitti07; then
  if [ -d "$DATA/kitti_07_first160" ]; then
    # Outdoor driving, no depth to train on: generalisation, not a goal. The KITTI layout with a
    # TUM ground truth next to it for ATE; t_rel over 50 m segments (160 frames: about 90 m).
    k="$WORK/kitti07"
    mkdir -p "$k"
    for f in calib.txt times.txt poses.txt; do cp "$DATA/kitti_07_first160/$f" "$k/"; done
    ln -s "$(cd "$DATA/kitti_07_first160/image_0" && pwd)" "$k/image_0"
    kitti_to_tum "$k" >"$k/groundtruth.txt"
    run kitti07 "$k"
    for method in net hybrid classical; do
      tum_to_kitti "$OUT/kitti07-$method.txt" >"$OUT/kitti07-$method.kitti"
      t_rel=$("$SEMMAP" --json eval kitti "$k/poses.txt" "$OUT/kitti07-$method.kitti" --lengths 50 \
        2>/dev/null | jq -r '.t_rel // "nan"' || echo nan)
      printf '  %-9s t_rel %s %% (50 m segments)\n' "$method" "$t_rel"
    done
  else
    echo "mono_bench: KITTI 07 absent: skipped"
  fi
fi
echo
echo "mono_bench: report in $REPORT"
