"""An RGB-D recording's landmarks keep the depth at each landmark: the depth models replay."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dexlfd.capture import open_source
from dexlfd.capture.landmark_recording import load_landmark_recording
from dexlfd.cli import main
from dexlfd.io import load_demonstration

from .test_realsense import FX, record_rgbd


def test_rgbd_landmarks_replay_with_the_pinhole_model(tmp_path: Path) -> None:
    from dexlfd.data import hand_video

    with open_source(hand_video(), max_frames=8, resize_width=320) as src:
        colors = [f.rgb for f in src]
    h, w = colors[0].shape[:2]
    depth = np.full((h, w), 600, np.uint16)  # the hand on a plane 0.6 m away...
    depth[::7, :] = 0  # ...with rows of holes
    bag = record_rgbd(tmp_path / "hand.db3", colors, [depth] * len(colors))
    lms, a, b = tmp_path / "L.npz", tmp_path / "a.npz", tmp_path / "b.npz"
    argv = ["record", str(bag), "--save-landmarks", str(lms), "-o", str(a), "--no-trim"]
    assert main([*argv, "-q"]) == 0
    rec = load_landmark_recording(lms)
    claimed = rec.label_selfie >= 0
    assert rec.depth_m is not None and claimed.any()
    np.testing.assert_allclose(rec.depth_m[claimed], 0.6, atol=1e-6)  # holes skipped
    assert np.isnan(rec.depth_m[~claimed]).all()
    assert rec.intrinsics is not None and rec.intrinsics.fx == FX
    assert not rec.intrinsics.approximate
    assert main(["record", str(lms), "-o", str(b), "--no-trim", "-q"]) == 0
    da, db = load_demonstration(a), load_demonstration(b)
    assert db.capture.lift_model == "pinhole" == da.capture.lift_model
    assert db.capture.to_json()["intrinsics"] == da.capture.to_json()["intrinsics"]
    np.testing.assert_allclose(db.keypoints, da.keypoints, atol=1e-9)
    np.testing.assert_allclose(db.position, da.position, atol=1e-9)
