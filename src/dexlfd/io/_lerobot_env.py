"""The ``lerobot`` package in its own cached virtual environment, to check our datasets.

LeRobot needs torch and torchvision and pins numpy < 2.3 and torch < 2.12, which
clash with dexlfd's stack, so it lives in a separate environment created once per
machine under :func:`default_lerobot_root` (``~/.cache/dexlfd/lerobot``, outside any
checkout; :func:`ensure_lerobot_venv`, ``make lerobot-env``), one folder per
release (``lerobot-0.6.1``); :func:`load_with_lerobot` runs
``LeRobotDataset(repo_id, root=DIR)`` there and returns what it read as JSON. Only
the tests and benchmarks use it: dexlfd reads and writes the format itself
(:mod:`dexlfd.io.lerobot`).

Two recipes (:data:`RECIPES`); :func:`choose_lerobot` takes the first whose
Python is found:

``0.6.1`` (the current release; Python >= 3.12)
    Created from ``$DEXLFD_LEROBOT_PYTHON`` if set, else a Python 3.12 or 3.13 found
    by :func:`dexlfd._interpreters.find_python` (the running one, ``python3.12`` /
    ``python3.13`` on ``PATH``, pyenv's ``~/.pyenv/versions/3.1x.y``). torch 2.11.0
    and torchvision 0.26.0 first (on Linux x86_64 PyPI has only CUDA builds; with
    their ``nvidia-*`` packages they run on the CPU too), then ``lerobot`` without
    its dependencies (they include cmake, setuptools, opencv and termcolor, and its
    ``dataset`` extra torchcodec and jsonlines, none of which loading a dataset
    imports), then exactly the packages ``lerobot.datasets`` imports. 5.2 GB (2.7 GB
    of it CUDA libraries); 135 s to build on a 2-core machine.
    Its video decoding runs here: without torchcodec (which needs the system's
    FFmpeg libraries) lerobot falls back to its ``pyav`` backend, which in 0.6.1
    decodes with PyAV itself (PyAV's wheel ships FFmpeg), so the loader also returns
    the decoded frames of a dataset's videos.
``0.4.4`` (the last release for Python 3.11; the fallback)
    Created from this interpreter's base. torch 2.14.1 + torchvision 0.29.1 first
    (pip takes torch from the machine's local wheel store where there is one),
    then ``lerobot`` without its dependency pins (it asks for torch < 2.11), then
    the packages its dataset code imports. About 6 GB. Its video decoding does not
    run there: the ``pyav`` backend calls ``torchvision.io.VideoReader`` (gone in
    torchvision 0.29) and ``torchcodec`` needs the system's FFmpeg libraries;
    datasets with videos are checked with OpenCV instead.
"""

from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dexlfd._interpreters import find_python, interpreter_version, pyenv_root
from dexlfd._venv import ensure_venv
from dexlfd.errors import DexlfdError

__all__ = [
    "RECIPES",
    "LeRobotChoice",
    "LeRobotRecipe",
    "LeRobotUnavailable",
    "choose_lerobot",
    "default_lerobot_root",
    "ensure_lerobot_venv",
    "lerobot_python",
    "load_with_lerobot",
]

logger = logging.getLogger(__name__)

PYTHON_ENV = "DEXLFD_LEROBOT_PYTHON"  # interpreter to create the environment from
NEWEST_PYTHON = (3, 13)  # the newest Python searched for (torch 2.11 has wheels up to it)
LOADER = Path(__file__).with_name("_lerobot_loader.py")


@dataclass(frozen=True, slots=True)
class LeRobotRecipe:
    """How one lerobot release is installed, and what of it works there."""

    version: str
    python: tuple[int, int]  # the oldest Python it installs on
    installs: tuple[tuple[str, ...], ...]  # arguments of each ``pip install`` step
    size: str  # of the built environment, for the log
    decodes_video: bool  # lerobot's own video decoding runs in the environment

    @property
    def folder(self) -> str:
        """Name of the environment's folder under the cache root."""
        return f"lerobot-{self.version}"


RECIPES = {
    "0.6.1": LeRobotRecipe(
        version="0.6.1",
        python=(3, 12),
        installs=(
            ("torch==2.11.0", "torchvision==0.26.0"),
            ("--no-deps", "lerobot==0.6.1"),
            (  # what lerobot.datasets imports (exact; their own dependencies resolved by pip)
                "av==15.1.0",
                "datasets==4.8.5",
                "draccus==0.11.6",
                "einops==0.8.2",
                "gymnasium==1.4.0",
                "huggingface-hub==1.33.0",
                "numpy==2.2.6",
                "packaging==25.0",
                "pandas==2.3.3",
                "pillow==12.3.0",
                "pyarrow==26.0.1",
                "requests==2.34.2",
                "safetensors==0.8.0",
                "tqdm==4.70.1",
            ),
        ),
        size="5.2 GB",
        decodes_video=True,
    ),
    "0.4.4": LeRobotRecipe(
        version="0.4.4",
        python=(3, 11),
        installs=(
            ("torch==2.14.1", "torchvision==0.29.1"),
            ("--no-deps", "lerobot==0.4.4"),
            (  # what lerobot.datasets imports (lerobot 0.4.4's own ranges)
                "datasets>=4.0,<5",
                "huggingface-hub>=0.34.2,<0.36",
                "av>=15,<16",
                "draccus==0.10.0",
                "jsonlines>=4,<5",
                "packaging>=24.2,<26",
                "deepdiff>=7,<9",
                "einops>=0.8,<0.9",
                "termcolor>=2.4,<4",
                "accelerate>=1.10,<2",
            ),
        ),
        size="~6 GB",
        decodes_video=False,
    ),
}
CURRENT, FALLBACK = RECIPES["0.6.1"], RECIPES["0.4.4"]


@dataclass(frozen=True, slots=True)
class LeRobotChoice:
    """The recipe this machine can build, the interpreter that builds it, and why."""

    recipe: LeRobotRecipe
    python: str
    reason: str


class LeRobotUnavailable(DexlfdError):
    """The LeRobot environment cannot be created, or its loader failed."""


def default_lerobot_root() -> Path:
    """Cache folder of the LeRobot environment, shared by every checkout on the machine.

    ``$DEXLFD_LEROBOT_ENV`` if set, else ``$XDG_CACHE_HOME/dexlfd/lerobot``
    (``~/.cache/dexlfd/lerobot``).
    """
    if os.environ.get("DEXLFD_LEROBOT_ENV"):
        return Path(os.environ["DEXLFD_LEROBOT_ENV"])
    cache = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(cache) / "dexlfd" / "lerobot"


def choose_lerobot(base_python: str | None = None) -> LeRobotChoice:
    """The newest recipe of :data:`RECIPES` whose Python is on this machine.

    Parameters
    ----------
    base_python : str or None
        Interpreter to build with; default ``$DEXLFD_LEROBOT_PYTHON``. Its version
        picks the recipe (>= 3.12: lerobot 0.6.1; 3.11: 0.4.4). Without either, a
        Python 3.12 or 3.13 is searched (:func:`dexlfd._interpreters.find_python`);
        if there is none, lerobot 0.4.4 is built from this interpreter's base.

    Raises
    ------
    LeRobotUnavailable
        If the given interpreter does not run, cannot create a virtual environment,
        or is older than Python 3.11.
    """
    explicit = base_python or os.environ.get(PYTHON_ENV)
    if explicit:
        said = "given" if base_python else f"${PYTHON_ENV}"
        version = interpreter_version(explicit)
        if version is None:
            raise LeRobotUnavailable(
                f"{said} interpreter {explicit} does not run or cannot create a virtual "
                "environment (expected a Python with venv and ensurepip)"
            )
        if version > NEWEST_PYTHON:
            raise LeRobotUnavailable(
                f"{said} interpreter {explicit} is Python {version[0]}.{version[1]}; the "
                f"LeRobot recipes are checked up to Python {NEWEST_PYTHON[0]}.{NEWEST_PYTHON[1]}"
            )
        for recipe in RECIPES.values():
            if version >= recipe.python:
                why = f"{said} interpreter is Python {version[0]}.{version[1]}"
                return LeRobotChoice(recipe, explicit, why)
        raise LeRobotUnavailable(
            f"{said} interpreter {explicit} is Python {version[0]}.{version[1]}; "
            f"expected Python {FALLBACK.python[0]}.{FALLBACK.python[1]} or newer"
        )
    found = find_python(CURRENT.python, newest=NEWEST_PYTHON)
    if found is not None:
        why = f"Python {found.version[0]}.{found.version[1]} {found.origin}"
        return LeRobotChoice(CURRENT, found.path, why)
    base = getattr(sys, "_base_executable", None) or sys.executable
    lo, hi = CURRENT.python, NEWEST_PYTHON
    why = (
        f"no Python {lo[0]}.{lo[1]}-{hi[0]}.{hi[1]} that can create environments found "
        f"(${PYTHON_ENV} unset; looked on PATH and under {pyenv_root() / 'versions'}) "
        f"for lerobot {CURRENT.version}"
    )
    return LeRobotChoice(FALLBACK, base, why)


def lerobot_python(root: Path, recipe: LeRobotRecipe | None = None) -> Path:
    """Python of the cached environment of ``recipe`` (default: :func:`choose_lerobot`'s)."""
    recipe = recipe or choose_lerobot().recipe
    return Path(root) / recipe.folder / "bin" / "python"


def ensure_lerobot_venv(
    root: Path, *, base_python: str | None = None, timeout_s: float = 3600.0
) -> Path:
    """Create (once) the virtual environment with ``lerobot`` and return its Python.

    The release is :func:`choose_lerobot`'s (logged with the reason).

    Parameters
    ----------
    root : Path
        Cache folder (:func:`default_lerobot_root`); the environment is
        ``root/lerobot-<version>/``, marked complete by a ``.installed`` file.
    base_python : str or None
        Interpreter used to create it (:func:`choose_lerobot`).
    timeout_s : float
        Limit for each install step [s].

    Raises
    ------
    LeRobotUnavailable
        If ``venv`` or a ``pip install`` fails; the message ends with pip's last lines.
    """
    choice = choose_lerobot(base_python)
    recipe = choice.recipe
    logger.info("LeRobot %s from %s (%s)", recipe.version, choice.python, choice.reason)
    return ensure_venv(
        lerobot_python(root, recipe),
        [list(step) for step in recipe.installs],
        what=f"LeRobot (lerobot=={recipe.version}, {recipe.size})",
        error=LeRobotUnavailable,
        base_python=choice.python,
        timeout_s=timeout_s,
    )


def load_with_lerobot(
    python: Path, dataset: Path, cache: Path, *, timeout_s: float = 900.0
) -> dict[str, Any]:
    """Open ``dataset`` with ``lerobot.datasets.LeRobotDataset`` in the environment of ``python``.

    ``cache`` receives Hugging Face's caches (``HF_HOME``); the hub is never
    contacted (``HF_HUB_OFFLINE=1``). Returns the loader's JSON (see
    ``_lerobot_loader.py``): fps, counts, tasks and every frame's features.
    """
    env = {**os.environ, "HF_HOME": str(cache), "HF_HUB_OFFLINE": "1", "HF_DATASETS_OFFLINE": "1"}
    env.pop("PYTHONPATH", None)
    cmd = [
        str(python),
        "-I",
        str(LOADER),
        str(dataset),
    ]  # -I: the loader's folder is not on the path
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s, env=env)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise LeRobotUnavailable(f"lerobot loader did not run: {exc}") from exc
    if out.returncode != 0:
        tail = "\n".join(out.stderr.strip().splitlines()[-8:])
        raise LeRobotUnavailable(f"lerobot could not load {dataset}:\n{tail}")
    result: dict[str, Any] = json.loads(out.stdout)
    return result
