# Two-command set-up: `make demo` and `make test`. Everything else is a convenience.
BUILD ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=
SAN_JOBS ?= 2

.PHONY: deps configure build demo test bench bench-batch clean check-sanitize check-shared fuzz soak

deps:
	@bash scripts/install-deps.sh

configure: deps
	@test -f $(BUILD)/build.ninja || cmake -S . -B $(BUILD) -G Ninja -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS)

build: configure
	@cmake --build $(BUILD) -j $(JOBS)

demo: build
	@$(BUILD)/bin/papertear run scenarios/demo.json --out out/demo --svg
	@echo "outputs: out/demo/result.json, out/demo/pattern.svg"

test: build
	@cd $(BUILD) && ctest --output-on-failure -j $(JOBS) --timeout 600

bench: build
	@bash scripts/run-bench.sh $(BUILD)

# Issue 6's batch scaling (2 threads against 1, with a two-process control), ~3 min; appends to
# bench/results/<date>-batch-scaling.txt.
bench-batch: build
	@python3 scripts/batch-scaling.py --bin $(BUILD)/bin/papertear --out bench/results/$(shell date +%Y-%m-%d)-batch-scaling.txt

# The embedding example against a BUILD_SHARED_LIBS=ON build of the library, installed in the build tree
# (the static one is `make test`'s embedding_consumer); it compiles the library once more, ~8-11 min.
check-shared: build
	@cmake --build $(BUILD) --target check_shared_package

# Reliability (issue 9). Each uses its own build directory (build-asan, build-tsan, build-fuzz, build-soak).
# ASan+UBSan over the whole suite, then TSan over the threaded tests.
check-sanitize: deps
	@JOBS=$(SAN_JOBS) bash scripts/check-sanitize.sh all

# libFuzzer targets (Debian clang): each runs FUZZ_SECONDS on its seed corpus (tests/fuzz/corpus/<target>).
FUZZ_SECONDS ?= 60
fuzz: deps
	@JOBS=$(SAN_JOBS) FUZZ_SECONDS=$(FUZZ_SECONDS) bash scripts/fuzz.sh

# 10 000 frames of tests/soak/soak.json: NaN, peak RSS, frame time vs triangles; bench/results/soak-<date>.txt.
soak: deps
	@JOBS=$(SAN_JOBS) bash scripts/soak.sh

clean:
	rm -rf $(BUILD)
