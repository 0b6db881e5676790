"""Atomic writes: a file or a folder appears complete under its name, or not at all.

Both are written next to their target (same file system) and renamed into place;
on failure the temporary is removed and an existing target is left as it was.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from dexlfd.errors import InvalidFile

__all__ = ["atomic_folder", "atomic_write"]


def _folder_of(path: Path) -> Path:
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise InvalidFile(f"cannot write {path}: folder {folder} does not exist")
    return folder


def atomic_write(path: Path, write: Any) -> None:
    """Call ``write(fileobj)`` on a temporary file next to ``path``, then rename it."""
    path = Path(path)
    folder = _folder_of(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    try:
        # mkstemp makes 0600 files; give the result the usual umask-based mode
        umask = os.umask(0)
        os.umask(umask)
        os.fchmod(fd, 0o666 & ~umask)
        with os.fdopen(fd, "wb") as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


@contextmanager
def atomic_folder(path: Path) -> Iterator[Path]:
    """Yield a new temporary folder (not yet created) named like ``path``; rename it on success.

    The caller fills the yielded path (creating it); when the block ends without an
    exception it replaces ``path``, which must not exist or be an empty folder. An
    :class:`OSError` becomes :class:`~dexlfd.errors.InvalidFile` naming ``path``.
    """
    path = Path(path)
    tmp_root = Path(tempfile.mkdtemp(prefix=f".{path.name}.", dir=_folder_of(path)))
    try:
        yield tmp_root / path.name
        if path.is_dir():
            path.rmdir()  # empty (else OSError)
        os.replace(tmp_root / path.name, path)
    except OSError as exc:
        raise InvalidFile(f"cannot write {path}: {exc.strerror or exc}") from exc
    finally:
        shutil.rmtree(tmp_root, ignore_errors=True)
