# The README's two commands: `make demo` and `make test`. Both install the Debian packages
# they need, configure and build (Release, Ninja, ccache) and then run.
JOBS ?= $(shell nproc)

.PHONY: demo test deps build test-asan test-tsan test-core lint format-check fuzz bench format clean

deps:
	bash scripts/install-deps.sh

# WERROR=ON (CI) turns warnings into errors.
WERROR ?= OFF
build: deps
	cmake --preset release -DSEMMAP_WERROR=$(WERROR)
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

# The core with the service off (no gRPC, no proto): it builds and its tests pass on their own
# (CI runs this; the objects come from the release build's ccache entries).
test-core: deps
	cmake --preset core -DSEMMAP_WERROR=$(WERROR)
	cmake --build --preset core -j $(JOBS)
	ctest --preset core -j 2

# clang-format and clang-tidy (.clang-tidy; cached per preprocessed file) on the tree, and the
# layer rule (CI runs this after `make test`, which writes build/release/compile_commands.json).
lint: format-check
	bash scripts/install-deps.sh lint
	python3 scripts/clang_tidy.py --build-dir build/release --jobs $(JOBS)

# clang-format on every file (no changes made) and the layer rule on the includes.
format-check:
	git ls-files '*.cc' '*.h' | xargs clang-format --dry-run --Werror
	python3 scripts/check_layers.py

# Unit and integration tests under ThreadSanitizer (clang; -Wthread-safety findings are errors).
test-tsan:
	bash scripts/install-deps.sh fuzz
	cmake --preset tsan
	cmake --build --preset tsan -j $(JOBS)
	ctest --preset tsan -j 2

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
