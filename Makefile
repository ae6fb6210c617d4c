# tetkit — common tasks. Needs only the Rust toolchain (cargo); anything else
# a target needs it installs itself.
CARGO ?= cargo
OUT ?= out

.PHONY: all build test demo bench fuzz fuzz-build fmt lint clean

all: build

build:
	$(CARGO) build --release --workspace

## The whole test suite (unit, integration, doc tests) on the bundled data.
test:
	$(CARGO) test --workspace --all-targets
	$(CARGO) test --workspace --doc

## The main job on a bundled real dataset: NASA Blunt Fin (PLOT3D) → bundle → summary.
TETPREP = $(CARGO) run -q --release -p tetprep --

demo:
	mkdir -p $(OUT)
	$(TETPREP) convert tests/data/plot3d/bluntfinxyz.bin --q tests/data/plot3d/bluntfinq.bin \
		--scalar density -o $(OUT)/bluntfin.tetb
	$(TETPREP) info $(OUT)/bluntfin.tetb
	$(TETPREP) export $(OUT)/bluntfin.tetb -o $(OUT)/bluntfin.vtu

## Criterion benchmarks (conversion pipeline on Blunt Fin and a generated 1M+-tet grid).
bench:
	$(CARGO) bench -p tetkit --bench convert

## Build the fuzz targets (plain, uninstrumented: checks they compile).
fuzz-build:
	cd fuzz && $(CARGO) build

## Coverage-guided fuzzing of every reader on stable Rust, FUZZ_SECS per target.
FUZZ_SECS ?= 60
fuzz:
	fuzz/run.sh $(FUZZ_SECS)

fmt:
	$(CARGO) fmt --all

lint:
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings

clean:
	$(CARGO) clean
	rm -rf $(OUT)
