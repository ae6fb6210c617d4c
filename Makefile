# tetkit — common tasks. Needs only the Rust toolchain (cargo); anything else
# a target needs it installs itself.
CARGO ?= cargo
OUT ?= out

.PHONY: all build install ci test test-gpu python-test python-deps mpi-test mpi-deps gpu-driver viewer-deps video-deps demo golden bench device-bin fuzz fuzz-build fmt lint clean

all: build

build:
	$(CARGO) build --release --workspace

## The three programs into cargo's bin directory (~/.cargo/bin, or $CARGO_HOME/bin).
install:
	$(CARGO) install --locked --path crates/tetprep
	$(CARGO) install --locked --path crates/tetlut
	$(CARGO) install --locked --path crates/tetview

## The whole test suite (unit, integration, doc tests) on the bundled data. GPU tests run
## on whatever Vulkan adapter exists (Mesa's software lavapipe is installed if missing) and
## skip with a printed reason where none does. The viewer's window test runs under Xvfb
## (installed if missing) and skips with a printed reason where it is absent.
##
## Without a session's XDG_RUNTIME_DIR, libwayland (probed by the Vulkan and
## OpenGL stacks the GPU and window tests load) prints "XDG_RUNTIME_DIR is
## invalid or not set" on every start: the tests then get a private empty one.
test: gpu-driver viewer-deps video-deps
	@d=; if [ ! -d "$$XDG_RUNTIME_DIR" ]; then d=$$(mktemp -d); export XDG_RUNTIME_DIR=$$d; fi; \
	trap '[ -z "$$d" ] || rm -rf "$$d"' EXIT; \
	echo "$(CARGO) test --workspace --all-targets && $(CARGO) test --workspace --doc"; \
	$(CARGO) test --workspace --all-targets && $(CARGO) test --workspace --doc
	$(MAKE) mpi-test
	$(MAKE) python-test

## The distributed crate and `tetview render --distributed` over MPI (their `mpi` features:
## rsmpi on Open MPI), run under mpirun.
## Skips with a note where Open MPI cannot be installed (needs apt-get and root or sudo).
mpi-test: mpi-deps
	@if command -v mpirun >/dev/null 2>&1 && command -v mpicc >/dev/null 2>&1; then \
		echo "$(CARGO) clippy -p tet_distributed -p tetview --features mpi --all-targets -- -D warnings && $(CARGO) test -p tet_distributed --features mpi && $(CARGO) test -p tetview --features mpi --test distributed"; \
		.ci/cargo-probe-retry $(CARGO) clippy -q -p tet_distributed -p tetview --features mpi --all-targets -- -D warnings && \
		.ci/cargo-probe-retry $(CARGO) test -p tet_distributed --features mpi && \
		.ci/cargo-probe-retry $(CARGO) test -p tetview --features mpi --test distributed; \
	else echo "note: no Open MPI here; the MPI tests are skipped"; fi

## Open MPI and libclang (rsmpi's bindings) from Debian's packages.
mpi-deps:
	@if ! command -v mpicc >/dev/null 2>&1 || ! ls /usr/lib/llvm-*/lib/libclang*.so* >/dev/null 2>&1; then \
		if command -v apt-get >/dev/null 2>&1 && { [ "$$(id -u)" = 0 ] || sudo -n true 2>/dev/null; }; then \
			SUDO=$$([ "$$(id -u)" = 0 ] || echo sudo); \
			$$SUDO apt-get install -y libopenmpi-dev openmpi-bin libclang-dev || { $$SUDO apt-get update && $$SUDO apt-get install -y libopenmpi-dev openmpi-bin libclang-dev; } \
			|| echo "note: installing Open MPI failed; the MPI tests will skip"; \
		else echo "note: no Open MPI, and it cannot be installed here (needs apt-get and root or sudo); the MPI tests will skip"; fi; \
	fi

## The Python package (python/, the native module crates/tet_python): a virtual environment
## in cargo's target directory with maturin, pytest, numpy, meshio, PyVista (with VTK), tqdm and
## ipywidgets from the registry, the package
## built in release (`maturin develop`), and its tests run against the tetview binary the
## cargo tests built (renders equal bit for bit).
TARGET_DIR = $(abspath $(or $(CARGO_TARGET_DIR),target))
PYVENV ?= $(TARGET_DIR)/pyvenv
python-test: python-deps
	@test -x $(PYVENV)/bin/python || python3 -m venv $(PYVENV)
	$(PYVENV)/bin/python -m pip install -q --upgrade "maturin>=1.5,<2" pytest numpy meshio pyvista tqdm ipywidgets
	cd python && VIRTUAL_ENV=$(PYVENV) PATH="$(PYVENV)/bin:$$PATH" maturin develop --release -q
	$(CARGO) build -q -p tetview
	TETVIEW=$(TARGET_DIR)/debug/tetview $(PYVENV)/bin/python -m pytest -q python/tests

## Python 3 with venv and its headers for the Python package, installed with apt-get when
## missing (needs root or passwordless sudo, otherwise prints a note and the Python tests fail).
python-deps:
	@if ! python3 -c "import venv, ensurepip, sysconfig" >/dev/null 2>&1; then \
		if command -v apt-get >/dev/null 2>&1 && { [ "$$(id -u)" = 0 ] || sudo -n true 2>/dev/null; }; then \
			SUDO=$$([ "$$(id -u)" = 0 ] || echo sudo); \
			$$SUDO apt-get install -y python3 python3-venv python3-dev || { $$SUDO apt-get update && $$SUDO apt-get install -y python3 python3-venv python3-dev; }; \
		else echo "note: no python3 with venv, and it cannot be installed here (needs apt-get and root or sudo)"; fi; \
	fi

## What CI runs (.ci/run): formatting and clippy (-D warnings), then the whole suite with
## every GPU test required to find an adapter (gpu-driver installs Mesa's lavapipe where no
## Vulkan driver is): a GPU test that would skip fails instead.
ci: lint
	TETKIT_REQUIRE_GPU=1 $(MAKE) test

## The GPU renderer's tests, where a skip (no adapter) is a failure.
test-gpu: gpu-driver
	@d=; if [ ! -d "$$XDG_RUNTIME_DIR" ]; then d=$$(mktemp -d); export XDG_RUNTIME_DIR=$$d; fi; \
	trap '[ -z "$$d" ] || rm -rf "$$d"' EXIT; \
	echo "TETKIT_REQUIRE_GPU=1 $(CARGO) test -p tet_gpu --all-targets -- --nocapture && … --doc"; \
	TETKIT_REQUIRE_GPU=1 $(CARGO) test -p tet_gpu --all-targets -- --nocapture && \
	TETKIT_REQUIRE_GPU=1 $(CARGO) test -p tet_gpu --doc

## Mesa's Vulkan drivers (lavapipe, a software adapter) when no Vulkan driver is installed;
## needs apt-get and root or passwordless sudo, otherwise prints a note.
VK_ICDS = $(wildcard /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json)
gpu-driver:
ifeq ($(VK_ICDS),)
	@if command -v apt-get >/dev/null 2>&1 && { [ "$$(id -u)" = 0 ] || sudo -n true 2>/dev/null; }; then \
		SUDO=$$([ "$$(id -u)" = 0 ] || echo sudo); \
		$$SUDO apt-get install -y mesa-vulkan-drivers || { $$SUDO apt-get update && $$SUDO apt-get install -y mesa-vulkan-drivers; } \
		|| echo "note: installing mesa-vulkan-drivers failed; GPU tests will skip"; \
	else echo "note: no Vulkan driver, and mesa-vulkan-drivers cannot be installed here (needs apt-get and root or sudo); GPU tests will skip"; fi
endif

## Xvfb (a virtual X server) for the viewer's window test when it is missing; needs apt-get
## and root or passwordless sudo, otherwise prints a note. OpenGL comes from Mesa (llvmpipe).
viewer-deps:
	@if ! command -v Xvfb >/dev/null 2>&1; then \
		if command -v apt-get >/dev/null 2>&1 && { [ "$$(id -u)" = 0 ] || sudo -n true 2>/dev/null; }; then \
			SUDO=$$([ "$$(id -u)" = 0 ] || echo sudo); \
			$$SUDO apt-get install -y xvfb libgl1-mesa-dri libegl1 || { $$SUDO apt-get update && $$SUDO apt-get install -y xvfb libgl1-mesa-dri libegl1; } \
			|| echo "note: installing xvfb failed; the viewer's window test will skip"; \
		else echo "note: no Xvfb, and it cannot be installed here (needs apt-get and root or sudo); the viewer's window test will skip"; fi; \
	fi

## ffmpeg for `tetview animate -o x.mp4` (videos are encoded by ffmpeg when it is installed),
## installed with apt-get when missing; without it the video test checks tetview's side with a
## stand-in ffmpeg and says so.
video-deps:
	@if ! command -v ffmpeg >/dev/null 2>&1; then \
		if command -v apt-get >/dev/null 2>&1 && { [ "$$(id -u)" = 0 ] || sudo -n true 2>/dev/null; }; then \
			SUDO=$$([ "$$(id -u)" = 0 ] || echo sudo); \
			$$SUDO apt-get install -y --no-install-recommends ffmpeg || { $$SUDO apt-get update && $$SUDO apt-get install -y --no-install-recommends ffmpeg; } \
			|| echo "note: installing ffmpeg failed; the video test will use a stand-in only"; \
		else echo "note: no ffmpeg, and it cannot be installed here (needs apt-get and root or sudo); the video test will use a stand-in only"; fi; \
	fi

## The main job on a bundled real dataset: NASA Blunt Fin (PLOT3D) → bundle with gradients and
## histograms → summary, 2D histogram PNG and a VTU for ParaView → the automatic transfer
## function (opacity on the scalar × |∇s| boundaries — the shock and the boundary layer —
## colours from viridis; saved as JSON to edit) → table3d tables baked by tetlut → a 512²
## render by tetview (PNG + float .npy) → the same view by the exact ray-cast reference and
## the image error between them (with a colour bar), all under $(OUT)/; the README's
## pictures are copied to docs/img/.
TETPREP = $(CARGO) run -q --release -p tetprep --
DOCS_IMG ?= docs/img

demo:
	mkdir -p $(OUT) $(DOCS_IMG)
	$(TETPREP) convert tests/data/plot3d/bluntfinxyz.bin --q tests/data/plot3d/bluntfinq.bin \
		--scalar density --gradients --histogram -o $(OUT)/bluntfin.tetb
	$(TETPREP) info $(OUT)/bluntfin.tetb
	$(TETPREP) hist $(OUT)/bluntfin.tetb -o $(OUT)/bluntfin_hist.png
	$(TETPREP) export $(OUT)/bluntfin.tetb -o $(OUT)/bluntfin.vtu
	$(CARGO) run -q --release -p tetlut -- bake --bundle $(OUT)/bluntfin.tetb \
		--method table3d --save-tf $(OUT)/bluntfin_tf.json -o $(OUT)/bluntfin_table3d.tetl
	$(CARGO) run -q --release -p tetview -- render $(OUT)/bluntfin.tetb --lut $(OUT)/bluntfin_table3d.tetl \
		--azimuth 35 --elevation 25 -o $(OUT)/bluntfin.png --float $(OUT)/bluntfin.npy --save-view $(OUT)/bluntfin_view.json
	$(CARGO) run -q --release -p tetview -- reference $(OUT)/bluntfin.tetb --tf $(OUT)/bluntfin_tf.json \
		--view $(OUT)/bluntfin_view.json -o $(OUT)/bluntfin_reference.png --float $(OUT)/bluntfin_reference.npy
	$(CARGO) run -q --release -p tetview -- diff $(OUT)/bluntfin_reference.npy $(OUT)/bluntfin.npy -o $(OUT)/bluntfin_diff.png
	cp $(OUT)/bluntfin.png $(OUT)/bluntfin_diff.png $(OUT)/bluntfin_hist.png $(DOCS_IMG)/
	@echo "image: $(OUT)/bluntfin.png (8-bit, Reinhard over the covered pixels); linear premultiplied RGBA: $(OUT)/bluntfin.npy; view: $(OUT)/bluntfin_view.json"
	@echo "transfer function used (edit and pass with --tf): $(OUT)/bluntfin_tf.json"
	@echo "exact reference of the same view: $(OUT)/bluntfin_reference.png; their difference (above, colour bar in linear RGBA): $(OUT)/bluntfin_diff.png"
	@echo "copied for the README: $(DOCS_IMG)/bluntfin.png, $(DOCS_IMG)/bluntfin_diff.png, $(DOCS_IMG)/bluntfin_hist.png"

## Rewrite the golden images under tests/golden/ from the current renderer (only this
## target writes them; `cargo test -p tetview --test golden` compares against them).
golden:
	TETKIT_WRITE_GOLDEN=1 $(CARGO) test -p tetview --test golden -- renders_match_golden_images

## Criterion benchmarks: conversion pipeline (Blunt Fin, 1.2M-tet grid), Delaunay
## (100k and 1M random points), analysis (Blunt Fin gradients + histograms + ranges).
bench:
	$(CARGO) bench -p tetkit --bench convert
	$(CARGO) bench -p tet_delaunay --bench delaunay
	$(CARGO) bench -p tet_analysis --bench analysis

## The GPU examples crates/tet_gpu/results/device.sh runs on a lent GPU machine (which has
## no toolchain): release builds, stripped, in target/device (carry that folder).
device-bin:
	$(CARGO) build --release -p tet_gpu --example gpu_render --example gpu_bake
	mkdir -p target/device
	for e in gpu_render gpu_bake; do strip -o target/device/$$e target/release/examples/$$e; done

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
