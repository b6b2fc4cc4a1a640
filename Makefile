# UVNAV — two commands set everything up: `make run` and `make test`.
# PYTHON: the interpreter of the main venv (the oldest supported, 3.11, where the machine's
# python3 is that). PYTHON_NEW: the newest Python the machine offers (.ci/newest-python);
# `make test` runs the suite on both.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
PYTHON_NEW ?= $(shell .ci/newest-python)
NEW_VERSION := $(if $(PYTHON_NEW),$(shell $(PYTHON_NEW) -c 'import sys; print("%d.%d" % sys.version_info[:2])'))
VENV_NEW := .venv-$(NEW_VERSION)
STAMP_NEW := $(VENV_NEW)/.installed

.PHONY: run test test-new bench bench-baseline lint venv venv-new clean

# The compiled kernels (engine/native/*.c, built by setup.py) are rebuilt when a source changes.
NATIVE_SRC := setup.py $(wildcard engine/native/*.c engine/native/*.h)

$(STAMP): pyproject.toml $(NATIVE_SRC)
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

venv: $(STAMP)

# The second venv, on the newest Python (the kernels are built for it too: their .so files carry
# the interpreter's tag, so both venvs' builds sit side by side in engine/native).
$(STAMP_NEW): pyproject.toml $(NATIVE_SRC)
	$(PYTHON_NEW) -m venv $(VENV_NEW)
	$(VENV_NEW)/bin/python -m pip install --quiet --upgrade pip
	$(VENV_NEW)/bin/python -m pip install --quiet -e '.[test]'
	touch $(STAMP_NEW)

venv-new: $(if $(PYTHON_NEW),$(STAMP_NEW))

run: $(STAMP)
	$(VENV)/bin/uvnav

test: $(STAMP)
	$(VENV)/bin/ruff check .
	$(PY) -m pytest -q
	@$(MAKE) --no-print-directory test-new

# The suite again on the newest Python; loud when the machine has none beside $(PYTHON).
test-new:
ifeq ($(PYTHON_NEW),)
	@echo "WARNING: no Python 3.12+ found (pyenv or PATH): the suite ran on $(PYTHON) only." >&2
else
	@$(MAKE) --no-print-directory $(STAMP_NEW)
	@echo "== the suite on $(PYTHON_NEW) ($(VENV_NEW))"
	$(VENV_NEW)/bin/python -m pytest -q -p no:cacheprovider
endif

BENCH_STAMP := $(VENV)/.bench-installed

# The bench extra (FilterPy, which pulls in matplotlib; the test extra has it too).
$(BENCH_STAMP): $(STAMP) pyproject.toml
	$(PY) -m pip install --quiet -e '.[bench]'
	touch $(BENCH_STAMP)

# Both venvs: bench/bench_baseline.py times this tree against the pinned baseline on the main
# venv's Python and on the newest (it prepares the baseline's own venvs in the temp folder).
bench: $(BENCH_STAMP) venv-new
	$(PY) -m bench

# Only that side-by-side table, also written into docs/PERFORMANCE.md's section for it.
bench-baseline: $(STAMP) venv-new
	$(PY) -m bench.bench_baseline --doc docs/PERFORMANCE.md

lint: $(STAMP)
	$(VENV)/bin/ruff check .

clean:
	rm -rf $(VENV) .venv-3.* .pytest_cache build *.egg-info engine/native/*.so
