"""One failed video = one line in the flags' words; no third-party noise; inputs first."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dexlfd.cli import main


def test_a_failed_video_in_a_batch_is_one_translated_line(
    hand_video: Path, tmp_path: Path, capfd
) -> None:
    a, b = tmp_path / "a.mp4", tmp_path / "b.mp4"
    a.write_bytes(hand_video.read_bytes())
    b.write_bytes(hand_video.read_bytes())
    code = main(["record", str(a), str(b), "-o", str(tmp_path / "out"), "--lift", "pinhole"])
    assert code == 1
    err = capfd.readouterr().err
    failed = [line for line in err.splitlines() if "FAILED" in line]
    assert len(failed) == 2 and all("FAILED: --lift model 'pinhole' needs depth" in line
                                    for line in failed)  # fmt: skip
    assert all("use the lift model pnp" in line for line in failed)
    assert "LiftConfig" not in err and "error:" not in err
    assert f"FAILED: {a}" not in err  # the name once per line


def test_a_broken_video_gives_one_line_and_no_ffmpeg_noise(
    hand_video: Path, tmp_path: Path, capfd
) -> None:
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(hand_video.read_bytes()[:50_000])  # no moov atom: ffmpeg complains
    assert main(["record", str(cut), "-o", str(tmp_path / "d.npz"), "--camera-pose", "front"]) == 1
    err = capfd.readouterr().err
    assert err.count("error:") == 1 and "moov" not in err and "W0000" not in err


def test_a_missing_file_comes_before_the_note_about_extrinsics(tmp_path: Path, capfd) -> None:
    assert main(["record", str(tmp_path / "none.mp4"), "-o", str(tmp_path / "d.npz")]) == 1
    err = capfd.readouterr().err
    assert "no such video file" in err and "--extrinsics" not in err


def test_negative_intrinsics_get_our_message_not_argparses(tmp_path: Path, capfd) -> None:
    video = tmp_path / "v.mp4"
    video.write_bytes(b"x")
    argv = ["record", str(video), "-o", str(tmp_path / "d.npz")]
    assert main([*argv, "--intrinsics", "-1000,1000,640,360"]) == 1
    err = capfd.readouterr().err
    assert "error: --intrinsics -1000,1000,640,360: not a camera matrix" in err
    assert "expected one argument" not in err and err.count("\n") == 1


def test_the_default_max_gap_fills_one_missing_frame_at_8_fps() -> None:
    from dexlfd.apps.record import default_max_gap_s
    from dexlfd.motion import MotionConfig, demonstration_from_keypoints

    from ..motion.test_smoothing_trim_quality import _pick_place

    assert default_max_gap_s(30.0) == 0.1 and default_max_gap_s(8.0) == 2.5 / 8
    t, kp = _pick_place(np.random.default_rng(0))
    t = t * 30 / 8  # the same motion filmed at 8 fps
    valid = np.ones(t.size, bool)
    valid[[50, 100, 101]] = False  # one missing frame, then two
    kp[~valid] = np.nan
    cfg = MotionConfig(max_gap_s=default_max_gap_s(8.0), smoothing="none")
    demo = demonstration_from_keypoints(t, kp, valid, cfg=cfg)
    assert demo.valid[50] and not demo.valid[100:102].any()
