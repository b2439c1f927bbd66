# Two entry points for a fresh machine with python3 and make: `make demo`, `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin

.PHONY: demo test lint bench mutation clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

# The server extra too: after `make demo`, `.venv/bin/hriplan serve` works as the docs say. Its
# compiled kernels (numba) are compiled into their cache here, once, not at a first use.
$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet --disable-pip-version-check -e '.[server]'
	$(BIN)/python -m hriplan.planner.kernels
	touch $@

$(VENV)/.installed-test: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet --disable-pip-version-check -e '.[test]'
	$(BIN)/python -m hriplan.planner.kernels
	touch $(VENV)/.installed $@

demo: $(VENV)/.installed
	$(BIN)/hriplan plan examples/handover_full_can.yaml -o out/handover_full_can.json --html out/handover_full_can.html --plots out/plots

LINTED := src tests benchmarks examples tools

test: $(VENV)/.installed-test
	$(BIN)/ruff check $(LINTED)
	$(BIN)/ruff format --check $(LINTED)
	$(BIN)/python -m pytest -q

lint: $(VENV)/.installed-test
	$(BIN)/ruff check --fix $(LINTED)
	$(BIN)/ruff format $(LINTED)

# mplib 0.2.1 for bench_glass.py, in an environment of its own: it needs numpy < 2, while pinocchio
# and coal (cmeel-boost) need numpy >= 2, and under numpy 2 it crashes. Not installing is no error:
# bench_glass.py then says mplib did not run.
MPLIB_VENV := .venv-mplib
$(MPLIB_VENV)/.installed:
	$(PYTHON) -m venv $(MPLIB_VENV)
	-$(MPLIB_VENV)/bin/python -m pip install --quiet --disable-pip-version-check 'numpy<2' mplib==0.2.1
	touch $@

# Every benchmarks/bench_*.py with its defaults, each one's seconds and the total at the end (about
# 30-35 minutes on 2 shared cores, bench_planner.py 20 or more of it: README, Benchmarks).
bench: $(VENV)/.installed $(MPLIB_VENV)/.installed
	$(BIN)/python benchmarks/run_all.py

# Not part of `make test` (too slow for CI): mutants of the safety-critical modules against the fast
# tests that reach them ([tool.mutmut] in pyproject.toml), one worker; then the rule files' mutants.
mutation: $(VENV)/.installed-test
	rm -rf mutants
	HRIPLAN_HYPOTHESIS_PROFILE=mutation $(BIN)/mutmut run --max-children 1
	$(BIN)/mutmut results
	$(BIN)/python benchmarks/mutate_rules.py

clean:
	rm -rf $(VENV) $(MPLIB_VENV)
