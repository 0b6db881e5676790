"""Finding a Python interpreter of a given minimum version on this machine.

A tool we test against may need a newer Python than dexlfd runs on (lerobot 0.5+
needs 3.12). Its cached environment (:mod:`dexlfd._venv`) is then created from
another interpreter: the running one if it is new enough, else ``pythonX.Y`` on
``PATH``, else one installed by pyenv (``$PYENV_ROOT/versions/X.Y.Z``, default
``~/.pyenv``). Each candidate is run once to read its version and to check that it
can create a virtual environment (``venv`` and ``ensurepip``; Debian ships those
separately).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Interpreter", "find_python", "interpreter_version", "pyenv_pythons", "pyenv_root"]

# prints "MAJOR MINOR" only where venv + ensurepip import (a venv with pip can be made)
_PROBE = "import sys, venv, ensurepip; print(*sys.version_info[:2])"
_PYENV_VERSION = re.compile(r"^(\d+)\.(\d+)\.\d+$")  # CPython releases only (no -dev, t, pypy)


@dataclass(frozen=True, slots=True)
class Interpreter:
    """A Python found on the machine: its path, version and where it was found."""

    path: str
    version: tuple[int, int]
    origin: str  # e.g. "on PATH", "under ~/.pyenv/versions"


def interpreter_version(path: str, *, timeout_s: float = 20.0) -> tuple[int, int] | None:
    """``(major, minor)`` of the interpreter ``path``; None if it does not run or lacks venv."""
    try:
        out = subprocess.run(
            [path, "-I", "-c", _PROBE], capture_output=True, text=True, timeout=timeout_s
        )
    except (OSError, subprocess.TimeoutExpired):
        return None
    parts = out.stdout.split()
    if out.returncode != 0 or len(parts) != 2 or not all(p.isdigit() for p in parts):
        return None
    return int(parts[0]), int(parts[1])


def pyenv_root() -> Path:
    """The folder pyenv installs into: ``$PYENV_ROOT``, default ``~/.pyenv``."""
    return Path(os.environ.get("PYENV_ROOT") or Path.home() / ".pyenv")


def pyenv_pythons(minimum: tuple[int, int]) -> list[Path]:
    """The CPython interpreters pyenv installed, of at least ``minimum``, oldest first (not run)."""
    found: list[tuple[tuple[int, int], Path]] = []
    versions = pyenv_root() / "versions"
    if not versions.is_dir():
        return []
    for folder in versions.iterdir():
        match = _PYENV_VERSION.match(folder.name)
        python = folder / "bin" / "python"
        if match and python.is_file():
            version = (int(match[1]), int(match[2]))
            if version >= minimum:
                found.append((version, python))
    return [p for _, p in sorted(found)]


def find_python(
    minimum: tuple[int, int], *, newest: tuple[int, int] = (3, 13)
) -> Interpreter | None:
    """An interpreter of version ``minimum`` .. ``newest`` that can create environments.

    Looks at, in order: the running interpreter; ``python3.M`` on ``PATH`` for each
    minor version from ``minimum`` to ``newest`` (oldest first); pyenv's versions
    (``$PYENV_ROOT/versions``, default ``~/.pyenv/versions``; oldest first). The
    oldest suitable minor version is preferred because the pins of a recipe are
    verified on it.

    Returns
    -------
    Interpreter or None
        The first candidate that runs, has ``venv`` and ``ensurepip``, and whose
        version is in range; None if there is none.
    """
    candidates: list[tuple[str, str]] = []
    if minimum <= sys.version_info[:2] <= newest:
        base = getattr(sys, "_base_executable", None) or sys.executable
        candidates.append((base, "running dexlfd"))
    for minor in range(minimum[1], newest[1] + 1):
        path = shutil.which(f"python{minimum[0]}.{minor}")
        if path:
            candidates.append((path, "on PATH"))
    where = f"under {pyenv_root() / 'versions'}"
    candidates += [(str(p), where) for p in pyenv_pythons(minimum)]
    for path, origin in candidates:
        version = interpreter_version(path)
        if version is not None and minimum <= version <= newest:
            return Interpreter(path, version, origin)
    return None
