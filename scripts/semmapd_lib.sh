# Sourced by scripts that run a throw-away semmapd (demo, benchmarks).
# start_semmapd SEMMAPD DATA_DIR [FLAGS...]: starts it on an ephemeral loopback port (with the
# extra flags) and waits until it prints its address; sets SEMMAPD_PID and SEMMAPD_ADDR. Logs go
# to DATA_DIR/semmapd.log.
start_semmapd() {
  local bin=$1 data_dir=$2
  shift 2
  "$bin" --listen 127.0.0.1:0 --data-dir "$data_dir" "$@" >"$data_dir/semmapd.out" \
    2>"$data_dir/semmapd.log" &
  SEMMAPD_PID=$!
  SEMMAPD_ADDR=""
  for _ in $(seq 1 100); do
    SEMMAPD_ADDR=$(sed -n 's/^semmapd: listening on //p' "$data_dir/semmapd.out" | head -n1)
    [ -n "$SEMMAPD_ADDR" ] && return 0
    kill -0 "$SEMMAPD_PID" 2>/dev/null || break
    sleep 0.1
  done
  echo "semmapd did not start:" >&2
  cat "$data_dir/semmapd.log" >&2
  return 1
}

# bench_setup NAME BINARIES...: checks the binaries, makes $OUT (default: a kept temp dir) and
# $WORK (a temp dir removed at exit, with any semmapd still running from start_semmapd).
bench_setup() {
  local name=$1 bin
  shift
  for bin in "$@"; do
    [ -x "$bin" ] || { echo "$name: $bin missing; run 'make build'" >&2; exit 1; }
  done
  command -v jq >/dev/null || { echo "$name: needs jq" >&2; exit 1; }
  OUT=${OUT:-$(mktemp -d -t "semmap-$name-XXXXXX")}
  mkdir -p "$OUT"
  OUT=$(cd "$OUT" && pwd)
  WORK=$(mktemp -d -t "semmap-$name-work-XXXXXX")
  trap bench_cleanup EXIT
}
bench_cleanup() {
  if [ -n "${SEMMAPD_PID:-}" ] && kill -0 "$SEMMAPD_PID" 2>/dev/null; then
    kill -TERM "$SEMMAPD_PID" 2>/dev/null || true
    wait "$SEMMAPD_PID" 2>/dev/null || true
  fi
  rm -rf "$WORK"
}
# stop_semmapd: SIGTERM to the server start_semmapd started, and wait for it.
stop_semmapd() {
  kill -TERM "$SEMMAPD_PID" 2>/dev/null || true
  wait "$SEMMAPD_PID" 2>/dev/null || true
  SEMMAPD_PID=""
}
