"""Choosing K by the held-out demonstrations' distance from the GMR mean."""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.learn import GmmConfig, LearnConfig, learn_trajectories
from dexlfd.learn.config import THESIS_K
from dexlfd.learn.model_selection import K_CANDIDATES, select_n_components


def _demos(rng: np.random.Generator, segments: int, n: int = 6, m: int = 200) -> np.ndarray:
    """n noisy copies of a curve with `segments` sharp turns (a zig-zag), (n, m, 2)."""
    t = np.linspace(0.0, 1.0, m)
    x = t
    y = np.abs(((segments * t) % 2.0) - 1.0)  # triangle wave: `segments` straight pieces
    base = np.column_stack([x, y])
    return np.stack([base + rng.normal(0.0, 0.005, base.shape) for _ in range(n)])


def test_more_segments_need_more_components(rng: np.random.Generator) -> None:
    t = np.linspace(0.0, 1.0, 200)
    cfg = GmmConfig(n_components=1)
    few = select_n_components(t, _demos(rng, 1), cfg, rng)
    many = select_n_components(t, _demos(rng, 12), cfg, rng)
    assert few.k <= 8  # a straight line: at or near the floor (the thesis's K)
    assert many.k >= 12 > few.k
    assert many.method == "held-out demonstration error"
    np.testing.assert_array_equal(many.candidates, K_CANDIDATES)
    assert many.scores[list(many.candidates).index(many.k)] == many.scores.min()


def test_one_demonstration_uses_the_thesis_k(rng: np.random.Generator) -> None:
    t = np.linspace(0.0, 1.0, 200)
    sel = select_n_components(t, _demos(rng, 4, n=1), GmmConfig(n_components=1), rng)
    assert sel.k == THESIS_K and sel.candidates.size == 0
    with pytest.raises(InvalidInput, match="aligned must have shape"):
        select_n_components(t, np.zeros((3, 5, 2)), GmmConfig(n_components=1), rng)


def test_pipeline_auto_and_override(rng: np.random.Generator) -> None:
    demos = _demos(rng, 12)
    t = np.linspace(0.0, 1.0, demos.shape[1])
    auto = learn_trajectories([t] * 6, list(demos), LearnConfig(window=1), rng)
    assert auto.k_selection is not None
    assert auto.gmm_result.gmm.n_components == auto.k_selection.k >= 12
    fixed = learn_trajectories([t] * 6, list(demos), LearnConfig(n_components=6, window=1), rng)
    assert fixed.k_selection is None and fixed.gmm_result.gmm.n_components == 6
    with pytest.raises(InvalidInput, match="an integer in 1..50 or auto"):
        LearnConfig(n_components="best")
