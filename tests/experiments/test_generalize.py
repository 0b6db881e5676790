"""experiment generalize: a small grid planned, simulated and scored (2 pairs, 1 payload)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dexlfd.datasets import pick_place_demonstrations
from dexlfd.errors import InvalidInput
from dexlfd.experiments.generalize import (
    GeneralizeConfig,
    check_areas,
    format_generalize,
    run_generalize,
    table_grid,
)
from dexlfd.learn import LearnConfig, learn_from_demonstrations


def test_grid_pairs_every_pick_with_a_different_place() -> None:
    pairs = table_grid(25, ((0.32, 0.62), (-0.45, -0.05)), ((0.32, 0.62), (0.05, 0.45)))
    assert len(pairs) == 25
    picks = {p for p, _ in pairs}
    places = {q for _, q in pairs}
    assert len(picks) == 25 and len(places) == 25  # each used once
    xs = [p[0] for p in picks]
    ys = [p[1] for p in picks]
    assert max(xs) - min(xs) == pytest.approx(0.30) and max(ys) - min(ys) == pytest.approx(0.40)
    dist = [np.hypot(p[0] - q[0], p[1] - q[1]) for p, q in pairs]
    assert max(dist) - min(dist) > 0.2  # carries of many lengths
    assert check_areas([((0.3, 0.5), (0.0, 0.4))]) and not check_areas([((0.3, 0.6), (0, 0.4))])


@pytest.mark.integration
def test_small_grid_is_carried_and_placed(tmp_path: Path) -> None:
    demos = pick_place_demonstrations(6, np.random.default_rng(0))
    model = learn_from_demonstrations(demos, LearnConfig(n_components=8),
                                      np.random.default_rng(0)).model  # fmt: skip
    cfg = GeneralizeConfig(n_pairs=2, payloads=(1.2,), controllers=("ntsm-pd",))
    result = run_generalize(model, cfg)
    assert all(p["ok"] for p in result.plans)
    (row,) = result.summary()
    assert row["pairs"] == 2
    for run in result.runs:
        pl = run["placement"]
        assert pl["carried"] and pl["success"], pl
        assert pl["place_error_m"] < 0.02 and pl["tilt_deg"] < 10 and pl["set_down_speed"] < 0.1
    text = format_generalize(result)
    assert "ntsm-pd" in text and "100%" in text
    from dexlfd.viz.control import plot_generalize

    assert plot_generalize(result, tmp_path / "g.png").is_file()
    # a model without grasp events has nothing to generalise
    no_events = learn_from_demonstrations(
        [d.__class__(**{**{f: getattr(d, f) for f in d.SPECS}, "grasp": np.zeros_like(d.grasp)},
                     meta=d.meta) for d in demos[:3]],
        LearnConfig(n_components=4), np.random.default_rng(0),
    ).model  # fmt: skip
    with pytest.raises(InvalidInput, match="no grasp events"):
        run_generalize(no_events, cfg)


def test_time_scaling_is_one_summary_line_per_study_the_pairs_at_debug(
    caplog: pytest.LogCaptureFixture,
) -> None:
    import logging

    from dexlfd.experiments import generalize

    planner = logging.getLogger("dexlfd.plan.pipeline")
    caplog.set_level(logging.INFO, logger="dexlfd")
    with generalize._time_scaling_at_debug():
        for i in range(5):  # what plan_from_model says of each pair it slows
            planner.warning("time scaling: 1 slow-down(s) ... pair %d", i)
        planner.warning("something else")  # other warnings pass unchanged
    plans = [{"ok": True, "time_scaling_needed": k % 2 == 0, "time_scaling_largest": 1.0 + k}
             for k in range(5)] + [{"ok": False, "error": "unreachable"}]  # fmt: skip
    generalize._say_time_scaling(plans)
    lines = [(r.levelname, r.getMessage()) for r in caplog.records]
    assert lines == [
        ("WARNING", "something else"),
        ("WARNING", "time scaling: 3 of 5 planned pair(s) slowed (the robot's limits, the "
                    "demonstrated speed), at most 5.00x (pair 4); each pair's slow-downs with -vv"),
    ]  # fmt: skip
    caplog.clear()
    caplog.set_level(logging.DEBUG, logger="dexlfd")
    with generalize._time_scaling_at_debug():
        planner.warning("time scaling: 1 slow-down(s) ... pair %d", 0)
    assert [(r.levelname, r.getMessage()) for r in caplog.records] == [
        ("DEBUG", "time scaling: 1 slow-down(s) ... pair 0")
    ]
    assert not planner.filters  # the filter is gone after the pair
