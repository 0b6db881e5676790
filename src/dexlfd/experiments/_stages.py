"""Resumable multi-stage runs: a manifest records which stages finished.

A stage is skipped on a rerun when the manifest says it finished with the same
settings key and all its output files still exist; otherwise it runs again and
so does every stage that depends on it (``Stage.after``; by default every
later stage). The manifest is rewritten atomically after each stage, so Ctrl-C
or a crash leaves either the old or the new manifest - never a stage marked
done whose outputs are incomplete.

A ``background`` stage runs in a forked child process while the following
stages go on; a stage that depends on it waits for it, and the run ends when
all have finished. Two cores are used when one stage alone would leave the
other idle (tracking a video while learning runs, rendering while exporting).
"""

from __future__ import annotations

import hashlib
import json
import logging
import multiprocessing
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dexlfd.errors import DexlfdError
from dexlfd.io import atomic_write

__all__ = ["Stage", "StageRunner", "settings_key"]

logger = logging.getLogger(__name__)

MANIFEST = "manifest.json"


def settings_key(*parts: Any) -> str:
    """A short stable hash of JSON-able settings (dataclasses via ``repr``)."""
    text = json.dumps([repr(p) if not isinstance(p, str | int | float) else p for p in parts])
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass
class Stage:
    """One step: ``run(out_dir) -> (outputs, summary)``; outputs are file paths.

    ``after`` names the stages whose outputs it reads (None: every earlier
    stage); ``background`` runs it in a child process (see the module docstring).
    """

    name: str
    title: str
    key: str
    run: Callable[[Path], tuple[dict[str, Path], dict[str, Any]]]
    after: tuple[str, ...] | None = None
    background: bool = False


StageOutput = tuple[dict[str, Path], dict[str, Any]]


def _child(stage: Stage, out: Path, conn: Any) -> None:  # pragma: no cover - in the child
    t0 = time.perf_counter()
    try:
        message: tuple[Any, ...] = ("ok", stage.run(out), time.perf_counter() - t0)
    except BaseException as exc:
        message = ("error", f"{type(exc).__name__}: {exc}", exc)
    try:
        conn.send(message)
    except Exception:  # the exception itself may not pickle: its text does
        conn.send(message[:2] + (None,))
    conn.close()


@dataclass
class _Running:
    stage: Stage
    process: Any
    conn: Any

    def result(self) -> tuple[StageOutput, float]:
        try:
            message = self.conn.recv()
        except EOFError:
            self.process.join()
            raise DexlfdError(
                f"stage {self.stage.name}: its process died (exit code {self.process.exitcode})"
            ) from None
        finally:
            self.conn.close()
        self.process.join()
        if message[0] == "error":
            if isinstance(message[2], BaseException):
                raise message[2]
            raise DexlfdError(f"stage {self.stage.name}: {message[1]}")
        return message[1], message[2]

    def stop(self) -> None:
        if self.process.is_alive():
            self.process.terminate()
        self.process.join()
        self.conn.close()


@dataclass
class StageRunner:
    """Runs stages in order under ``out``, resuming from ``out/manifest.json``."""

    out: Path
    fresh: bool = False
    results: dict[str, dict[str, Any]] = field(default_factory=dict)

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

    def _record(
        self, manifest: dict[str, Any], stage: Stage, result: StageOutput, seconds: float
    ) -> None:
        outputs, summary = result
        self.results[stage.name] = {
            "outputs": outputs,
            "summary": summary,
            "seconds": seconds,
            "reused": False,
        }
        manifest[stage.name] = {
            "key": stage.key,
            "outputs": {k: str(Path(v).relative_to(self.out)) for k, v in outputs.items()},
            "summary": summary,
            "seconds": seconds,
        }
        self._save(manifest)

    def _finish(self, manifest: dict[str, Any], running: _Running) -> None:
        result, seconds = running.result()
        logger.info("%s done in %.1f s (in the background)", running.stage.title, seconds)
        self._record(manifest, running.stage, result, seconds)

    def run(self, stages: list[Stage]) -> dict[str, dict[str, Any]]:
        """Run or reuse each stage; returns ``{name: {"outputs", "summary", "seconds"}}``."""
        manifest = self._load()
        rerun: set[str] = set()
        running: dict[str, _Running] = {}
        try:
            for i, stage in enumerate(stages, start=1):
                deps = [s.name for s in stages[: i - 1]] if stage.after is None else stage.after
                for name in deps:  # this stage reads their outputs
                    if name in running:
                        self._finish(manifest, running.pop(name))
                prev = manifest.get(stage.name)
                if not isinstance(prev, dict):
                    prev = {}
                done = (
                    not rerun.intersection(deps)
                    and prev.get("key") == stage.key
                    and all((self.out / p).exists() for p in prev.get("outputs", {}).values())
                )
                if done:
                    logger.info("[%d/%d] %s: reusing finished outputs", i, len(stages),
                                stage.title)  # fmt: skip
                    self.results[stage.name] = {
                        "outputs": {k: self.out / v for k, v in prev["outputs"].items()},
                        "summary": prev.get("summary", {}),
                        "seconds": prev.get("seconds", 0.0),
                        "reused": True,
                    }
                    continue
                rerun.add(stage.name)  # the stages that depend on it run again too
                stale = {stage.name}
                for j, later in enumerate(stages[i - 1 :], start=i - 1):
                    ldeps = [s.name for s in stages[:j]] if later.after is None else later.after
                    if later.name in stale or stale.intersection(ldeps):
                        stale.add(later.name)
                        manifest.pop(later.name, None)
                self._save(manifest)
                if stage.background:
                    logger.info("[%d/%d] %s ... (in the background)", i, len(stages), stage.title)
                    ctx = multiprocessing.get_context("fork")
                    recv, send = ctx.Pipe(duplex=False)
                    proc = ctx.Process(target=_child, args=(stage, self.out, send),
                                       name=f"dexlfd-{stage.name}")  # fmt: skip
                    proc.start()
                    send.close()
                    running[stage.name] = _Running(stage, proc, recv)
                    continue
                logger.info("[%d/%d] %s ...", i, len(stages), stage.title)
                t0 = time.perf_counter()
                result = stage.run(self.out)
                seconds = time.perf_counter() - t0
                logger.info("[%d/%d] %s done in %.1f s", i, len(stages), stage.title, seconds)
                self._record(manifest, stage, result, seconds)
            while running:
                self._finish(manifest, running.pop(next(iter(running))))
        finally:
            for r in running.values():  # an error or Ctrl-C: stop the children
                r.stop()
        # the stages in their listed order, whenever they finished
        self.results = {s.name: self.results[s.name] for s in stages if s.name in self.results}
        return self.results
