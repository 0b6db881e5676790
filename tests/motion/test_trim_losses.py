"""Trim cuts only a hand that is seen and still; the report counts what it cut."""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.motion import (
    MotionConfig,
    demonstration_from_keypoints,
    format_quality,
    motion_span,
    quality_report,
    trim_demonstration,
)

from .test_smoothing_trim_quality import _pick_place


def test_a_lost_stretch_is_not_trimmed_as_idle() -> None:
    t = np.arange(300) / 30.0  # moves 3-6 s; lost 6.5-8 s, seen and still after
    x = np.clip((t - 3.0) / 3.0, 0, 1) * 0.3
    pos = np.stack([x, 0 * x, 0 * x], 1)
    valid = np.ones(t.size, bool)
    assert t[motion_span(t, pos, valid)[1] - 1] == pytest.approx(6.3, abs=0.05)
    valid[195:240] = False
    pos[~valid] = np.nan
    start, stop, moved = motion_span(t, pos, valid)
    assert moved and stop == 240  # the loss is kept; the still, seen tail after it is cut
    # not yet in view at the start: may be cut (it is not a loss between seen frames)
    valid[:30] = False
    pos[:30] = np.nan
    assert motion_span(t, pos, valid)[0] == pytest.approx(np.searchsorted(t, 2.7), abs=2)


def test_the_report_keeps_the_recording_wide_detection_rate_and_flags_flips(
    rng: np.random.Generator,
) -> None:
    cfg = MotionConfig(smoothing="none", euler_mode="palm")
    t, kp = _pick_place(rng)
    valid = np.ones(t.size, bool)
    valid[:20] = False  # the hand enters at 0.67 s
    kp[~valid] = np.nan
    demo = trim_demonstration(demonstration_from_keypoints(t, kp, valid, cfg=cfg))
    q = quality_report(demo)
    assert q["n_frames_recorded"] == 240 and q["detection_rate_recorded"] == pytest.approx(
        220 / 240
    )
    assert q["detection_rate"] == pytest.approx(1.0)  # of the frames kept
    text = format_quality("demo", q)
    assert f"{q['n_frames']} frames" in text and "of all 240 frames" in text and "91.7 %" in text
    assert q["usable"]
    # the palm turned over for one frame: a tracking flip, not a demonstration
    flipped = kp.copy()
    flipped[120, :, 1] *= -1
    flipped[120, :, 2] *= -1
    bad = quality_report(demonstration_from_keypoints(t, flipped, valid, cfg=cfg))
    assert bad["max_orientation_step_deg"] > 90 and not bad["usable"]
    assert any("orientation flips" in w for w in bad["warnings"])
