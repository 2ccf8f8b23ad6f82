# The two commands of the README: `make demo` and `make test`. Both create .venv on first use.
SHELL := /bin/bash
.SHELLFLAGS := -o pipefail -c
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp

.PHONY: demo test test-fast lint docs bench install clean-results

# The grep drops pip's notes about unused local index folders of this machine's pip configuration;
# pip's own exit status still decides (pipefail).
$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check -e '.[dev]' 2>&1 \
		| { grep -v '^WARNING: Location' || true; }
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	$(BIN)/vpr-smr run configs/demo.yaml

test: $(STAMP)
	$(BIN)/python -m pytest -q tests

test-fast: $(STAMP)
	$(BIN)/python -m pytest -q tests/unit

# ruff, the layers contract (import-linter) and mypy (strict; pyproject's [tool.mypy]). CI runs it before the tests.
lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/lint-imports --no-cache
	MYPY=$(BIN)/mypy .ci/typecheck

# The documentation site, offline, every warning an error (nitpicky: every reference must resolve); open the path it
# prints. CI builds it too.
docs: $(STAMP)
	$(BIN)/sphinx-build --quiet --fail-on-warning --keep-going --nitpicky --builder html docs docs/_build/html
	@echo "docs: docs/_build/html/index.html"

# Full-size speed and memory measurements (minutes; see benchmarks/README.md). CI runs them small, in the tests.
bench: $(STAMP)
	$(BIN)/python benchmarks/attributes.py
	$(BIN)/python benchmarks/live.py

clean-results:
	rm -rf results .snakemake
