"""Atomic writes: a file or a folder appears complete under its name, or not at all.

Both are written next to their target (same file system) and renamed into place;
on failure the temporary is removed and an existing target is left as it was.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import re
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from dexlfd.errors import InvalidFile

__all__ = [
    "PART_MARK",
    "atomic_folder",
    "atomic_write",
    "discard",
    "put_in_place",
    "remove_strays",
    "temp_file",
]

# Every temporary file or folder dexlfd writes next to a target is named
# ``.<target name>.<random>.dexlfd-part<suffix>``: recognisable, so the strays of a run
# that was killed before it could clean up are found and removed (:func:`remove_strays`).
PART_MARK = ".dexlfd-part"
_NAME_MAX = 255  # bytes of one path component on Linux/macOS file systems
_RANDOM = "[a-z0-9_]{8}"  # mkstemp's / mkdtemp's random part
# A live temporary is locked (flock) by the process writing it, until it is renamed into
# place or discarded: a temporary that can be locked is a stray of a run that was killed.
_held: dict[str, int] = {}


def _temp_affixes(path: Path, suffix: str) -> tuple[str, str]:
    """``mkstemp``'s prefix and suffix for ``path``, shortened to fit one path component.

    The target's name is cut (at a character boundary) so that the whole temporary name
    (prefix, mkstemp's 8 random characters, mark and suffix) stays within 255 bytes: a
    target whose own name is at the limit can still be written atomically.
    """
    tail = f"{PART_MARK}{suffix}"
    room = _NAME_MAX - len(os.fsencode(tail)) - 2 - 8  # the two dots and the random part
    name = path.name
    while len(os.fsencode(name)) > room:  # the bytes on disk (a name need not be UTF-8)
        name = name[:-1]
    return f".{name}.", tail


def temp_file(path: Path, suffix: str = "") -> Path:
    """Create (empty, with the usual umask-based mode) and return a temporary next to ``path``.

    ``suffix`` ends the name (e.g. ``".mp4"`` where a writer picks its format from it).
    """
    path = Path(path)
    prefix, tail = _temp_affixes(path, suffix)
    fd, tmp = tempfile.mkstemp(prefix=prefix, suffix=tail, dir=_folder_of(path))
    try:
        umask = os.umask(0)  # mkstemp makes 0600 files
        os.umask(umask)
        os.fchmod(fd, 0o666 & ~umask)
    except BaseException:
        os.close(fd)
        raise
    _hold(tmp, fd)
    return Path(tmp)


def _hold(tmp: str, fd: int) -> None:
    """Lock ``tmp`` (open as ``fd``) for this process until :func:`_release`."""
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:  # a file system without locks: the temporary is simply not held
        os.close(fd)
        return
    _held[os.fspath(tmp)] = fd


def _release(tmp: Path | str) -> None:
    fd = _held.pop(os.fspath(tmp), None)
    if fd is not None:
        os.close(fd)


def put_in_place(tmp: Path, path: Path) -> None:
    """Rename the finished temporary ``tmp`` to ``path``; remove ``path``'s strays.

    A stray is a temporary of the same target that no live process holds: what a run
    killed mid-write (SIGKILL, a power cut) left. Another run still writing the same
    target keeps its own.
    """
    os.replace(tmp, path)
    _release(tmp)
    remove_strays_of(path)


def discard(tmp: Path) -> None:
    """Remove the temporary ``tmp`` (a file) if it is there, and let it go."""
    try:
        Path(tmp).unlink(missing_ok=True)
    finally:
        _release(tmp)


def remove_strays_of(path: Path) -> list[Path]:
    """Remove the temporaries of ``path`` (file or folder) that no live process holds."""
    path = Path(path)
    prefix, _ = _temp_affixes(path, "")
    pattern = re.compile(re.escape(prefix) + _RANDOM + re.escape(PART_MARK) + ".*", re.DOTALL)
    try:
        names = os.listdir(path.parent)
    except OSError:
        return []
    strays = [path.parent / name for name in names if pattern.fullmatch(name)]
    return [stray for stray in strays if _remove_if_stray(stray)]


def _remove_if_stray(tmp: Path) -> bool:
    """Remove the temporary ``tmp`` unless a live process (this one or another) holds it."""
    if os.fspath(tmp) in _held or not _unheld(tmp):
        return False
    if tmp.is_dir() and not tmp.is_symlink():
        shutil.rmtree(tmp, ignore_errors=True)
    else:
        with contextlib.suppress(OSError):
            tmp.unlink()
    return True


def _unheld(path: Path) -> bool:
    """Whether no process holds ``path``'s lock (it can be taken now)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return False
    finally:
        os.close(fd)
    return True


def remove_strays(folder: Path) -> list[Path]:
    """Remove the temporaries that runs killed mid-write left under ``folder`` (recursively).

    Only names made by :func:`temp_file` / :func:`atomic_folder` are touched, and only
    those no live process holds. Returns what was removed.
    """
    strays = sorted(Path(folder).rglob(f".*{PART_MARK}*"))
    return [stray for stray in strays if _remove_if_stray(stray)]


def _folder_of(path: Path) -> Path:
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise InvalidFile(f"cannot write {path}: folder {folder} does not exist")
    return folder


def atomic_write(path: Path, write: Any) -> None:
    """Call ``write(fileobj)`` on a temporary file next to ``path``, then rename it.

    An :class:`OSError` (a full disk, a read-only folder) removes the temporary and
    becomes one :class:`~dexlfd.errors.InvalidFile` naming ``path``.
    """
    path = Path(path)
    try:
        tmp = temp_file(path)
    except OSError as exc:
        raise InvalidFile(f"cannot write {path}: {exc.strerror or exc}") from exc
    try:
        with open(tmp, "wb") as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        put_in_place(tmp, path)
    except OSError as exc:
        discard(tmp)
        raise InvalidFile(f"cannot write {path}: {exc.strerror or exc}") from exc
    except BaseException:
        discard(tmp)
        raise


@contextmanager
def atomic_folder(path: Path) -> Iterator[Path]:
    """Yield a new temporary folder (not yet created) named like ``path``; rename it on success.

    The caller fills the yielded path (creating it); when the block ends without an
    exception it replaces ``path``, which must not exist or be an empty folder. An
    :class:`OSError` becomes :class:`~dexlfd.errors.InvalidFile` naming ``path``.
    """
    path = Path(path)
    prefix, tail = _temp_affixes(path, "")
    tmp_root = Path(tempfile.mkdtemp(prefix=prefix, suffix=tail, dir=_folder_of(path)))
    _hold(os.fspath(tmp_root), os.open(tmp_root, os.O_RDONLY))
    try:
        yield tmp_root / path.name
        if path.is_dir():
            path.rmdir()  # empty (else OSError)
        os.replace(tmp_root / path.name, path)
    except OSError as exc:
        raise InvalidFile(f"cannot write {path}: {exc.strerror or exc}") from exc
    finally:
        shutil.rmtree(tmp_root, ignore_errors=True)
        _release(tmp_root)
    remove_strays_of(path)
