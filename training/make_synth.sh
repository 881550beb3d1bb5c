#!/usr/bin/env bash
# Renders the synthetic part of the VO training set with semmap-synth (deterministic; skips
# sequences that already exist) and the held-out synthetic evaluation sequence.
#
# usage: training/make_synth.sh [OUT_DIR]      (default $SEMMAP_VO_CACHE/synth or ~/.cache/semmap/vo/synth)
#   env: SEMMAP_SYNTH  the generator (default build/release/tools/semmap-synth)
#
# Sizes: 192x144 renders (area-resampled to the 128x96 network camera by the loader), 12 training
# sequences, 5,000 frames, about 450 MB and 6 minutes on one core. Frame counts set the speed: a
# loop makes one lap over its frames, so 300-600 frames give 1-4 cm and 1-4 deg per frame at
# 30 Hz (hand-held speeds); the trainer's frame-stride augmentation covers faster motion.
# Seeds 1-12 train; seed 99 (`eval_tour_s99`) is held out for evaluation (never pass it to train).
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/.." && pwd)
OUT=${1:-${SEMMAP_VO_CACHE:-$HOME/.cache/semmap/vo}/synth}
SYNTH=${SEMMAP_SYNTH:-$ROOT/build/release/tools/semmap-synth}
if [ ! -x "$SYNTH" ]; then
  echo "make_synth: $SYNTH not found (build it with 'make build'); no synthetic data generated" >&2
  exit 3
fi
mkdir -p "$OUT/train" "$OUT/eval"

W=192; H=144
#      name              trajectory frames seed  options
SEQS=(
  "circle_s1           circle    500  1   "
  "circle_s2           circle    350  2   --depth-noise --colour-noise"
  "figure8_s3          figure8   600  3   --blur --depth-noise"
  "figure8_s4          figure8   400  4   --colour-noise --fx 126"
  "corridor_s5         corridor  500  5   --depth-noise"
  "corridor_s6         corridor  350  6   --blur --colour-noise --depth-noise"
  "rotation_s7         rotation  300  7   --colour-noise"
  "fast_s8             fast      400  8   --depth-noise --colour-noise --blur"
  "fast_s9             fast      300  9   --fx 190"
  "tour_s10            tour      600  10  --depth-noise"
  "tour_s11            tour      500  11  --colour-noise --blur --drop-depth 0.05"
  "figure8_s12         figure8   450  12  --depth-noise --fx 210"
)
render() { # DEST name traj frames seed options...
  local dest=$1 name=$2 traj=$3 frames=$4 seed=$5; shift 5
  if [ -f "$dest/$name/rgb.txt" ]; then return 0; fi
  rm -rf "$dest/$name.tmp"
  "$SYNTH" "$dest/$name.tmp" --trajectory "$traj" --frames "$frames" --seed "$seed" \
    --width $W --height $H --no-templates --quiet "$@"
  mv "$dest/$name.tmp" "$dest/$name"
  echo "make_synth: $dest/$name ($traj, $frames frames, seed $seed $*)"
}
for s in "${SEQS[@]}"; do
  # shellcheck disable=SC2086
  render "$OUT/train" $s
done
# held out: a seed and path the trainer never sees
render "$OUT/eval" eval_tour_s99 tour 400 99 --depth-noise --colour-noise
echo "make_synth: training sequences in $OUT/train, held-out evaluation sequence in $OUT/eval"
