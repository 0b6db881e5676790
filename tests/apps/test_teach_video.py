"""``teach``'s robot video, drawn while the simulation runs, is the replay of its rollout."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ._teach_sources import write_camera_demos

SRC = Path(__file__).resolve().parents[2] / "src"


def _teach(sources: list[Path], out: Path, logs: Path) -> subprocess.Popen:
    """``dexlfd teach`` in a process of its own session (no OpenGL context before it)."""
    path = os.pathsep.join(filter(None, [str(SRC), os.environ.get("PYTHONPATH")]))
    env = {**os.environ, "PYTHONPATH": path}
    cmd = [sys.executable, "-m", "dexlfd", "teach", *map(str, sources), "-o", str(out)]
    with logs.open("w") as err:  # a file, not a pipe
        proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=err,
                                start_new_session=True)  # fmt: skip
        proc.wait(timeout=1800)
    return proc


def _frames(path: Path) -> list[np.ndarray]:
    import cv2

    cap = cv2.VideoCapture(str(path))
    frames = []
    try:
        while True:
            ok, frame = cap.read()
            if not ok:
                return frames
            frames.append(frame)
    finally:
        cap.release()


def _replayed(out: Path, to: Path) -> list[np.ndarray]:
    """The saved rollout replayed afterwards (as the video stage does without a stream)."""
    from dexlfd._gl import RenderingUnavailable
    from dexlfd.apps.teach import TeachConfig, _video_settings
    from dexlfd.apps.teach_robot import render_video
    from dexlfd.io import load_plan, load_rollout

    frame = {"summary": json.loads((out / "manifest.json").read_text())["frame"]["summary"]}
    try:
        render_video(load_rollout(out / "rollout.npz"), load_plan(out / "plan.npz"), to,
                     **_video_settings(TeachConfig(sources=()), frame))  # fmt: skip
    except RenderingUnavailable as exc:
        pytest.skip(f"no offscreen OpenGL here: {exc}")
    return _frames(to)


@pytest.mark.integration
def test_the_video_drawn_during_the_simulation_is_the_replay_and_resumes(
    tmp_path: Path, session_processes
) -> None:
    sources = write_camera_demos(tmp_path / "takes", n=4, seed=0)
    out, logs = tmp_path / "out", tmp_path / "stderr.txt"
    proc = _teach(sources, out, logs)
    assert proc.returncode == 0, logs.read_text()[-2000:]
    assert not session_processes(proc.pid)  # its render process was waited for
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["video"]["summary"] == {"rendered": "during the simulation"}
    assert "render the robot video ... (here: drawn during the simulation)" in logs.read_text()
    streamed, replayed = _frames(out / "robot.mp4"), _replayed(out, tmp_path / "replay.mp4")
    assert len(streamed) == len(replayed) > 100
    assert all(np.array_equal(a, b) for a, b in zip(streamed, replayed, strict=True))

    # only the video is missing: it is rendered from the saved rollout, nothing simulated
    (out / "robot.mp4").unlink()
    proc = _teach(sources, out, logs)
    assert proc.returncode == 0, logs.read_text()[-2000:]
    assert not session_processes(proc.pid)
    text = logs.read_text()
    assert "simulate: ntsm-pd, 0.3 kg object: reusing finished outputs" in text
    assert "render the robot video: rerunning: robot.mp4 is missing" in text
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["video"]["summary"] == {"rendered": "after the simulation"}
    again = _frames(out / "robot.mp4")
    assert len(again) == len(replayed)
    assert all(np.array_equal(a, b) for a, b in zip(again, replayed, strict=True))


def test_a_render_process_that_hung_leaves_the_video_to_the_replay(
    tmp_path: Path, monkeypatch
) -> None:
    """The stream's result is None (its child hung and was killed): the rollout is replayed."""
    import dexlfd.io
    from dexlfd.apps import teach, teach_robot

    class _Hung:
        def result(self) -> None:
            return None

    replayed: list[tuple] = []
    monkeypatch.setattr(dexlfd.io, "load_rollout", lambda path: ("rollout", path.name))
    monkeypatch.setattr(dexlfd.io, "load_plan", lambda path: ("plan", path.name))
    monkeypatch.setattr(teach_robot, "render_video",
                        lambda *args, **kw: replayed.append(args) or args[2])  # fmt: skip
    frame = {"summary": {"placement": {"object_size": [0.05, 0.05, 0.05]}}}
    streams = {"video": _Hung()}
    outputs, summary = teach._stage_video(teach.TeachConfig(sources=()), tmp_path, frame, streams)
    assert summary == {"rendered": "after the simulation"} and not streams
    assert outputs == {"video": tmp_path / "robot.mp4"}
    assert replayed == [(("rollout", "rollout.npz"), ("plan", "plan.npz"), tmp_path / "robot.mp4")]
