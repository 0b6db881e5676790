from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dexlfd.errors import InvalidInput
from dexlfd.motion import (
    MOUNTS,
    euler_from_keypoints,
    euler_from_quat,
    gripper_opening,
    hand_quat_from_euler,
    pose_from_keypoints,
    quat_from_euler,
)


def _hand(wrist, thumb, index) -> np.ndarray:
    kp = np.zeros((21, 3))
    kp[:] = wrist
    kp[0], kp[4], kp[8] = wrist, thumb, index
    return kp


def test_rest_pose_is_zero_and_quaternion_is_the_mount() -> None:
    # right hand palm down, fingers +x: thumb tip ahead of the wrist, on the +y side of the index
    kp = _hand([0.1, 0.2, 0.3], [0.19, 0.25, 0.3], [0.19, 0.2, 0.3])
    np.testing.assert_allclose(euler_from_keypoints(kp), 0.0, atol=1e-12)
    pose = pose_from_keypoints(kp)
    np.testing.assert_allclose(pose.position, [0.1, 0.2, 0.3], atol=0)
    np.testing.assert_allclose(pose.quaternion, MOUNTS["thesis"], atol=1e-12)
    np.testing.assert_allclose(pose.gripper, 0.05, atol=1e-12)


def test_euler_closed_forms_and_quadrants() -> None:
    # Eq. (4.11) with atan2: numerators and denominators as printed
    w, t, i = np.array([0.0, 0, 0]), np.array([-0.03, 0.02, -0.04]), np.array([0.05, -0.01, 0.02])
    psi, theta, phi = euler_from_keypoints(_hand(w, t, i), mode="thesis")
    assert psi == pytest.approx(np.arctan2(i[0] - t[0], t[1] - i[1]), abs=1e-15)
    assert theta == pytest.approx(np.arctan2(w[2] - t[2], t[0] - w[0]), abs=1e-15)
    assert phi == pytest.approx(np.arctan2(i[2] - t[2], t[1] - i[1]), abs=1e-15)
    # thumb behind the wrist: arctan of the ratio would report -53 deg, atan2 keeps 127 deg
    assert abs(theta) > np.pi / 2
    assert abs(np.arctan((w[2] - t[2]) / (t[0] - w[0]))) < np.pi / 2
    # heading mode: the same ratios along f = (cos psi, sin psi, 0), l = (-sin psi, cos psi, 0)
    f = np.array([np.cos(psi), np.sin(psi), 0.0])
    lat = np.array([-np.sin(psi), np.cos(psi), 0.0])
    h = euler_from_keypoints(_hand(w, t, i))
    assert h[0] == psi
    assert h[1] == pytest.approx(np.arctan2(w[2] - t[2], (t - w) @ f), abs=1e-15)
    assert h[2] == pytest.approx(np.arctan2(t[2] - i[2], (t - i) @ lat), abs=1e-15)


def test_composition_matches_scipy_intrinsic_xyz(rng: np.random.Generator) -> None:
    euler = rng.uniform(-np.pi, np.pi, (50, 3))
    q = hand_quat_from_euler(euler)
    # H_x(phi) H_y(theta) H_z(psi) = intrinsic rotations x, then y, then z
    ref = Rotation.from_euler("XYZ", euler[:, [2, 1, 0]]).as_quat()
    np.testing.assert_allclose(np.abs(np.sum(q * ref, axis=1)), 1.0, atol=1e-12)
    full = quat_from_euler(euler)
    ref_full = (Rotation.from_quat(ref) * Rotation.from_euler("y", 90, degrees=True)).as_quat()
    np.testing.assert_allclose(np.abs(np.sum(full * ref_full, axis=1)), 1.0, atol=1e-12)


@pytest.mark.parametrize("mount", sorted(MOUNTS))
def test_euler_from_quat_inverts(rng: np.random.Generator, mount: str) -> None:
    euler = np.column_stack(
        [rng.uniform(-3, 3, 40), rng.uniform(-1.5, 1.5, 40), rng.uniform(-3, 3, 40)]
    )
    back = euler_from_quat(quat_from_euler(euler, mount), mount)
    np.testing.assert_allclose(back, euler, atol=1e-9)


def test_rigid_rotation_about_z_changes_only_yaw() -> None:
    kp = _hand([0, 0, 0], [0.09, 0.05, -0.02], [0.17, 0.03, 0.01])
    base = euler_from_keypoints(kp)
    for yaw in np.radians([-170, -90, -30, 0, 45, 135, 179]):
        R = Rotation.from_euler("z", yaw).as_matrix()
        e = euler_from_keypoints(kp @ R.T)
        assert np.angle(np.exp(1j * (e[0] - base[0] - yaw))) == pytest.approx(0, abs=1e-12)
        np.testing.assert_allclose(e[1:], base[1:], atol=1e-12)
        # the printed form reads a hand yawed past 90 deg as pitched by ~180 deg
        if abs(yaw) > np.radians(100):
            assert abs(euler_from_keypoints(kp @ R.T, mode="thesis")[1]) > np.pi / 2


def test_thesis_and_heading_modes_agree_at_zero_yaw(rng: np.random.Generator) -> None:
    kp = rng.normal(0, 0.05, (30, 21, 3))
    kp[:, 8, 0] = kp[:, 4, 0]  # index tip straight across from the thumb tip: yaw 0
    kp[:, 4, 1] = kp[:, 8, 1] + 0.03
    # same yaw and pitch; the roll has the opposite sign (see euler_from_keypoints)
    np.testing.assert_allclose(
        euler_from_keypoints(kp, mode="thesis") * [1, 1, -1], euler_from_keypoints(kp), atol=1e-12
    )


def test_left_hand_mirror_rest_pose_is_zero() -> None:
    right = _hand([0, 0, 0], [0.09, 0.05, 0.0], [0.09, 0.0, 0.0])
    left = right * np.array([1.0, -1.0, 1.0])
    np.testing.assert_allclose(euler_from_keypoints(left, "left"), 0.0, atol=1e-12)
    # as a right hand, the mirrored rest pose is yaw/roll = pi (the quadrant atan2 keeps)
    assert abs(euler_from_keypoints(left, "right")[0]) == pytest.approx(np.pi)
    with pytest.raises(InvalidInput, match="hand must be one of"):
        euler_from_keypoints(left, "both")


def test_series_is_unwrapped_and_sign_continuous() -> None:
    yaw = np.linspace(0, 4 * np.pi, 200)  # two full turns
    base = _hand([0, 0, 0], [0.09, 0.05, 0.0], [0.1, 0.0, 0.0])
    kp = np.stack([base @ Rotation.from_euler("z", a).as_matrix().T for a in yaw])
    kp[50] = np.nan  # an unseen frame is skipped, not a break
    pose = pose_from_keypoints(kp)
    e = pose.euler[:, 0]
    ok = np.isfinite(e)
    np.testing.assert_allclose(e[ok] - e[ok][0], yaw[ok] - yaw[0], atol=1e-9)
    q = pose.quaternion[ok]
    assert (np.sum(q[1:] * q[:-1], axis=1) > 0).all()
    assert np.isnan(pose.quaternion[50]).all() and np.isnan(pose.gripper[50])


def test_gripper_is_thumb_index_distance(rng: np.random.Generator) -> None:
    kp = rng.normal(size=(10, 21, 3))
    np.testing.assert_allclose(
        gripper_opening(kp), np.sqrt(((kp[:, 4] - kp[:, 8]) ** 2).sum(-1)), rtol=1e-14
    )


def test_bad_keypoint_shape() -> None:
    with pytest.raises(InvalidInput, match=r"\(\.\.\., 21, 3\)"):
        pose_from_keypoints(np.zeros((5, 20, 3)))


def test_triad_recovers_rigid_rotations(rng: np.random.Generator) -> None:
    from dexlfd.motion import hand_matrix_from_keypoints

    rest = _hand([0, 0, 0], [0.09, 0.05, 0.0], [0.09, 0.0, 0.0])
    np.testing.assert_allclose(hand_matrix_from_keypoints(rest), np.eye(3), atol=1e-12)
    R = Rotation.random(40, random_state=3)
    kp = np.einsum("nij,kj->nki", R.as_matrix(), rest) + rng.normal(0, 1, (40, 1, 3))
    pose = pose_from_keypoints(kp, mode="triad", mount="identity")
    np.testing.assert_allclose(_dots(pose.quaternion, R.as_quat()), 1, atol=1e-12)
    # single-axis rotations: the same Euler angles as Eq. (4.11) in heading form (about x
    # the heading pitch also sees the thumb rise, as the thumb sits beside the index)
    for axis, dims in (("z", [0, 1, 2]), ("y", [0, 1, 2]), ("x", [0, 2])):
        Rk = Rotation.from_euler(axis, 0.4).as_matrix()
        np.testing.assert_allclose(
            euler_from_keypoints(rest @ Rk.T, mode="triad")[dims],
            euler_from_keypoints(rest @ Rk.T)[dims],
            atol=1e-12,
        )
    # the printed roll has the opposite sign of the hand's (right-handed) roll
    Rx = Rotation.from_euler("x", 0.4).as_matrix()
    assert euler_from_keypoints(rest @ Rx.T, mode="thesis")[2] == pytest.approx(-0.4)


def _dots(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(np.sum(a * b, axis=-1))


def test_triad_is_continuous_where_three_point_euler_is_singular() -> None:
    rest = _hand([0, 0, 0], [0.09, 0.05, 0.0], [0.09, 0.0, 0.0])
    # roll the hand through 90 deg (thumb straight above the index tip) while it yaws a
    # little: a smooth motion of 0.4 deg per frame
    a = np.linspace(0, 1, 101)[:, None]
    R = Rotation.from_euler("x", np.pi / 2 * (0.8 + 0.4 * a)) * Rotation.from_euler("z", 0.2 * a)
    kp = np.einsum("nij,kj->nki", R.as_matrix(), rest)
    step_true = np.degrees((R[1:] * R[:-1].inv()).magnitude())
    tri = pose_from_keypoints(kp, mode="triad").quaternion
    head = pose_from_keypoints(kp).quaternion
    step_tri = np.degrees(2 * np.arccos(np.clip(_dots(tri[1:], tri[:-1]), 0, 1)))
    step_head = np.degrees(2 * np.arccos(np.clip(_dots(head[1:], head[:-1]), 0, 1)))
    np.testing.assert_allclose(step_tri, step_true, rtol=1e-6, atol=1e-6)
    # the Euler angles of Eq. (4.11) lose the yaw where the thumb-index vector is vertical
    assert step_head.max() > 5 * step_true.max()


def test_palm_frame_is_the_rotation_of_a_rigid_hand(rng: np.random.Generator) -> None:
    from dexlfd.motion import palm_matrix_from_keypoints
    from dexlfd.rotations import matrix_from_quat

    rest = np.zeros((21, 3))  # right hand, palm down, fingers along +x, thumb side +y
    rest[5] = (0.09, 0.03, 0.0)  # index MCP
    rest[17] = (0.08, -0.035, 0.005)  # pinky MCP
    rest[9] = (0.09, 0.0, 0.0)
    np.testing.assert_allclose(palm_matrix_from_keypoints(rest), np.eye(3), atol=0.1)  # near I
    R0 = palm_matrix_from_keypoints(rest)
    q = rng.normal(size=(50, 4))
    R = matrix_from_quat(q / np.linalg.norm(q, axis=1, keepdims=True))
    moved = np.einsum("nij,kj->nki", R, rest) + rng.normal(0, 1, (50, 1, 3))  # rotate, shift
    np.testing.assert_allclose(palm_matrix_from_keypoints(moved), R @ R0, atol=1e-12)
    # fingers do not turn it: move every fingertip and the thumb
    curled = moved.copy()
    curled[:, [4, 8, 12, 16, 20]] += rng.normal(0, 0.05, (50, 5, 3))
    np.testing.assert_allclose(palm_matrix_from_keypoints(curled), R @ R0, atol=1e-12)
    # a left hand (mirror image through the x-z plane) has the same rest frame
    left = rest * np.array([1.0, -1.0, 1.0])
    flip = np.array([[1, -1, 1], [-1, 1, -1], [1, -1, 1]])  # R0 mirrored through y
    np.testing.assert_allclose(palm_matrix_from_keypoints(left, "left"), R0 * flip, atol=1e-12)
