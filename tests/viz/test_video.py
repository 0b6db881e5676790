from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.io.video import VideoWriter


def test_writes_h264_mp4_readable_back(tmp_path: Path) -> None:
    path = tmp_path / "v.mp4"
    with VideoWriter(path, fps=30) as vw:
        for i in range(15):
            frame = np.zeros((47, 64, 3), np.uint8)  # odd height: padded to even
            frame[:, : 4 * i] = 255
            vw.write(frame)
    cap = cv2.VideoCapture(str(path))
    try:
        assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == 15
        fourcc = int(cap.get(cv2.CAP_PROP_FOURCC)).to_bytes(4, "little").decode()
        assert fourcc in {"avc1", "h264"}
        ok, frame = cap.read()
        assert ok and frame.shape[:2] == (48, 64)
    finally:
        cap.release()
    assert [p.name for p in tmp_path.iterdir()] == ["v.mp4"]


def _decoded(path: Path) -> np.ndarray:
    cap = cv2.VideoCapture(str(path))
    frames = []
    try:
        while (got := cap.read())[0]:
            frames.append(got[1][..., ::-1])  # RGB
    finally:
        cap.release()
    return np.array(frames)


@pytest.mark.parametrize("size", [(48, 64), (47, 63)])
def test_the_cheap_encoding_shows_the_same_picture(tmp_path: Path, size: tuple) -> None:
    """x264's ultrafast fed YUV 4:2:0 converted here: the picture decodes as by default
    (the odd size goes to ffmpeg as RGB, padded to even as always)."""
    h, w = size
    frames = []
    for i in range(12):  # a grey ramp with an orange block moving across
        frame = np.repeat(np.linspace(40, 220, w, dtype=np.uint8)[None, :, None], 3, axis=2)
        frame = np.repeat(frame, h, axis=0)
        frame[10:30, 2 * i : 2 * i + 16] = (230, 90, 30)
        frames.append(frame)
    for name, kw in [("default", {}), ("cheap", {"preset": "ultrafast", "subsample_here": True})]:
        with VideoWriter(tmp_path / f"{name}.mp4", 12.0, **kw) as vw:
            for frame in frames:
                vw.write(frame)
    src = np.array(frames).astype(int)
    err = {}
    for name in ("default", "cheap"):
        got = _decoded(tmp_path / f"{name}.mp4")
        assert got.shape == (12, h + h % 2, w + w % 2, 3)
        err[name] = np.abs(got[:, :h, :w] - src)
    # as close to the frames as the default (here closer: ultrafast spends more bits)
    assert err["cheap"].mean() < 1.5 and np.percentile(err["cheap"], 99) < 12
    assert err["cheap"].mean() < err["default"].mean() + 0.5
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cheap.mp4", "default.mp4"]


def test_an_unknown_x264_preset_is_refused_naming_the_presets(tmp_path: Path) -> None:
    with pytest.raises(InvalidInput, match="preset must be one of ultrafast, .*, got 'quick'"):
        VideoWriter(tmp_path / "v.mp4", 10, preset="quick")
    assert list(tmp_path.iterdir()) == []


def test_error_discards_partial_file(tmp_path: Path) -> None:
    path = tmp_path / "v.mp4"
    with pytest.raises(InvalidInput, match="frame size changed"), VideoWriter(path, 10) as vw:
        vw.write(np.zeros((8, 8, 3), np.uint8))
        vw.write(np.zeros((8, 10, 3), np.uint8))
    assert list(tmp_path.iterdir()) == []


def test_ffmpeg_does_not_share_the_terminal_process_group(tmp_path: Path) -> None:
    # a terminal's Ctrl-C goes to its foreground process group: ffmpeg must not be in
    # ours, or it dies (exit 255) before dexlfd has saved what it promised
    import os

    vw = VideoWriter(tmp_path / "v.mp4", fps=10)
    vw.write(np.zeros((16, 16, 3), np.uint8))
    proc = vw._proc
    assert proc is not None
    assert os.getpgid(proc.pid) != os.getpgid(0)
    assert vw.close(ok=True) == tmp_path / "v.mp4"


def test_caption_darkens_a_top_band_and_writes_white_text() -> None:
    from dexlfd.viz.video import draw_caption

    frame = np.full((480, 640, 3), 200, np.uint8)
    out = draw_caption(frame, "NTSM-PD, unknown 1.2 kg object")
    assert (frame == 200).all()  # the input is not changed
    band = np.flatnonzero((out != 200).any(axis=(1, 2)))
    assert band[0] == 0 and 15 < band[-1] < 60  # a band of a few text lines' height at the top
    assert (out[band[-1] + 1 :] == 200).all()
    top = out[: band[-1] + 1]
    assert (top == 70).mean() > 0.5  # darkened to 35 %
    assert (top.min(axis=2) > 200).sum() > 200  # white glyphs
    small = draw_caption(np.zeros((120, 160, 3), np.uint8), "PD")
    assert small.shape == (120, 160, 3)


def test_ctrl_c_while_ffmpeg_finishes_leaves_no_file(tmp_path: Path, monkeypatch) -> None:
    """An interrupt inside close (ffmpeg encoding the last frames) removes the temporary."""
    import subprocess

    out = tmp_path / "v.mp4"
    writer = VideoWriter(out, fps=10)
    for _ in range(3):
        writer.write(np.zeros((32, 32, 3), np.uint8))
    proc = writer._proc

    real_wait = subprocess.Popen.wait
    calls = []

    def interrupted_wait(self, timeout=None):
        calls.append(self)
        if len(calls) == 1:  # the Ctrl-C lands while close waits for ffmpeg
            raise KeyboardInterrupt
        return real_wait(self, timeout)

    if proc is not None:  # the H.264 path; the OpenCV fallback has no process to wait for
        monkeypatch.setattr(subprocess.Popen, "wait", interrupted_wait)
    else:
        monkeypatch.setattr(writer, "_close", lambda ok: (_ for _ in ()).throw(KeyboardInterrupt))
    with pytest.raises(KeyboardInterrupt):
        writer.close(ok=True)
    monkeypatch.undo()
    if proc is not None:
        assert proc.poll() is not None  # ffmpeg was stopped, not left writing
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_rollout_caption_names_the_controller_and_the_object() -> None:
    from dexlfd.io import Rollout
    from dexlfd.robot import PlantConfig
    from dexlfd.viz.robot_video import rollout_caption

    n = 3
    z7, z3, quat = np.zeros((n, 7)), np.zeros((n, 3)), np.tile([0.0, 0, 0, 1], (n, 1))
    ro = Rollout(t=np.arange(n) * 1e-3, q=z7, dq=z7, tau=z7, ee_position=z3, ee_quaternion=quat,
                 ref_position=z3, ref_quaternion=quat, gripper=np.zeros(n),
                 controller="ntsm-pd")  # fmt: skip
    assert rollout_caption(ro, PlantConfig(payload_kg=1.2)) == "NTSM-PD, 1.2 kg object"
    assert rollout_caption(ro, PlantConfig()) == "NTSM-PD, no object"
