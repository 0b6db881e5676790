# Two commands set everything up on a fresh Debian machine with Python 3.11:
#   make demo   - the whole pipeline on bundled data (outputs in dexlfd-demo/)
#   make test   - lint, type checks, unit + integration tests, examples
PYTHON ?= python3.11
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test lint typecheck pytest bench clean franka-sim lerobot-env

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
	MUJOCO_GL=$${MUJOCO_GL:-egl} $(BIN)/dexlfd demo -o dexlfd-demo

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks examples
	$(BIN)/ruff format --check src tests benchmarks examples

typecheck: $(STAMP)
	$(BIN)/mypy

# The Franka-protocol simulator (franky-sim, ~660 MB, numpy 2) in its own cached venv;
# the franka tests skip with the reason when it cannot be created (no package index).
FRANKA_SIM_ROOT := .venv-franka-sim
franka-sim: $(STAMP)
	-$(BIN)/python -c "import logging, sys; from pathlib import Path; \
	from dexlfd.robot.franka_sim import ensure_simulator_venv as e; \
	logging.basicConfig(level=logging.INFO); e(Path('$(FRANKA_SIM_ROOT)'))"

# LeRobot (lerobot 0.4.4 + torch/torchvision, numpy 2; 5.9 GB; 7 min from the local torch wheels,
# 45 min on a heavily loaded machine) in its own cached venv,
# used only by tests/io/test_lerobot.py to load our exported datasets with lerobot's own
# loader. Not a pytest prerequisite (too big for every CI run): that test skips without it.
LEROBOT_ROOT := .venv-lerobot
lerobot-env: $(STAMP)
	-$(BIN)/python -c "import logging; from pathlib import Path; \
	from dexlfd.io._lerobot_env import ensure_lerobot_venv as e; \
	logging.basicConfig(level=logging.INFO); e(Path('$(LEROBOT_ROOT)'))"

pytest: $(STAMP) franka-sim
	MPLBACKEND=Agg MUJOCO_GL=$${MUJOCO_GL:-egl} $(BIN)/python -m pytest -q -p no:cacheprovider  # no .pytest_cache in the checkout

test: lint typecheck pytest

bench: $(STAMP)
	@for f in benchmarks/bench_*.py; do echo "== $$f"; $(BIN)/python $$f || exit 1; done

clean:
	rm -rf $(VENV) $(FRANKA_SIM_ROOT) $(LEROBOT_ROOT) dexlfd-demo .mypy_cache .pytest_cache .ruff_cache
