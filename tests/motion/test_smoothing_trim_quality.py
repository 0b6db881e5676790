"""One Euro filter, idle trim and the quality report, on series with known answers."""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.motion import (
    MotionConfig,
    OneEuroFilter,
    SmoothingConfig,
    demonstration_from_keypoints,
    format_quality,
    jitter_mm,
    motion_span,
    quality_report,
    smooth_keypoints,
    trim_demonstration,
)


def test_one_euro_is_an_exponential_smoother_at_rest() -> None:
    """With beta = 0 the filter is x_hat = a x + (1 - a) x_hat_prev, a = 1 / (1 + tau / dt)."""
    cfg = SmoothingConfig(min_cutoff_hz=2.0, beta=0.0)
    f = OneEuroFilter(cfg)
    dt = 1 / 30
    a = 1 / (1 + 1 / (2 * np.pi * 2.0) / dt)
    x = np.array([0.0, 1.0, 1.0, 1.0])
    out = [float(f.filter(np.array(v), i * dt)) for i, v in enumerate(x)]
    expect = [0.0, a, a + (1 - a) * a, 1 - (1 - a) ** 3]
    np.testing.assert_allclose(out, expect, rtol=1e-12)
    with pytest.raises(InvalidInput, match="times must increase"):
        f.filter(np.array(1.0), 0.0)


def test_one_euro_smooths_rest_and_follows_motion(rng: np.random.Generator) -> None:
    """Noise at rest is cut; a fast move lags less than under the fixed-cut-off filter."""
    t = np.arange(300) / 30.0
    truth = np.where(t < 5, 0.0, np.minimum((t - 5) * 0.5, 0.3))  # rest, 0.5 m/s move, rest
    noisy = truth + rng.normal(0, 0.002, t.size)
    kp = np.repeat(noisy[:, None, None], 3, axis=2).repeat(21, axis=1)
    valid = np.ones(t.size, bool)
    euro = smooth_keypoints(t, kp, valid, SmoothingConfig())[:, 0, 0]
    fixed = smooth_keypoints(t, kp, valid, SmoothingConfig(beta=0.0))[:, 0, 0]
    rest = t < 4.5
    assert np.std(euro[rest] - truth[rest]) < 0.5 * np.std(noisy[rest] - truth[rest])
    moving = (t > 5.2) & (t < 5.55)
    assert np.abs(euro - truth)[moving].max() < 0.5 * np.abs(fixed - truth)[moving].max()


def test_smoothing_restarts_after_a_gap_and_keeps_nan() -> None:
    t = np.arange(10) / 30.0
    kp = np.zeros((10, 21, 3))
    kp[6:] = 1.0
    valid = np.ones(10, bool)
    valid[4:6] = False
    kp[4:6] = np.nan
    out = smooth_keypoints(t, kp, valid, SmoothingConfig())
    assert np.isnan(out[4:6]).all()
    np.testing.assert_array_equal(out[6], 1.0)  # the run after the gap starts fresh
    mean = smooth_keypoints(t, kp, valid, SmoothingConfig(method="mean", window=3))
    np.testing.assert_allclose(mean[:4], 0.0)


def test_trim_cuts_the_idle_start_and_end_and_keeps_the_grasp() -> None:
    t = np.arange(300) / 30.0  # 10 s: idle until 3 s, move to 6 s, idle
    x = np.clip((t - 3.0) / 3.0, 0, 1) * 0.3
    pos = np.stack([x, 0 * x, 0 * x], 1)
    valid = np.ones(t.size, bool)
    start, stop, moved = motion_span(t, pos, valid)
    assert moved
    assert t[start] == pytest.approx(3.0 - 0.3, abs=0.05) and t[stop - 1] == pytest.approx(
        6.0 + 0.3, abs=0.05
    )
    grasp = (t > 1.0) & (t < 5.0)  # grasped before moving: kept
    start2, _, _ = motion_span(t, pos, valid, grasp)
    assert t[start2] <= 1.0 - 0.3 + 1e-9
    # jitter only: nothing is cut
    still = np.random.default_rng(0).normal(0, 0.001, pos.shape)
    assert motion_span(t, still, valid) == (0, t.size, False)


def _pick_place(rng: np.random.Generator, move: bool = True, grasp: bool = True):
    """Keypoints of a hand that rests, carries 30 cm while pinching, rests."""
    t = np.arange(240) / 30.0
    kp = np.zeros((t.size, 21, 3))
    kp[:, 9] = (0.09, 0, 0)
    kp[:, 5] = (0.09, 0.03, 0)
    kp[:, 17] = (0.08, -0.035, 0)
    kp[:, 8] = (0.15, 0.0, 0)
    closed = (t > 2.5) & (t < 5.5) if grasp else np.zeros(t.size, bool)
    kp[:, 4] = np.where(closed[:, None], (0.15, 0.03, 0), (0.12, 0.08, 0))
    shift = np.clip((t - 2.0) / 4.0, 0, 1) * 0.3 if move else 0 * t
    kp[..., 0] += shift[:, None]
    kp += rng.normal(0, 0.0005, kp.shape)
    return t, kp


def test_quality_report_of_a_good_and_of_unusable_demonstrations(
    rng: np.random.Generator,
) -> None:
    cfg = MotionConfig(smoothing="one_euro", euler_mode="palm")
    t, kp = _pick_place(rng)
    demo = trim_demonstration(demonstration_from_keypoints(t, kp, cfg=cfg))
    q = quality_report(demo)
    assert q.usable and not q.warnings
    assert len(q.grasp_intervals_s) == 1
    a, b = q.grasp_intervals_s[0]
    assert a == pytest.approx(2.5, abs=0.1) and b == pytest.approx(5.5, abs=0.1)
    assert 0.25 < q.travel_extent_m < 0.31
    assert q.trimmed.start_s > 1.0 and q.trimmed.end_s > 1.0
    assert q.max_orientation_step_deg < 5
    assert "usable" in format_quality("demo", q)
    # a hand that neither moves nor grasps, and one lost half of the time
    t, kp = _pick_place(rng, move=False, grasp=False)
    valid = np.ones(t.size, bool)
    valid[60:180] = False
    bad = quality_report(demonstration_from_keypoints(t, kp, valid, cfg=cfg))
    assert not bad.usable
    text = " ".join(bad.warnings)
    assert "no grasp event" in text and "no motion" in text and "hand lost" in text
    assert "NOT USABLE" in format_quality("bad", bad)


def test_jitter_of_a_straight_line_is_the_noise(rng: np.random.Generator) -> None:
    t = np.arange(600) / 30.0
    line = np.stack([0.1 * t, 0.05 * t, 0 * t], 1)
    assert jitter_mm(t, line, np.ones(t.size, bool)) == pytest.approx(0.0, abs=1e-9)
    noise = rng.normal(0, 0.001, line.shape)  # 1 mm per axis
    j = jitter_mm(t, line + noise, np.ones(t.size, bool))
    # residual of white noise around a 5-sample mean: sqrt(3 * (1 - 1/5)) mm
    assert j == pytest.approx(np.sqrt(3 * 0.8), rel=0.1)
