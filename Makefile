# jackson: the two commands a newcomer needs are `make demo` and `make test`.
# Both run `make setup` first, which installs whatever is missing (see tools/setup.sh).

PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
NATIVE := build/native
JOBS   ?= 2

.PHONY: help setup test lint typecheck generated native native-test pytest bench demo clean soak \
        firmware flash firmware-test docs-check

help:
	@echo "make demo    set up, then drive the 1 m square and Stage 3's maze on the twin with the real host"
	@echo "make test    set up, then ruff, mypy, generated-code check, C++ tests (ASan+UBSan), pytest"
	@echo "make bench   benchmarks: table on screen, JSON in build/bench.json"
	@echo "make docs-check  re-run the commands behind the figures the docs quote (docs/figures.yaml)"
	@echo "make soak    8 robot-hours of the navigation service on the twin (docs/patrol.md; about 1 h)"
	@echo "make setup   only install what is missing (.venv, Debian packages)"
	@echo "make firmware        build the ESP32-S3 firmware (PlatformIO)"
	@echo "make flash PORT=...  build and flash it (default PORT=/dev/ttyACM0)"
	@echo "make firmware-test   build the firmware core natively and run its tests"

setup:
	@PYTHON=$(PYTHON) bash tools/setup.sh

# The checks before pytest run side by side (mypy is one process, the C++ build two jobs);
# each one's output is printed whole when it ends.
test: setup
	@$(MAKE) --no-print-directory -j 2 --output-sync=target lint typecheck generated native-test
	@$(MAKE) --no-print-directory pytest
	@echo "make test: all passed"

lint:
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

# mypy reads the package through the editable install's link tree (site-packages), so the
# folder-to-package mapping is the one users get; strict on jackson.protocol (pyproject.toml).
typecheck:
	mkdir -p build && cd build && ../$(BIN)/mypy --config-file ../pyproject.toml -p jackson

generated:
	$(BIN)/python protocol/codegen.py --check
	$(BIN)/python -m jackson.protocol.make_vectors --check

native:
	@mkdir -p build
	@cmake -S . -B $(NATIVE) -DCMAKE_BUILD_TYPE=Debug -DJACKSON_SANITIZE=ON > $(NATIVE).log 2>&1 \
	  || { cat $(NATIVE).log; exit 1; }
	@env -u MAKEFLAGS -u MAKELEVEL cmake --build $(NATIVE) -j $(JOBS)

native-test: native
	ctest --test-dir $(NATIVE) --output-on-failure

# One pytest worker per CPU (pytest-xdist); a file's tests run together in one worker, in file
# order (module fixtures such as tests/experiments/test_cluster.py's Ray instance).
pytest:
	$(BIN)/pytest -q -n auto --dist loadfile --durations=12

bench: setup
	$(BIN)/jackson bench

# The figures the docs quote, made again by the commands the docs name (about 2 minutes);
# ALL=1 also runs the long ones.
docs-check: setup
	$(BIN)/python tools/docs_check.py $(if $(ALL),--all,)

# The navigation service for 8 robot-hours on the twin: one daemon process, goal after goal; its
# memory, CPU and disk over time (docs/patrol.md). HOURS=1 for a shorter one.
HOURS ?= 8
soak: setup
	$(BIN)/jackson patrol --world warehouse --robot-hours $(HOURS) --seed 8 --sample-s 30 --budget-mb 1000 \
	  --out build/soak

# The newcomer's first command: the twin and the real host daemon over a pty drive the paper's
# 1 m square, then Stage 3: the host maps the maze with the twin's RPLIDAR and navigates around
# the cylinder dropped in its way; a table and a plot each, and the run folders (the previous
# demo's folders are replaced).
demo: setup
	@rm -rf build/demo/square build/demo/maze
	@$(BIN)/jackson run square --out build/demo/square
	@$(BIN)/jackson run maze --out build/demo/maze

# ---- firmware ---------------------------------------------------------------------------------
PORT ?= /dev/ttyACM0
PIO  ?= $(shell command -v pio 2>/dev/null || command -v platformio 2>/dev/null)
PIO_MISSING = echo "PlatformIO is not installed; install it with: pipx install platformio  (or python3 -m pip install --user platformio), then run make $@ again" >&2; exit 1

firmware:
	@if [ -z "$(PIO)" ]; then $(PIO_MISSING); fi
	$(PIO) run -d firmware

flash:
	@if [ -z "$(PIO)" ]; then $(PIO_MISSING); fi
	@[ -e "$(PORT)" ] || { echo "$(PORT) does not exist: plug the ESP32-S3 in by its USB port, or pass PORT=/dev/ttyACMx" >&2; exit 1; }
	$(PIO) run -d firmware -t upload --upload-port $(PORT)

firmware-test: setup native
	ctest --test-dir $(NATIVE) --output-on-failure -R firmware
	$(BIN)/pytest -q tests/firmware

clean:
	rm -rf build $(VENV)
