"""Exceptions raised by dexlfd.

Every error a user can cause derives from :class:`DexlfdError`, so the CLI can
print it as one line and exit with status 1.
"""

from __future__ import annotations

__all__ = [
    "DependencyNotInstalled",
    "DexlfdError",
    "InvalidDemonstration",
    "InvalidFile",
    "InvalidInput",
    "SimulationDiverged",
    "SourceError",
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
