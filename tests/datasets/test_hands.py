from __future__ import annotations

import numpy as np
import pytest

from dexlfd.datasets import (
    HandModelConfig,
    demonstration_with_hand,
    hand_keypoints_from_pose,
    pick_place_demonstrations,
)
from dexlfd.errors import InvalidInput
from dexlfd.motion import euler_from_keypoints, pose_from_keypoints, quat_from_euler


def _same_rotation(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    return np.abs(np.sum(q1 * q2, axis=-1))


def test_pick_place_round_trip(rng: np.random.Generator) -> None:
    for demo in pick_place_demonstrations(3, rng):
        out = demonstration_with_hand(demo, rng)
        assert np.isfinite(out.keypoints).all()
        np.testing.assert_allclose(out.position, demo.position, atol=1e-12)
        np.testing.assert_allclose(_same_rotation(out.quaternion, demo.quaternion), 1, atol=1e-12)
        np.testing.assert_allclose(out.gripper, demo.gripper, atol=1e-12)
        assert out.motion.mount == "top_grasp"
        # the grasp phase (gripper closed on the object) is found from the keypoints
        assert out.grasp[np.argmin(demo.gripper)] and not out.grasp[0]


@pytest.mark.parametrize("hand", ["right", "left"])
def test_random_poses_round_trip_thesis_mount(rng: np.random.Generator, hand: str) -> None:
    n = 200
    lim = np.radians(80)
    euler = rng.uniform(-lim, lim, (n, 3))
    q = quat_from_euler(euler)
    p = rng.uniform(-0.5, 0.5, (n, 3))
    g = rng.uniform(0.005, 0.15, n)
    kp = hand_keypoints_from_pose(p, q, g, rng, hand=hand)
    pose = pose_from_keypoints(kp, hand)
    np.testing.assert_allclose(pose.position, p, atol=1e-12)
    np.testing.assert_allclose(_same_rotation(pose.quaternion, q), 1, atol=1e-9)
    np.testing.assert_allclose(pose.gripper, g, atol=1e-12)
    # hand-like: wrist-to-middle-MCP distance within the template's scale range
    palm = np.linalg.norm(kp[:, 9] - kp[:, 0], axis=1)
    assert ((palm > 0.07) & (palm < 0.12)).all()


def test_keypoint_noise_changes_pose_only_slightly(rng: np.random.Generator) -> None:
    demo = pick_place_demonstrations(1, rng)[0]
    out = demonstration_with_hand(demo, rng, HandModelConfig(keypoint_noise=0.001))
    # 1 mm landmark noise: position error ~1 mm, opening error ~1.4 mm
    assert np.abs(out.position - demo.position).max() < 0.006
    assert np.abs(out.gripper - demo.gripper).max() < 0.008


def test_any_orientation_round_trips_in_heading_mode(rng: np.random.Generator) -> None:
    from scipy.spatial.transform import Rotation

    q = Rotation.random(300, random_state=1).as_quat()
    kp = hand_keypoints_from_pose(np.zeros((300, 3)), q, np.full(300, 0.06), rng)
    pose = pose_from_keypoints(kp)
    np.testing.assert_allclose(_same_rotation(pose.quaternion, q), 1, atol=1e-9)


def test_thesis_mode_round_trip_and_inexpressible_orientation(rng: np.random.Generator) -> None:
    euler = rng.uniform(-1.3, 1.3, (50, 3))
    q = quat_from_euler(euler)
    kp = hand_keypoints_from_pose(np.zeros((50, 3)), q, np.full(50, 0.05), rng, mode="thesis")
    pose = pose_from_keypoints(kp, mode="thesis")
    np.testing.assert_allclose(_same_rotation(pose.quaternion, q), 1, atol=1e-9)
    # yaw 0 and roll 180 deg: cosines of opposite sign cannot come from the printed Eq. (4.11)
    q = quat_from_euler(np.array([[0.0, 0.2, np.pi - 0.1]]))
    with pytest.raises(InvalidInput, match="not expressible"):
        hand_keypoints_from_pose(np.zeros((1, 3)), q, np.array([0.05]), rng, mode="thesis")


def test_zero_opening_is_rejected(rng: np.random.Generator) -> None:
    with pytest.raises(InvalidInput, match="gripper must be > 0"):
        hand_keypoints_from_pose(np.zeros((1, 3)), np.array([[0, 0, 0, 1.0]]), np.array([0.0]), rng)


def test_nan_rows_stay_nan(rng: np.random.Generator) -> None:
    p = np.zeros((3, 3))
    p[1] = np.nan
    q = np.tile(quat_from_euler(np.zeros(3)), (3, 1))
    kp = hand_keypoints_from_pose(p, q, np.full(3, 0.05), rng)
    assert np.isnan(kp[1]).all() and np.isfinite(kp[[0, 2]]).all()
    np.testing.assert_allclose(euler_from_keypoints(kp[0]), 0, atol=1e-12)


def test_deterministic(rng: np.random.Generator) -> None:
    demo = pick_place_demonstrations(1, np.random.default_rng(3))[0]
    a = demonstration_with_hand(demo, np.random.default_rng(7))
    b = demonstration_with_hand(demo, np.random.default_rng(7))
    np.testing.assert_array_equal(a.keypoints, b.keypoints)


def test_triad_mode_round_trip(rng: np.random.Generator) -> None:
    from scipy.spatial.transform import Rotation

    q = Rotation.random(100, random_state=5).as_quat()
    g = rng.uniform(0.01, 0.1, 100)
    for hand in ("right", "left"):
        kp = hand_keypoints_from_pose(np.zeros((100, 3)), q, g, rng, hand=hand, mode="triad")
        pose = pose_from_keypoints(kp, hand, mode="triad")
        np.testing.assert_allclose(_same_rotation(pose.quaternion, q), 1, atol=1e-9)
        np.testing.assert_allclose(pose.gripper, g, atol=1e-12)
