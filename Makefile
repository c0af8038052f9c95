# accelcore developer commands. `make help` lists them.
# Quick start on a fresh machine: `make demo` and `make test`; nothing else to install by hand.

SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(PY) -m pip
STAMP := $(VENV)/.deps-stamp
HYPOTHESIS_PROFILE ?= dev
export PYTHONDONTWRITEBYTECODE := 1

.DEFAULT_GOAL := help
.PHONY: wheel help venv dev demo test test-rust test-py lint fmt bench clean

help:  ## List the targets
	@grep -E '^[a-z-]+:.*##' $(MAKEFILE_LIST) | awk -F':.*## ' '{printf "  %-10s %s\n", $$1, $$2}'

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PIP) install -q --upgrade "pip>=25.1"
	$(PIP) install -q "maturin>=1.9,<2"
	$(PIP) install -q --group dev "numpy>=1.24" "pandas>=2.0"
	touch $(STAMP)

venv: $(STAMP)  ## Create .venv with every dependency from the registries

dev: $(STAMP)  ## Build the extension in release mode into .venv
	VIRTUAL_ENV=$(abspath $(VENV)) $(VENV)/bin/maturin develop --release -q

wheel: $(STAMP)  ## abi3 manylinux2014 wheel and the sdist into dist/ (maturin; zig from PyPI links for old glibc)
	$(VENV)/bin/pip install -q "ziglang>=0.11"
	VIRTUAL_ENV=$(abspath $(VENV)) PATH=$(abspath $(VENV))/bin:$$PATH $(VENV)/bin/maturin build --release --zig --compatibility manylinux2014 --out dist
	VIRTUAL_ENV=$(abspath $(VENV)) $(VENV)/bin/maturin sdist --out dist

demo: dev  ## Calibrate and diagnose the bundled example session and print the result
	$(PY) -m accelcore demo

test: dev test-rust test-py  ## cargo test, then pytest (the CI command)

test-rust:  ## Rust unit, property and doc tests of the core crate
	cargo test -p accelcore-core --quiet

test-py: dev  ## Python tests (hypothesis profile from HYPOTHESIS_PROFILE=dev|ci|thorough)
	ACCELCORE_HYPOTHESIS_PROFILE=$(HYPOTHESIS_PROFILE) $(PY) -m pytest -q

lint: dev  ## rustfmt, clippy -D warnings, ruff, mypy --strict, stubtest
	cargo fmt --all -- --check
	cargo clippy --workspace --all-targets --quiet -- -D warnings
	$(VENV)/bin/ruff check python tests benches
	$(VENV)/bin/ruff format --check python tests benches
	$(VENV)/bin/mypy
	$(PY) -m mypy.stubtest accelcore._accelcore --allowlist .stubtest-allowlist

fmt: $(STAMP)  ## Format Rust and Python sources
	cargo fmt --all
	$(VENV)/bin/ruff format python tests benches
	$(VENV)/bin/ruff check --fix python tests benches

bench: dev  ## Benchmarks: accelcore vs the NumPy reference (and pandas/polars for reading)
	$(PY) -m benches

clean:  ## Remove build output and the virtual environment
	rm -rf $(VENV) target .pytest_cache .mypy_cache .ruff_cache .hypothesis
