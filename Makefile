# tetkit — common tasks. Needs only the Rust toolchain (cargo); anything else
# a target needs it installs itself.
CARGO ?= cargo
OUT ?= out

.PHONY: all build test demo bench fuzz-build fmt lint clean

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

## Build (not run) the cargo-fuzz targets; needs a nightly toolchain and cargo-fuzz.
fuzz-build:
	cd fuzz && cargo +nightly fuzz build

fmt:
	$(CARGO) fmt --all

lint:
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings

clean:
	$(CARGO) clean
	rm -rf $(OUT)
