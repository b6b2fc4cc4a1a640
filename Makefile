# UVNAV — two commands set everything up: `make run` and `make test`.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: run test bench lint venv clean

# The compiled kernels (engine/native/*.c, built by setup.py) are rebuilt when a source changes.
NATIVE_SRC := setup.py $(wildcard engine/native/*.c engine/native/*.h)

$(STAMP): pyproject.toml $(NATIVE_SRC)
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

venv: $(STAMP)

run: $(STAMP)
	$(VENV)/bin/uvnav

test: $(STAMP)
	$(VENV)/bin/ruff check .
	$(PY) -m pytest -q

BENCH_STAMP := $(VENV)/.bench-installed

# The bench extra (FilterPy, which pulls in matplotlib; the test extra has it too).
$(BENCH_STAMP): $(STAMP) pyproject.toml
	$(PY) -m pip install --quiet -e '.[bench]'
	touch $(BENCH_STAMP)

bench: $(BENCH_STAMP)
	$(PY) -m bench

lint: $(STAMP)
	$(VENV)/bin/ruff check .

clean:
	rm -rf $(VENV) .pytest_cache build *.egg-info engine/native/*.so
