"""Shared fixtures."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

# ../shared beside the checkout; DEXLFD_SHARED overrides it (e.g. from a git worktree)
SHARED = Path(os.environ.get("DEXLFD_SHARED", Path(__file__).resolve().parents[2] / "shared"))
HAND_VIDEO = SHARED / "data" / "human_hand_video.mp4"


@pytest.hookimpl(trylast=True)  # after the tmp_path plugin has set up its factory
def pytest_configure(config: pytest.Config) -> None:
    """Hypothesis keeps its caches (constants, unicode data) under pytest's temporary
    folder, not in a ``.hypothesis/`` folder of the checkout (before collection, which
    already writes them)."""
    try:
        from hypothesis.configuration import set_hypothesis_home_dir
    except ImportError:  # pragma: no cover - hypothesis is in the dev lock
        return
    base = config._tmp_path_factory.getbasetemp()  # type: ignore[attr-defined]
    set_hypothesis_home_dir(base / "hypothesis")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(42)


@pytest.fixture
def hand_video() -> Path:
    if not HAND_VIDEO.is_file():
        pytest.skip(f"real hand video not found at {HAND_VIDEO} (../shared/data/)")
    return HAND_VIDEO


@pytest.fixture
def demos(rng: np.random.Generator):
    from dexlfd.datasets import pick_place_demonstrations

    return pick_place_demonstrations(6, rng)


@pytest.fixture(autouse=True)
def _reset_dexlfd_logging():
    """Undo cli.main's logging set-up after each test.

    ``main`` gives the "dexlfd" logger a handler on the (captured) stderr and stops
    propagation; later tests would then log to a closed stream and caplog would see nothing.
    """
    yield
    import logging

    log = logging.getLogger("dexlfd")
    log.handlers.clear()
    log.propagate = True
    log.setLevel(logging.NOTSET)
