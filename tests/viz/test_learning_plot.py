from __future__ import annotations

from pathlib import Path

import numpy as np

from dexlfd.learn import LearnConfig, learn_from_demonstrations, learn_trajectories
from dexlfd.viz.learning import plot_learning


def test_plot_learning_writes_all_figures(demos, tmp_path: Path) -> None:
    res = learn_from_demonstrations(demos, LearnConfig(), np.random.default_rng(0))
    paths = plot_learning(res, tmp_path)
    assert len(paths) == 6 and all(p.is_file() and p.stat().st_size > 10_000 for p in paths)


def test_plot_learning_any_channel_count_and_single_series(tmp_path: Path) -> None:
    t = np.linspace(0, 2, 80)
    traj = learn_trajectories(
        [t], [np.stack([np.sin(t), np.cos(t)], 1)], LearnConfig(), np.random.default_rng(0)
    )
    paths = plot_learning(traj, tmp_path, labels=["a", "b"])
    assert [p.name for p in paths] == [
        "dtw_example.png",
        "alignment.png",
        "gmm.png",
        "gmr.png",
        "quality.png",
    ]
