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
