#!/usr/bin/env bash
# Builds the image and tests it for real (make docker-test; root, podman with runc):
# base images (docker/make-base.sh when missing), build, image sizes, run with a named volume,
# wait for the HEALTHCHECK, stream the bundled sample from the host's CLI into the container's
# port, ask where the teddy is, SIGTERM (exit code 0 expected), then a second container on the
# same volume must still have the map and the teddy. Prints every step; exits 1 on a failure.
set -euo pipefail
cd "$(dirname "$0")/.."
ENGINE=${ENGINE:-podman}
RUNTIME=(--runtime "${RUNTIME:-runc}")  # crun fails on this kernel's cgroups
# podman's default limits exceed this machine's hard ones (runc then cannot set them).
LIMITS=(--ulimit "nofile=$(ulimit -Hn):$(ulimit -Hn)" --ulimit nproc=4096:4096)
IMAGE=${IMAGE:-semmap:test}
PORT=${PORT:-50551}
NAME=semmap-test-$$
VOLUME=semmap-test-data-$$
SEMMAP=${SEMMAP:-build/release/client/cli/semmap}
start=$SECONDS

step() { echo "== docker-test: $* ($((SECONDS - start)) s)"; }
fail() { echo "== docker-test: FAILED: $*"; $ENGINE logs "$NAME" 2>&1 | tail -n 20 || true; exit 1; }
cleanup() {
  $ENGINE rm -f "$NAME" >/dev/null 2>&1 || true
  $ENGINE volume rm -f "$VOLUME" >/dev/null 2>&1 || true
}
trap cleanup EXIT

[ -x "$SEMMAP" ] || { echo "docker-test: no $SEMMAP (make build first)"; exit 1; }
step "base images"
ENGINE=$ENGINE bash docker/make-base.sh

step "building $IMAGE (install-deps + Release build inside: ~20 minutes on 2 cores)"
build_start=$SECONDS
CCACHE_HOST=${CCACHE_DIR:-$HOME/.cache/ccache}
mkdir -p "$CCACHE_HOST"
$ENGINE build "${RUNTIME[@]}" --network host --format docker -v "$CCACHE_HOST:/ccache" \
  -f docker/Dockerfile -t "$IMAGE" . \
  >/tmp/semmap-docker-build.log 2>&1 || { tail -n 40 /tmp/semmap-docker-build.log; fail build; }
echo "built in $((SECONDS - build_start)) s; runtime packages:"
sed -n '/^runtime packages:/,/^[-a-zA-Z]*STEP\|^--> /p' /tmp/semmap-docker-build.log | grep -v "^-->\|STEP\|runtime packages" | tr '\n' ' '
echo
size_mb() { $ENGINE image inspect --format '{{.Size}}' "$1" | awk '{printf "%.0f", $1 / 1e6}'; }
echo "image sizes: $IMAGE $(size_mb "$IMAGE") MB (goal < 400), debian:bookworm-slim $(size_mb debian:bookworm-slim) MB, debian:bookworm $(size_mb debian:bookworm) MB"
[ "$(size_mb "$IMAGE")" -lt 400 ] || fail "the runtime image is not under 400 MB"

run_container() {
  $ENGINE run -d "${RUNTIME[@]}" "${LIMITS[@]}" --name "$NAME" -p "127.0.0.1:$PORT:50051" -v "$VOLUME:/data" \
    "$IMAGE" >/dev/null || fail "run"
  for _ in $(seq 60); do
    if $ENGINE healthcheck run "$NAME" >/dev/null 2>&1; then
      echo "healthy: $($ENGINE inspect --format '{{.State.Health.Status}}' "$NAME" 2>/dev/null)"
      return
    fi
    sleep 1
  done
  fail "no healthy container within 60 s"
}
stop_container() {
  $ENGINE stop -t 30 "$NAME" >/dev/null
  code=$($ENGINE inspect --format '{{.State.ExitCode}}' "$NAME")
  echo "semmapd exit code after SIGTERM: $code"
  [ "$code" = 0 ] || fail "semmapd exited $code on SIGTERM"
  $ENGINE logs "$NAME" 2>&1 | tail -n 3
  $ENGINE rm "$NAME" >/dev/null
}

$ENGINE volume create "$VOLUME" >/dev/null
step "first container: user $($ENGINE run --rm "${RUNTIME[@]}" "${LIMITS[@]}" --entrypoint id "$IMAGE" -un), volume $VOLUME"
run_container
export SEMMAP_SERVER=127.0.0.1:$PORT
"$SEMMAP" health --server "$SEMMAP_SERVER"
step "streaming the bundled sample from the host CLI into the container"
"$SEMMAP" objects add teddy data/samples/objects/teddy.png --server "$SEMMAP_SERVER"
"$SEMMAP" ingest data/samples/tum_fr3_teddy_80 --map demo --session teddy --server "$SEMMAP_SERVER"
step "where is the teddy?"
where=$("$SEMMAP" where teddy --server "$SEMMAP_SERVER")
echo "$where"
grep -q teddy <<<"$where" || fail "the teddy was not placed"
step "SIGTERM"
stop_container

step "second container on the same volume"
run_container
"$SEMMAP" maps --server "$SEMMAP_SERVER"
again=$("$SEMMAP" where teddy --server "$SEMMAP_SERVER")
echo "$again"
[ "$again" = "$where" ] || fail "the map did not survive the restart unchanged"
stop_container
step "passed"
