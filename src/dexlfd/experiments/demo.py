"""The end-to-end demo on bundled synthetic data (``dexlfd demo``)."""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd.datasets import pick_place_demonstrations
from dexlfd.io import save_demonstration

__all__ = ["DemoConfig", "DemoResult", "run_demo"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class DemoConfig:
    """Settings of the demo run."""

    seed: int = 0
    n_demos: int = 6


@dataclass(frozen=True, slots=True)
class DemoResult:
    """Files the demo wrote and its key figures."""

    outputs: dict[str, Path] = field(default_factory=dict)
    summary: dict[str, Any] = field(default_factory=dict)


def run_demo(cfg: DemoConfig, out: Path) -> DemoResult:
    """Run every stage that exists on bundled data; write all outputs under ``out``."""
    rng = np.random.default_rng(cfg.seed)
    logger.info("[1/1] demonstrations: %d synthetic pick-and-place", cfg.n_demos)
    demo_dir = out / "demos"
    demo_dir.mkdir(exist_ok=True)
    demos = pick_place_demonstrations(cfg.n_demos, rng)
    outputs = {}
    for i, demo in enumerate(demos):
        outputs[f"demo_{i}"] = save_demonstration(demo_dir / f"demo_{i:02d}.npz", demo)
    return DemoResult(outputs=outputs, summary={"n_demos": len(demos)})
