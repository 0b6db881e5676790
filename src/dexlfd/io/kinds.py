"""Which contract a dexlfd ``.npz`` file holds, and loading it by that kind."""

from __future__ import annotations

import json
import os
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

from dexlfd.errors import InvalidFile
from dexlfd.io._gate import ZIP_READ_ERRORS, check_zip_members, zip_member
from dexlfd.io._record import Record
from dexlfd.io.demonstration import load_demonstration
from dexlfd.io.model import load_model
from dexlfd.io.plan import load_plan
from dexlfd.io.rollout import load_rollout

__all__ = ["LOADERS", "kind_of", "load_any"]

LOADERS: dict[str, Callable[[str | os.PathLike[str]], Record]] = {
    "demonstration": load_demonstration,
    "model": load_model,
    "plan": load_plan,
    "rollout": load_rollout,
}


def kind_of(path: str | os.PathLike[str]) -> str:
    """The ``kind`` in the file's ``meta`` (one of :data:`LOADERS`); raises InvalidFile."""
    path = Path(path)
    if not path.is_file():
        raise InvalidFile(f"{path}: no such file")
    try:
        with open(path, "rb") as fh, zipfile.ZipFile(fh) as zf:
            check_zip_members(zf, str(path))  # encrypted, unreadable compression: one line
            if zf.getinfo("meta.npy").file_size > 16 * 1024**2:
                raise ValueError("meta larger than 16 MiB")
            with zip_member(str(path), "meta.npy"), zf.open("meta.npy") as member:
                meta = json.loads(str(np.lib.format.read_array(member, allow_pickle=False)))
        kind = meta.get("kind") if isinstance(meta, dict) else None
    except (*ZIP_READ_ERRORS, KeyError, TypeError, RecursionError) as exc:
        raise InvalidFile(f"{path}: not a dexlfd file ({type(exc).__name__})") from exc
    if kind not in LOADERS:
        raise InvalidFile(f"{path}: unknown kind {kind!r}; expected one of {sorted(LOADERS)}")
    return str(kind)


def load_any(path: str | os.PathLike[str]) -> Record:
    """Load and check a dexlfd file of any kind; raises InvalidFile."""
    return LOADERS[kind_of(path)](path)
