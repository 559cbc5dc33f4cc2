# `make run`: set up .venv and run the whole default pipeline. `make test`: set up and run the tests.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-$(shell cat pyproject.toml | sha1sum | cut -c1-12)

export DVC_NO_ANALYTICS := 1
export DO_NOT_TRACK := 1
export PREFECT_HOME ?= $(CURDIR)/.prefect
export PREFECT_SERVER_ANALYTICS_ENABLED := false
export PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS := 120
export MPLBACKEND := Agg
export PATH := $(CURDIR)/$(BIN):$(PATH)

.PHONY: setup run test test-slow bench lint profile deps

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e ".[dev]"
	rm -f $(VENV)/.installed-*
	touch $(STAMP)

setup: $(STAMP)
	test -f params.yaml || $(BIN)/robocompose profile default

# Under the pinned CPU dispatch (robocompose/io/dispatch.py): the same bytes as dvc.lock on any x86-64-v3 machine.
run: setup
	$(BIN)/python -m robocompose.io.dispatch $(BIN)/dvc repro

# `make test`: lint and the suite without the tests marked slow (kills, real servers); `make test-slow`: those.
# Both on TEST_WORKERS pytest-xdist processes (`make test TEST_WORKERS=0`: one process, as `python -m pytest` runs),
# a test file per worker at a time (its module fixtures built once).
TEST_WORKERS ?= 2
XDIST := -n $(TEST_WORKERS) --dist loadfile

test: setup
	$(BIN)/ruff check robocompose stages flows tests benchmarks
	$(BIN)/python -m pytest -q -ra -m "not slow" $(XDIST)

test-slow: setup
	$(BIN)/python -m pytest -q -ra -m slow $(XDIST)

bench: setup
	$(BIN)/python -m benchmarks

# `make profile PROFILE=paper` switches params.yaml to the thesis's scale; `make profile PROFILE=default` back.
profile: setup
	$(BIN)/robocompose profile $(PROFILE)

# `make deps`: rewrite each stage's code deps in dvc.yaml from its script's import closure (robocompose/dvc_deps.py).
deps: setup
	$(BIN)/python -m robocompose.dvc_deps
