"""Finding a newer Python on the machine: PATH and pyenv, each candidate run once."""

from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from dexlfd import _interpreters
from dexlfd._interpreters import find_python, interpreter_version, pyenv_pythons


def test_the_version_is_read_by_running_the_interpreter(tmp_path: Path, fake_python) -> None:
    assert interpreter_version(sys.executable) == sys.version_info[:2]
    assert interpreter_version(str(fake_python(tmp_path / "p", "echo 3 12"))) == (3, 12)
    assert interpreter_version(str(fake_python(tmp_path / "q", "exit 1"))) is None  # no venv
    assert interpreter_version(str(tmp_path / "missing")) is None


def test_pyenv_versions_are_listed_oldest_first(pythons: Path, fake_python) -> None:
    for name in ("3.13.0", "3.12.1", "3.11.7", "3.12-dev", "3.13.0t", "pypy3.10-7.3.12"):
        fake_python(pythons / "pyenv/versions" / name / "bin/python", "echo 3 12")
    (pythons / "pyenv/versions/3.14.0").mkdir()  # no interpreter in it
    versions = pythons / "pyenv/versions"
    assert pyenv_pythons((3, 12)) == [
        versions / "3.12.1/bin/python",
        versions / "3.13.0/bin/python",
    ]


def test_path_comes_before_pyenv_and_broken_candidates_are_passed_over(
    pythons: Path, fake_python
) -> None:
    fake_python(pythons / "pyenv/versions/3.12.1/bin/python", "echo 3 12")
    found = find_python((3, 12))
    assert found is not None and found.version == (3, 12)
    assert found.path == str(pythons / "pyenv/versions/3.12.1/bin/python")
    assert found.origin == f"under {pythons / 'pyenv/versions'}"
    fake_python(pythons / "bin/python3.13", "echo 3 13")
    fake_python(pythons / "bin/python3.12", "exit 1")  # e.g. Debian's without python3-venv
    found = find_python((3, 12))
    assert found is not None and (found.path, found.version, found.origin) == (
        str(pythons / "bin/python3.13"),
        (3, 13),
        "on PATH",
    )


def test_none_found_and_the_running_interpreter_first(
    pythons: Path, fake_python, monkeypatch: pytest.MonkeyPatch
) -> None:
    fake_python(pythons / "bin/python3.12", "echo 3 11")  # lies about its name
    fake_python(pythons / "pyenv/versions/3.11.7/bin/python", "echo 3 11")
    assert find_python((3, 12)) is None
    # the running interpreter comes first, and is probed like every other candidate
    me = pythons / "opt/py312/bin/python3"
    running = SimpleNamespace(version_info=(3, 12, 4), executable=str(me))
    monkeypatch.setattr(_interpreters, "sys", running)
    assert find_python((3, 12)) is None  # it does not run (yet)
    fake_python(me, "echo 3 12")
    found = find_python((3, 12))
    assert found is not None
    assert (found.path, found.version, found.origin) == (str(me), (3, 12), "running dexlfd")
