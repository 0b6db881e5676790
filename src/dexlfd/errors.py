"""Exceptions raised by dexlfd.

Every error a user can cause derives from :class:`DexlfdError`, so the CLI can
print it as one line and exit with status 1.
"""

from __future__ import annotations

from pathlib import Path

__all__ = [
    "DependencyNotInstalled",
    "DexlfdError",
    "InvalidDemonstration",
    "InvalidFile",
    "InvalidInput",
    "SimulationDiverged",
    "SourceError",
    "broken_import",
    "import_culprit",
]


class DexlfdError(Exception):
    """Base class of every error dexlfd raises on purpose.

    ``param`` names the setting at fault (a config field such as ``"margin"``, or an
    argument such as ``"pick"``); the command line shows the flag that sets it instead.
    """

    def __init__(self, *args: object, param: str | None = None) -> None:
        super().__init__(*args)
        self.param = param


class InvalidInput(DexlfdError, ValueError):
    """An argument has the wrong shape, type, range or contains NaN/inf."""


class InvalidDemonstration(InvalidInput):
    """A demonstration cannot be used for learning (too short, empty, ...)."""


class InvalidFile(DexlfdError):
    """A file is missing, truncated, foreign, or breaks its contract."""


class SourceError(DexlfdError):
    """A capture source (video file, camera, recording) cannot be opened or read."""


class SimulationDiverged(DexlfdError):
    """The simulated or real robot stopped: non-finite state or a limit exceeded."""


class DependencyNotInstalled(DexlfdError, ImportError):
    """An optional dependency is missing; the message says how to install it.

    ``extra`` names the dexlfd extra that installs it (``pip install 'dexlfd[EXTRA]'``,
    see :mod:`dexlfd._extras`); without one the package itself is named.
    """

    def __init__(self, package: str, purpose: str, *, extra: str | None = None) -> None:
        if extra is not None:
            how = f"the optional package '{package}': pip install 'dexlfd[{extra}]'"
        else:
            how = f"the Python package '{package}': pip install '{package}'"
        super().__init__(f"{purpose} needs {how}")
        self.package = package
        self.extra = extra


def import_culprit(exc: ImportError) -> str:
    """The top-level package an ImportError is about ("" when it cannot be told).

    ``exc.name`` when Python set it, else the innermost frame of the traceback that is
    inside an installed package (``.../site-packages/cv2/__init__.py`` -> ``cv2``).
    """
    if exc.name:
        return exc.name.split(".")[0]
    culprit = ""
    tb = exc.__traceback__
    while tb is not None:
        parts = Path(tb.tb_frame.f_code.co_filename).parts
        for marker in ("site-packages", "dist-packages"):
            if marker in parts and parts.index(marker) + 1 < len(parts):
                culprit = Path(parts[parts.index(marker) + 1]).stem
        tb = tb.tb_next
    return culprit


def broken_import(exc: ImportError) -> str:
    """One line for an installed package that cannot be imported, and how to repair it."""
    top = import_culprit(exc)
    if top == "cv2":
        return (
            f"OpenCV (cv2) cannot be imported ({exc}): reinstall it with "
            "pip install --force-reinstall opencv-contrib-python (one cv2 package per "
            "environment: uninstall any other opencv-* first)"
        )
    return (
        f"the Python package {top!r} cannot be imported ({exc}): reinstall it "
        f"(pip install --force-reinstall {top})"
    )
