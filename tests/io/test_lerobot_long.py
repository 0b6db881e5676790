"""Long LeRobot exports: made and written a block of frames at a time, bounded, stoppable."""

from __future__ import annotations

import json
import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest

from dexlfd._signals import Terminated, describe
from dexlfd.cli import main
from dexlfd.io import Demonstration, Rollout, save_demonstration
from dexlfd.io.lerobot import _write, export_lerobot

pq = pytest.importorskip("pyarrow.parquet", reason="pyarrow not installed")


def _demo(n: int, rate: float = 100.0) -> Demonstration:
    rng = np.random.default_rng(n)
    t = np.arange(n) / rate
    pos = np.column_stack([0.4 + 0.1 * np.sin(t), 0.1 * np.cos(t), np.full(n, 0.2)])
    valid = rng.random(n) > 0.2
    valid[0] = True
    kp = np.repeat(pos[:, None, :], 21, axis=1) + rng.normal(0, 1e-3, (n, 21, 3))
    kp[~valid] = np.nan
    kp[5:40, 3] = np.nan  # one landmark unseen for a while, the hand seen
    pos[~valid] = np.nan
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    quat[~valid] = np.nan
    grip = np.where(valid, 0.06, np.nan)
    return Demonstration(t=t, keypoints=kp, valid=valid, position=pos, quaternion=quat,
                         gripper=grip, grasp=rng.random(n) > 0.5)  # fmt: skip


def _rollout(n: int) -> Rollout:
    rng = np.random.default_rng(n)
    t = np.arange(n) * 1e-3
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    return Rollout(t=t, q=rng.normal(size=(n, 7)), dq=rng.normal(size=(n, 7)),
                   tau=rng.normal(size=(n, 7)), ee_position=rng.normal(size=(n, 3)),
                   ee_quaternion=quat, ref_position=rng.normal(size=(n, 3)),
                   ref_quaternion=quat, gripper=np.full(n, 0.04))  # fmt: skip


def _dataset(folder: Path) -> tuple[object, object, dict]:
    data = pq.read_table(folder / "data/chunk-000/file-000.parquet")
    episodes = pq.read_table(folder / "meta/episodes/chunk-000/file-000.parquet")
    return data, episodes, json.loads((folder / "meta/stats.json").read_text())


@pytest.mark.parametrize(
    ("records", "fps"),
    [
        ([_demo(130), _demo(70)], None),  # on the grid: copied
        ([_demo(130), _demo(70)], 37.0),  # resampled
        ([_rollout(300), _rollout(120)], None),  # resampled to 30 Hz
        ([_rollout(300)], 1000.0),  # copied
    ],
)
def test_frames_written_by_blocks_are_those_made_at_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, records: list, fps: float | None
) -> None:
    whole = export_lerobot(records, tmp_path / "whole", fps=fps)
    monkeypatch.setattr(_write, "CHUNK_FRAMES", 7)  # blocks across episode ends too
    monkeypatch.setattr(_write._Spill, "BUDGET", 50)  # statistics by a few dimensions at once
    blocks = export_lerobot(records, tmp_path / "blocks", fps=fps)
    (data_a, ep_a, stats_a), (data_b, ep_b, stats_b) = _dataset(whole), _dataset(blocks)
    assert (
        data_b.num_rows
        == data_a.num_rows
        == _write.frame_count(records, _write.frame_rate(records, fps))
    )
    assert pq.ParquetFile(blocks / "data/chunk-000/file-000.parquet").num_row_groups > 1
    for name in data_a.column_names:  # NaN in the same places, every number the same
        a, b = data_a.column(name).to_pylist(), data_b.column(name).to_pylist()
        np.testing.assert_array_equal(np.asarray(a, dtype=float), np.asarray(b, dtype=float))
    assert ep_a.column_names == ep_b.column_names
    for key in stats_a:
        for stat, value in stats_a[key].items():
            np.testing.assert_allclose(stats_b[key][stat], value, rtol=1e-12, atol=1e-15)
    assert not list(blocks.rglob(".frames")) and not list(whole.rglob("*.bin"))


def test_a_dataset_past_the_frame_bound_is_refused_in_one_line_naming_fps(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    src = save_demonstration(tmp_path / "long.npz", _demo(300))
    monkeypatch.setattr(_write, "MAX_FRAMES", 250)
    capsys.readouterr()
    out = tmp_path / "ds"
    assert main(["export", str(src), "--format", "lerobot", "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert "Traceback" not in "\n".join(err)
    assert (
        len(err) == 2
        and err[0].startswith("I ")
        and "300 frames" in err[0]
        and "MB of parquet" in err[0]
    )
    assert err[-1].startswith("dexlfd export: error: --fps 100 Hz makes 300 frames")
    assert str(src) in err[-1] and "at most 250" in err[-1]
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["long.npz"]
    # a lower rate fits
    assert main(["export", str(src), "--format", "lerobot", "--fps", "50", "-o", str(out)]) == 0
    assert pq.read_table(out / "data/chunk-000/file-000.parquet").num_rows == 150


@pytest.mark.parametrize(("sig", "code"), [(signal.SIGTERM, 143), (signal.SIGHUP, 129)])
def test_a_signal_between_blocks_stops_the_export_and_leaves_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
    sig: int, code: int,
) -> None:  # fmt: skip
    src = save_demonstration(tmp_path / "long.npz", _demo(200))
    monkeypatch.setattr(_write, "CHUNK_FRAMES", 20)
    put = _write._Spill.put
    blocks: list[int] = []

    def put_then_signal(self, start, cols):  # type: ignore[no-untyped-def]
        put(self, start, cols)
        blocks.append(start)
        if len(blocks) == 3:  # the dataset's temporary folder and spill exist now
            assert list(tmp_path.glob("*.dexlfd-part*"))
            os.kill(os.getpid(), sig)
            time.sleep(1.0)  # the handler runs at the next bytecode; never reached in practice

    monkeypatch.setattr(_write._Spill, "put", put_then_signal)
    inherited = signal.signal(sig, signal.SIG_DFL)
    try:
        code_got = main(["export", str(src), "--format", "lerobot", "-o", str(tmp_path / "ds")])
    finally:
        signal.signal(sig, inherited)
    assert code_got == code
    err = capsys.readouterr().err
    assert "Traceback" not in err
    last = err.strip().splitlines()[-1]
    assert last == f"dexlfd export: {describe(Terminated(sig))}; finished outputs are kept"
    assert blocks == [0, 20, 40]  # stopped at the block it landed in, not at the end
    assert sorted(p.name for p in tmp_path.iterdir()) == ["long.npz"]


def test_the_help_states_the_bound_the_library_keeps() -> None:
    import argparse

    from dexlfd._commands.export import add_parser

    parser = add_parser(argparse.ArgumentParser().add_subparsers(), "export")
    (fps,) = [a for a in parser._actions if "--fps" in a.option_strings]
    assert f"{_write.MAX_FRAMES:,} frames" in " ".join(fps.help.split())
