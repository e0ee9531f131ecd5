# Two entry points: `make run` (set up, then the main job on the built-in
# default) and `make test` (set up, then the test suite); `make docs` builds
# the documentation site into site/. Only Python 3.11+ and pip are needed;
# everything installs into .venv.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: setup run test docs lint validate clean

setup: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test,docs]"
	touch $(STAMP)

# The main job: the calibration with the tip edges' corner laws measured too.
run: $(STAMP)
	$(BIN)/fe-impact calibrate --corners --out out/calibration

# Two processes, each taking whole test files (module fixtures run once); a
# worker that dies ends the run at once, naming the test (pytest-xdist's
# file scheduler can wait forever for a replaced worker).
test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -q -n 2 --dist loadfile --max-worker-restart 0

# The documentation site (mkdocs.yml) with warnings as errors: a dead internal
# link or anchor fails the build; then the README's links and the external
# links' form (tests/test_docs.py). The examples are not run here (the tests
# run them). Open site/index.html.
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --site-dir site
	$(BIN)/python -m pytest -q -p no:xdist -p no:cacheprovider tests/test_docs.py

# Every study and benchmark, each asserting its figures; ends with one
# pass/fail line per study (VALIDATE_FLAGS=--quick for the coarse settings).
validate: $(STAMP)
	$(BIN)/python validation/run_all.py --out out $(VALIDATE_FLAGS)

clean:
	rm -rf out site docs/examples .pytest_cache
