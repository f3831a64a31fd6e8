# Two entry points: `make demo` and `make test`. Both create $(VENV) when missing.
#
#   make demo                      the runtime only (no test tools, no peers), then the demo
#   make test                      adds the test extras (pytest, hypothesis, ruff, mypy), lints, type-checks, tests
#   make test PYTHON=python3.13 VENV=.venv-313 CONSTRAINTS=constraints/py313-pin41.txt
#                                  another environment, pinned exactly as CI pins it
#   make test EXTRAS=test,peers    also PlaCo (needs pinocchio 3.8: Python 3.11 here)

# the newest supported Python on the PATH (3.10-3.13), else python3
PYTHON ?= $(or $(firstword $(foreach p,python3.13 python3.12 python3.11 python3.10,\
	$(shell $(p) -c 'import sys' >/dev/null 2>&1 && echo $(p)))),python3)
VENV ?= .venv
comma := ,
EXTRAS ?= test
CONSTRAINTS ?=
PY := $(VENV)/bin/python
PIP := $(PY) -m pip install --quiet $(if $(CONSTRAINTS),-c $(CONSTRAINTS))
RUNTIME := $(VENV)/.installed-runtime
TESTING := $(VENV)/.installed-$(subst $(comma),-,$(EXTRAS))

.PHONY: demo test test-slow lint bench clean clean-cache

$(PY):
	@$(PYTHON) -c 'import sys; sys.exit(not (3, 10) <= sys.version_info[:2] < (3, 14))' 2>/dev/null \
		|| { echo "error: $(PYTHON) is missing or not Python 3.10-3.13 (set PYTHON=/path/to/python3.1x)"; exit 2; }
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

$(RUNTIME): $(PY) pyproject.toml $(CONSTRAINTS)
	$(PIP) -e .
	@touch $@

$(TESTING): $(PY) pyproject.toml $(CONSTRAINTS)
	$(PIP) -e '.[$(EXTRAS)]'
	@touch $@ $(RUNTIME)

demo: $(RUNTIME)
	$(PY) demos/talos_balance_reach.py $(ARGS)

lint: $(TESTING)
	$(VENV)/bin/ruff check .

test: $(TESTING)
	$(VENV)/bin/ruff check .
	$(PY) -m mypy wbc
	$(PY) -m pytest -q --durations=15 $(PYTEST_ARGS)

test-slow: $(TESTING)
	$(PY) -m pytest -q -m slow

bench: $(RUNTIME)
	$(VENV)/bin/wbc bench $(ARGS)

clean: clean-cache
	rm -rf $(VENV) build dist *.egg-info .pytest_cache

# numba caches a kernel by its own file's date only: after editing a kernel another module
# calls, drop the caches so the callers are compiled again
clean-cache:
	find wbc tests -name '*.nbi' -delete -o -name '*.nbc' -delete
