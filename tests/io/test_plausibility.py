from __future__ import annotations

import dataclasses
import logging
import re
from pathlib import Path

import numpy as np
import pytest

from dexlfd.errors import InvalidFile, InvalidInput
from dexlfd.io import (
    Demonstration,
    load_demonstration,
    load_model,
    save_demonstration,
    save_model,
)
from dexlfd.io.plausibility import HAND_MAX_OPENING_M, MAX_POSITION_M, WARN_POSITION_M


def _demo(n: int = 30) -> Demonstration:
    t = np.arange(n) / 30.0
    pos = np.column_stack([np.linspace(0.3, 0.5, n), np.zeros(n), np.full(n, 0.2)])
    return Demonstration(t=t, keypoints=np.repeat(pos[:, None, :], 21, axis=1),
                         valid=np.ones(n, bool), position=pos,
                         quaternion=np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)),
                         gripper=np.full(n, 0.06), grasp=np.zeros(n, bool))  # fmt: skip


def _save_unchecked(path: Path, rec) -> Path:
    """``rec`` written as another program might: without the writer's own checks."""
    return rec._write(path)


def _roundtrip(tmp_path: Path, **changes) -> Demonstration:
    """Load ``_demo()`` changed; the writer refuses exactly what the loader refuses."""
    demo = dataclasses.replace(_demo(), **changes)
    path = _save_unchecked(tmp_path / "d.npz", demo)
    try:
        loaded = load_demonstration(path)
    except InvalidFile as exc:
        why = str(exc).split(": ", 1)[1]
        (tmp_path / "w.npz").unlink(missing_ok=True)
        with pytest.raises(InvalidInput, match=r"not written: .*w\.npz: " + re.escape(why)):
            save_demonstration(tmp_path / "w.npz", demo)
        assert not (tmp_path / "w.npz").exists()
        raise
    save_demonstration(tmp_path / "w.npz", demo)  # what loads is written
    return loaded


def test_plausible_demonstration_loads_silently(tmp_path: Path, caplog) -> None:
    with caplog.at_level(logging.WARNING):
        _roundtrip(tmp_path)
    assert caplog.text == ""


def test_timestamps_in_milliseconds_are_refused(tmp_path: Path) -> None:
    with pytest.raises(InvalidFile, match=r"d\.npz: t spans .* milliseconds"):
        _roundtrip(tmp_path, t=_demo().t * 1000)


def test_timestamps_that_are_frame_numbers_are_refused(tmp_path: Path) -> None:
    with pytest.raises(InvalidFile, match=r"d\.npz: t counts whole numbers .* frame numbers\?"):
        _roundtrip(tmp_path, t=np.arange(30.0))
    # a 1 s step of non-integer times is a slow but real sampling (refused only by > 1 s)
    _roundtrip(tmp_path, t=np.arange(30.0) + 0.5)


def test_a_short_demonstration_in_milliseconds_is_refused(tmp_path: Path) -> None:
    short = dataclasses.replace(
        _demo(8),
        t=np.arange(8) * 33.3,  # 8 frames of a 30 fps video, in ms
    )
    with pytest.raises(InvalidFile, match=r"d\.npz: t spans .* milliseconds"):
        load_demonstration(_save_unchecked(tmp_path / "d.npz", short))
    with pytest.raises(InvalidInput, match=r"not written: .*w\.npz: t spans .* milliseconds"):
        save_demonstration(tmp_path / "w.npz", short)


def test_an_hour_long_recording_at_30hz_is_refused_but_a_short_coarse_grid_is_not(
    tmp_path: Path,
) -> None:
    with pytest.raises(InvalidFile, match="at most 3600 s"):
        _roundtrip(tmp_path, t=np.arange(30) * 200.0)
    # a model on a coarse grid of few samples (n < 10) may have long steps
    model = _model_with(t=np.linspace(0, 8, 3))
    load_model(save_model(tmp_path / "m.npz", model))


def _model_with(**changes):
    from dexlfd.io import LearnedModel

    m = len(changes.get("t", np.linspace(0, 1, 4)))
    mean = np.zeros((m, 8))
    mean[:, 6] = 1.0
    mean[:, 7] = 0.04
    base = dict(t=np.linspace(0, 1, m), mean=mean, cov=np.tile(np.eye(8), (m, 1, 1)),
                gmm_weights=np.array([1.0]), gmm_means=np.zeros((1, 9)),
                gmm_covs=np.eye(9)[None])  # fmt: skip
    return LearnedModel(**{**base, **changes})


@pytest.mark.parametrize("scale", [1e3, 1e200, -50.0])
def test_positions_far_beyond_the_workspace_are_refused(tmp_path: Path, scale: float) -> None:
    d = _demo()
    with pytest.raises(InvalidFile, match=rf"position reaches .* within {MAX_POSITION_M:g} m"):
        _roundtrip(tmp_path, position=d.position * scale, keypoints=d.keypoints * scale)


def test_positions_beyond_reach_warn(tmp_path: Path, caplog) -> None:
    d = _demo()
    far = d.position * 0 + [WARN_POSITION_M + 1.0, 0.0, 0.0]
    with caplog.at_level(logging.WARNING):
        _roundtrip(tmp_path, position=far)
    assert "d.npz: position reaches 3 m" in caplog.text


def test_camera_frame_positions_beyond_reach_do_not_warn_of_the_workspace(
    tmp_path: Path, caplog
) -> None:
    """A camera-frame recording is not in reach terms: a camera 2.4 m away is no error."""
    d = _demo()
    far = d.position * 0 + [0.0, 0.3, WARN_POSITION_M + 0.4]
    with caplog.at_level(logging.WARNING):
        _roundtrip(tmp_path, position=far, frame="camera (no extrinsics)")
    assert "workspace" not in caplog.text
    with pytest.raises(InvalidFile, match="from the camera"):  # millimetres still refused
        _roundtrip(tmp_path, position=far * 1e3, frame="camera (no extrinsics)")


def test_gripper_opening_negative_is_refused_and_too_wide_warns(tmp_path: Path, caplog) -> None:
    with pytest.raises(InvalidFile, match="gripper opening down to -5 m"):
        _roundtrip(tmp_path, gripper=np.full(30, -5.0))
    with caplog.at_level(logging.WARNING):
        _roundtrip(tmp_path, gripper=np.full(30, HAND_MAX_OPENING_M + 0.5))
    assert "wider than a hand opens" in caplog.text and "d.npz" in caplog.text
    # GMR may undershoot a closed gripper a little: accepted
    model = _model_with()
    mean = model.mean.copy()
    mean[:, 7] = -0.002
    load_model(save_model(tmp_path / "m.npz", dataclasses.replace(model, mean=mean)))


def test_a_plan_faster_than_the_panda_warns_and_one_within_does_not(tmp_path: Path, caplog) -> None:
    from dexlfd.io import Plan, load_plan, save_plan
    from dexlfd.io.plausibility import MAX_SPEED

    n = 50
    t = np.linspace(0.0, 2.0, n)
    pos = np.column_stack([np.linspace(0.3, 0.5, n), np.zeros(n), np.full(n, 0.3)])
    vel = np.gradient(pos, t, axis=0)
    plan = Plan(t=t, position=pos, velocity=vel, acceleration=np.zeros((n, 3)),
                quaternion=np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)),
                angular_velocity=np.zeros((n, 3)), gripper=np.full(n, 0.04))  # fmt: skip
    with caplog.at_level(logging.WARNING):
        load_plan(save_plan(tmp_path / "p.npz", plan))
    assert caplog.text == ""
    at_limit = dataclasses.replace(plan, velocity=np.full((n, 3), MAX_SPEED))
    with caplog.at_level(logging.WARNING):
        load_plan(save_plan(tmp_path / "p.npz", at_limit))
    assert caplog.text == ""
    fast = dataclasses.replace(plan, velocity=vel * 1e6)
    with caplog.at_level(logging.WARNING):
        load_plan(save_plan(tmp_path / "p.npz", fast))
    assert (
        "p.npz: the plan's velocity reaches" in caplog.text and "beyond the Panda's" in caplog.text
    )
