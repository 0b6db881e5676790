"""One output policy for every subcommand, checked before any work is done.

A subcommand names its outputs and inputs in one call::

    out, video = check_outputs(
        [("-o/--output", args.output, ".npz"), ("--video", args.video, ".mp4")],
        inputs=[args.plan],
    )

and gets back the checked paths (``None`` where a flag was not given). The rules:

- the name ends in the suffix of the format that is written (``.npz`` for an npz archive,
  ``.mp4`` for H.264 video, ``.png``, ``.csv``, ``.json``); ``DIR`` outputs are folders and
  must not carry a data file's suffix;
- an output is never an input of the same run (same file after resolving links and hard
  links: :func:`os.path.samefile`), and no two outputs of one run name the same file;
- the folder of an output file exists and is writable, and the output is not a folder.

Every input of the run counts, whichever flag named it: while :func:`dexlfd.cli.main`
runs a command it hands the parsed flags to :func:`guard_run`, and every later
:func:`check_outputs` call also compares its outputs with each file any other flag names
(``--intrinsics``, ``--board-pose``, ``--extrinsics``, ``--plan``, a model, both files of
a ``videos:TOP,SIDE`` source: :func:`source_files`), not only with the ``inputs`` it is
given. A new command gets this by calling :func:`check_outputs` for its outputs (the
``teach`` command does so like every other).

Files a command places by itself inside an output folder (``experiment payload -o ex/``
writes ``ex/payload_lift_z.png``) are checked by :func:`check_folder_files`: an existing
one is replaced only when a dexlfd run wrote it there and it is unchanged since (the
folder's :data:`LEDGER` holds the SHA-256 of each file written, :func:`record_written`),
or when ``--overwrite`` says so; a user's file of the same name is refused.

Existing outputs are replaced only atomically (the writers of :mod:`dexlfd.io` and
:mod:`dexlfd.viz` write a temporary file and rename it when the run succeeded), so a failed
run leaves the earlier file as it was. :func:`partial_path` picks where a run that stopped
early keeps its partial result without replacing a finished file of an earlier run.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import json
import os
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from dexlfd.errors import InvalidInput

__all__ = [
    "DIR",
    "LEDGER",
    "NEW_DIR",
    "check_folder_files",
    "check_outputs",
    "failed_run",
    "guard_run",
    "partial_path",
    "record_written",
    "source_files",
]

DIR = "DIR"  # the output is a folder, created if missing (figures, a run's files)
NEW_DIR = "NEW_DIR"  # the output is a folder that must not exist yet (a ROS 2 bag)

# suffix -> what is written under it (for the message)
FORMATS = {
    ".npz": "an .npz archive",
    ".mp4": "H.264 MP4 video",
    ".png": "a PNG image",
    ".csv": "CSV text",
    ".json": "JSON text",
}

Spec = tuple[str, "str | os.PathLike[str] | None", str | None]
LEDGER = ".dexlfd-outputs.json"  # in an output folder: name -> SHA-256 of what dexlfd wrote
_SOURCE_PAIRS = ("videos:",)  # SOURCE forms that name several files, comma-separated
_NOT_FLAGS = frozenset({"_run", "_params", "_auto_camera_pose", "command", "verbose", "quiet"})
# the running command's flags ("args"), output dests ("outputs"), folders it made ("made")
_run: dict[str, Any] = {}
# suffixes of files a new output folder is mistaken for (out.txt written as a bag); other
# dotted names (ds.v2, franka.pick, bag_2024.05) are folder names
_FILE_SUFFIXES = frozenset(
    (".txt", ".mcap", ".db3", ".bag", ".parquet", ".yaml", ".yml", ".zip", ".tar", ".gz",
     ".h5", ".hdf5", ".pkl", ".npy", ".mkv", ".avi", ".mov", ".jpg", ".jpeg")
)  # fmt: skip


def check_outputs(
    outputs: Sequence[Spec], inputs: Iterable[str | os.PathLike[str] | None] = ()
) -> list[Path | None]:
    """Check every output of one run against the policy; create ``DIR`` outputs.

    Parameters
    ----------
    outputs : sequence of (flag, path or None, suffix)
        ``suffix`` is the written format's (``".npz"``), :data:`DIR` for a folder,
        :data:`NEW_DIR` for a folder the run creates, or ``None`` for any file name.
    inputs : iterable of path-like or None
        The run's input files (``None`` and non-paths such as ``webcam:0`` are ignored).

    Returns
    -------
    list of Path or None
        The output paths, in order; ``None`` where the path was ``None``.

    Raises
    ------
    InvalidInput
        Naming the flag, the path and the rule broken.
    """
    given = [(flag, Path(path), kind) for flag, path, kind in outputs if path is not None]
    named = [f for p in inputs if p is not None for f in source_files(p)]
    sources = [Path(p) for p in (*named, *_flag_inputs(outputs)) if Path(p).exists()]
    for flag, out, kind in given:
        for src in sources:
            if out.exists() and _same(out, src):
                what = "the input" if out == src else f"the input {src} (the same file)"
                raise InvalidInput(f"{flag} {out} is {what}: refusing to overwrite an input")
        _check_suffix(flag, out, kind)
        if kind == DIR:
            _check_folder(flag, out)
        elif kind == NEW_DIR:
            if out.exists():
                raise InvalidInput(f"{flag} {out}: already exists; this output is a new folder")
            _check_file(flag, out)
        else:
            _check_file(flag, out)
    for i, (flag_a, a, _) in enumerate(given):
        for flag_b, b, _ in given[i + 1 :]:
            if _real(a) == _real(b) or (a.exists() and b.exists() and _same(a, b)):
                raise InvalidInput(
                    f"{flag_a} and {flag_b} both name {a}: one would overwrite the other"
                )
    for flag, out, kind in given:
        if kind == DIR:
            _make_folder(flag, out)
    by_flag = {flag: out for flag, out, _ in given}
    return [by_flag.get(flag) if path is not None else None for flag, path, _ in outputs]


@contextmanager
def guard_run(args: argparse.Namespace) -> Iterator[None]:
    """Every file a flag of ``args`` names is an input for :func:`check_outputs` meanwhile.

    The CLI wraps each command's run in this.
    """
    _run.update(args=args, outputs=set(), made=[])
    try:
        yield
    except BaseException:
        _remove_made_folders(_run["made"])
        raise
    finally:
        _run.clear()


def failed_run() -> None:
    """The running command failed (a nonzero exit): remove the empty folders it made."""
    _remove_made_folders(_run.get("made", []))


def _remove_made_folders(made: list[Path]) -> None:
    """Remove the folders this run created that are still empty, deepest first.

    A run refused (bad input, a stop signal) after its output folders were checked and
    made leaves nothing behind; a folder something was written into is kept.
    """
    for folder in reversed(made):
        with contextlib.suppress(OSError):
            folder.rmdir()


def source_files(value: str | os.PathLike[str]) -> list[str]:
    """The files one flag value names: ``videos:TOP,SIDE`` names two, a path one."""
    text = os.fspath(value)
    for prefix in _SOURCE_PAIRS:
        if text.lower().startswith(prefix):
            return [p.strip() for p in text[len(prefix) :].split(",") if p.strip()]
    return [text]


def _dest(flag: str) -> str:
    """The argparse attribute of a flag spelled ``-o/--output`` or ``--save-landmarks``."""
    return flag.split("/")[-1].lstrip("-").replace("-", "_")


def _flag_inputs(outputs: Sequence[Spec]) -> list[str]:
    """Existing regular files named by the running command's other flags."""
    args = _run.get("args")
    if args is None:
        return []
    declared: set[str] = _run["outputs"]
    declared.update(_dest(flag) for flag, _, _ in outputs)
    found: list[str] = []
    for name, value in vars(args).items():
        if name in _NOT_FLAGS or name in declared:
            continue
        values = value if isinstance(value, list | tuple) else [value]
        for v in values:
            if isinstance(v, str | os.PathLike) and v:
                found.extend(f for f in source_files(v) if _is_file(f))
    return found


def _is_file(path: str) -> bool:
    try:
        return Path(path).is_file()
    except (OSError, ValueError):  # a name the file system refuses is no input file
        return False


def check_folder_files(
    flag: str, folder: str | os.PathLike[str], names: Iterable[str], *, overwrite: bool = False
) -> None:
    """Refuse to replace a file in ``folder`` that no dexlfd run wrote there.

    ``names`` are the files the command is about to write in the folder. One that exists
    may be replaced when the folder's :data:`LEDGER` records it (a dexlfd run wrote it)
    and its content is unchanged since, or with ``overwrite`` (the ``--overwrite`` flag).
    """
    folder = Path(folder)
    if overwrite or not folder.is_dir():
        return
    ledger = _read_ledger(folder)
    for name in names:
        path = folder / name
        if not path.exists():
            continue
        if not path.is_file() or ledger.get(name) != _digest(path):
            raise InvalidInput(
                f"{flag} {folder}: {name} exists and was not written there by dexlfd; "
                "refusing to replace it (--overwrite replaces it, or use another folder)"
            )


def record_written(folder: str | os.PathLike[str], paths: Iterable[Path]) -> None:
    """Note ``paths`` (files just written in ``folder``) in its :data:`LEDGER`."""
    from dexlfd.io import atomic_write

    folder = Path(folder)
    ledger = _read_ledger(folder)
    for path in paths:
        path = Path(path)
        if path.parent.resolve() == folder.resolve() and path.is_file():
            ledger[path.name] = _digest(path)
    text = json.dumps(ledger, indent=1, sort_keys=True).encode()
    atomic_write(folder / LEDGER, lambda fh: fh.write(text))


def _read_ledger(folder: Path) -> dict[str, str]:
    try:
        data = json.loads((folder / LEDGER).read_text())
    except (OSError, ValueError):
        return {}
    if not isinstance(data, dict):
        return {}
    return {str(k): str(v) for k, v in data.items()}


def _digest(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def partial_path(out: Path) -> Path:
    """Where a run that stopped early writes its partial result.

    ``out`` itself when it does not exist yet, else ``<stem>.partial<suffix>`` next to it:
    a stopped run never replaces a finished file of an earlier run.
    """
    if not out.exists():
        return out
    return out.with_name(f"{out.stem}.partial{out.suffix}")


def _same(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def _real(p: Path) -> str:
    return os.path.normcase(os.path.realpath(p))


def _check_suffix(flag: str, out: Path, kind: str | None) -> None:
    suffix = out.suffix.lower()
    if kind in (DIR, NEW_DIR):
        # a new folder (a bag, a dataset) named like a file (out.txt, out.mcap) would be
        # taken for one: only an existing folder or a plain name is a folder's name
        file_like = suffix in FORMATS or suffix in _FILE_SUFFIXES
        if file_like and not out.is_dir():
            raise InvalidInput(
                f"{flag} {out}: expected a folder name, got a {suffix} file name "
                f"(this output is a folder)"
            )
    elif kind is not None and suffix != kind:
        got = f"'{out.suffix}'" if out.suffix else "no suffix"
        raise InvalidInput(
            f"{flag} {out}: must end in {kind} ({FORMATS.get(kind, kind)} is written), got {got}"
        )


def _check_file(flag: str, out: Path) -> None:
    folder = out.parent if str(out.parent) else Path(".")
    if folder.exists() and not folder.is_dir():
        raise InvalidInput(f"{flag}: cannot write {out}: {folder} is a file, not a folder")
    if not folder.is_dir():
        raise InvalidInput(f"{flag}: cannot write {out}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK):
        raise InvalidInput(f"{flag}: cannot write {out}: folder {folder} is not writable")
    if out.is_dir():
        raise InvalidInput(f"{flag}: {out} is a folder; expected a file name")
    if out.exists() and not out.is_file():
        raise InvalidInput(f"{flag}: {out} exists and is not a regular file")


def _check_folder(flag: str, out: Path) -> None:
    for parent in (out, *out.parents):
        if parent.exists() and not parent.is_dir():
            raise InvalidInput(f"{flag}: cannot create folder {out}: {parent} is a file")


def _make_folder(flag: str, out: Path) -> None:
    new = [p for p in (out, *out.parents) if not p.exists()]  # deepest first
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InvalidInput(f"{flag}: cannot create folder {out}: {exc.strerror or exc}") from exc
    if "made" in _run:  # made by this run: removed again if it fails before writing there
        _run["made"].extend(p for p in reversed(new) if p not in _run["made"])
    if not os.access(out, os.W_OK):
        raise InvalidInput(f"{flag}: folder {out} is not writable")
