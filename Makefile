# Two commands on a fresh machine with Python >= 3.11: `make demo` and `make test`.
# The interpreter: the first of python3.11, python3.12, python3.13, python3 that is >= 3.11 (or PYTHON=...).
PYTHON ?= $(shell for p in python3.11 python3.12 python3.13 python3; do \
	command -v $$p >/dev/null 2>&1 && $$p -c 'import sys; sys.exit(sys.version_info < (3, 11))' 2>/dev/null \
	&& { echo $$p; break; }; done)
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: demo test test-all lint docs bench clean venv

$(PY):
	@test -n "$(PYTHON)" || { echo "need Python >= 3.11 (python3.11, 3.12, 3.13 or python3); or run: make PYTHON=/path/to/python ..."; exit 2; }
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

$(STAMP): $(PY) pyproject.toml
	$(PY) -m pip install --quiet -e ".[test]"
	@touch $(STAMP)

venv: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/gyrojax demo --out demo-report --force

# the whole suite, statistical studies included (marked slow); the 20 slowest tests are printed
test: $(STAMP)
	$(PY) -m pytest -q -n 2 --dist loadfile --durations=20 tests

lint: $(STAMP)
	$(VENV)/bin/ruff check gyrojax tests benchmarks
	$(VENV)/bin/ruff format --check gyrojax tests benchmarks

docs: $(STAMP)
	$(PY) -m pip install --quiet -e ".[docs]"
	$(PY) -m pdoc --docformat google --math -o docs/api gyrojax

bench: $(STAMP)
	$(PY) -m pip install --quiet -e ".[test,bench]"
	$(PY) -m benchmarks

clean:
	rm -rf $(VENV) demo-report .pytest_cache build *.egg-info docs/api
