# freeloc entry points (see README "Quick start"):
#   make demo   install deps → Release build → freeloc demo
#   make test   install deps → build → ctest (output on failure)
#   make fuzz   clang + ASan/UBSan libFuzzer targets (fuzz/), each run FUZZ_SECONDS (or FUZZ_RUNS executions)
#   make sanitize   the whole tree with ASan + UBSan (SANITIZE_DIR), then its unit tests
BUILD_DIR ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=

FUZZ_DIR ?= build-fuzz
FUZZ_SECONDS ?= 60
FUZZ_RUNS ?= -1
SANITIZE_DIR ?= build-sanitize
FUZZ_TARGETS = pickle checkpoint safetensors npy image exif mapfree_text submission correspondence pth_structured header_structured tracking_poses multipart service_fields options_file

.PHONY: all deps configure build test demo bench clean format fuzz sanitize

all: build

deps:
	bash scripts/install-deps.sh

configure: deps
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS)

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS)

demo: build
	$(BUILD_DIR)/freeloc demo

bench: build
	$(BUILD_DIR)/bench/gemm

fuzz:
	FREELOC_DEPS_FUZZ=1 bash scripts/install-deps.sh
	CC=clang CXX=clang++ cmake -S . -B $(FUZZ_DIR) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFREELOC_FUZZ=ON \
	  -DFREELOC_SANITIZE=address,undefined -DFREELOC_BUILD_TESTS=OFF -DFREELOC_BUILD_BENCH=OFF \
	  -DFREELOC_BUILD_PYTHON=OFF
	cmake --build $(FUZZ_DIR) -j $(JOBS) --target $(addprefix fuzz_,$(FUZZ_TARGETS))
	bash scripts/run-fuzzers.sh $(FUZZ_DIR) $(FUZZ_SECONDS) $(FUZZ_RUNS)

sanitize: deps
	cmake -S . -B $(SANITIZE_DIR) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFREELOC_SANITIZE=address,undefined \
	  -DFREELOC_BUILD_BENCH=OFF -DFREELOC_BUILD_PYTHON=OFF
	cmake --build $(SANITIZE_DIR) -j $(JOBS)
	cd $(SANITIZE_DIR) && ASAN_OPTIONS=detect_leaks=1:detect_odr_violation=0 ctest --output-on-failure -j $(JOBS)

format:
	find src bench tests python/src fuzz \( -name '*.cc' -o -name '*.h' \) -not -path '*/corpus/*' -not -path '*/regressions/*' | xargs clang-format -i

clean:
	rm -rf $(BUILD_DIR) $(FUZZ_DIR) $(SANITIZE_DIR)
