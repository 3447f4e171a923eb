# The whole set-up of neckid: `make demo` and `make test` on a machine with Python >= 3.11, pip, gcc.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint typecheck pytest bench docs clean

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

# docs: mkdocs build --strict, 7-8 s on the 2-core machine.
test: lint typecheck pytest docs

bench: $(STAMP)
	for f in benchmarks/bench_*.py; do $(BIN)/python $$f || exit 1; done

# The documentation site (mkdocs.yml): docs/*.md and an API reference from the docstrings.
docs: $(STAMP)
	$(BIN)/mkdocs build --strict --site-dir build/site

clean:
	rm -rf $(VENV) build dist .pytest_cache .mypy_cache .ruff_cache neckid-demo
