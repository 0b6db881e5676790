"""learn carries the demonstrations' grasp and release into the model (pick and place)."""

from __future__ import annotations

import dataclasses
import logging

import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.io import Demonstration, load_model, save_model
from dexlfd.learn import LearnConfig, learn_from_demonstrations
from dexlfd.learn.events import demonstration_events

FAST = LearnConfig(n_components=6)


def _events(demo: Demonstration) -> tuple[float, float, np.ndarray, np.ndarray]:
    k0, k1 = demonstration_events(demo.t, demo.grasp)  # type: ignore[misc]
    return demo.t[k0] - demo.t[0], demo.t[k1] - demo.t[0], demo.position[k0], demo.position[k1]


def test_pick_and_place_poses_are_where_the_demonstrations_closed_and_opened(
    demos: list[Demonstration], tmp_path
) -> None:
    model = learn_from_demonstrations(demos, FAST, np.random.default_rng(0)).model
    assert model.has_events and model.event_count.tolist() == [6, 6]
    ev = [_events(d) for d in demos]
    pick = np.mean([e[2] for e in ev], axis=0)
    place = np.mean([e[3] for e in ev], axis=0)
    # the filtered pose at the event sample: within a few mm of the raw mean
    assert np.linalg.norm(model.event_position[0] - pick) < 0.005
    assert np.linalg.norm(model.event_position[1] - place) < 0.005
    # the spread in position is the demonstrations' (filtered: below the raw samples'
    # noise-inflated spread), not zero
    std = np.sqrt(np.diagonal(model.event_cov, axis1=1, axis2=2))
    raw_std = np.std([e[2] for e in ev], axis=0, ddof=1)
    assert (std[0, :3] > 1e-5).all() and (std[0, :3] <= raw_std + 1e-3).all()
    # on the model's clock (the reference's), grasp before release, spread small
    assert 0 < model.event_t[0] < model.event_t[1] < model.t[-1]
    assert (model.event_t_std < 0.3).all()
    back = load_model(save_model(tmp_path / "m.npz", model))
    np.testing.assert_array_equal(back.event_cov, model.event_cov)
    assert back.grasp_events.n_with_events == 6


def test_demonstrations_without_a_grasp_give_a_model_without_events(
    demos: list[Demonstration], caplog
) -> None:
    open_hand = [dataclasses.replace(d, grasp=np.zeros_like(d.grasp)) for d in demos[:3]]
    with caplog.at_level(logging.WARNING):
        model = learn_from_demonstrations(open_hand, FAST, np.random.default_rng(0)).model
    assert not model.has_events and "the hand never closes" in caplog.text
    assert "no demonstration with a grasp" in model.grasp_events.note
    # a run that touches the recording's end shows no release: skipped, said so
    cut = [dataclasses.replace(d, grasp=d.grasp | (d.t > d.t[-1] - 3.0)) for d in demos[:3]]
    assert isinstance(demonstration_events(cut[0].t, cut[0].grasp), str)


def test_event_arrays_come_together_and_in_order(demos: list[Demonstration]) -> None:
    model = learn_from_demonstrations(demos[:3], FAST, np.random.default_rng(0)).model
    with pytest.raises(InvalidInput, match="missing"):
        dataclasses.replace(model, event_cov=None)
    with pytest.raises(InvalidInput, match="grasp < release"):
        dataclasses.replace(model, event_t=model.event_t[::-1].copy())
