"""Shared fixtures."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

# Real recordings that do not ship with the package (landmark files, other videos) are read
# from ../shared/data beside the checkout (DEXLFD_SHARED overrides it, e.g. from a git
# worktree); tests that need them skip without it. The real hand video ships in the package
# (dexlfd.data) and is always there.
SHARED = Path(os.environ.get("DEXLFD_SHARED", Path(__file__).resolve().parents[2] / "shared"))


def _packaged_hand_video() -> Path:
    from dexlfd.data import hand_video

    return hand_video()


HAND_VIDEO = _packaged_hand_video()


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


# fixtures that read the real video (the shared one and those of single test files built on it)
VIDEO_FIXTURES = {"hand_video", "real_video", "real_observations", "cli_run"}


# test files that hold a machine-wide resource while they run: the Franka-protocol
# simulator's fixed ports (1337/1338), a local Ray cluster, ROS 2 discovery on loopback.
# Under pytest-xdist (``make test`` runs on every core) each group runs on one worker,
# one test after another, so two of them never meet.
ONE_AT_A_TIME = {
    "test_franka.py": "franka-ports",
    "test_franka_generations.py": "franka-ports",
    "test_engine.py": "ray",
    "test_engine_ray_session.py": "ray",
    "test_ros2.py": "ros2",
    "test_ros2_cli.py": "ros2",
}


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Mark every test that uses the packaged real video ``video`` (left out by test-fast),
    and keep the tests of one machine-wide resource on one worker."""
    for item in items:
        if VIDEO_FIXTURES & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.video)
        group = ONE_AT_A_TIME.get(item.path.name)
        if group is not None:
            item.add_marker(pytest.mark.xdist_group(group))


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(42)


@pytest.fixture
def hand_video() -> Path:
    """The real hand video shipped in the package (dexlfd.data)."""
    return HAND_VIDEO


@pytest.fixture
def shared_data() -> Path:
    """../shared/data (real recordings that do not ship); skips when it is absent."""
    folder = SHARED / "data"
    if not folder.is_dir():
        pytest.skip(f"real recordings not found at {folder} (../shared/data/)")
    return folder


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


def _fake_python(path: Path, answer: str) -> Path:
    """An executable that answers dexlfd's version probe with the shell line ``answer``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"#!/bin/sh\n{answer}\n")
    path.chmod(0o755)
    return path


@pytest.fixture
def fake_python():
    """``fake_python(path, "echo 3 12")`` writes a stand-in interpreter (``exit 1``: broken)."""
    return _fake_python


@pytest.fixture
def pythons(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A machine without other Pythons: empty ``PATH`` and pyenv root under the returned
    folder (``bin/``, ``pyenv/``), ``$DEXLFD_LEROBOT_PYTHON`` unset, dexlfd running on 3.11."""
    import sys
    from types import SimpleNamespace

    from dexlfd import _interpreters

    (tmp_path / "bin").mkdir()
    monkeypatch.setenv("PATH", str(tmp_path / "bin"))
    monkeypatch.setenv("PYENV_ROOT", str(tmp_path / "pyenv"))
    monkeypatch.delenv("DEXLFD_LEROBOT_PYTHON", raising=False)
    running = SimpleNamespace(version_info=(3, 11, 7), executable=sys.executable)
    monkeypatch.setattr(_interpreters, "sys", running)
    return tmp_path


class FakeBar:
    """A stand-in progress bar: its total, description, updates and shown phase names."""

    def __init__(self, total, desc, quiet=False, **kw):
        self.total, self.desc, self.n, self.shown = total, desc, 0, []

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def update(self, n):
        self.n += n

    def refresh(self):
        pass

    def set_postfix_str(self, text, refresh=True):
        self.shown.append((text, self.n))


@pytest.fixture
def fake_progress(monkeypatch: pytest.MonkeyPatch):
    """``install(module)``: ``module.progress`` makes :class:`FakeBar` s; returns their list."""

    def install(module) -> list[FakeBar]:
        bars: list[FakeBar] = []
        monkeypatch.setattr(
            module, "progress", lambda *a, **k: bars.append(FakeBar(*a, **k)) or bars[-1]
        )
        return bars

    return install


def _session_processes(sid: int) -> list[str]:
    """The processes (any state, zombies too) of session ``sid``: "pid state command"."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            text = stat.read_text()
        except OSError:  # ended meanwhile
            continue
        name, rest = text[text.index("(") + 1 : text.rindex(")")], text[text.rindex(")") + 2 :]
        if int(rest.split()[3]) == sid:  # state ppid pgrp session ...
            found.append(f"{stat.parent.name} {rest.split()[0]} {name}")
    return found


@pytest.fixture
def session_processes():
    """``f(sid)``: what is left of a command run with ``start_new_session`` (Linux /proc)."""
    if not Path("/proc/self/stat").is_file():
        pytest.skip("needs Linux's /proc to list a session's processes")
    return _session_processes
