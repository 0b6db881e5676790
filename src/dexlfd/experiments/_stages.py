"""Resumable multi-stage runs: a manifest records which stages finished.

A stage is skipped on a rerun only when the manifest says it finished with the
same settings key and every output it recorded is still what it wrote: the file
(or folder) exists, its SHA-256 content hash matches the one recorded when it was
written, and it passes the stage's check (by default every ``.npz`` output loads
and validates as the dexlfd file it claims to be). Otherwise the stage runs again,
with a warning that says why, and so does every later stage. The manifest is
rewritten atomically after each stage, so Ctrl-C or a crash leaves either the old
or the new manifest - never a stage marked done whose outputs are incomplete.
"""

from __future__ import annotations

import hashlib
import json
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dexlfd.errors import DexlfdError
from dexlfd.io import atomic_write

__all__ = ["Stage", "StageRunner", "check_npz_outputs", "content_hash", "settings_key"]

logger = logging.getLogger(__name__)

MANIFEST = "manifest.json"


def settings_key(*parts: Any) -> str:
    """A short stable hash of JSON-able settings (dataclasses via ``repr``)."""
    text = json.dumps([repr(p) if not isinstance(p, str | int | float) else p for p in parts])
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def content_hash(path: Path) -> str:
    """SHA-256 of a file's bytes, or of a folder's relative file names and bytes."""
    h = hashlib.sha256()
    files = [path] if path.is_file() else sorted(p for p in path.rglob("*") if p.is_file())
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
    """

    name: str
    title: str
    key: str
    run: Callable[[Path], tuple[dict[str, Path], dict[str, Any]]]
    check: Callable[[dict[str, Path]], None] = check_npz_outputs


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

    def _why_not_reusable(self, stage: Stage, prev: dict[str, Any]) -> str | None:
        """None when the recorded outputs of ``stage`` can be reused, else the reason."""
        if not prev:
            return "not run before"
        if prev.get("key") != stage.key:
            return "settings changed"
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

    def run(self, stages: list[Stage]) -> dict[str, dict[str, Any]]:
        """Run or reuse each stage; returns ``{name: {"outputs", "summary", "seconds"}}``."""
        manifest = self._load()
        reuse = True
        for i, stage in enumerate(stages, start=1):
            prev = manifest.get(stage.name)
            if not isinstance(prev, dict):
                prev = {}
            why = self._why_not_reusable(stage, prev) if reuse else "an earlier stage reran"
            if why is None:
                logger.info("[%d/%d] %s: reusing finished outputs", i, len(stages), stage.title)
                self.results[stage.name] = {
                    "outputs": {k: self.out / v for k, v in prev["outputs"].items()},
                    "summary": prev.get("summary", {}),
                    "seconds": prev.get("seconds", 0.0),
                    "reused": True,
                }
                continue
            if prev and reuse:  # a finished stage that is not reused: say why
                log = logger.info if why == "settings changed" else logger.warning
                log("[%d/%d] %s: rerunning: %s", i, len(stages), stage.title, why)
            reuse = False  # later stages depend on this one's outputs
            logger.info("[%d/%d] %s ...", i, len(stages), stage.title)
            t0 = time.perf_counter()
            outputs, summary = stage.run(self.out)
            seconds = time.perf_counter() - t0
            logger.info("[%d/%d] %s done in %.1f s", i, len(stages), stage.title, seconds)
            self.results[stage.name] = {
                "outputs": outputs,
                "summary": summary,
                "seconds": seconds,
                "reused": False,
            }
            manifest[stage.name] = {
                "key": stage.key,
                "outputs": {k: str(Path(v).relative_to(self.out)) for k, v in outputs.items()},
                "hashes": {k: content_hash(Path(v)) for k, v in outputs.items()},
                "summary": summary,
                "seconds": seconds,
            }
            for later in stages[i:]:
                manifest.pop(later.name, None)
            self._save(manifest)
        return self.results
