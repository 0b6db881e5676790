"""The robot video rendered by several processes holds the same frames, in order."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest


def _rollout(n: int = 400):
    from dexlfd.io import Rollout
    from dexlfd.panda import Q_READY

    t = np.arange(n) * 1e-3 * 5  # 2 s at 200 Hz
    q = np.tile(np.asarray(Q_READY, dtype=float), (n, 1))
    q[:, 0] += np.linspace(0.0, 1.2, n)  # the arm turns about its base: every frame differs
    z7, z3, quat = np.zeros((n, 7)), np.zeros((n, 3)), np.tile([0.0, 0, 0, 1], (n, 1))
    return Rollout(t=t, q=q, dq=z7, tau=z7, ee_position=z3, ee_quaternion=quat,
                   ref_position=z3, ref_quaternion=quat, gripper=np.full(n, 0.04),
                   controller="ntsm-pd")  # fmt: skip


class _Collect:
    """Stands in for the MP4 writer: keeps the frames it is given."""

    frames: list[np.ndarray]

    def __init__(self, path: Path, fps: float, **encoding) -> None:
        self.path = Path(path)
        self.frames = []
        _Collect.last = self

    def __enter__(self):
        return self

    def __exit__(self, *exc: object) -> None:
        self.path.write_bytes(b"")

    def write(self, frame: np.ndarray) -> None:
        self.frames.append(np.array(frame))


def _render(tmp_path: Path, workers: int, monkeypatch) -> tuple[list[np.ndarray], list[int]]:
    import dexlfd.viz.robot_video as robot_video
    from dexlfd._gl import RenderingUnavailable
    from dexlfd.robot import PlantConfig

    monkeypatch.setattr(robot_video, "VideoWriter", _Collect)
    ticks: list[int] = []
    try:
        robot_video.render_rollout_video(
            _rollout(), PlantConfig(), tmp_path / f"w{workers}.mp4", fps=6.0, width=64,
            height=48, workers=workers, callback=lambda i, t: ticks.append(i),
        )  # fmt: skip
    except RenderingUnavailable as exc:
        pytest.skip(f"no offscreen OpenGL here: {exc}")
    return _Collect.last.frames, ticks


def test_frames_rendered_in_three_processes_equal_the_single_process_ones(
    tmp_path: Path, monkeypatch
) -> None:
    one, ticks_one = _render(tmp_path, 1, monkeypatch)
    three, ticks_three = _render(tmp_path, 3, monkeypatch)
    assert len(one) == len(three) == 12  # 2 s at 6 fps
    assert ticks_one == ticks_three == list(range(12))
    assert any(np.abs(a.astype(int) - b).max() > 0 for a, b in zip(one[:-1], one[1:], strict=True))
    for i, (a, b) in enumerate(zip(one, three, strict=True)):
        assert np.array_equal(a, b), f"frame {i} differs"


def test_a_failed_render_process_is_rendered_here(tmp_path: Path, monkeypatch) -> None:
    import dexlfd.viz.robot_video as robot_video

    one, _ = _render(tmp_path, 1, monkeypatch)

    # the child cannot read its work: it exits with an error
    monkeypatch.setattr(robot_video.pickle, "dumps", lambda obj: b"not a pickle")
    two, _ = _render(tmp_path, 2, monkeypatch)
    assert len(two) == len(one)
    assert all(np.array_equal(a, b) for a, b in zip(one, two, strict=True))


def _frames_with(tmp_path: Path, monkeypatch, **options: bool) -> list[np.ndarray]:
    """The frames of :func:`_rollout` at 160x120 with the render ``options``."""
    import dexlfd.viz.robot_video as robot_video
    from dexlfd._gl import RenderingUnavailable
    from dexlfd.robot import PlantConfig

    monkeypatch.setattr(robot_video, "VideoWriter", _Collect)
    try:
        robot_video.render_rollout_video(
            _rollout(), PlantConfig(), tmp_path / "o.mp4", fps=2.0, width=160, height=120,
            caption=None, **options,
        )  # fmt: skip
    except RenderingUnavailable as exc:
        pytest.skip(f"no offscreen OpenGL here: {exc}")
    return _Collect.last.frames


def test_shadows_and_antialiasing_can_be_switched_off(tmp_path: Path, monkeypatch) -> None:
    full = _frames_with(tmp_path, monkeypatch)
    no_shadow = _frames_with(tmp_path, monkeypatch, shadows=False)
    aliased = _frames_with(tmp_path, monkeypatch, antialias=False)
    assert len(full) == len(no_shadow) == len(aliased) == 4  # 2 s (less 5 ms) at 2 fps
    assert all(f.shape == (120, 160, 3) for f in (*full, *no_shadow, *aliased))
    for a, b in zip(full, no_shadow, strict=True):
        # the key light reaches the floor under the arm: brighter there, darker nowhere
        # (but a few edge pixels)
        diff = b.astype(int) - a.astype(int)
        assert (diff > 20).sum() > 100 and (diff < -20).sum() < 10
    for a, b in zip(full, aliased, strict=True):
        # the same picture; only the edges step (no multisampling)
        diff = np.abs(b.astype(int) - a.astype(int))
        assert 0 < (diff > 20).mean() < 0.05
