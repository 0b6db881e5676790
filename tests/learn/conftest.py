"""Fixtures of the learning-stage tests."""

from __future__ import annotations

import logging
from collections.abc import Iterator

import pytest


@pytest.fixture(autouse=True)
def _dexlfd_logs_reach_caplog() -> Iterator[None]:
    # dexlfd.cli.main() sets propagate=False on the "dexlfd" logger (its own stderr
    # handler); after a CLI test in the same process, caplog would see nothing
    root = logging.getLogger("dexlfd")
    saved = (root.propagate, list(root.handlers), root.level)
    root.propagate, root.handlers[:], root.level = True, [], logging.NOTSET
    yield
    root.propagate, root.handlers[:], root.level = saved[0], saved[1], saved[2]
