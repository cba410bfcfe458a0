# The two commands of the README:
#   make serve   set everything up (local .venv) and start contactnet on the default terrain
#   make test    set everything up and run the whole test suite
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
# Reinstall whenever pyproject.toml changes.
STAMP  := $(VENV)/.installed-$(shell cat pyproject.toml | cksum | cut -d' ' -f1)

.PHONY: setup browser serve test test-fast bench docs clean check-install

# The browser tests drive Debian's chromium (no browser download): install it when it is missing.
CHROMIUM ?= /usr/bin/chromium

$(STAMP): pyproject.toml
	@$(PYTHON) -c 'import sys; assert sys.version_info >= (3, 11), "contactnet needs Python >= 3.11"'
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --upgrade --quiet pip
	$(BIN)/python -m pip install --quiet -e ".[dev,ray,train]"
	rm -f $(VENV)/.installed-*
	touch $@

setup: $(STAMP)

# The web tool on the default terrain (stepping_stones): open http://127.0.0.1:8000/ (the 3D view
# is viser on port 8080, or the next free one). Ctrl-C stops it.
serve: setup
	$(BIN)/contactnet serve --host 127.0.0.1 --port 8000 --viser-port 8080 --terrain stepping_stones

browser:
	@test -x $(CHROMIUM) || { \
	  if [ "$$(id -u)" = 0 ]; then SUDO=; elif command -v sudo >/dev/null; then SUDO=sudo; \
	  else echo "the browser tests need Debian's chromium: apt-get install chromium"; exit 1; fi; \
	  $$SUDO apt-get update -qq && $$SUDO apt-get install -y -qq chromium; }

# One worker per core (pytest-xdist); a test file stays on one worker, its tests in order (docs/contributing.md):
# 19 min on this project's 2-core machines against 29 min in one process.
PYTEST_WORKERS ?= auto
test: setup browser
	$(BIN)/python -m pytest -q -n $(PYTEST_WORKERS) --dist loadfile

test-fast: setup
	$(BIN)/python -m pytest -q -n $(PYTEST_WORKERS) --dist loadfile -m "not slow"

bench: setup
	$(BIN)/contactnet bench terrain
	$(BIN)/contactnet bench sim

# The documentation site (mkdocs.yml, docs/), built offline into site/: open site/index.html.
docs: setup
	$(BIN)/mkdocs build --strict -d site

clean:
	rm -rf $(VENV) .pytest_cache build *.egg-info site

# A fresh install on another Python from wheels only (nothing compiled; no pybullet beyond 3.11, no torch), then the
# stepping stones in MuJoCo: make check-install OTHER_PYTHON=python3.12 (with pyenv: PYENV_VERSION=3.12.1).
OTHER_PYTHON ?= python3.12
CHECK_VENV   ?= /tmp/contactnet-check-install
check-install:
	rm -rf $(CHECK_VENV) && $(OTHER_PYTHON) -m venv $(CHECK_VENV)
	$(CHECK_VENV)/bin/python -m pip install --quiet --upgrade pip
	$(CHECK_VENV)/bin/python -m pip install --quiet --only-binary=:all: -e .
	$(CHECK_VENV)/bin/contactnet simulate --terrain stepping_stones --gait walk --planner contactnet --duration 40
