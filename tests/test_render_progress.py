"""``simulate --video`` renders with a progress bar over every frame it writes."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def test_simulate_video_progress_counts_every_rendered_frame(tmp_path: Path, monkeypatch) -> None:
    import dexlfd._commands.simulate as simulate
    import dexlfd.viz.robot_video as robot_video

    bars: list[dict] = []

    class Bar:
        def __init__(self, total, desc, quiet=False, **kw):
            self.record = {"total": total, "desc": desc, "updates": 0}
            bars.append(self.record)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def update(self, n):
            self.record["updates"] += n

    def fake_render(rollout, plant, path, *, fps=30.0, callback=None, **kw):
        n = max(1, int(np.floor((rollout.t[-1] - rollout.t[0]) * fps)) + 1)
        for i in range(n):
            callback(i, float(i / fps))
        Path(path).write_bytes(b"")
        return Path(path)

    monkeypatch.setattr(simulate, "progress", Bar)
    monkeypatch.setattr(robot_video, "render_rollout_video", fake_render)

    class Rollout:
        t = np.linspace(0.0, 2.5, 2501)

    args = argparse.Namespace(plot=None, video=tmp_path / "r.mp4", quiet=False)
    simulate._write_views(args, Rollout(), plant=None)
    assert bars == [{"total": 76, "desc": "render video", "updates": 76}]


def test_phase_progress_counts_finished_phases_and_refuses_an_unlisted_one(monkeypatch) -> None:
    import pytest

    import dexlfd._commands._common as common

    class Bar:
        def __init__(self, total, desc, quiet=False, **kw):
            self.total, self.n, self.shown = total, 0, []

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def update(self, n):
            self.n += n

        def set_postfix_str(self, text, refresh=True):
            self.shown.append(text)

    bars: list[Bar] = []
    monkeypatch.setattr(common, "progress", lambda *a, **k: bars.append(Bar(*a, **k)) or bars[-1])
    with common.phase_progress(["a", "b", "c"], "job") as step:
        step("a")
        step("b")
        with pytest.raises(ValueError, match="'z' is not one of"):
            step("z")
    (bar,) = bars
    assert (bar.total, bar.n, bar.shown) == (3, 2, ["a", "b"])  # c never started
