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

## The main job on a bundled real dataset: NASA Blunt Fin (PLOT3D) → bundle with gradients and
## histograms → summary, 2D histogram PNG and a VTU for ParaView, all under $(OUT)/.
TETPREP = $(CARGO) run -q --release -p tetprep --

demo:
	mkdir -p $(OUT)
	$(TETPREP) convert tests/data/plot3d/bluntfinxyz.bin --q tests/data/plot3d/bluntfinq.bin \
		--scalar density --gradients --histogram -o $(OUT)/bluntfin.tetb
	$(TETPREP) info $(OUT)/bluntfin.tetb
	$(TETPREP) hist $(OUT)/bluntfin.tetb -o $(OUT)/bluntfin_hist.png
	$(TETPREP) export $(OUT)/bluntfin.tetb -o $(OUT)/bluntfin.vtu

## Criterion benchmarks: conversion pipeline (Blunt Fin, 1.2M-tet grid), Delaunay
## (100k and 1M random points), analysis (Blunt Fin gradients + histograms + ranges).
bench:
	$(CARGO) bench -p tetkit --bench convert
	$(CARGO) bench -p tet_delaunay --bench delaunay
	$(CARGO) bench -p tet_analysis --bench analysis

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
