# vines_stoch: set-up, run, test, bench. Every target creates the environment if missing.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
CUDA_STAMP := $(VENV)/.installed-cuda

.PHONY: run test test-slow lint bench bench-gpu seeds elcentro env docs clean clean-cache

# The test tools (pytest, ruff, sdeint, numba-cuda for the CUDA simulator's tests): make test,
# make bench and make env install them.
$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $(STAMP)

# What make run needs: the package and its plots (no test tools, no CUDA wheels).
RUN_STAMP := $(VENV)/.installed-run
$(RUN_STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[report]"
	touch $(RUN_STAMP)

env: $(STAMP)

run: $(RUN_STAMP)
	$(BIN)/vines-stoch run scenarios/parallel_nes_impulse.toml

# The linter, then every test but the slow ones on one worker process per core: the kernels they
# compile are shared through numba's on-disk cache; an idle worker takes tests from a busy one's
# queue (worksteal: 97 s warm on 2 cores against 115 s a file a worker). test-slow: the tests
# marked slow (loops of their own to compile, long statistical runs); .ci/run runs both.
test: lint
	$(BIN)/python -m pytest -q -n auto --dist worksteal -m "not slow"

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -n auto --dist worksteal -m slow

lint: $(STAMP)
	$(BIN)/ruff check .

bench: $(STAMP)
	$(BIN)/vines-stoch bench

# The docs extra (Sphinx, myst-parser, sphinx-gallery, furo), installed once.
DOCS_STAMP := $(VENV)/.installed-docs
$(DOCS_STAMP): $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[docs]"
	touch $(DOCS_STAMP)

# The documentation, into docs/_build/html: the scenario and CLI references are written from the
# code, the examples in examples/ run (docs/conf.py). Nothing is fetched while it builds. Nitpicky
# (-n) and strict (-W): a broken link or cross-reference, the README's included sections' among
# them, fails the build.
docs: $(STAMP) $(DOCS_STAMP)
	$(BIN)/python -m sphinx -b html -q -n -W --keep-going docs docs/_build/html

# The cuda extra (numba-cuda with the CUDA 12 compiler wheels), installed once.
$(CUDA_STAMP): $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[cuda]"
	touch $(CUDA_STAMP)

# GPU ensembles: their section of reports/benchmarks.md (needs an NVIDIA GPU and a CUDA 12 driver).
bench-gpu: $(STAMP) $(CUDA_STAMP)
	$(BIN)/vines-stoch bench --backend cuda

seeds: $(STAMP)
	$(BIN)/vines-stoch reproduce

# The 1940 El Centro N-S record is not shipped (no licence text at its source); this fetches the
# quakeio 0.1.21 wheel from the package index and extracts the samples, checking both checksums.
elcentro: $(STAMP)
	rm -rf $(VENV)/quakeio && $(BIN)/python -m pip download --quiet --no-deps --dest $(VENV)/quakeio quakeio==0.1.21
	$(BIN)/python tools/extract_elcentro.py \
		$(VENV)/quakeio/quakeio-0.1.21-py3-none-any.whl scenarios/records/elcentro_1940_ns.txt

# numba's on-disk cache of the kernels lives in folders named by a hash of the physics and
# kernel sources (vines_stoch/jit/cache.py): edits compile afresh; this removes every such folder.
clean-cache:
	find vines_stoch -depth -type d -name 'vines-stoch-*' -exec rm -rf {} +
	find vines_stoch -name '*.nbi' -delete -o -name '*.nbc' -delete

clean: clean-cache
	rm -rf $(VENV) results .pytest_cache docs/_build docs/auto_examples docs/reference/cli.md \
		docs/reference/scenario-keys.md
