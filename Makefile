# The whole set-up of neckid: `make demo` and `make test` on a machine with Python >= 3.11, pip, gcc.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint typecheck pytest pytest-narrow bench docs clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): $(BIN)/python pyproject.toml
	$(BIN)/python -m pip install --quiet -e ".[test,docs]"
	$(BIN)/neckid warmup
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/neckid demo --force

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks docs/examples docs/_hooks.py
	$(BIN)/ruff format --check src tests benchmarks docs/examples docs/_hooks.py

typecheck: $(STAMP)
	$(BIN)/mypy src

pytest: $(STAMP)
	$(BIN)/python -m pytest

# The tests marked cpu_dependent (they compare neckid's kernels with NumPy's and OpenBLAS's
# arithmetic, whose order depends on the CPU) once more with NumPy's SIMD dispatch narrowed to
# its baseline and OpenBLAS on another core's kernels: a CPU-dependent assertion fails on any
# machine, not only on the one whose CPU differs (docs/performance.md, "On every CPU").
NARROW_NUMPY = $(shell $(BIN)/python -c "import numpy as np; m = getattr(np, '_core', None) or np.core; print(' '.join(m._multiarray_umath.__cpu_dispatch__))" 2>/dev/null)
NARROW_BLAS = $(if $(filter aarch64 arm64,$(shell uname -m)),ARMV8,Prescott)
pytest-narrow: $(STAMP)
	NPY_DISABLE_CPU_FEATURES="$(NARROW_NUMPY)" OPENBLAS_CORETYPE="$(NARROW_BLAS)" \
		$(BIN)/python -m pytest -p no:cacheprovider -m cpu_dependent tests

# docs: mkdocs build --strict, 7-8 s on the 2-core machine.
test: lint typecheck pytest pytest-narrow docs

bench: $(STAMP)
	for f in benchmarks/bench_*.py; do $(BIN)/python $$f || exit 1; done

# The documentation site (mkdocs.yml): docs/*.md and an API reference from the docstrings.
docs: $(STAMP)
	$(BIN)/mkdocs build --strict --site-dir build/site

clean:
	rm -rf $(VENV) build dist .pytest_cache .mypy_cache .ruff_cache neckid-demo
