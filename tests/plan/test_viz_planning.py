from __future__ import annotations

from pathlib import Path

from dexlfd.plan import Box, PlanConfig, plan_from_model
from dexlfd.viz.planning import plot_obstacle_profile, plot_paths


def test_figures_are_written(ref_model, tmp_path: Path) -> None:
    plans = [
        plan_from_model(ref_model, PlanConfig(goal=g, rate_hz=50))
        for g in ((0.51, 0.11, 0.31), (0.5, 0.19, 0.3))
    ]
    p = plot_paths(ref_model, plans, tmp_path / "paths.png")
    assert p.stat().st_size > 10_000
    box = Box((0.45, 0.0, 0.2), (0.1, 0.1, 0.4))
    plan = plan_from_model(ref_model, PlanConfig(obstacles=(box,), rate_hz=50))
    assert plot_obstacle_profile(ref_model, plan, tmp_path / "z.png").stat().st_size > 10_000
