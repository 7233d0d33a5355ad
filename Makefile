# The README's commands.  A fresh machine needs nothing but python3 (>= 3.11) and make.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
HASH := $(shell cat pyproject.toml | cksum | cut -d' ' -f1)
# What each target needs: the demo only armlab and its dependencies; tests also the test extra
# (Pinocchio, hypothesis, pandas, pyarrow, ruff), a much larger download; benchmarks also the
# bench extra (MuJoCo, the startup benchmark's reference).
RUN_STAMP := $(VENV)/.installed-run-$(HASH)
TEST_STAMP := $(VENV)/.installed-test-$(HASH)
BENCH_STAMP := $(VENV)/.installed-bench-$(HASH)

.PHONY: demo test bench lint clean clean-caches docs

# The venv's own pip (>= 21.3) installs this project; upgrading it first cost seconds for nothing.
# --no-compile: modules are byte-compiled when first imported instead of all at install (most
# of SymPy, SciPy and Matplotlib never are), a fresh `make demo` ~10 s sooner.
PIP := $(BIN)/python -m pip install --quiet --disable-pip-version-check --no-compile

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

$(RUN_STAMP): $(BIN)/python pyproject.toml
	$(PIP) -e .
	rm -f $(VENV)/.installed-run-*
	touch $(RUN_STAMP)

$(TEST_STAMP): $(BIN)/python pyproject.toml
	$(PIP) -e ".[test]"
	rm -f $(VENV)/.installed-*
	touch $(TEST_STAMP) $(RUN_STAMP)

# Without a MuJoCo wheel for this platform the benchmarks still run; the startup benchmark then
# says that its MuJoCo side is skipped.
$(BENCH_STAMP): $(TEST_STAMP)
	$(PIP) -e ".[test,bench]" || echo "MuJoCo could not be installed: its benchmark side will be skipped" >&2
	touch $(BENCH_STAMP)

demo: $(RUN_STAMP)
	$(BIN)/armlab warmup
	$(BIN)/armlab demo
	$(BIN)/armlab report

test: $(TEST_STAMP)
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/python -m pytest -n 2 --dist loadfile -q

bench: $(BENCH_STAMP)
	$(BIN)/python benchmarks/run_all.py

lint: $(TEST_STAMP)
	$(BIN)/ruff check src tests benchmarks

clean: clean-caches
	rm -rf $(VENV) build src/*.egg-info .pytest_cache

# numba's disk cache beside the sources: a cached function keeps the code it inlined or called
# from another file, and numba checks only the function's own file, so after an edit of the
# kernels the functions of other files that use them must be compiled again.
clean-caches:
	find src tests benchmarks -name '*.nbi' -delete -o -name '*.nbc' -delete

# The documentation site (Sphinx: docs/*.md and the API reference), warnings as errors.
docs: $(TEST_STAMP)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check -e ".[docs]"
	$(BIN)/python -m sphinx -W --keep-going -b html docs docs/_build/html
