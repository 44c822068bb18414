# Two commands on a fresh machine with Python >= 3.11: `make demo` and `make test`.
# The interpreter: the first of python3.11, python3.12, python3.13, python3 that is >= 3.11 (or PYTHON=...).
PYTHON ?= $(shell for p in python3.11 python3.12 python3.13 python3; do \
	command -v $$p >/dev/null 2>&1 && $$p -c 'import sys; sys.exit(sys.version_info < (3, 11))' 2>/dev/null \
	&& { echo $$p; break; }; done)
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
# The lock: every package version `make test` and `make demo` install (pip constraints, all extras). Refreshed only
# deliberately, by `make lock`, after the suite passed with the newest versions (`make test-latest`).
LOCK   := constraints.txt
LATEST := .venv-latest
# versions the lock holds back on purpose: ml_dtypes 0.7.0's import costs 0.8 s CPU in every process (0.1 s for 0.6.0;
# jax needs >= 0.5)
HOLD   := "ml_dtypes<0.7"
NEED_PYTHON = @test -n "$(PYTHON)" || { echo "need Python >= 3.11 (python3.11, 3.12, 3.13 or python3); or run: make PYTHON=/path/to/python ..."; exit 2; }

.PHONY: demo test studies test-isa test-latest lock lint docs bench clean venv

$(PY):
	$(NEED_PYTHON)
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip -c $(LOCK)

$(STAMP): $(PY) pyproject.toml $(LOCK)
	$(PY) -m pip install --quiet -c $(LOCK) -e ".[test]"
	@touch $(STAMP)

venv: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/gyrojax demo --out demo-report --force

# the suite, without the studies; the 20 slowest tests are printed
test: $(STAMP)
	$(PY) -m pytest -q -n 2 --dist loadfile --durations=20 -m "not slow" tests

# the studies (marked slow): Monte Carlo coverage and null rates, whole campaigns of the loop, the campaign notebook
studies: $(STAMP)
	$(PY) -m pytest -q -n 2 --dist loadfile --durations=20 -m slow tests

# the whole suite as another CPU would run it: XLA's code and OpenBLAS's kernels held to an older instruction set
# (default AVX2; ISA=SSE4_2 BLAS_CORE=Nehalem for older still), with a compilation cache of its own so that no
# executable compiled for this CPU is loaded. Tolerances must hold there too: they are the numerics', not one CPU's.
ISA       ?= AVX2
BLAS_CORE ?= Haswell
test-isa: $(STAMP)
	cache=$$(mktemp -d) && trap 'rm -rf "$$cache"' EXIT && \
	XDG_CACHE_HOME="$$cache" XLA_FLAGS="--xla_cpu_max_isa=$(ISA)" OPENBLAS_CORETYPE=$(BLAS_CORE) \
	$(PY) -m pytest -q -n 2 --dist loadfile tests

# the whole suite with the newest versions the registries serve (no lock), in a venv of its own
test-latest:
	$(NEED_PYTHON)
	rm -rf $(LATEST)
	$(PYTHON) -m venv $(LATEST)
	$(LATEST)/bin/python -m pip install --quiet --upgrade pip
	$(LATEST)/bin/python -m pip install --quiet --upgrade -e ".[test,bench,docs]" $(HOLD)
	$(LATEST)/bin/python -m pip list --format=freeze --exclude-editable
	$(LATEST)/bin/python -m pytest -q -n 2 --dist loadfile tests

# refresh the lock from the newest versions, only after they passed the suite
lock: test-latest
	{ echo "# gyrojax's lock: pip constraints for every extra, refreshed by 'make lock' after 'make test-latest' passed"; \
	  echo "# ($$($(LATEST)/bin/python -V), $$(date -u +%Y-%m-%d))"; \
	  $(LATEST)/bin/python -m pip freeze --exclude-editable --all | LC_ALL=C sort -f; } > $(LOCK).tmp
	mv $(LOCK).tmp $(LOCK)

lint: $(STAMP)
	$(VENV)/bin/ruff check gyrojax tests benchmarks notebooks
	$(VENV)/bin/ruff format --check gyrojax tests benchmarks notebooks

docs: $(STAMP)
	$(PY) -m pip install --quiet -c $(LOCK) -e ".[docs]"
	$(PY) -m pdoc --docformat google --math -o docs/api gyrojax

bench: $(STAMP)
	$(PY) -m pip install --quiet -c $(LOCK) -e ".[test,bench]"
	$(PY) -m benchmarks

clean:
	rm -rf $(VENV) $(LATEST) demo-report .pytest_cache build *.egg-info docs/api
