"""Helpers shared by subcommands: output folders, progress bars, seeds."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from dexlfd.errors import InvalidInput

__all__ = ["ensure_output_dir", "nonnegative_int", "output_file", "positive_int", "progress"]


def ensure_output_dir(path: str | os.PathLike[str], arg: str = "-o/--output") -> Path:
    """Create ``path`` (and parents) and check it is writable; name ``arg`` on failure."""
    out = Path(path)
    for parent in (out, *out.parents):
        if parent.exists() and not parent.is_dir():
            raise InvalidInput(f"{arg}: cannot create folder {out}: {parent} is a file")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InvalidInput(f"{arg}: cannot create folder {out}: {exc.strerror or exc}") from exc
    if not os.access(out, os.W_OK):
        raise InvalidInput(f"{arg}: folder {out} is not writable")
    return out


def output_file(path: str | os.PathLike[str], arg: str, suffix: str | None = None) -> Path:
    """Check an output file can be created (its folder exists and is writable).

    With ``suffix`` (e.g. ``".mp4"``) the name must end in it: the file is written
    in that format whatever its name says, so a ``.avi`` name would mislead.
    """
    out = Path(path)
    if suffix is not None and out.suffix.lower() != suffix:
        raise InvalidInput(f"{arg}: {out} must end in {suffix} (that is the format written)")
    folder = out.parent if str(out.parent) else Path(".")
    if folder.exists() and not folder.is_dir():
        raise InvalidInput(f"{arg}: cannot write {out}: {folder} is a file, not a folder")
    if not folder.is_dir():
        raise InvalidInput(f"{arg}: cannot write {out}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK):
        raise InvalidInput(f"{arg}: cannot write {out}: folder {folder} is not writable")
    if out.is_dir():
        raise InvalidInput(f"{arg}: {out} is a folder; expected a file name")
    return out


def nonnegative_int(text: str) -> int:
    """Argparse type: an integer >= 0 (seeds, counts)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {value}")
    return value


def positive_int(text: str) -> int:
    """Argparse type: an integer > 0 (sizes in pixels, frame counts)."""
    value = nonnegative_int(text)
    if value == 0:
        raise argparse.ArgumentTypeError("expected an integer > 0, got 0")
    return value


def progress(total: int | None, desc: str, *, quiet: bool = False) -> Any:
    """A tqdm bar on stderr, disabled when stderr is not a terminal or ``quiet``."""
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, disable=quiet or not sys.stderr.isatty(), leave=False)


def tick_callback(bar: Any) -> Callable[[int, float], None]:
    """Adapt a tqdm bar to the library's ``callback(i, value)`` convention."""

    def _cb(i: int, value: float) -> None:
        bar.update(1)

    return _cb
