# Two entry points: `make demo` and `make test`. Both create .venv when missing.
PYTHON ?= python3.11
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: demo test test-slow bench clean clean-cache

$(PY):
	@command -v $(PYTHON) >/dev/null 2>&1 || { echo "error: $(PYTHON) not found (wbc needs Python 3.11; set PYTHON=/path/to/python3.11)"; exit 2; }
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

$(STAMP): $(PY) pyproject.toml
	$(PY) -m pip install --quiet -e '.[dev]'
	@touch $(STAMP)

demo: $(STAMP)
	$(PY) demos/talos_balance_reach.py $(ARGS)

test: $(STAMP)
	$(PY) -m pytest -q

test-slow: $(STAMP)
	$(PY) -m pytest -q -m slow

bench: $(STAMP)
	$(VENV)/bin/wbc bench $(ARGS)

clean: clean-cache
	rm -rf $(VENV) build *.egg-info .pytest_cache

# numba caches a kernel by its own file's date only: after editing a kernel another module
# calls, drop the caches so the callers are compiled again
clean-cache:
	find wbc tests -name '*.nbi' -delete -o -name '*.nbc' -delete
