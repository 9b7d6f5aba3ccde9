# gearbench: two commands set everything up on a fresh machine.
#   make run   - create .venv, install, reproduce Table I, the gain scans, the tutorial's
#                diagnosis, the EMPS study, the standard errors' coverage, the tuning study and the two-mass
#                bench study into results/
#   make test  - create .venv, install with test extras, run the test suite
#   make test-all - the same with the slow tests too (the 10,000-input fuzz, every hidden-effect
#                case on its 16 s record)
#   make docs  - create .venv, install with the docs extras, build the docs site into site/ (strict:
#                a broken link, a page missing from the nav or a failing API reference fails)
PYTHON ?= python3
# Test files run on this many processes (pytest-xdist), each file whole on one (its module
# fixtures are computed once): 2 fits CI's 2 cores, and the diagnoses the tests run spread their
# own work over the cores too.  On 2 cores the suite took 407 s for 645-677 s on one.
TEST_WORKERS ?= 2
VENV := .venv
BIN := $(VENV)/bin

.PHONY: run test test-all docs bench clean-cache install install-test install-docs

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

install: $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .

install-test: $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[test]"

run: install
	$(BIN)/gearbench run experiments/table1.yaml
	$(BIN)/gearbench validate
	$(BIN)/gearbench run experiments/table1_translational.yaml
	$(BIN)/gearbench run experiments/compensators.yaml
	# --fresh: the store keeps the points of every earlier physics (their keys hash the source), so
	# without it the committed sweep.csv gains a stale copy of each point at every change of the physics
	$(BIN)/gearbench sweep experiments/gain_scan.yaml --param controller.kp=0.5,5,50,500,5000 \
		--summary results/gain_scan.md --fresh
	$(BIN)/gearbench sweep experiments/gain_scan.yaml --param "controller.kp=geomspace(50,5000,11)" \
		--results results/gain_scan_fine --summary results/gain_scan.md --fresh
	$(BIN)/gearbench stability experiments/plants/thesis_gear.yaml --controller p \
		--at 0.5,1,5,50,88,126,500,1256,1448,5000 --markdown results/gain_scan.md
	$(BIN)/gearbench stability experiments/plants/thesis_gear.yaml --controller pi --ki 0.005 \
		--markdown results/gain_scan.md
	$(BIN)/gearbench compare experiments/plants/bench_rig.yaml experiments/data/bench_rig_hidden.csv
	$(BIN)/gearbench diagnose experiments/plants/bench_rig.yaml experiments/data/bench_rig_hidden.csv
	$(BIN)/python -m studies.hidden_effects --results results
	$(BIN)/python -m studies.emps --results results
	$(BIN)/python -m studies.coverage --results results
	$(BIN)/python -m studies.tuning --results results
	$(BIN)/python -m studies.twomass --results results

test: install-test
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadfile

test-all: install-test
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadfile --runslow

install-docs: $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[docs]"

# NO_MKDOCS_2_WARNING, DISABLE_MKDOCS_2_WARNING: the theme's and a plugin's banners about
# MkDocs' future, printed on every build, say nothing about this site
docs: install-docs
	NO_MKDOCS_2_WARNING=1 DISABLE_MKDOCS_2_WARNING=true $(BIN)/mkdocs build --strict --site-dir site

bench: install
	$(BIN)/python benchmarks/bench_table1.py
	$(BIN)/python benchmarks/bench_sweep.py
	$(BIN)/python benchmarks/bench_diagnose.py
	$(BIN)/python benchmarks/bench_dask_diagnose.py
	$(BIN)/python benchmarks/bench_ladder.py
	$(BIN)/python benchmarks/bench_practice.py
	$(BIN)/python benchmarks/bench_tune.py

clean-cache:
	rm -rf $$HOME/.cache/gearbench
