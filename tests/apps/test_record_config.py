"""RecordConfig is composed of the capture and motion stage configs, resolved per source."""

from __future__ import annotations

import dataclasses

import pytest

from dexlfd.apps.record import RecordConfig, capture_config, motion_config, setting
from dexlfd.capture import CaptureConfig, open_source
from dexlfd.data import hand_video
from dexlfd.errors import InvalidInput
from dexlfd.motion import MotionConfig


def test_defaults_are_the_stage_configs_with_the_recording_choices() -> None:
    cfg = RecordConfig()
    assert isinstance(cfg.capture, CaptureConfig) and isinstance(cfg.motion, MotionConfig)
    assert cfg.capture.tracker.max_num_hands == 2  # the most active of two hands is followed
    assert (cfg.motion.smoothing, cfg.motion.mount, cfg.motion.euler_mode) == (
        "one_euro", "top_grasp", "palm",
    )  # fmt: skip
    assert (
        setting(cfg, "capture.lift.assumed_wrist_depth_m") == cfg.capture.lift.assumed_wrist_depth_m
    )


def test_capture_config_resolves_lift_intrinsics_and_hand_from_the_source() -> None:
    base = RecordConfig(hand="left", intrinsics_px=(900.0, 900.0, 640.0, 360.0), resize_width=320)
    with open_source(str(hand_video()), resize_width=320) as src:
        assert src.native_size == (1280, 720)  # as decoded, before resizing
        cap = capture_config(src, base)
    assert cap.lift.model == "pnp"  # an RGB video file
    assert (cap.lift.intrinsics.width, cap.lift.intrinsics.height) == (1280, 720)
    assert cap.tracker.hand == "left" and cap.tracker.max_num_hands == 2
    assert base.capture.lift.intrinsics is None  # the config itself is unchanged
    assert motion_config(base, "left").hand == "left"
    assert motion_config(base, "left").smoothing == base.motion.smoothing


def test_bounds_name_the_setting() -> None:
    capture = dataclasses.replace(RecordConfig().capture, assumed_hfov_deg=179.5)
    with pytest.raises(InvalidInput, match=r"CaptureConfig.assumed_hfov_deg must be in \[1, 179\]"):
        RecordConfig(capture=capture)
    with pytest.raises(InvalidInput, match="lift must be one of"):
        RecordConfig(lift="stereo")


def test_max_gap_s_is_from_the_frame_rate_or_the_record_setting() -> None:
    from dexlfd.apps.record import default_max_gap_s
    from dexlfd.cli import _build_parser, _subparser, error_text

    assert motion_config(RecordConfig(), "right", fps=8.0).max_gap_s == default_max_gap_s(8.0)
    assert motion_config(RecordConfig(max_gap_s=0.4), "right", fps=8.0).max_gap_s == 0.4
    with pytest.raises(InvalidInput) as err:
        RecordConfig(max_gap_s=9.0)
    flags = {c: _subparser(_build_parser(), c).get_default("_params") for c in ("record", "teleop")}
    assert error_text(err.value, flags["record"]).startswith("--max-gap-s must be in")
    # teleop has no --max-gap-s: its errors never name one
    assert "max_gap_s" in flags["record"] and "max_gap_s" not in flags["teleop"]
