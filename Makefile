# Two entry points for a fresh machine; each makes its own virtual environment.
#   make demo   set up, then run the main job (paper table, a verdict, the sidecar, the closed loop)
#   make test   set up, then run the test suite
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin

.PHONY: demo test bench clean

$(BIN)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[planner,test]'
	touch $@

demo: $(BIN)/.installed
	$(BIN)/discern demo

test: $(BIN)/.installed
	$(BIN)/python -m pytest

bench: $(BIN)/.installed
	$(BIN)/python bench/bench_core.py

clean:
	rm -rf $(VENV) out
