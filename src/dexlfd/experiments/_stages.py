"""Resumable multi-stage runs: a manifest records which stages finished.

A stage is skipped on a rerun when the manifest says it finished with the same
settings key and all its output files still exist; otherwise it runs again and
so does every later stage. The manifest is rewritten atomically after each
stage, so Ctrl-C or a crash leaves either the old or the new manifest - never a
stage marked done whose outputs are incomplete.
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
    """One step: ``run(out_dir) -> (outputs, summary)``; outputs are file paths."""

    name: str
    title: str
    key: str
    run: Callable[[Path], tuple[dict[str, Path], dict[str, Any]]]


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

    def run(self, stages: list[Stage]) -> dict[str, dict[str, Any]]:
        """Run or reuse each stage; returns ``{name: {"outputs", "summary", "seconds"}}``."""
        manifest = self._load()
        reuse = True
        for i, stage in enumerate(stages, start=1):
            prev = manifest.get(stage.name)
            if not isinstance(prev, dict):
                prev = {}
            done = (
                reuse
                and prev.get("key") == stage.key
                and all((self.out / p).exists() for p in prev.get("outputs", {}).values())
            )
            if done:
                logger.info("[%d/%d] %s: reusing finished outputs", i, len(stages), stage.title)
                self.results[stage.name] = {
                    "outputs": {k: self.out / v for k, v in prev["outputs"].items()},
                    "summary": prev.get("summary", {}),
                    "seconds": prev.get("seconds", 0.0),
                    "reused": True,
                }
                continue
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
                "summary": summary,
                "seconds": seconds,
            }
            for later in stages[i:]:
                manifest.pop(later.name, None)
            self._save(manifest)
        return self.results
