# The README's two commands: `make demo` and `make test`. Both install the Debian packages
# they need, configure and build (Release, Ninja, ccache) and then run.
JOBS ?= $(shell nproc)

.PHONY: demo test deps build test-asan test-tsan test-core lint format-check fuzz bench format clean docker-test

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

# Unit and integration tests under AddressSanitizer + UndefinedBehaviorSanitizer (clang; CI runs
# this). The same build holds the libFuzzer targets of `make fuzz`. The longest accuracy
# evaluations (recognition laps, the 391-frame cafe sequence) run in `make test` only: their code
# paths are the shorter tests' (CMakePresets.json, test preset asan).
test-asan:
	bash scripts/install-deps.sh fuzz
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
# layer rule (after `make build`, which writes build/release/compile_commands.json).
# LINT_SINCE=REV checks only what changed since REV (CI: .ci/tidy-baseline, the commit where the
# whole tree was last checked clean; a cold run of every file takes ~25 minutes on 2 cores).
LINT_SINCE ?=
lint: format-check
	bash scripts/install-deps.sh lint
	python3 scripts/clang_tidy.py --build-dir build/release --jobs $(JOBS) $(if $(LINT_SINCE),--since $(LINT_SINCE))

# clang-format on every file (no changes made), the layer rule on the includes, and every
# script with a #! line executable in git (a lost mode bit breaks `bench/x.sh` for a user).
format-check:
	git ls-files '*.cc' '*.h' | xargs clang-format --dry-run --Werror
	python3 scripts/check_layers.py
	@bad=$$(git ls-files -s '*.sh' '*.py' | awk '$$1 != "100755" {print $$4}' | \
	  while read -r f; do head -c2 "$$f" | grep -q '^#!' && echo "$$f"; done); \
	if [ -n "$$bad" ]; then echo "not executable in git (git update-index --chmod=+x FILE):"; \
	  echo "$$bad"; exit 1; fi

# ThreadSanitizer (clang; -Wthread-safety findings are errors) over the unit tests of the modules
# that run threads of their own and the integration tests (SEMMAP_TEST_SCOPE=concurrency; CI).
test-tsan:
	bash scripts/install-deps.sh fuzz
	cmake --preset tsan
	cmake --build --preset tsan -j $(JOBS)
	ctest --preset tsan -j 2

# libFuzzer targets (clang, ASan + UBSan; built in build/asan) over the parsers of outside bytes,
# FUZZ_SECONDS each (CI runs this too); fails on a crash and prints the input and how to
# reproduce it.
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
	build/release/bench/recognition_cost_bench
	build/release/bench/matcher_bench
	build/release/bench/place_recognition_bench
	build/release/bench/object_query_bench
	build/release/bench/map_layers_bench
	bash bench/slam_bench.sh
	bash bench/map_bench.sh

format:
	git ls-files '*.cc' '*.h' | xargs clang-format -i

clean:
	rm -rf build

# Learned monocular VO (training/README.md), Debian's /usr/bin/python3 with apt's PyTorch.
# train-vo: the full reproducible recipe (data, training, export to models/vo/, evaluation;
# hours on 2 cores; resumable: run it again to continue). train-smoke: the Python tests and a
# tiny training run on semmap-synth data that must lower the loss and export a model cv2.dnn
# runs with PyTorch's outputs and `semmapd --check-vo-model` loads (CI, after `make build`;
# a few minutes; skips the run when semmap-synth is absent).
VO_RUN ?= $(HOME)/.cache/semmap/vo/runs/full
.PHONY: train-vo train-smoke
train-vo:
	bash scripts/install-deps.sh train
	test -x build/release/tools/semmap-synth || cmake --build --preset release --target semmap-synth
	bash training/train_vo.sh $(VO_RUN)

train-smoke:
	bash scripts/install-deps.sh train
	/usr/bin/python3 -m pytest training/tests -q -m "not slow"
	cd training && OMP_WAIT_POLICY=PASSIVE /usr/bin/python3 -m semmap_vo.train --smoke --threads 2

# The Docker image, built and tested for real with podman (root; not part of `make test`: the
# image build takes minutes). docker/README.md.
docker-test: build
	apt-get install -y -q podman runc debootstrap >/dev/null
	bash docker/test-image.sh
