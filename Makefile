# Two commands set everything up on a fresh Debian machine with Python 3.11:
#   make demo   - the whole pipeline on bundled data (outputs in dexlfd-demo/)
#   make test   - lint, type checks, unit + integration tests, examples
PYTHON ?= python3.11
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test lint typecheck pytest bench clean

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

pytest: $(STAMP)
	MPLBACKEND=Agg MUJOCO_GL=$${MUJOCO_GL:-egl} $(BIN)/python -m pytest -q

test: lint typecheck pytest

bench: $(STAMP)
	@for f in benchmarks/bench_*.py; do echo "== $$f"; $(BIN)/python $$f || exit 1; done

clean:
	rm -rf $(VENV) dexlfd-demo .mypy_cache .pytest_cache .ruff_cache
