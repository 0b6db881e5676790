"""Helpers shared by subcommands: output folders, progress bars, seeds."""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from dexlfd.errors import InvalidInput

__all__ = ["ensure_output_dir", "progress"]


def ensure_output_dir(path: str | os.PathLike[str], arg: str = "-o/--output") -> Path:
    """Create ``path`` (and parents) and check it is writable; name ``arg`` on failure."""
    out = Path(path)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InvalidInput(f"{arg}: cannot create folder {out}: {exc.strerror or exc}") from exc
    if not os.access(out, os.W_OK):
        raise InvalidInput(f"{arg}: folder {out} is not writable")
    return out


def progress(total: int | None, desc: str, *, quiet: bool = False) -> Any:
    """A tqdm bar on stderr, disabled when stderr is not a terminal or ``quiet``."""
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, disable=quiet or not sys.stderr.isatty(), leave=False)


def tick_callback(bar: Any) -> Callable[[int, float], None]:
    """Adapt a tqdm bar to the library's ``callback(i, value)`` convention."""

    def _cb(i: int, value: float) -> None:
        bar.update(1)

    return _cb
