"""Which lerobot release the LeRobot check builds, from which Python, and why."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from dexlfd.io._lerobot_env import (
    RECIPES,
    LeRobotUnavailable,
    choose_lerobot,
    ensure_lerobot_venv,
    lerobot_python,
)


def test_a_python_312_found_under_pyenv_builds_the_current_release(
    pythons: Path, fake_python
) -> None:
    fake_python(pythons / "pyenv/versions/3.11.7/bin/python", "echo 3 11")
    py312 = fake_python(pythons / "pyenv/versions/3.12.1/bin/python", "echo 3 12")
    choice = choose_lerobot()
    assert choice.recipe is RECIPES["0.6.1"] and choice.python == str(py312)
    assert choice.reason == f"Python 3.12 under {pythons / 'pyenv/versions'}"
    assert choice.recipe.decodes_video
    root = pythons / "cache"
    assert lerobot_python(root) == root / "lerobot-0.6.1/bin/python"


def test_without_python_312_the_311_release_is_built(pythons: Path, fake_python) -> None:
    fake_python(pythons / "bin/python3.12", "exit 1")  # cannot create environments
    choice = choose_lerobot()
    assert choice.recipe is RECIPES["0.4.4"] and not choice.recipe.decodes_video
    assert choice.reason.startswith("no Python 3.12-3.13 that can create environments found")
    assert lerobot_python(pythons) == pythons / "lerobot-0.4.4/bin/python"


def test_the_given_interpreter_decides(
    pythons: Path, fake_python, monkeypatch: pytest.MonkeyPatch
) -> None:
    fake_python(pythons / "bin/python3.12", "echo 3 12")
    py311 = fake_python(pythons / "old/python", "echo 3 11")
    monkeypatch.setenv("DEXLFD_LEROBOT_PYTHON", str(py311))
    choice = choose_lerobot()
    assert (choice.recipe.version, choice.python) == ("0.4.4", str(py311))
    assert choice.reason == "$DEXLFD_LEROBOT_PYTHON interpreter is Python 3.11"
    py313 = fake_python(pythons / "new/python", "echo 3 13")
    assert choose_lerobot(str(py313)).recipe.version == "0.6.1"  # the argument first
    with pytest.raises(LeRobotUnavailable, match=r"is Python 3\.10; expected Python 3\.11"):
        choose_lerobot(str(fake_python(pythons / "older/python", "echo 3 10")))
    with pytest.raises(LeRobotUnavailable, match=r"is Python 3\.14; the LeRobot recipes are "):
        choose_lerobot(str(fake_python(pythons / "newer/python", "echo 3 14")))
    monkeypatch.setenv("DEXLFD_LEROBOT_PYTHON", str(pythons / "nowhere/python"))
    with pytest.raises(LeRobotUnavailable, match="does not run or cannot create"):
        choose_lerobot()


def test_a_built_environment_is_reused_and_the_choice_logged(
    pythons: Path, fake_python, caplog: pytest.LogCaptureFixture
) -> None:
    py312 = fake_python(pythons / "pyenv/versions/3.12.1/bin/python", "echo 3 12")
    env = pythons / "cache/lerobot-0.6.1"
    fake_python(env / "bin/python", "exit 1")
    (env / ".installed").write_text("done\n")
    with caplog.at_level(logging.INFO, logger="dexlfd"):
        assert ensure_lerobot_venv(pythons / "cache") == env / "bin/python"  # nothing installed
    assert f"LeRobot 0.6.1 from {py312} (Python 3.12 under" in caplog.text
    assert (env / ".installed").read_text() == "done\n"
