from __future__ import annotations

import logging

import numpy as np
import pytest

from dexlfd.errors import InvalidDemonstration, InvalidInput
from dexlfd.io import load_demonstration, save_demonstration
from dexlfd.motion import (
    MotionConfig,
    demonstration_from_keypoints,
    fill_short_gaps,
    find_gaps,
    grasp_state,
)


def test_grasp_threshold_and_hysteresis() -> None:
    g = np.array([0.15, 0.12, 0.099, 0.105, 0.098, 0.108, 0.111, 0.105, 0.09, np.nan, 0.2])
    s = grasp_state(g, threshold=0.1, hysteresis=0.01)
    # on below 0.1; stays on until above 0.11; NaN holds; off above 0.11
    expected = [False, False, True, True, True, True, False, False, True, True, False]
    assert s.tolist() == expected
    # without hysteresis the noisy part chatters
    bare = grasp_state(g, threshold=0.1, hysteresis=0.0)
    assert np.abs(np.diff(bare.astype(int))).sum() > np.abs(np.diff(s.astype(int))).sum()


def test_grasp_chatter_free_on_noise(rng: np.random.Generator) -> None:
    g = 0.1 + rng.normal(0, 0.002, 500)  # hovering at the threshold
    s = grasp_state(g, 0.1, 0.01)
    assert np.abs(np.diff(s.astype(int))).sum() == 1  # switches on once, never off


def test_grasp_bad_threshold() -> None:
    with pytest.raises(InvalidInput, match="threshold"):
        grasp_state(np.zeros(3), threshold=-1)


def test_find_and_fill_gaps() -> None:
    t = np.arange(20) / 10.0
    valid = np.ones(20, bool)
    valid[[0, 5, 6, 12, 13, 14, 15, 19]] = False
    gaps = find_gaps(t, valid)
    assert [(g.start, g.stop, g.interior) for g in gaps] == [
        (0, 1, False),
        (5, 7, True),
        (12, 16, True),
        (19, 20, False),
    ]
    assert gaps[1].duration_s == pytest.approx(0.3)
    kp = np.where(valid[:, None, None], t[:, None, None] * np.arange(63).reshape(21, 3), np.nan)
    out, v, filled = fill_short_gaps(t, kp, valid, max_gap_s=0.3)
    # the 2-frame gap (0.3 s without data) is filled exactly (the motion is linear in t)
    np.testing.assert_allclose(out[5:7], t[5:7, None, None] * np.arange(63).reshape(21, 3))
    assert filled.tolist() == [i in (5, 6) for i in range(20)]
    assert np.isnan(out[[0, 12, 13, 14, 15, 19]]).all() and not v[12]
    assert np.isnan(kp[5]).all()  # input untouched


def test_demonstration_contract_and_gap_report(
    rng: np.random.Generator, tmp_path, caplog: pytest.LogCaptureFixture
) -> None:
    from dexlfd.datasets import hand_keypoints_from_pose, pick_place_demonstrations

    demo = pick_place_demonstrations(1, rng)[0]
    kp = hand_keypoints_from_pose(
        demo.position, demo.quaternion, demo.gripper, rng, mount="top_grasp"
    )
    valid = np.ones(demo.n_samples, bool)
    valid[10:12] = False  # short gap: filled
    valid[40:70] = False  # 1 s gap: reported, left NaN
    kp[~valid] = np.nan
    with caplog.at_level(logging.WARNING):
        out = demonstration_from_keypoints(
            demo.t, kp, valid, MotionConfig(mount="top_grasp", max_gap_s=0.1)
        )
    assert "frames 40-69" in caplog.text
    assert out.valid[10:12].all() and out.extras["interpolated"][10:12].all()
    assert not out.valid[40:70].any()
    assert np.isnan(out.position[40:70]).all() and np.isnan(out.quaternion[40:70]).all()
    assert np.isfinite(out.pose[out.valid]).all()
    assert [g["start"] for g in out.meta["gaps"]] == [40]
    path = save_demonstration(tmp_path / "d.npz", out)
    back = load_demonstration(path)
    np.testing.assert_array_equal(back.valid, out.valid)
    np.testing.assert_array_equal(back.extras["euler"], out.extras["euler"])


def test_no_hand_at_all_is_an_error() -> None:
    t = np.arange(5) / 30
    with pytest.raises(InvalidDemonstration, match="no hand"):
        demonstration_from_keypoints(t, np.full((5, 21, 3), np.nan))


def test_valid_with_nan_keypoints_is_rejected() -> None:
    t = np.arange(3) / 30
    with pytest.raises(InvalidInput, match="keypoints\\[1\\]"):
        demonstration_from_keypoints(
            t,
            np.where(np.arange(3)[:, None, None] == 1, np.nan, 0.0) + np.zeros((3, 21, 3)),
            np.ones(3, bool),
        )


def test_motion_config_checks() -> None:
    with pytest.raises(InvalidInput, match="mount must be one of"):
        MotionConfig(mount="sideways")
    with pytest.raises(InvalidInput, match="grasp_threshold"):
        MotionConfig(grasp_threshold=0)


def _aperture_series(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Open (ratio 0.8) - closed (0.4, holding a mug) - open, with tracking noise."""
    t = np.arange(300) / 30.0
    level = np.where((t > 3.0) & (t < 7.0), 0.4, 0.8)
    return t, level + rng.normal(0, 0.03, t.size)


def test_adaptive_grasp_finds_the_two_levels(rng: np.random.Generator) -> None:
    from dexlfd.motion import GraspConfig, detect_grasp

    t, ratio = _aperture_series(rng)
    gripper = ratio * 0.09  # a 9 cm hand: 7 cm open, 3.6 cm closed, all below 0.1 m
    res = detect_grasp(t, gripper, ratio, GraspConfig())
    truth = (t > 3.0) & (t < 7.0)
    assert (res.grasp == truth).mean() > 0.98
    assert np.abs(np.diff(res.grasp.astype(int))).sum() == 2  # one grasp, one release
    assert 0.3 < res.info["closed_level"] < 0.45 < 0.75 < res.info["open_level"] < 0.9
    # the thesis's absolute 0.1 m calls every frame of this real-sized hand a grasp
    thesis = detect_grasp(t, gripper, ratio, GraspConfig(method="absolute"))
    assert thesis.grasp.all()


def test_adaptive_grasp_without_aperture_change_has_no_event(rng: np.random.Generator) -> None:
    from dexlfd.motion import GraspConfig, detect_grasp

    t = np.arange(200) / 30.0
    ratio = 0.85 + rng.normal(0, 0.03, t.size)  # an open hand that only moves
    res = detect_grasp(t, ratio * 0.09, ratio, GraspConfig())
    assert not res.grasp.any() and res.info["single_state"] == "open"
    closed = detect_grasp(t, ratio * 0.03, ratio * 0.35, GraspConfig())  # held all along
    assert closed.grasp.all() and closed.info["single_state"] == "closed"


def test_short_states_are_dropped() -> None:
    from dexlfd.motion import drop_short_runs

    t = np.arange(20) / 30.0
    s = np.zeros(20, bool)
    s[5:7] = True  # 2 frames = 0.067 s: a blip
    s[10:18] = True  # 8 frames: a real grasp, with a 1-frame release inside
    s[13] = False
    out = drop_short_runs(s, t, 0.15)
    assert out.tolist() == [10 <= i < 18 for i in range(20)]
    assert s[5] and not s[13]  # input untouched


def test_aperture_ratio_is_scale_free(rng: np.random.Generator) -> None:
    from dexlfd.motion import aperture_ratio

    kp = rng.normal(0, 0.05, (10, 21, 3))
    uv = rng.normal(300, 40, (10, 21, 2))
    r = aperture_ratio(kp, uv)
    np.testing.assert_allclose(aperture_ratio(3.7 * kp, 0.5 * uv), r, rtol=1e-12)
    d = np.linalg.norm(kp[:, 4] - kp[:, 8], axis=1) / np.linalg.norm(kp[:, 9] - kp[:, 0], axis=1)
    np.testing.assert_allclose(aperture_ratio(kp), d, rtol=1e-12)


def test_gripper_is_clipped_to_a_hand_range(caplog: pytest.LogCaptureFixture) -> None:
    from dexlfd.motion.demonstration import HAND_APERTURE_MAX_M

    t = np.arange(5) / 30.0
    kp = np.zeros((5, 21, 3))
    kp[:, 9, 0] = 0.1
    kp[:, 8, 1] = np.array([0.05, 0.1, 0.5, 5.0, 0.05])  # metres: 5 m is no hand
    with caplog.at_level(logging.WARNING):
        demo = demonstration_from_keypoints(t, kp, cfg=MotionConfig(max_gap_s=0.0))
    assert demo.gripper.max() == HAND_APERTURE_MAX_M
    assert demo.gripper[0] == pytest.approx(0.05)
    assert "above a hand's range" in caplog.text
