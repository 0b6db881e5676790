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
    # the loss is kept with the seen frame after it; the still, seen tail after that is cut
    assert moved and stop == 241 and valid[stop - 1]
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
    assert q.n_frames_recorded == 240 and q.detection_rate_recorded == pytest.approx(220 / 240)
    assert q.detection_rate == pytest.approx(1.0)  # of the frames kept
    text = format_quality("demo", q)
    assert f"{q.n_frames} frames" in text and "of all 240 frames" in text and "91.7 %" in text
    assert q.usable
    # the palm turned over for one frame: a tracking flip, not a demonstration
    flipped = kp.copy()
    flipped[120, :, 1] *= -1
    flipped[120, :, 2] *= -1
    bad = quality_report(demonstration_from_keypoints(t, flipped, valid, cfg=cfg))
    assert bad.max_orientation_step_deg > 90 and not bad.usable
    assert any("orientation flips" in w for w in bad.warnings)


def test_the_kept_span_starts_and_ends_on_seen_frames() -> None:
    """A loss in the idle lead-in or tail keeps only its seen neighbours, never a NaN edge."""
    t = np.arange(300) / 30.0  # moves 3-6 s, still (and seen) before and after
    x = np.clip((t - 3.0) / 3.0, 0, 1) * 0.3
    pos = np.stack([x, 0 * x, 0 * x], 1)
    valid = np.ones(t.size, bool)
    start0, stop0, _ = motion_span(t, pos, valid)
    valid[60:70] = False  # lost 2.0-2.3 s in the idle lead-in
    valid[250:280] = False  # lost 8.3-9.3 s in the idle tail
    pos[~valid] = np.nan
    start, stop, moved = motion_span(t, pos, valid)
    assert moved and valid[start] and valid[stop - 1]
    assert (start, stop) == (59, 281)  # the seen frames around the losses, not the whole ends
    assert start > 0 and stop < t.size  # trimming still cuts both ends
    assert start <= start0 and stop >= stop0
    # a span edge that falls inside a loss moves out to the seen frame around it
    valid = np.ones(t.size, bool)
    valid[start0 - 3 : start0 + 3] = False
    valid[stop0 - 3 : stop0 + 3] = False
    pos = np.stack([x, 0 * x, 0 * x], 1)
    pos[~valid] = np.nan
    start, stop, _ = motion_span(t, pos, valid)
    assert valid[start] and valid[stop - 1]
    assert start == start0 - 4 and stop == stop0 + 4
