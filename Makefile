# pmrender — build, test, render, benchmark.
SHELL := /bin/bash
CARGO ?= cargo
DEB_PACKAGES := libembree-dev libflann-dev libopenimageio-dev libopenexr-dev pkg-config g++ liblz4-dev
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
BIN := target/release/pmrender
PYTHON ?= python3
VENV := .venv

.PHONY: deps build lint render test test-isa test-slow bench chart fuzz clean venv pytest

deps:
	@missing=""; for p in $(DEB_PACKAGES); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing:$$missing"; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq $$missing; \
	else echo "system packages present"; fi
	@if $(CARGO) fmt --version >/dev/null 2>&1 && $(CARGO) clippy --version >/dev/null 2>&1; then \
	  echo "rustfmt and clippy present"; \
	elif command -v rustup >/dev/null 2>&1; then \
	  rustup component add rustfmt clippy; \
	else \
	  echo "make lint needs cargo fmt and cargo clippy: install rustfmt and clippy for this toolchain" >&2; \
	  exit 1; \
	fi

build:
	$(CARGO) build --release --workspace

# Format and lints as CI checks them; `cargo fmt --all` fixes the first.
lint:
	$(CARGO) fmt --all --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings

render: deps build
	mkdir -p out
	$(BIN) render scenes/cornell-caustics.toml -o out/cornell-caustics.exr --png out/cornell-caustics.png --stats out/cornell-caustics.json

test: build
	$(CARGO) test --release --workspace
	$(MAKE) pytest

# The Python module installed as a user installs it (`pip install .`), into the project's own virtual
# environment with its test dependencies; then its pytest suite, which compares it with the binary.
venv:
	@[ -x $(VENV)/bin/python ] || $(PYTHON) -m venv $(VENV)
	$(VENV)/bin/pip install -q --disable-pip-version-check '.[test]'

pytest: build venv
	PMRENDER_BIN=$(BIN) $(VENV)/bin/python -m pytest -q python/tests

# The suite as a machine without AVX2 runs it: Embree's ray kernels forced to SSE4.2 (ISA=avx512
# where the CPU has it), so that a bound set from one machine's noise fails here, not on another's.
ISA ?= sse4.2
test-isa: build
	PMRENDER_EMBREE_ISA=$(ISA) $(CARGO) test --release --workspace

test-slow: build
	$(CARGO) test --release --workspace -- --ignored
	python3 tools/chart.py --quick --out out/charts-quick

chart: build
	pip install -q -r tools/chart_requirements.txt
	python3 tools/chart.py --out charts
	python3 tools/progressive_chart.py --out charts

fuzz: build
	FUZZ_ITERS=200000 $(CARGO) test --release --test fuzz -- --nocapture

bench: build
	$(CARGO) bench --bench render
	$(CARGO) bench --bench passes
	$(CARGO) bench --bench glossy
	$(CARGO) bench --bench animation
	$(CARGO) bench --bench ao

clean:
	$(CARGO) clean
