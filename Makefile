# BRDF Studio: `make run` sets up and runs the main job; `make test` sets up and runs every check.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp
WARMED := $(VENV)/.warmed-stamp
# numba's cached compiles are stamped by the sources they import (core/_numba_cache.py) and the modules' .npz
# tables: an edit of any of these makes some of them stale, and the warm-up compiles those again
KERNEL_SOURCES := $(shell find core renderer \( -name '*.py' -o -name '*.npz' \) -not -path '*/__pycache__/*' 2>/dev/null)
JOBS   ?= 2

.PHONY: setup sysdeps run test lint docs bench clean

setup: sysdeps $(STAMP) $(WARMED)

sysdeps:
	@bash .ci/system-deps.sh

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[test]'
	@touch $(STAMP)

# Compile every cached kernel now rather than in the first render, test or edit of the app (the warm-ups of
# core and renderer, in two processes at once).
$(WARMED): $(STAMP) $(KERNEL_SOURCES)
	$(BIN)/brdf-studio setup
	@touch $(WARMED)

# With a display: the desktop app on the demo scene. Headless: the demo summary and a render of the demo scene.
run: setup
	@if [ -n "$$DISPLAY$$WAYLAND_DISPLAY" ]; then \
		$(BIN)/brdf-studio; \
	else \
		echo "no display: printing the demo summary and rendering the demo scene to results/demo.* instead"; \
		$(BIN)/brdf-studio demo && mkdir -p results && \
		$(BIN)/brdf-studio render --demo --spp 16 --width 320 --height 240 -o results/demo.exr; \
	fi

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/lint-imports

# The user guide, the results and the API reference from the docstrings, into site/ (a warning is an error).
docs: $(STAMP)
	$(BIN)/mkdocs build --strict --config-file .ci/mkdocs.yml --site-dir site

test: setup lint
	$(BIN)/python -m pytest -n $(JOBS) -q

test-slow: setup
	$(BIN)/python -m pytest -n $(JOBS) -q -m slow

bench: setup
	$(BIN)/python bench/models.py
	$(BIN)/python bench/adaptive.py
	$(BIN)/brdf-studio bench samplers
	$(BIN)/python bench/render.py

clean:
	rm -rf $(VENV) .pytest_cache build site *.egg-info
