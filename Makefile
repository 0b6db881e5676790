# Two commands set everything up on a fresh Debian machine with Python 3.11:
#   make demo       - the whole pipeline on bundled data (outputs in dexlfd-demo/)
#   make test       - lint, type checks, every test (all extras, simulators, LeRobot check)
# and, while working on the code:
#   make test-fast  - lint, type checks and the unit tests (no simulator venv, no video)
PYTHON ?= python3.11
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
# environments of tools whose dependencies clash with ours, built once per machine and
# shared by every checkout (a fresh clone reuses them)
CACHE  ?= $(or $(XDG_CACHE_HOME),$(HOME)/.cache)/dexlfd

.PHONY: demo test test-fast test-wheel lint typecheck pytest pytest-fast bench clean \
        franka-sim lerobot-env

# the test environment: the core, every extra and the dev tools, at the locked versions
$(STAMP): requirements.lock requirements-dev.lock pyproject.toml
	@command -v $(PYTHON) >/dev/null || { echo "need $(PYTHON) (Debian: apt-get install python3.11 python3.11-venv)"; exit 1; }
	@# pyrealsense2 needs libusb (Debian libusb-1.0-0); without it only the RealSense tests skip
	@ldconfig -p | grep -q libusb-1.0.so.0 || { apt-get install -y -q libusb-1.0-0 >/dev/null 2>&1 || \
	  { apt-get update -q >/dev/null 2>&1 && apt-get install -y -q libusb-1.0-0 >/dev/null 2>&1; } || \
	  echo "note: could not install libusb-1.0-0 (RealSense support off; tests skip)"; }
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -r requirements.lock -r requirements-dev.lock
	$(BIN)/pip install -q --no-deps -e .
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/dexlfd demo -o dexlfd-demo

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks examples
	$(BIN)/ruff format --check src tests benchmarks examples

typecheck: $(STAMP)
	$(BIN)/mypy

# The Franka-protocol simulator (franky-sim, ~660 MB) in its own cached venv;
# the franka tests skip with the reason when it cannot be created (no package index).
FRANKA_SIM_ROOT := .venv-franka-sim
franka-sim: $(STAMP)
	-$(BIN)/python -c "import logging, sys; from pathlib import Path; \
	from dexlfd.robot.franka_sim import ensure_simulator_venv as e; \
	logging.basicConfig(level=logging.INFO); e(Path('$(FRANKA_SIM_ROOT)'))"

# LeRobot in its own venv under $(CACHE)/lerobot/lerobot-<version>, built once per machine:
# lerobot 0.6.1 (the current release) when a Python 3.12/3.13 is found ($DEXLFD_LEROBOT_PYTHON,
# python3.12/python3.13 on PATH, pyenv's ~/.pyenv/versions; 5.2 GB with PyPI's CUDA torch
# and its nvidia-* packages, 135 s here), else lerobot 0.4.4 on Python 3.11 (~6 GB; 7 min from
# the machine's local torch wheels); the log says which and why. tests/io/test_lerobot.py loads
# our exported datasets with lerobot's own LeRobotDataset there (0.6.1 also decodes the video);
# it skips, with the reason, only when the environment cannot be built.
lerobot-env: $(STAMP)
	-$(BIN)/python -c "import logging; from pathlib import Path; \
	from dexlfd.io._lerobot_env import ensure_lerobot_venv as e; \
	logging.basicConfig(level=logging.INFO); e(Path('$(CACHE)/lerobot'))"

# the tests run on every core, at most 4 workers (each holds MuJoCo, MediaPipe and friends;
# most tests also start processes of their own): TEST_WORKERS=1 runs them in one process.
# Tests of one machine-wide resource (the Franka simulator's ports, Ray, ROS 2) share a
# worker (tests/conftest.py: ONE_AT_A_TIME).
TEST_WORKERS ?= $(shell n=$$(nproc 2>/dev/null || echo 2); [ "$$n" -gt 4 ] && n=4; echo $$n)
PYTEST := MPLBACKEND=Agg DEXLFD_LEROBOT_ENV=$(CACHE)/lerobot $(BIN)/python -m pytest -q \
          -p no:cacheprovider -n $(TEST_WORKERS) --dist loadgroup  # no .pytest_cache in the checkout

# everything but the wheel test (make test-wheel: a fresh ~1 GB environment and a whole demo)
pytest: $(STAMP) franka-sim lerobot-env
	$(PYTEST) -m "not wheel"

# unit tests only: no simulator process, no real video, no end-to-end runs
pytest-fast: $(STAMP)
	$(PYTEST) -m "not slow and not integration and not franka and not video and not wheel"

test: lint typecheck pytest

test-fast: lint typecheck pytest-fast

# a wheel built from the checkout, installed with its core dependencies only in a fresh venv,
# runs `dexlfd demo` (also a slow test: tests/test_wheel.py)
test-wheel: $(STAMP)
	$(PYTEST) tests/test_wheel.py

bench: $(STAMP)
	@for f in benchmarks/bench_*.py; do echo "== $$f"; $(BIN)/python $$f || exit 1; done

clean:
	rm -rf $(VENV) $(FRANKA_SIM_ROOT) dexlfd-demo .mypy_cache .pytest_cache .ruff_cache build dist
