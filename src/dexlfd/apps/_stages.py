"""Resumable multi-stage runs: a manifest records which stages finished.

A stage is skipped on a rerun only when the manifest says it finished with the
same settings key in the same environment (:func:`environment`: dexlfd's version, a
hash of its source files and the installed extras) and every output it recorded is
still what it wrote: the file (or folder) exists, its SHA-256 content hash matches
the one recorded when it was written, and it passes the stage's check (by default
every ``.npz`` output loads and validates as the dexlfd file it claims to be).
Otherwise the stage runs again, with a warning that says why, and so does every
stage that depends on it (``Stage.after``; by default every later stage). The
manifest is rewritten atomically after each stage, so Ctrl-C or a crash leaves either the old
or the new manifest - never a stage marked done whose outputs are incomplete.

A ``background`` stage runs in a forked child process while the following
stages go on; a stage that depends on it waits for it, and the run ends when
all have finished. Two cores are used when one stage alone would leave the
other idle (tracking a video while learning runs, rendering while exporting).
A stage that draws with OpenGL (``renders``) stays in this process when this process
already made an OpenGL context: a forked child of it would hang at its first frame.

The children are :mod:`dexlfd.apps._stage_process`'s.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import logging
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dexlfd._gl import context_made
from dexlfd.apps._stage_process import LogQueue, Running, cpu_seconds, start_child
from dexlfd.errors import DexlfdError
from dexlfd.io import atomic_write
from dexlfd.io._atomic import remove_strays

__all__ = [
    "Stage",
    "StageRunner",
    "check_npz_outputs",
    "content_hash",
    "environment",
    "settings_key",
    "source_hash",
]

logger = logging.getLogger(__name__)

MANIFEST = "manifest.json"


def settings_key(*parts: Any) -> str:
    """A short stable hash of JSON-able settings (dataclasses via ``repr``)."""
    text = json.dumps([repr(p) if not isinstance(p, str | int | float) else p for p in parts])
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@functools.lru_cache(maxsize=8)
def source_hash(root: Path | None = None) -> str:
    """SHA-256 (16 hex digits) of the ``*.py`` files under ``root`` (default: dexlfd's own).

    Their paths relative to ``root`` and their bytes, in sorted order: an edited
    source (a fix between two runs of an unchanged version number) changes it. Read
    once per process (a few MB).
    """
    if root is None:
        import dexlfd

        root = Path(dexlfd.__file__).resolve().parent
    return content_hash(root, "*.py")[:16]


def environment(source_root: Path | None = None) -> dict[str, str | None]:
    """What a stage's outputs depend on beside its settings: dexlfd's code, the extras.

    ``{"dexlfd": version, "dexlfd_source": hash, <distribution>: version or None}``:
    the version, :func:`source_hash` of the package's source files (``source_root``,
    default dexlfd's own; a changed source reruns the stages although the version
    number did not move), and every optional dependency of
    :data:`dexlfd._extras.EXTRAS` (installed or not): installing an extra
    (``imageio-ffmpeg`` makes the videos H.264, ``rosbags`` adds the bags) changes what
    a stage writes, so a finished stage is not reused across it.
    """
    from importlib import metadata

    from dexlfd import __version__
    from dexlfd._extras import EXTRAS

    env: dict[str, str | None] = {"dexlfd": __version__, "dexlfd_source": source_hash(source_root)}
    for dist, _ in sorted(EXTRAS.values()):
        try:
            env[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            env[dist] = None
    return env


def content_hash(path: Path, pattern: str = "*") -> str:
    """SHA-256 of a file's bytes, or of a folder's relative file names and bytes.

    In a folder: its files whose names match ``pattern``, in every subfolder.
    """
    h = hashlib.sha256()
    files = [path] if path.is_file() else sorted(p for p in path.rglob(pattern) if p.is_file())
    for f in files:
        if f != path:
            h.update(f.relative_to(path).as_posix().encode() + b"\0")
        with open(f, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
    return h.hexdigest()


def check_npz_outputs(outputs: dict[str, Path]) -> None:
    """Load and validate every ``.npz`` output as its dexlfd kind; raises DexlfdError."""
    from dexlfd.io.kinds import load_any

    for path in outputs.values():
        if path.suffix == ".npz":
            load_any(path)


@dataclass
class Stage:
    """One step: ``run(out_dir) -> (outputs, summary)``; outputs are file paths.

    ``check(outputs)`` raises a :class:`~dexlfd.errors.DexlfdError` when finished outputs
    cannot be reused (default: :func:`check_npz_outputs`).
    ``after`` names the stages whose outputs it reads (None: every earlier
    stage); ``background`` runs it in a child process (see the module docstring).
    ``renders``: it draws with OpenGL, so it runs in this process instead when this
    process has made an OpenGL context (:func:`dexlfd._gl.context_made`): a forked
    child of such a process hangs at its first frame. ``here``: when it returns a
    reason (asked as the stage starts), a background stage runs in this process
    instead (e.g. it collects what an earlier stage started in this process).
    ``nice``: a background stage's child lowers its CPU priority by this much (Unix
    ``nice``), so that on a busy machine the stages on the run's critical path get the
    cores first and it takes what they leave (a figure drawn beside the simulation).
    """

    name: str
    title: str
    key: str
    run: Callable[[Path], tuple[dict[str, Path], dict[str, Any]]]
    check: Callable[[dict[str, Path]], None] = check_npz_outputs
    after: tuple[str, ...] | None = None
    background: bool = False
    renders: bool = False
    here: Callable[[], str | None] | None = None
    nice: int = 0


StageOutput = tuple[dict[str, Path], dict[str, Any]]


def _why_here(stage: Stage) -> str | None:
    """Why a background ``stage`` must run in this process (None: it may fork)."""
    if stage.renders and context_made():
        return "this process has an OpenGL context, a fork of it could not draw"
    return None if stage.here is None else stage.here()


@contextlib.contextmanager
def _stage_bar(total: int) -> Any:
    """A progress bar over the stages on a terminal (stderr), the running ones named."""
    from tqdm import tqdm

    with tqdm(
        total=total, desc="stages", leave=False, disable=not sys.stderr.isatty(),
        bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}{postfix}]",
    ) as bar:  # fmt: skip
        yield bar


@dataclass
class StageRunner:
    """Runs stages in order under ``out``, resuming from ``out/manifest.json``.

    On a terminal a progress bar counts the stages finished (or reused) and names the
    running ones; a background stage's log lines are written by this process, above it.
    """

    out: Path
    fresh: bool = False
    results: dict[str, dict[str, Any]] = field(default_factory=dict)
    env: dict[str, str | None] = field(default_factory=environment)
    _logs: Any = field(default=None, init=False, repr=False)
    _bar: Any = field(default=None, init=False, repr=False)

    def _advance(self, running: Any, current: str | None = None) -> None:
        """The bar's postfix: the stages running now (``current`` in the foreground)."""
        if self._bar is not None:
            names = ([current] if current else []) + list(running)
            self._bar.set_postfix_str(", ".join(names), refresh=True)

    def _load(self) -> dict[str, Any]:
        path = self.out / MANIFEST
        if self.fresh or not path.is_file():
            return {}
        try:
            data = json.loads(path.read_text())
        except (OSError, ValueError):
            logger.warning("%s is unreadable; starting clean", path)
            return {}
        return data if isinstance(data, dict) else {}

    def _save(self, manifest: dict[str, Any]) -> None:
        data = json.dumps(manifest, indent=2, sort_keys=True, default=str).encode()
        atomic_write(self.out / MANIFEST, lambda fh: fh.write(data))

    def _why_not_reusable(self, stage: Stage, prev: dict[str, Any]) -> str | None:
        """None when the recorded outputs of ``stage`` can be reused, else the reason."""
        if not prev:
            return "not run before"
        if prev.get("key") != stage.key:
            return "settings changed"
        if prev.get("environment") != self.env:
            return "installed extras, the dexlfd version or its source changed"
        outputs, hashes = prev.get("outputs"), prev.get("hashes")
        if not isinstance(outputs, dict) or not isinstance(hashes, dict):
            return "no content hashes recorded (written by an older dexlfd)"
        paths = {k: self.out / v for k, v in outputs.items()}
        for name, path in paths.items():
            rel = outputs[name]
            if not path.exists():
                return f"{rel} is missing"
            if hashes.get(name) != content_hash(path):
                return f"{rel} changed since it was written (content hash differs)"
        try:
            stage.check(paths)
        except DexlfdError as exc:
            return f"an output does not validate: {exc}"
        return None

    def _record(
        self,
        manifest: dict[str, Any],
        stage: Stage,
        result: StageOutput,
        seconds: float,
        cpu_seconds: float,
    ) -> None:
        outputs, summary = result
        self.results[stage.name] = {
            "outputs": outputs,
            "summary": summary,
            "seconds": seconds,
            "cpu_seconds": cpu_seconds,
            "reused": False,
        }
        manifest[stage.name] = {
            "key": stage.key,
            "environment": self.env,
            "outputs": {k: str(Path(v).relative_to(self.out)) for k, v in outputs.items()},
            "hashes": {k: content_hash(Path(v)) for k, v in outputs.items()},
            "summary": summary,
            "seconds": seconds,
            "cpu_seconds": cpu_seconds,
        }
        self._save(manifest)
        if self._bar is not None:
            self._bar.update(1)

    def _finish(self, manifest: dict[str, Any], running: Running) -> None:
        result, seconds, cpu = running.result()
        logger.info("%s done in %.1f s (in the background)", running.stage.title, seconds)
        self._record(manifest, running.stage, result, seconds, cpu)

    def run(self, stages: list[Stage]) -> dict[str, dict[str, Any]]:
        """Run or reuse each stage; returns ``{name: {"outputs", "summary", "seconds"}}``.

        First the temporaries of an earlier run that was killed mid-write (a background
        stage is terminated on Ctrl-C, before it can clean up) are removed.
        """
        if self.out.is_dir():
            strays = remove_strays(self.out)
            if strays:
                logger.info("removed %d temporary file(s) left by an interrupted run", len(strays))
        manifest = self._load()
        rerun: set[str] = set()
        running: dict[str, Running] = {}
        with contextlib.ExitStack() as stack:
            self._logs, self._bar = (
                stack.enter_context(LogQueue()),
                stack.enter_context(_stage_bar(len(stages))),
            )
            self._run(stages, manifest, rerun, running)
        # the stages in their listed order, whenever they finished
        self.results = {s.name: self.results[s.name] for s in stages if s.name in self.results}
        return self.results

    def _run(
        self,
        stages: list[Stage],
        manifest: dict[str, Any],
        rerun: set[str],
        running: dict[str, Running],
    ) -> None:
        """:meth:`run`'s loop: each stage run, reused or started in the background."""
        try:
            for i, stage in enumerate(stages, start=1):
                deps = [s.name for s in stages[: i - 1]] if stage.after is None else stage.after
                for name in deps:  # this stage reads their outputs
                    if name in running:
                        self._finish(manifest, running.pop(name))
                prev = manifest.get(stage.name)
                if not isinstance(prev, dict):
                    prev = {}
                upstream = sorted(rerun.intersection(deps))
                why = (
                    f"{', '.join(upstream)} reran"
                    if upstream
                    else self._why_not_reusable(stage, prev)
                )
                if why is None:
                    logger.info("[%d/%d] %s: reusing finished outputs", i, len(stages),
                                stage.title)  # fmt: skip
                    self.results[stage.name] = {
                        "outputs": {k: self.out / v for k, v in prev["outputs"].items()},
                        "summary": prev.get("summary", {}),
                        "seconds": prev.get("seconds", 0.0),
                        "cpu_seconds": prev.get("cpu_seconds", 0.0),
                        "reused": True,
                    }
                    if self._bar is not None:
                        self._bar.update(1)
                    continue
                if prev and not upstream:  # a finished stage that is not reused: say why
                    expected = (
                        "settings changed",
                        "installed extras, the dexlfd version or its source changed",
                    )
                    log = logger.info if why in expected else logger.warning
                    log("[%d/%d] %s: rerunning: %s", i, len(stages), stage.title, why)
                rerun.add(stage.name)  # the stages that depend on it run again too
                stale = {stage.name}
                for j, later in enumerate(stages[i - 1 :], start=i - 1):
                    ldeps = [s.name for s in stages[:j]] if later.after is None else later.after
                    if later.name in stale or stale.intersection(ldeps):
                        stale.add(later.name)
                        manifest.pop(later.name, None)
                self._save(manifest)
                here = _why_here(stage)
                if stage.background and here is None:
                    logger.info("[%d/%d] %s ... (in the background)", i, len(stages), stage.title)
                    running[stage.name] = start_child(stage, self.out, self._logs)
                    self._advance(running)
                    continue
                logger.info("[%d/%d] %s ...%s", i, len(stages), stage.title,
                            f" (here: {here})" if stage.background else "")  # fmt: skip
                self._advance(running, stage.name)
                t0, c0 = time.perf_counter(), cpu_seconds()
                result = stage.run(self.out)
                seconds, cpu = time.perf_counter() - t0, cpu_seconds() - c0
                logger.info("[%d/%d] %s done in %.1f s", i, len(stages), stage.title, seconds)
                self._record(manifest, stage, result, seconds, cpu)
                self._advance(running)
            while running:
                self._finish(manifest, running.pop(next(iter(running))))
                self._advance(running)
        finally:
            for r in running.values():  # an error or Ctrl-C: stop the children
                r.stop()
            if running:  # a terminated child could not remove its temporaries
                remove_strays(self.out)
