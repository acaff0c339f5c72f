# vines_stoch: set-up, run, test, bench. Every target creates the environment if missing.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: run test bench seeds env clean clean-cache

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $(STAMP)

env: $(STAMP)

run: $(STAMP)
	$(BIN)/vines-stoch run scenarios/parallel_nes_impulse.toml

test: $(STAMP)
	$(BIN)/python -m pytest -q

bench: $(STAMP)
	$(BIN)/vines-stoch bench

seeds: $(STAMP)
	$(BIN)/vines-stoch reproduce

# numba's on-disk cache is keyed on each kernel's own file: clear it after editing the
# formula modules the kernels inline (physics.py, kernels/common.py).
clean-cache:
	find vines_stoch -name '*.nbi' -delete -o -name '*.nbc' -delete

clean: clean-cache
	rm -rf $(VENV) results .pytest_cache
