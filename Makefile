# The README's two commands: `make demo` and `make test`. Both install the Debian packages
# they need, configure and build (Release, Ninja, ccache) and then run.
JOBS ?= $(shell nproc)
# ccache keys on paths relative to the checkout, so a fresh clone (CI) reuses earlier builds.
export CCACHE_BASEDIR := $(CURDIR)
export CCACHE_NOHASHDIR := 1

.PHONY: demo test deps build test-asan fuzz bench format clean

deps:
	bash scripts/install-deps.sh

build: deps
	cmake --preset release
	cmake --build --preset release -j $(JOBS)

demo: build
	bash scripts/demo.sh

test: build
	ctest --preset release -j 2

# Unit tests under AddressSanitizer + UndefinedBehaviorSanitizer (CI runs this too).
test-asan: deps
	cmake --preset asan
	cmake --build --preset asan -j $(JOBS)
	ctest --preset asan -j 2

# libFuzzer targets (clang, ASan + UBSan) over the parsers of outside bytes, FUZZ_SECONDS each
# (CI runs this too); fails on a crash and prints the input and how to reproduce it.
FUZZ_SECONDS ?= 30
fuzz:
	bash scripts/install-deps.sh fuzz
	BUILD_JOBS=$(JOBS) bash scripts/fuzz.sh --seconds $(FUZZ_SECONDS)

# Figures, not pass/fail: dataset harness (teddy, or the bundled sample) and micro-benchmarks.
bench: build
	bash bench/run_dataset.sh $(if $(wildcard ../shared/data/tum_fr3_teddy_200),../shared/data/tum_fr3_teddy_200,data/samples/tum_fr3_teddy_80) --poses groundtruth.txt
	build/release/bench/decode_bench
	build/release/bench/eval_bench
	build/release/bench/synth_bench
	build/release/bench/tracking_bench
	build/release/bench/matcher_bench
	build/release/bench/place_recognition_bench
	build/release/bench/object_query_bench
	bash bench/slam_bench.sh
	bash bench/map_bench.sh

format:
	git ls-files '*.cc' '*.h' | xargs clang-format -i

clean:
	rm -rf build
