"""plan.moves: the approach and lift moves on the minimum-jerk profile."""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.control import approach_plan as approach_from_control
from dexlfd.plan.moves import approach_plan
from dexlfd.rotations import matrix_from_quat, rotation_angle
from dexlfd.trajectory import MIN_JERK_PEAK_SPEED


def test_approach_reaches_the_pose_with_the_speed_bound() -> None:
    assert approach_from_control is approach_plan  # the old name still imports
    p0, p1 = np.array([0.4, -0.1, 0.3]), np.array([0.55, 0.1, 0.45])
    R0 = np.eye(3)
    R1 = matrix_from_quat(np.array([0.0, 0.0, np.sin(0.3), np.cos(0.3)]))  # 0.6 rad about z
    plan = approach_plan(p0, R0, p1, R1, max_speed=0.1, max_angular_speed=0.5, dt=0.001)
    dist = float(np.linalg.norm(p1 - p0))
    T = float(plan.t[-1])
    assert pytest.approx(max(1.0, MIN_JERK_PEAK_SPEED * dist / 0.1), abs=1e-3) == T
    np.testing.assert_allclose(plan.position[0], p0, atol=1e-12)
    np.testing.assert_allclose(plan.position[-1], p1, atol=1e-6)
    R_end = matrix_from_quat(plan.quaternion[-1])
    assert float(rotation_angle(R_end, R1)) < 1e-6
    speed = np.linalg.norm(plan.velocity, axis=1)
    assert speed.max() <= 0.1 + 1e-9 and speed.max() == pytest.approx(0.1, rel=1e-3)
    # velocity and acceleration are the derivatives of the sampled path
    np.testing.assert_allclose(np.gradient(plan.position, plan.t, axis=0), plan.velocity, atol=2e-4)
    np.testing.assert_allclose(
        np.gradient(plan.velocity, plan.t, axis=0), plan.acceleration, atol=2e-3
    )
    w = np.linalg.norm(plan.angular_velocity, axis=1)
    assert w.max() == pytest.approx(MIN_JERK_PEAK_SPEED * 0.6 / T, rel=1e-3)
