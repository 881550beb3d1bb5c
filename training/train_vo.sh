#!/usr/bin/env bash
# The full, reproducible VO training recipe (`make train-vo`): data, training, ONNX export,
# evaluation on held-out sequences. Resumable: run it again after an interruption and training
# continues from RUN_DIR/last.pt.
#
# usage: training/train_vo.sh [RUN_DIR]     (default ~/.cache/semmap/vo/runs/full)
#   env: STEPS (default 10000), THREADS (2), SEMMAP_EXTRA_DATA (~/.cache/semmap/data),
#        MODEL_OUT (models/vo/semmap_vo.onnx; the JSON sidecar goes next to it)
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/.." && pwd)
RUN=${1:-${SEMMAP_VO_CACHE:-$HOME/.cache/semmap/vo}/runs/full}
STEPS=${STEPS:-10000}
THREADS=${THREADS:-2}
EXTRA=${SEMMAP_EXTRA_DATA:-$HOME/.cache/semmap/data}
SHARED=$ROOT/../shared/data
MODEL_OUT=${MODEL_OUT:-$ROOT/models/vo/semmap_vo.onnx}
SYNTH_DIR=${SEMMAP_VO_CACHE:-$HOME/.cache/semmap/vo}/synth
PY=/usr/bin/python3
export OMP_NUM_THREADS=$THREADS OMP_WAIT_POLICY=PASSIVE PYTHONHASHSEED=0

need() { [ -f "$1/rgb.txt" ] || { echo "train_vo: missing $1 ($2)" >&2; exit 2; }; }
need "$SHARED/kinect_cafe_391_nogt" "shared/data"
need "$EXTRA/7scenes_redkitchen_tsdfpy" "build it: MIRROR=... bash ../shared/data/extra/extract.sh (shared/data/extra/README.md)"
need "$EXTRA/icl_livingroom_kt2_cmu16833" "build it: MIRROR=... bash ../shared/data/extra/extract.sh"

bash "$HERE/make_synth.sh" "$SYNTH_DIR"

cd "$HERE"
if [ -f "$RUN/last.pt" ]; then
  $PY -m semmap_vo.train --out "$RUN" --resume --threads "$THREADS"
else
  # redkitchen frames 800-999 are held out for evaluation; tum_fr3_teddy (evaluation) and
  # every freiburg1 sequence are refused by the loader.
  $PY -m semmap_vo.train --out "$RUN" --threads "$THREADS" --steps "$STEPS" --seed 1 \
    --real "$SHARED/kinect_cafe_391_nogt" "$EXTRA/7scenes_redkitchen_tsdfpy:0:800" \
           "$EXTRA/icl_livingroom_kt2_cmu16833" \
    --synth-dir "$SYNTH_DIR/train"
fi

CKPT=$RUN/last.pt
$PY -m semmap_vo.export "$CKPT" --out "$MODEL_OUT"

# Held-out evaluation (rigid ATE: metric scale counts; Sim(3) ATE and its scale; RPE over 1 s),
# then the evaluation sequence teddy, for reporting only.
EVAL=(
  "$EXTRA/7scenes_redkitchen_tsdfpy:800"
  "$SYNTH_DIR/eval/eval_tour_s99"
)
[ -f "$SHARED/tum_fr3_teddy_200/rgb.txt" ] && EVAL+=("$SHARED/tum_fr3_teddy_200")
$PY -m semmap_vo.evaluate "${EVAL[@]}" --model "$MODEL_OUT" --out "$RUN/trajectories" --json "$RUN/eval.json"
echo "train_vo: model $MODEL_OUT, run folder $RUN (curve.png, history.json, eval.json)"
