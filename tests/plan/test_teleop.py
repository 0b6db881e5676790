from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dexlfd.errors import InvalidInput
from dexlfd.plan.teleop import TeleopConfig, teleop_init, teleop_step

Q_DOWN = np.array([1.0, 0.0, 0.0, 0.0])
P0 = np.array([0.45, 0.0, 0.4])


def _run(cfg, hand, rate_hz=30.0):
    state = teleop_init(0.0, P0, Q_DOWN, 0.08)
    out = []
    for i, (p, q, g) in enumerate(hand, start=1):
        state, target = teleop_step(state, i / rate_hz, p, q, g, cfg)
        out.append(target)
    return out


def test_relative_retargeting_converges_to_offset() -> None:
    cfg = TeleopConfig()
    hand_q = Rotation.from_euler("z", 0.3).as_quat()
    first = (np.array([1.0, 2.0, 3.0]), np.array([0, 0, 0, 1.0]), 0.05)
    moved = (np.array([1.1, 2.0, 3.05]), hand_q, 0.02)
    out = _run(cfg, [first] + [moved] * 90)
    np.testing.assert_allclose(out[0].position, P0, atol=1e-12)  # anchor: no jump at first sight
    np.testing.assert_allclose(out[-1].position, P0 + [0.1, 0.0, 0.05], atol=1e-6)
    expected_q = (Rotation.from_quat(hand_q) * Rotation.from_quat(Q_DOWN)).as_quat()
    assert abs(np.dot(out[-1].quaternion, expected_q)) == pytest.approx(1.0, abs=1e-9)
    assert out[-1].gripper == pytest.approx(0.02, abs=1e-6)


def test_rate_limits_and_workspace_clamp() -> None:
    cfg = TeleopConfig(max_speed=0.3, smoothing_s=0.0)
    first = (np.zeros(3), np.array([0, 0, 0, 1.0]), 0.08)
    far = (np.array([5.0, 0.0, 0.0]), np.array([0, 0, 0, 1.0]), 0.08)  # 5 m: glitch
    out = _run(cfg, [first] + [far] * 120)
    p = np.array([o.position for o in out])
    steps = np.linalg.norm(np.diff(p, axis=0), axis=1)
    assert steps.max() <= 0.3 / 30 + 1e-12
    assert p[:, 0].max() == pytest.approx(cfg.workspace_max[0])


def test_hand_lost_holds_then_resumes_smoothly() -> None:
    cfg = TeleopConfig(max_speed=0.5)
    q = np.array([0, 0, 0, 1.0])
    hand = [(np.zeros(3), q, 0.08)] * 10 + [(None, None, None)] * 60
    hand += [(np.array([0.2, 0.0, 0.0]), q, 0.08)] * 60
    out = _run(cfg, hand)
    held = np.array([o.position for o in out[10:70]])
    np.testing.assert_array_equal(held, np.tile(out[9].position, (60, 1)))
    assert not any(o.tracking for o in out[10:70])
    p = np.array([o.position for o in out])
    assert np.linalg.norm(np.diff(p, axis=0), axis=1).max() <= 0.5 / 30 + 1e-12
    np.testing.assert_allclose(out[-1].position, P0 + [0.2, 0, 0], atol=1e-4)


def test_bad_config_and_time() -> None:
    with pytest.raises(InvalidInput, match="workspace_min"):
        TeleopConfig(workspace_min=(1, 0, 0), workspace_max=(0, 1, 1))
    state = teleop_init(1.0, P0, Q_DOWN, 0.08)
    with pytest.raises(InvalidInput, match="must increase"):
        teleop_step(state, 1.0, None, None, None, TeleopConfig())


def test_low_pass_after_the_limits_keeps_speed_and_box_and_starts_smoothly() -> None:
    """Filter after clamp + rate limit: the bounds survive and the ramp starts gently."""
    cfg = TeleopConfig(max_speed=0.3, smoothing_s=0.1)
    q = np.array([0, 0, 0, 1.0])
    out = _run(cfg, [(np.zeros(3), q, 0.08)] + [(np.array([5.0, 0.0, 0.0]), q, 0.08)] * 120)
    p = np.array([o.position for o in out])
    steps = np.linalg.norm(np.diff(p, axis=0), axis=1)
    assert steps.max() <= 0.3 / 30 + 1e-12  # |Δy| <= max |Δu| for the first-order filter
    assert p[:, 0].max() <= cfg.workspace_max[0] + 1e-12
    a = 1 - np.exp(-1 / 30 / 0.1)
    assert steps[0] == pytest.approx(a * 0.3 / 30, rel=1e-9)  # first step: a fraction, no jump
    np.testing.assert_allclose(p[-1, 0], cfg.workspace_max[0], atol=1e-6)


def test_reach_ball_keeps_the_command_in_box_and_ball() -> None:
    rng = np.random.default_rng(42)
    center, R = np.array([0.0, 0.0, 0.333]), 0.7
    cfg = TeleopConfig(reach_center=tuple(center), reach_radius=R, smoothing_s=0.0,
                       max_speed=1.7)  # fmt: skip
    q = np.array([0, 0, 0, 1.0])
    for _ in range(5):
        far = rng.normal(0.0, 2.0, 3)
        # one frame a second: at the Panda's 1.7 m/s the command crosses the box in a frame
        out = _run(cfg, [(np.zeros(3), q, 0.08), (far, q, 0.08)], rate_hz=1.0)
        p = out[-1].position
        assert np.linalg.norm(p - center) <= R + 1e-12
        assert (p >= np.array(cfg.workspace_min) - 1e-12).all()
        assert (p <= np.array(cfg.workspace_max) + 1e-12).all()
        # on the segment from the start pose to the box-clamped command, at the sphere
        c = np.clip(P0 + far, cfg.workspace_min, cfg.workspace_max)
        if np.linalg.norm(c - center) > R:
            assert np.linalg.norm(p - center) == pytest.approx(R, abs=1e-9)
            d, e = c - P0, p - P0
            np.testing.assert_allclose(np.cross(d, e), 0.0, atol=1e-12)
            assert 0 < e @ d <= d @ d
        else:
            np.testing.assert_allclose(p, c, atol=1e-12)
    with pytest.raises(InvalidInput, match="reach_radius"):
        TeleopConfig(reach_radius=-1.0)
