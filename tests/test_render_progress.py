"""``simulate --video`` renders with a progress bar over every frame it writes."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def test_simulate_video_progress_counts_every_rendered_frame(
    tmp_path: Path, monkeypatch, fake_progress
) -> None:
    import dexlfd._commands.simulate as simulate
    import dexlfd.viz.robot_video as robot_video

    def fake_render(rollout, plant, path, *, fps=30.0, callback=None, **kw):
        n = max(1, int(np.floor((rollout.t[-1] - rollout.t[0]) * fps)) + 1)
        for i in range(n):
            callback(i, float(i / fps))
        Path(path).write_bytes(b"")
        return Path(path)

    bars = fake_progress(simulate)
    monkeypatch.setattr(robot_video, "render_rollout_video", fake_render)

    class Rollout:
        t = np.linspace(0.0, 2.5, 2501)

    args = argparse.Namespace(plot=None, video=tmp_path / "r.mp4", quiet=False)
    simulate._write_views(args, Rollout(), plant=None)
    assert [(b.total, b.desc, b.n) for b in bars] == [(76, "render video", 76)]


def test_phase_progress_counts_finished_phases_and_refuses_an_unlisted_one(fake_progress) -> None:
    import pytest

    import dexlfd._commands._common as common

    bars = fake_progress(common)
    with common.phase_progress(["a", "b", "c"], "job") as step:
        step("a")
        step("b")
        with pytest.raises(ValueError, match="'z' is not one of"):
            step("z")
    (bar,) = bars
    shown = [name for name, _ in bar.shown]
    assert (bar.total, bar.n, shown) == (3, 2, ["a", "b"])  # c never started
