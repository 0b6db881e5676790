"""A recording's per-frame ``pnp`` lift: unseeded, since the whole recording's pose replaces it."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .landmark_helpers import synthetic_recording


def _captured(path: Path, seeded: bool | None) -> dict:
    """``pnp_frames`` of ``capture_recording`` (None) or of track_source, seeded or not."""
    from dexlfd.capture import CaptureConfig, LiftConfig, open_source
    from dexlfd.capture.hand_capture import HandCapture
    from dexlfd.capture.recording_capture import capture_recording, recording_tracker
    from dexlfd.capture.source_tracking import track_source

    cfg = CaptureConfig(lift=LiftConfig(model="pnp"))
    with open_source(path) as src:
        tracking = recording_tracker(src, cfg, keep_landmarks=False, redetect=False)
        if seeded is None:
            series = capture_recording(src, cfg, tracking, hand="auto").series
        else:
            with HandCapture(cfg, src.intrinsics, tracking.tracker, seeded_pnp=seeded) as cap:
                series = track_source(src, capture=cap, hand="auto")
    return {**series.meta["pnp_frames"], "valid": int(series.valid.sum())}


def test_a_recording_lifts_each_frame_alone_before_its_whole_pose(tmp_path: Path) -> None:
    """World landmarks 35 % smaller from frame 30 on: the seeded lift gates the depth jump.

    ``record``'s capture fits each frame alone (nothing gated or held, as the whole
    recording's pose replaces the depths) and keeps the same frames valid.
    """
    path = tmp_path / "rec.npz"
    synthetic_recording(path, n=60)
    data = dict(np.load(path, allow_pickle=False))
    data["world_xyz_m"][30:] *= 0.65
    np.savez(path, **data)
    seeded = _captured(path, seeded=True)
    assert seeded["gated"] >= 1  # the jump in depth
    got = _captured(path, seeded=None)
    assert got == _captured(path, seeded=False)
    assert got["gated"] == got["shape_held"] == got["failed"] == 0
    assert got["fitted"] == 60 and got["valid"] == seeded["valid"] == 60
