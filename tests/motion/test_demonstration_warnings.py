"""The motion stage's orientation-jump warning: true for the euler mode in use."""

from __future__ import annotations

import logging

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dexlfd.datasets.hands import hand_keypoints_from_pose
from dexlfd.motion import MotionConfig, demonstration_from_keypoints


def _swinging_hand(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A rigid hand (fingers never move) that turns 150 deg about the vertical in one frame."""
    n = 20
    yaw = np.where(np.arange(n) < 10, 0.0, 150.0)
    q = Rotation.from_euler("z", yaw[:, None], degrees=True).as_quat()
    pos = np.tile([0.5, 0.0, 0.3], (n, 1))
    kp = hand_keypoints_from_pose(pos, q, np.full(n, 0.08), rng)
    return np.arange(n) / 30.0, kp


def _jump_warnings(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if "orientation jumps" in r.getMessage()]


@pytest.mark.parametrize("mode", ["palm", "heading", "thesis", "triad"])
def test_orientation_jump_warning_names_the_mode_in_use(
    rng: np.random.Generator, caplog: pytest.LogCaptureFixture, mode: str
) -> None:
    t, kp = _swinging_hand(rng)
    with caplog.at_level(logging.WARNING):
        demonstration_from_keypoints(t, kp, cfg=MotionConfig(euler_mode=mode))
    (msg,) = _jump_warnings(caplog)
    assert "1 time(s)" in msg
    assert "triad" not in msg or mode == "triad"  # never recommends the 163-deg mode
    if mode == "palm":
        # the palm frame does not read the fingertips: no claim that they caused it
        assert "palm frame" in msg and "thumb" not in msg and "euler_mode" not in msg
    else:
        assert f"euler_mode {mode} reads the thumb and index tips" in msg
        assert "euler_mode palm uses the rigid palm" in msg
