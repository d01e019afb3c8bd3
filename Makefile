# patchlight: `make demo` bakes the built-in room; `make test` installs what the tests need and runs them.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: demo test bench browser clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/patchlight demo

browser:
	bash tools/setup_browser.sh

test: $(STAMP) browser
	$(PY) -m pytest tests

bench: $(STAMP)
	$(PY) bench/bench_bake.py

clean:
	rm -rf $(VENV) out node_modules
