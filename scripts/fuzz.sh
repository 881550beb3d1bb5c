#!/usr/bin/env bash
# Builds the libFuzzer targets (preset asan: clang, ASan + UBSan), makes their seed corpora
# (tests/fuzz/seed_corpus.sh), runs each target once over the full-size real files, then
# fuzzes it for a while on its work corpus, build/fuzz/corpus/<target> (kept between runs, so
# later runs start where earlier ones stopped) plus the seeds.
#
#   scripts/fuzz.sh [--seconds N] [--jobs N] [--no-build] [target...]
#
#   --seconds N  per target (default 30; libFuzzer -max_total_time)
#   --jobs N     targets fuzzed at the same time, one process each (default 1)
#   --no-build   use the fuzz binaries as they are
#   target       names without the fuzz_ prefix (default: every target tests/fuzz registers)
#
# Crash, leak, timeout and out-of-memory inputs go to build/fuzz/artifacts/<target>/, logs to
# build/fuzz/logs/<target>.log. Prints one line per target and a total; exits 1 when any
# target crashed, with the input and the command that reproduces it.
set -euo pipefail

cd "$(dirname "$0")/.."
root=$(pwd)
seconds=30
jobs=1
build=1
targets=()
while [ $# -gt 0 ]; do
  case "$1" in
    --seconds) seconds=$2; shift 2 ;;
    --jobs) jobs=$2; shift 2 ;;
    --no-build) build=0; shift ;;
    -h | --help) sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "fuzz: unknown option $1" >&2; exit 2 ;;
    *) targets+=("${1#fuzz_}"); shift ;;
  esac
done
if ! [[ "$seconds" =~ ^[1-9][0-9]*$ && "$jobs" =~ ^[1-9][0-9]*$ ]]; then
  echo "fuzz: --seconds and --jobs take positive integers" >&2
  exit 2
fi
# The binaries come from the asan build (shared with the sanitizer tests); the corpora, crash
# inputs and logs live in build/fuzz.
asan_dir=$root/build/asan
bin_dir=$asan_dir/tests/fuzz
build_dir=$root/build/fuzz
if [ $build -eq 1 ]; then
  cmake --preset asan >/dev/null
  cmake --build --preset asan --target fuzz_all -j "${BUILD_JOBS:-$(nproc)}"
fi
# Default: every target tests/fuzz/CMakeLists.txt registers (the configure step lists them).
if [ ${#targets[@]} -eq 0 ]; then
  if [ -f "$asan_dir/fuzz_targets.txt" ]; then
    while read -r name; do [ -n "$name" ] && targets+=("$name"); done <"$asan_dir/fuzz_targets.txt"
  else
    for f in "$bin_dir"/fuzz_*; do
      name=$(basename "$f")
      [ "$name" = fuzz_make_seeds ] || targets+=("${name#fuzz_}")
    done
  fi
fi
for t in "${targets[@]}"; do
  if [ ! -x "$bin_dir/fuzz_$t" ]; then
    echo "fuzz: no target fuzz_$t in $bin_dir" >&2
    exit 2
  fi
done

mkdir -p "$build_dir"
seeds=$build_dir/seeds
rm -rf "$seeds"
FUZZ_MAKE_SEEDS=$bin_dir/fuzz_make_seeds bash tests/fuzz/seed_corpus.sh "$seeds" >/dev/null
mkdir -p "$build_dir/logs"

# Stack traces for UBSan reports; leaks are reported by libFuzzer (-detect_leaks, default on).
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_stack_use_after_return=1}

# One target: once over the large real files, then libFuzzer on the work corpus (new units go
# there) and the seeds (read only).
run_target() {
  local t=$1
  local corpus=$build_dir/corpus/$t artifacts=$build_dir/artifacts/$t
  local log=$build_dir/logs/$t.log dict=$root/tests/fuzz/dicts/$t.dict
  mkdir -p "$corpus" "$artifacts"
  local large=("$seeds/large/$t"/*)
  if [ -e "${large[0]}" ]; then
    set +e
    "$bin_dir/fuzz_$t" -rss_limit_mb=2048 -timeout=10 "${large[@]}" >"$build_dir/logs/$t.large.log" 2>&1
    echo $? >"$build_dir/logs/$t.large.rc"
    set -e
  else
    echo 0 >"$build_dir/logs/$t.large.rc"
  fi
  local args=(-max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1
              -artifact_prefix="$artifacts/")
  [ -f "$dict" ] && args+=(-dict="$dict")
  ls "$artifacts" >"$build_dir/logs/$t.before"
  set +e
  "$bin_dir/fuzz_$t" "${args[@]}" "$corpus" "$seeds/$t" >"$log" 2>&1
  echo $? >"$build_dir/logs/$t.rc"
  set -e
}

running=0
for t in "${targets[@]}"; do
  if [ "$running" -ge "$jobs" ]; then
    wait -n || true
    running=$((running - 1))
  fi
  echo "fuzz: running fuzz_$t for ${seconds}s"
  run_target "$t" &
  running=$((running + 1))
done
wait

total_execs=0
total_crashes=0
failed=()
for t in "${targets[@]}"; do
  log=$build_dir/logs/$t.log
  rc=$(cat "$build_dir/logs/$t.rc")
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -n 1)
  # Without final stats (a crash stops libFuzzer first), the last status line has the count.
  if [ -z "$execs" ]; then
    execs=$(grep -o '^#[0-9]*' "$log" | tail -n 1 | tr -d '#')
  fi
  execs=${execs:-0}
  corpus=$(find "$build_dir/corpus/$t" -type f | wc -l)
  new=$(comm -13 "$build_dir/logs/$t.before" <(ls "$build_dir/artifacts/$t") |
        grep -E '^(crash|leak|timeout|oom)-' || true)
  crashes=$(printf '%s' "$new" | grep -c . || true)
  if [ "$rc" -ne 0 ] && [ "$crashes" -eq 0 ]; then crashes=1; fi
  large_rc=$(cat "$build_dir/logs/$t.large.rc")
  if [ "$large_rc" -ne 0 ]; then
    crashes=$((crashes + 1))
    large_file=$(sed -n 's/^Running: //p' "$build_dir/logs/$t.large.log" | tail -n 1)
  fi
  printf 'fuzz: %-15s executions %10d  exec/s %7s  corpus %5d  crashes %d\n' \
    "$t" "$execs" "${rate:-?}" "$corpus" "$crashes"
  total_execs=$((total_execs + execs))
  total_crashes=$((total_crashes + crashes))
  if [ "$crashes" -gt 0 ]; then
    failed+=("$t")
    for a in $new; do
      echo "  crashing input: $build_dir/artifacts/$t/$a"
      echo "  reproduce:      $bin_dir/fuzz_$t $build_dir/artifacts/$t/$a"
    done
    if [ "$large_rc" -ne 0 ]; then
      echo "  crashing input: $large_file (a real sample)"
      echo "  reproduce:      $bin_dir/fuzz_$t $large_file"
      grep -m 3 -E 'ERROR:|runtime error|FUZZ_CHECK|SUMMARY:' "$build_dir/logs/$t.large.log" |
        sed 's/^/  /' || true
    fi
    if [ "$rc" -ne 0 ]; then
      [ -n "$new" ] || echo "  fuzz_$t exited with status $rc; see $log"
      grep -m 3 -E 'ERROR:|runtime error|FUZZ_CHECK|SUMMARY:' "$log" | sed 's/^/  /' || true
    fi
  fi
done
printf 'fuzz: total %d executions over %d targets (%ss each), %d crashes\n' \
  "$total_execs" "${#targets[@]}" "$seconds" "$total_crashes"
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz: FAILED: ${failed[*]} (logs in $build_dir/logs/)" >&2
  exit 1
fi
