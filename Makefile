# One-command set-up: `make demo` runs the main job, `make test` runs the whole test suite.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
# torch first, pinned: on these machines 2.13.0 is a CPU wheel on disk; a bare `torch` would pull CUDA.
TORCH := torch==2.13.0

.PHONY: demo test install dev clean bench

$(BIN)/activate:
	$(PY) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip

$(VENV)/.installed: $(BIN)/activate pyproject.toml
	$(BIN)/pip install -q $(TORCH)
	$(BIN)/pip install -q -e .
	touch $@

$(VENV)/.installed-dev: $(VENV)/.installed
	$(BIN)/pip install -q -e ".[dev]"
	touch $@

install: $(VENV)/.installed

dev: $(VENV)/.installed-dev

demo: $(VENV)/.installed
	$(BIN)/pressurepose demo --out demo_out

test: $(VENV)/.installed-dev
	$(BIN)/lint-imports --no-cache
	OMP_NUM_THREADS=2 MPLBACKEND=Agg $(BIN)/python -m pytest -q

bench: $(VENV)/.installed-dev
	OMP_NUM_THREADS=1 MPLBACKEND=Agg $(BIN)/python -m benchmarks.run_all

clean:
	rm -rf $(VENV) demo_out build *.egg-info
