# Two entry points for a fresh machine; each makes its own virtual environment.
#   make demo   set up, then run the main job (paper table, a verdict, the sidecar, the closed loop)
#   make test   set up, then run the test suite
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin

.PHONY: demo test browser malloc bench clean

# Debian's package $(1), installed quietly; fails without root or Debian's packages (the caller says so).
apt_install = apt-get install -y -q $(1) >/dev/null 2>&1 \
	  || (apt-get update -q >/dev/null 2>&1 && apt-get install -y -q $(1) >/dev/null 2>&1)

$(BIN)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[planner,test]'
	touch $@

demo: $(BIN)/.installed malloc
	$(BIN)/discern demo

# Tests run on every core, then those that time a monitor alone (the wall_clock marker, pyproject.toml); both
# parts run whatever the first found, and the target fails if either did.
test: $(BIN)/.installed browser
	$(BIN)/python -m pytest -n auto -m "not wall_clock"; parallel=$$?; \
	  $(BIN)/python -m pytest -m wall_clock && exit $$parallel

# The audit's HTML report is checked in a real headless browser.
browser:
	@command -v chromium >/dev/null 2>&1 || $(call apt_install,chromium) \
	  || echo "warning: could not install chromium (needs root and Debian's packages); the browser tests will skip"

# jemalloc makes the rules about a fifth faster on small frames (monitor/allocator.py); without it, glibc's malloc.
malloc: $(BIN)/.installed
	@$(BIN)/python -c "from discern.monitor.allocator import chosen; raise SystemExit(chosen() is None)" \
	  || $(call apt_install,libjemalloc2) \
	  || echo "note: could not install jemalloc (needs root and Debian's packages); Discern runs on glibc's malloc"

# Each benchmark writes its own section of docs/benchmarks.md; run them on an otherwise idle machine.
bench: $(BIN)/.installed malloc
	$(BIN)/python bench/bench_core.py
	$(BIN)/python bench/bench_idle.py
	$(BIN)/python bench/bench_sanity.py
	$(BIN)/python bench/bench_zenoh.py
	$(BIN)/python bench/bench_worker.py
	$(BIN)/python bench/bench_audit.py
	-$(BIN)/python bench/bench_allocator.py  # needs jemalloc: where it could not be installed, says so and goes on

clean:
	rm -rf $(VENV) out
