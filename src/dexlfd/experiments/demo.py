"""The end-to-end demo on bundled synthetic data (``dexlfd demo``)."""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd.datasets import pick_place_demonstrations
from dexlfd.io import save_demonstration, save_model
from dexlfd.learn import LearnConfig, learn_from_demonstrations

__all__ = ["DemoConfig", "DemoResult", "run_demo"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class DemoConfig:
    """Settings of the demo run."""

    seed: int = 0
    n_demos: int = 6
    learn: LearnConfig = field(default_factory=LearnConfig)


@dataclass(frozen=True, slots=True)
class DemoResult:
    """Files the demo wrote and its key figures."""

    outputs: dict[str, Path] = field(default_factory=dict)
    summary: dict[str, Any] = field(default_factory=dict)


def run_demo(cfg: DemoConfig, out: Path) -> DemoResult:
    """Run every stage that exists on bundled data; write all outputs under ``out``."""
    rng = np.random.default_rng(cfg.seed)
    logger.info("[1/2] demonstrations: %d synthetic pick-and-place", cfg.n_demos)
    demo_dir = out / "demos"
    demo_dir.mkdir(exist_ok=True)
    demos = pick_place_demonstrations(cfg.n_demos, rng)
    outputs = {}
    names = []
    for i, demo in enumerate(demos):
        outputs[f"demo_{i}"] = save_demonstration(demo_dir / f"demo_{i:02d}.npz", demo)
        names.append(f"demos/demo_{i:02d}.npz")
    logger.info("[2/2] learn: mean filter, DTW, GMM, GMR")
    learned = learn_from_demonstrations(demos, cfg.learn, rng, names=names)
    outputs["model"] = save_model(out / "model.npz", learned.model)
    from dexlfd.viz.learning import plot_learning

    fig_dir = out / "figures"
    fig_dir.mkdir(exist_ok=True)
    for path in plot_learning(learned, fig_dir):
        outputs[f"figure_{path.stem}"] = path
    traj = learned.trajectory
    summary = {
        "n_demos": len(demos),
        "reference": names[traj.alignment.reference_index],
        "dtw_distances": [round(float(d), 4) for d in traj.quality.distances],
        "outliers": learned.model.meta["outliers"],
        "gmm_iterations": traj.gmm_result.n_iter,
        "gmm_log_likelihood": round(traj.gmm_result.log_likelihood, 2),
    }
    return DemoResult(outputs=outputs, summary=summary)
