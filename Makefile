# Two entry points: `make run` (set up, then the main job on the built-in
# default) and `make test` (set up, then the test suite). Only Python 3.11+
# and pip are needed; everything installs into .venv.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: setup run test lint validate clean

setup: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $(STAMP)

run: $(STAMP)
	$(BIN)/fe-impact calibrate --out out/calibration

test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -q

validate: $(STAMP)
	$(BIN)/python validation/hertz_static.py --out out/hertz_static
	$(BIN)/python validation/hertz_impact.py --out out/hertz_impact
	$(BIN)/python validation/plastic_impact.py --out out/plastic_impact
	$(BIN)/python validation/bench_static.py
	$(BIN)/python validation/bench_dynamic.py

clean:
	rm -rf out .pytest_cache
