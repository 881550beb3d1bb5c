#!/usr/bin/env bash
# tests/fuzz/seed_corpus.sh OUT_DIR: one seed directory per fuzz target, OUT_DIR/<target>/,
# from the repo's real samples (data/samples, models/orb_vocab.bin), the small hand-written
# seeds in tests/fuzz/seeds/, and, for the binary formats, fuzz_make_seeds (built by the fuzz
# preset; $FUZZ_MAKE_SEEDS overrides its path). ../shared/data adds seeds when present.
# Real files too big to mutate quickly (the 512 kB vocabulary, whole lists) go to
# OUT_DIR/large/<target>/ instead: scripts/fuzz.sh runs each target once over them, and
# fuzzes from the small seeds (a 512 kB seed makes every mutation cost 10x more).
set -euo pipefail

if [ $# -ne 1 ]; then
  echo "usage: $0 OUT_DIR" >&2
  exit 2
fi
out=$1
root=$(cd "$(dirname "$0")/../.." && pwd)
here=$root/tests/fuzz
make_seeds=${FUZZ_MAKE_SEEDS:-$root/build/asan/tests/fuzz/fuzz_make_seeds}
sample=$root/data/samples/tum_fr3_teddy_80
shared=${SEMMAP_SHARED_DATA_DIR:-$root/../shared/data}

# Every target gets a directory, with tests/fuzz/seeds/<target>/* when there are such files.
targets=()
for f in "$here"/*_fuzz.cc; do targets+=("$(basename "$f" _fuzz.cc)"); done
for t in "${targets[@]}"; do
  mkdir -p "$out/$t" "$out/large/$t"
  if [ -d "$here/seeds/$t" ]; then cp "$here/seeds/$t/"* "$out/$t/"; fi
done

# Joins files into one input with NUL separators (the multi-file targets split there).
join_nul() {
  local first=1
  for f in "$@"; do
    [ $first -eq 1 ] || printf '\0'
    first=0
    cat "$f"
  done
}

# A PNG header for kitti_lists (the image size comes from it): the sample's first depth PNG.
png=$(find "$sample/depth" -name '*.png' 2>/dev/null | sort | head -n 1 || true)
png_head=$(mktemp)
trap 'rm -f "$png_head"' EXIT
if [ -n "$png" ]; then head -c 64 "$png" >"$png_head"; fi

# TUM lists: the sample's rgb.txt and depth.txt, their first lines (whole ones: large).
if [ -f "$sample/rgb.txt" ]; then
  join_nul "$sample/rgb.txt" "$sample/depth.txt" >"$out/large/tum_lists/teddy_80"
  join_nul <(head -n 8 "$sample/rgb.txt") <(head -n 8 "$sample/depth.txt") \
    >"$out/tum_lists/teddy_head"
fi

# KITTI: times '\0' poses '\0' calib '\0' PNG, from the hand-written parts (synthetic values).
kitti=$here/seeds/kitti_parts
join_nul "$kitti/times.txt" "$kitti/poses.txt" "$kitti/calib.txt" "$png_head" \
  >"$out/kitti_lists/synthetic"
join_nul "$kitti/times.txt" "$kitti/poses.txt" >"$out/kitti_lists/times_poses"
if [ -f "$shared/kitti_07_first160/times.txt" ]; then
  k=$shared/kitti_07_first160
  join_nul <(head -n 12 "$k/times.txt") <(head -n 12 "$k/poses.txt") "$k/calib.txt" \
    "$png_head" >"$out/kitti_lists/kitti_07_head"
  join_nul "$k/times.txt" "$k/poses.txt" "$k/calib.txt" "$png_head" \
    >"$out/large/kitti_lists/kitti_07"
fi

# camera.yaml: the sample's (and the hand-written ones above), the shared datasets'.
[ -f "$sample/camera.yaml" ] && cp "$sample/camera.yaml" "$out/camera_yaml/teddy_80.yaml"
if [ -d "$shared" ]; then
  for y in "$shared"/*/camera.yaml "$shared"/samples/*/camera.yaml; do
    [ -f "$y" ] && cp "$y" "$out/camera_yaml/shared_$(basename "$(dirname "$y")").yaml"
  done
fi

# Trajectories: the sample's ground truth (its head; whole: large), TUM and KITTI hand-written.
if [ -f "$sample/groundtruth.txt" ]; then
  cp "$sample/groundtruth.txt" "$out/large/trajectory/teddy_80_groundtruth.txt"
  head -n 12 "$sample/groundtruth.txt" >"$out/trajectory/teddy_80_head.txt"
fi
if [ -f "$shared/kitti_07_first160/poses.txt" ]; then
  head -n 12 "$shared/kitti_07_first160/poses.txt" >"$out/trajectory/kitti_07_head.txt"
  cp "$shared/kitti_07_first160/poses.txt" "$out/large/trajectory/kitti_07_poses.txt"
fi

# Binary formats: written by the repo's writers; the real vocabulary too.
if [ -x "$make_seeds" ]; then
  "$make_seeds" "$out"
else
  echo "seed_corpus: $make_seeds not built (cmake --build --preset asan --target fuzz_all); binary targets" \
    "get no generated seeds" >&2
fi
[ -f "$root/models/orb_vocab.bin" ] && cp "$root/models/orb_vocab.bin" "$out/large/bow_vocabulary/"

for t in "${targets[@]}"; do
  printf 'seed_corpus: %-15s %3d seeds, %d large files\n' "$t" "$(find "$out/$t" -type f | wc -l)" \
    "$(find "$out/large/$t" -type f | wc -l)"
done
