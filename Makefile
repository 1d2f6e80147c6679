# BRDF Studio: `make run` sets up and runs the main job; `make test` sets up and runs every check.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp
JOBS   ?= 2

.PHONY: setup sysdeps run test lint bench clean

setup: sysdeps $(STAMP)

sysdeps:
	@bash .ci/system-deps.sh

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[test]'
	@touch $(STAMP)

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
	rm -rf $(VENV) .pytest_cache build *.egg-info
