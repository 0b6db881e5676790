from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dexlfd.cli import main
from dexlfd.io import load_demonstration


def test_record_real_video_with_overlay_and_plots(hand_video: Path, tmp_path: Path, capsys) -> None:
    import cv2

    out = tmp_path / "demo.npz"
    overlay = tmp_path / "overlay.mp4"
    argv = ["record", str(hand_video), "-o", str(out), "--max-frames", "40"]
    argv += ["--overlay", str(overlay), "--plot", str(tmp_path / "fig"), "--resize-width-px", "640"]
    argv += ["--camera-pose", "front", "--camera-height-m", "1.2", "--lift", "assumed_depth"]
    argv += ["--smoothing", "none"]
    assert main(argv) == 0
    err = capsys.readouterr().err
    # the logged summary: frames, detection rate, handedness, processing fps, gaps
    assert "40 frames, hand detected in 100.0 % (right hand)" in err
    assert "fps processing, 0 gap(s)" in err and "APPROXIMATE" in err
    demo = load_demonstration(out)
    assert demo.n_samples == 40 and demo.valid.all()
    assert demo.capture.lift_model == "assumed_depth"
    assert "APPROXIMATE" in demo.meta["capture"]["note"]
    # front camera at 1.2 m looking along +x: the wrist is 0.5 m ahead (assumed depth),
    # left/right and up/down by the pinhole offsets of its pixel
    K = demo.capture.to_json()["intrinsics"]
    u, v = demo.extras["uv_px"][:, 0].T
    np.testing.assert_allclose(demo.position[:, 0], 0.5, atol=1e-12)
    np.testing.assert_allclose(demo.position[:, 1], -(u - 0.5 - K["cx"]) / K["fx"] * 0.5, atol=1e-9)
    np.testing.assert_allclose(
        demo.position[:, 2], 1.2 - (v - 0.5 - K["cy"]) / K["fy"] * 0.5, atol=1e-9
    )
    cap = cv2.VideoCapture(str(overlay))
    assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == 40
    cap.release()
    for name in ("hand_3d.png", "motion.png"):
        assert (tmp_path / "fig" / name).stat().st_size > 10_000
    assert not list(tmp_path.glob(".*.tmp")) and not list(tmp_path.glob(".overlay*"))


def test_record_without_hand_writes_nothing(tmp_path: Path, capsys) -> None:
    import cv2

    rng = np.random.default_rng(0)
    video = tmp_path / "noise.mp4"
    vw = cv2.VideoWriter(str(video), cv2.VideoWriter.fourcc(*"mp4v"), 30.0, (160, 120))
    for _ in range(6):
        vw.write(rng.integers(0, 256, (120, 160, 3), dtype=np.uint8))
    vw.release()
    out, overlay = tmp_path / "demo.npz", tmp_path / "ov.mp4"
    assert main(["record", str(video), "-o", str(out), "--overlay", str(overlay)]) == 1
    err = capsys.readouterr().err
    assert "no hand detected" in err and "Traceback" not in err
    assert not out.exists() and not overlay.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["noise.mp4"]


@pytest.mark.parametrize(
    ("source", "message"),
    [
        ("no/such/video.mp4", "no such video file"),
        ("udp-stream", "not supported"),
        ("webcam:97", "camera not connected"),
    ],
)
def test_record_bad_sources(tmp_path: Path, capsys, source: str, message: str) -> None:
    assert main(["record", source, "-o", str(tmp_path / "d.npz")]) == 1
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "d.npz").exists()


def test_record_pinhole_on_rgb_video_is_an_error(hand_video: Path, tmp_path: Path, capsys) -> None:
    assert main(["record", str(hand_video), "-o", str(tmp_path / "d.npz"), "--lift", "angle"]) == 1
    assert "needs depth" in capsys.readouterr().err


def _clip(src: Path, dst: Path, start: int, n: int, width: int = 480) -> None:
    import cv2

    from dexlfd.capture import open_source

    with open_source(src, max_frames=start + n, resize_width=width) as s:
        frames = [f.rgb for i, f in enumerate(s) if i >= start]
    h = frames[0].shape[0]
    vw = cv2.VideoWriter(str(dst), cv2.VideoWriter.fourcc(*"mp4v"), 30.0, (width, h))
    for rgb in frames:
        vw.write(cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    vw.release()


def test_record_several_videos_one_bad(hand_video: Path, tmp_path: Path, capsys) -> None:
    """A batch writes every good video, reports the bad one and exits 1 at the end."""
    import cv2

    good = tmp_path / "fist.mp4"
    _clip(hand_video, good, 240, 45)  # open hand -> fist -> open
    bad = tmp_path / "noise.mp4"
    vw = cv2.VideoWriter(str(bad), cv2.VideoWriter.fourcc(*"mp4v"), 30.0, (160, 120))
    for _ in range(5):
        vw.write(np.random.default_rng(0).integers(0, 256, (120, 160, 3), dtype=np.uint8))
    vw.release()
    out = tmp_path / "demos"
    code = main(["record", str(bad), str(good), "-o", str(out), "--camera-pose", "front",
                 "--grasp", "adaptive"])  # fmt: skip
    assert code == 1
    err = capsys.readouterr().err
    assert f"{bad}: FAILED" in err and "no hand detected" in err
    assert "recorded 1 of 2 video(s)" in err and "Traceback" not in err
    assert sorted(p.name for p in out.iterdir()) == ["fist.npz"]
    demo = load_demonstration(out / "fist.npz")
    q = demo.quality
    assert q.hand == "right" and q.detection_rate == 1.0
    assert len(q.grasp_intervals_s) == 1  # the fist
    assert f"{good}: 45 frames" in err and "grasp (adaptive): " in err


def test_record_batch_same_files_with_two_workers(hand_video: Path, tmp_path: Path) -> None:
    """The batch runs on the engine (dexlfd.engine.map_items): 2 processes give the
    same demonstrations as 1, byte for byte in every array."""
    clips = [tmp_path / "fist.mp4", tmp_path / "pinch.mp4"]
    _clip(hand_video, clips[0], 240, 30, width=320)
    _clip(hand_video, clips[1], 300, 30, width=320)
    runs = {}
    for workers in ("1", "2"):
        out = tmp_path / f"w{workers}"
        argv = ["record", *map(str, clips), "-o", str(out), "--camera-pose", "front"]
        assert main([*argv, "--workers", workers, "-q"]) == 0
        runs[workers] = {c.stem: load_demonstration(out / f"{c.stem}.npz") for c in clips}
    for stem in ("fist", "pinch"):
        a, b = runs["1"][stem], runs["2"][stem]
        for name in ("t", "position", "quaternion", "gripper", "grasp", "keypoints"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


@pytest.mark.parametrize(
    ("flags", "message", "code"),
    [
        (["--camera-pose", "front", "--camera-height-m", "-5"], "--camera-height-m: expected", 1),
        # a setting's own range: refused while the flags are parsed (usage error)
        (["--resize-width-px", "100000"], "--resize-width-px: expected an integer in 16..7680", 2),
        (["--grasp-threshold-m", "5"], "--grasp-threshold-m: expected a number in [0.005, 0.2]", 2),
        (["--max-hands", "0"], "--max-hands: expected an integer in 1..4", 2),
        (["--max-gap-s", "-1"], "--max-gap-s: expected a number in [0, 5] s", 2),
    ],
)  # fmt: skip
def test_record_rejects_nonsense_flags_before_any_work(
    tmp_path: Path, capsys, flags: list[str], message: str, code: int
) -> None:
    # the source does not exist: the flag error must come first (no video opened)
    argv = ["record", "missing.mp4", "-o", str(tmp_path / "d.npz"), *flags]
    if code == 2:
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2
    else:
        assert main(argv) == 1
    err = capsys.readouterr().err
    assert message in err and "no such video" not in err


def test_record_refuses_to_overwrite_its_input(hand_video: Path, tmp_path: Path, capsys) -> None:
    video = tmp_path / "h.npz"  # a "video" named like the output
    video.write_bytes(b"not really")
    assert main(["record", str(video), "-o", str(video)]) == 1
    assert "refusing to overwrite an input" in capsys.readouterr().err
    assert video.read_bytes() == b"not really"


def test_record_hand_left_on_a_right_hand_video_is_an_error(
    hand_video: Path, tmp_path: Path, capsys
) -> None:
    clip = tmp_path / "r.mp4"
    _clip(hand_video, clip, 0, 10, 320)
    assert main(["record", str(clip), "-o", str(tmp_path / "d.npz"), "--hand", "left"]) == 1
    err = capsys.readouterr().err
    assert "--hand left: no left hand" in err and not (tmp_path / "d.npz").exists()


@pytest.mark.parametrize(
    ("matrix", "message"),
    [
        (np.eye(3), "expected a 4x4 rigid transform"),
        (np.diag([1.0, 1.0, 2.0, 1.0]), "not orthonormal"),
        (np.diag([1.0, 1.0, -1.0, 1.0]), "det -1"),
    ],
)
def test_record_rejects_bad_extrinsics(
    tmp_path: Path, capsys, matrix: np.ndarray, message: str
) -> None:
    ext = tmp_path / "T.npy"
    np.save(ext, matrix)
    out = tmp_path / "d.npz"
    assert main(["record", "missing.mp4", "-o", str(out), "--extrinsics", str(ext)]) == 1
    err = capsys.readouterr().err
    assert f"--extrinsics {ext}: " in err and message in err and "Traceback" not in err
    junk = tmp_path / "demo.npz"
    np.savez(junk, a=np.zeros(3))
    assert main(["record", "missing.mp4", "-o", str(out), "--extrinsics", str(junk)]) == 1
    assert "a .npz archive, expected a single 4x4 array" in capsys.readouterr().err


def test_overlay_of_a_1080p_video_is_scaled_to_1280(tmp_path: Path) -> None:
    import cv2

    from dexlfd.viz.capture import OverlayWriter

    uv = np.column_stack([np.linspace(100, 1800, 21), np.linspace(100, 1000, 21)])
    frame = np.zeros((1080, 1920, 3), np.uint8)
    with OverlayWriter(tmp_path / "o.mp4", 30.0) as w:
        for _ in range(3):
            w.write(frame, uv, "right")
    cap = cv2.VideoCapture(str(tmp_path / "o.mp4"))
    ok, img = cap.read()
    assert ok and img.shape[:2] == (720, 1280) and int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == 3
    cap.release()
    # the skeleton is drawn where the scaled landmarks are (last point 1800*2/3 = 1200 px)
    assert img[660:675, 1190:1210].max() > 100 and img[:, 1250:].max() < 60
