"""The quality report flags motion that is mostly tracking noise."""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.data import hand_video as _packaged_video
from dexlfd.motion.quality import (
    MAX_P99_SPEED,
    MAX_PATH_RATIO,
    format_quality,
    jitter_dominated,
    quality_report,
)

VIDEO = _packaged_video()


def test_jitter_dominated_thresholds() -> None:
    assert jitter_dominated(0.3, 0.1, 1.0) is None  # a pick and place: path 3x extent
    why = jitter_dominated(0.72, 0.048, 0.2)
    assert why is not None and "15 times its extent (4.8 cm)" in why
    assert jitter_dominated(MAX_PATH_RATIO * 0.1 * 0.99, 0.1, 0.5) is None
    jumps = jitter_dominated(0.3, 0.1, MAX_P99_SPEED + 0.5)
    assert jumps is not None and "2.50 m/s" in jumps


def test_real_pick_and_place_like_motion_is_not_jitter(rng: np.random.Generator) -> None:
    from dexlfd.datasets import pick_place_demonstrations

    for demo in pick_place_demonstrations(3, rng):
        q = quality_report(demo)
        assert not [w for w in q.warnings if "jitter" in w or "jumpy" in w], q.warnings
        assert q.travel_path_m < 4 * q.travel_extent_m


@pytest.mark.video
def test_the_still_hand_of_the_real_video_is_flagged_as_jitter() -> None:
    """The shared video: a hand held in place opening, making fists and pinching.

    With the pnp lift (shape-gated) its wrist extent is a few cm and its path ~15 times
    that: record called it "usable" before this check.
    """
    from dexlfd.capture import CaptureConfig, LiftConfig, open_source, track_source
    from dexlfd.motion import MotionConfig, demonstration_from_capture, trim_demonstration

    with open_source(VIDEO, resize_width=640) as src:
        series = track_source(src, CaptureConfig(lift=LiftConfig(model="pnp")))
    mcfg = MotionConfig(hand="right", smoothing="one_euro", euler_mode="palm")
    q = quality_report(trim_demonstration(demonstration_from_capture(series, mcfg)))
    assert q.travel_extent_m > 0.02  # the old "no motion" check passes
    assert q.travel_path_m > MAX_PATH_RATIO * q.travel_extent_m
    assert not q.usable
    assert any(w.startswith("jitter-dominated motion") for w in q.warnings)
    assert "NOT USABLE" in format_quality("hand", q)
