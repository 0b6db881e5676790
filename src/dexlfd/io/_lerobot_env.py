"""The ``lerobot`` package in its own cached virtual environment, to check our datasets.

LeRobot (0.4.4, the last release for Python 3.11; 0.5+ needs Python 3.12) needs
torch and torchvision and pins numpy < 2.3 and torch < 2.11, which clash with
dexlfd's stack, so it lives in a separate environment created once per machine
under :func:`default_lerobot_root` (``~/.cache/dexlfd/lerobot``, outside any
checkout; :func:`ensure_lerobot_venv`, ``make lerobot-env``); :func:`load_with_lerobot`
runs ``LeRobotDataset(repo_id, root=DIR)`` there and returns what it read as
JSON. Only the tests and benchmarks use it: dexlfd reads and writes the format
itself (:mod:`dexlfd.io.lerobot`).

torch 2.14.1 + torchvision 0.29.1 are installed first (pip takes them from the
machine's local wheel store; PyPI's torchvision does not import beside the local
torch 2.13.0 CPU wheel), then ``lerobot`` without its dependency pins (it asks
for torch < 2.11), then the packages its dataset code imports. About 6 GB.
Its video decoding does not run there: the ``pyav`` backend calls
``torchvision.io.VideoReader`` (gone in torchvision 0.29) and ``torchcodec``
needs the system's FFmpeg libraries; datasets with videos are checked with
OpenCV instead.
"""

from __future__ import annotations

import json
import logging
import os
import subprocess
from pathlib import Path
from typing import Any

from dexlfd._venv import ensure_venv
from dexlfd.errors import DexlfdError

__all__ = [
    "LEROBOT_REQUIREMENT",
    "LeRobotUnavailable",
    "default_lerobot_root",
    "ensure_lerobot_venv",
    "lerobot_python",
    "load_with_lerobot",
]

logger = logging.getLogger(__name__)

LEROBOT_REQUIREMENT = "lerobot==0.4.4"
TORCH_REQUIREMENTS = ("torch==2.14.1", "torchvision==0.29.1")
DATASET_REQUIREMENTS = (  # what lerobot.datasets imports (lerobot 0.4.4's own ranges)
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
)
LOADER = Path(__file__).with_name("_lerobot_loader.py")


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


def lerobot_python(root: Path) -> Path:
    """Python of the cached LeRobot environment under ``root`` (keyed by version)."""
    return Path(root) / LEROBOT_REQUIREMENT.replace("==", "-") / "bin" / "python"


def ensure_lerobot_venv(
    root: Path, *, base_python: str | None = None, timeout_s: float = 3600.0
) -> Path:
    """Create (once) the virtual environment with ``lerobot`` and return its Python.

    Parameters
    ----------
    root : Path
        Cache folder (:func:`default_lerobot_root`); the environment is
        ``root/lerobot-<version>/``, marked complete by a ``.installed`` file.
    base_python : str or None
        Interpreter used to create it (Python 3.11); default: this one's base.
    timeout_s : float
        Limit for each install step [s].

    Raises
    ------
    LeRobotUnavailable
        If ``venv`` or a ``pip install`` fails; the message ends with pip's last lines.
    """
    return ensure_venv(
        lerobot_python(root),
        [TORCH_REQUIREMENTS, ["--no-deps", LEROBOT_REQUIREMENT], DATASET_REQUIREMENTS],
        what=f"LeRobot ({LEROBOT_REQUIREMENT}, ~6 GB)",
        error=LeRobotUnavailable,
        base_python=base_python,
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
