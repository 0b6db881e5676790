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


def _legend_overlaps(fig) -> list[str]:
    """Legends (of axes or of the figure) whose box overlaps any axes' plotting area."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend()] + list(fig.legends)
    hits = []
    for legend in legends:
        box = legend.get_window_extent(renderer)
        for ax in fig.axes:
            if box.overlaps(ax.get_window_extent(renderer)):
                hits.append(f"legend {[t.get_text() for t in legend.get_texts()]} over {ax}")
    return hits


def test_obstacle_figures_keep_their_legends_off_the_paths_and_obstacles(
    ref_model, tmp_path: Path, monkeypatch
) -> None:
    import dexlfd.viz.planning as planning
    from dexlfd.plan import Sphere

    seen: list[list[str]] = []
    save = planning.save_figure

    def checked(fig, path):
        seen.append(_legend_overlaps(fig))
        return save(fig, path)

    monkeypatch.setattr(planning, "save_figure", checked)
    box = Box((0.45, 0.0, 0.2), (0.1, 0.1, 0.4))
    sphere = Sphere((0.45, 0.12, 0.3), 0.05)
    one = plan_from_model(ref_model, PlanConfig(obstacles=(box,), rate_hz=50))
    two = plan_from_model(ref_model, PlanConfig(obstacles=(box, sphere), rate_hz=50))
    planning.plot_obstacle_profile(ref_model, one, tmp_path / "one.png")
    planning.plot_obstacle_profile(ref_model, two, tmp_path / "two.png", title="two")
    planning.plot_obstacle_comparison(ref_model, [one, two], ["box", "both"], tmp_path / "c.png")
    assert len(seen) == 3 and seen == [[], [], []]
