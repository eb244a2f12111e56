# Every target does its own set-up on a fresh machine.
#
# `make test` / `make demo` install from requirements.lock (exact versions of every dependency,
# all extras, markers for Python 3.10-3.13), so a fresh clone gets the releases the suite was
# run with. `make lock` refreshes both lock files; `make test-latest` ignores the lock and runs
# the suite on the newest releases; `make test-oldest` runs it on Python 3.10 with the oldest
# releases pyproject.toml admits (its floors), from requirements-oldest.lock.
PYTHON    ?= python3
# A Python 3.10 for test-oldest: on the PATH, or one that pyenv installed.
PYTHON310 ?= $(shell for p in python3.10 $$(ls -d $${PYENV_ROOT:-$$HOME/.pyenv}/versions/3.10*/bin/python3.10 2>/dev/null) /usr/bin/python3.10; do $$p -c 'import sys; assert sys.version_info[:2] == (3, 10)' 2>/dev/null && { echo $$p; break; }; done)
EXTRAS    := test,fast,dask,stonesoup,labelled
VENV      := .venv
PY        := $(VENV)/bin/python
STAMP     := $(VENV)/.installed-stamp
LOCK      := requirements.lock
OLDEST    := requirements-oldest.lock

.PHONY: install browser test test-slow test-latest test-oldest lock demo lint bench clean

$(STAMP): pyproject.toml $(LOCK)
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --constraint $(LOCK) -e '.[$(EXTRAS)]'
	touch $(STAMP)

install: $(STAMP)

# The headless browser of the report's browser test (tests/plots/test_report_browser.py):
# Debian's chromium, installed with apt-get when it is missing and we are root; otherwise
# the target says what to install (the test skips locally, and fails in CI, without it).
CHROMIUM  ?= /usr/bin/chromium
export ARRAYPROC_CHROMIUM ?= $(CHROMIUM)
browser:
	@if [ -x "$(CHROMIUM)" ]; then echo "browser: $(CHROMIUM)"; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium; \
	else echo "make browser: $(CHROMIUM) is missing; install Debian's chromium" \
	    "(sudo apt-get install chromium) or give make CHROMIUM=/path/to/chromium;" \
	    "the report's browser test skips without it (and fails when CI=true)"; fi

test: install browser
	$(PY) -m pytest -q

test-slow: install
	$(PY) -m pytest -q -m slow

demo: install
	$(VENV)/bin/arrayproc demo -o demo_out

lint: install
	$(VENV)/bin/ruff check .

# The newest releases of everything, ignoring the lock (docs/testing.md).
test-latest:
	$(PYTHON) -m venv .venv-latest
	.venv-latest/bin/python -m pip install --quiet --upgrade pip
	.venv-latest/bin/python -m pip install --quiet --upgrade --upgrade-strategy eager -e '.[$(EXTRAS)]'
	.venv-latest/bin/python -m pip list --format=freeze | grep -iE '^(numpy|scipy|numba|h5py)=='
	.venv-latest/bin/python -m pytest -q

# Python 3.10 with the floors of pyproject.toml (numpy, scipy, numba, h5py ... at their lowest).
test-oldest:
	@test -n "$(PYTHON310)" || { echo "make: no Python 3.10 found (set PYTHON310=/path/to/python3.10)"; exit 2; }
	$(PYTHON310) -m venv .venv-oldest
	.venv-oldest/bin/python -m pip install --quiet --requirement $(OLDEST) -e .
	.venv-oldest/bin/python -m pytest -q -p no:cacheprovider

# Refresh both lock files (uv resolves for every supported Python at once).
lock: install
	$(PY) -m pip install --quiet uv
	$(VENV)/bin/uv pip compile pyproject.toml --all-extras --universal --python-version 3.10 \
	    --upgrade --quiet -o $(LOCK)
	$(VENV)/bin/uv pip compile pyproject.toml --extra test --extra fast --extra dask \
	    --extra stonesoup --resolution lowest-direct --python-version 3.10 --quiet -o $(OLDEST)

clean:
	rm -rf $(VENV) .venv-latest .venv-oldest demo_out build *.egg-info
