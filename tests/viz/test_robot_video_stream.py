"""The robot video drawn while the rollout is simulated holds the replay's frames.

The child's drawing and writing are stood in for (no OpenGL: a frame is the sample it
shows), so that these checks also run in a process that has rendered before.
"""

from __future__ import annotations

import logging
import os
import signal
from pathlib import Path

import numpy as np
import pytest

from dexlfd.errors import DexlfdError


def _rollout(n: int = 2300, payload: bool = True):
    from dexlfd.io import Rollout
    from dexlfd.panda import Q_READY

    t = np.arange(n) * 1e-3  # 1 kHz, as the loop records
    q = np.tile(np.asarray(Q_READY, dtype=float), (n, 1))
    q[:, 0] += np.linspace(0.0, 1.2, n)
    z7, z3, quat = np.zeros((n, 7)), np.zeros((n, 3)), np.tile([0.0, 0, 0, 1], (n, 1))
    extras = {}
    if payload:
        extras = {"payload_position": np.linspace([0.5, 0, 0.1], [0.3, 0.2, 0.3], n),
                  "payload_quaternion": quat.copy()}  # fmt: skip
    return Rollout(t=t, q=q, dq=z7, tau=z7, ee_position=z3, ee_quaternion=quat,
                   ref_position=z3, ref_quaternion=quat, gripper=np.linspace(0.08, 0.0, n),
                   controller="ntsm-pd", extras=extras)  # fmt: skip


class _Scene:
    """Stands in for the drawn scene: a 'frame' is the sample's numbers."""

    encoding: dict = {}  # the writer's keywords

    def __init__(self, delay_s: float = 0.0, fail_at: int | None = None, gate=None) -> None:
        self.delay_s, self.fail_at, self.drawn = delay_s, fail_at, 0
        self.gate = gate  # an Event the first frame waits for (never set: a hung child)

    def sim(self, q0: np.ndarray, payload_at) -> _Sim:
        return _Sim(q0, payload_at)

    def draw(self, sim, q, gripper, payload, t_s) -> np.ndarray:
        import time

        if self.gate is not None:
            self.gate.wait()
        time.sleep(self.delay_s)
        self.drawn += 1
        if self.fail_at is not None and self.drawn > self.fail_at:
            raise RuntimeError("the scene broke")
        pos = np.zeros(3) if payload is None else payload[0]
        return np.concatenate([q, [gripper, t_s], pos, sim.q0])


class _Sim:
    def __init__(self, q0, payload_at) -> None:
        self.q0 = np.asarray(q0)

    def close(self) -> None:
        pass


class _Writer:
    """Stands in for the MP4 writer: the frames to ``path`` (.npy) when closed well."""

    def __init__(self, path: Path, fps: float, **encoding) -> None:
        self.path, self.frames = Path(path), []

    def __enter__(self) -> _Writer:
        return self

    def __exit__(self, exc_type, *rest) -> None:
        if exc_type is None:
            with open(self.path, "wb") as fh:
                np.save(fh, np.array(self.frames), allow_pickle=False)

    def write(self, frame) -> None:
        self.frames.append(np.array(frame))


@pytest.fixture
def stream_parts(monkeypatch):
    """The stream module with its writer stood in for, free to fork (nothing is drawn)."""
    from dexlfd.viz import robot_video_stream

    monkeypatch.setattr(robot_video_stream, "VideoWriter", _Writer)
    monkeypatch.setattr(robot_video_stream, "context_made", lambda: False)
    return robot_video_stream


def _replayed(rollout, fps: float) -> np.ndarray:
    """What the replay shows: the frame_samples of the finished rollout."""
    from dexlfd.viz.robot_video import frame_samples

    k = frame_samples(rollout.t, fps)
    pos = rollout.extras.get("payload_position", np.zeros((rollout.n_samples, 3)))
    return np.column_stack([rollout.q[k], rollout.gripper[k], rollout.t[k] - rollout.t[0],
                            pos[k], np.tile(rollout.q[0], (k.size, 1))])  # fmt: skip


def _feed(stream, rollout, upto: int, every: int = 250) -> None:
    """The loop's hand-overs: every ``every`` ticks the rows recorded so far."""
    rows = {"t": rollout.t, "q": rollout.q, "gripper": rollout.gripper, **rollout.extras}
    for k in range(0, upto, every):
        stream.rows({name: v[: k + 1] for name, v in rows.items()})


@pytest.mark.parametrize("payload", [True, False])
def test_the_streamed_frames_are_the_replay_of_the_finished_rollout(
    tmp_path: Path, stream_parts, payload: bool
) -> None:
    rollout = _rollout(payload=payload)
    stream = stream_parts.VideoStream.start(_Scene(), tmp_path / "v.npy", 12.0,
                                            payload=payload)  # fmt: skip
    assert stream is not None
    _feed(stream, rollout, 2000)  # the last hand-over before the end: tick 1750
    assert len(stream._sent) == 22  # the frames up to 1.75 s went during the "simulation"
    assert stream.finish(rollout)
    assert stream.result() == tmp_path / "v.npy"
    got = np.load(tmp_path / "v.npy", allow_pickle=False)
    want = _replayed(rollout, 12.0)
    assert got.shape == want.shape == (28, 7 + 2 + 3 + 7)  # 2.299 s at 12 fps
    assert np.array_equal(got, want)  # bit for bit
    assert not stream._process.is_alive()


def test_a_stopped_simulation_gets_the_video_of_what_was_simulated(
    tmp_path: Path, stream_parts
) -> None:
    """A safety stop keeps the rollout up to it: the video shows that, to its end."""
    import dataclasses

    full = _rollout()
    stream = stream_parts.VideoStream.start(_Scene(), tmp_path / "v.npy", 12.0, payload=True)
    _feed(stream, full, 1400)  # handed over up to tick 1250; stopped at 1401
    n = 1401
    part = dataclasses.replace(
        full, t=full.t[:n], q=full.q[:n], dq=full.dq[:n], tau=full.tau[:n],
        ee_position=full.ee_position[:n], ee_quaternion=full.ee_quaternion[:n],
        ref_position=full.ref_position[:n], ref_quaternion=full.ref_quaternion[:n],
        gripper=full.gripper[:n], extras={k: v[:n] for k, v in full.extras.items()},
    )  # fmt: skip
    assert stream.finish(part)
    stream.result()
    got = np.load(tmp_path / "v.npy", allow_pickle=False)
    assert np.array_equal(got, _replayed(part, 12.0)) and got.shape[0] == 17


def test_a_render_process_that_dies_is_dropped_and_said_never_waited_for(
    tmp_path: Path, stream_parts, caplog
) -> None:
    rollout = _rollout()
    # killed while the simulation runs: the samples go nowhere, the stream is dropped
    stream = stream_parts.VideoStream.start(_Scene(), tmp_path / "a.npy", 12.0, payload=True)
    _feed(stream, rollout, 800)
    os.kill(stream._process.pid, signal.SIGKILL)
    stream._process.join()
    _feed(stream, rollout, rollout.n_samples)  # no error in the simulation's loop
    with caplog.at_level(logging.WARNING, logger="dexlfd"):
        assert not stream.finish(rollout)
    said = "rendered after the simulation: its render process ended (exit code -9)"
    assert any(said in r.getMessage() for r in caplog.records)
    assert not (tmp_path / "a.npy").exists()
    # killed after the last frame was sent: its result is a one-line error, not a hang
    slow = _Scene(delay_s=0.2)
    stream = stream_parts.VideoStream.start(slow, tmp_path / "b.npy", 12.0, payload=True)
    _feed(stream, rollout, rollout.n_samples)
    assert stream.finish(rollout)
    os.kill(stream._process.pid, signal.SIGKILL)
    with pytest.raises(DexlfdError, match=r"render process died \(exit code -9\)"):
        stream.result()
    assert not stream._process.is_alive() and not (tmp_path / "b.npy").exists()


def test_a_render_process_that_fails_says_why(tmp_path: Path, stream_parts, caplog) -> None:
    rollout = _rollout()
    # it fails at its first frame, while the simulation runs: dropped, its error said
    stream = stream_parts.VideoStream.start(_Scene(fail_at=0), tmp_path / "a.npy", 12.0,
                                            payload=True)  # fmt: skip
    _feed(stream, rollout, 800)
    stream._process.join()
    _feed(stream, rollout, rollout.n_samples)
    with caplog.at_level(logging.WARNING, logger="dexlfd"):
        assert not stream.finish(rollout)
    assert any("its render process failed: RuntimeError: the scene broke" in r.getMessage()
               for r in caplog.records)  # fmt: skip
    # it fails after the last frame was sent: the result is the error
    stream = stream_parts.VideoStream.start(_Scene(delay_s=0.05, fail_at=20),
                                            tmp_path / "b.npy", 12.0, payload=True)  # fmt: skip
    _feed(stream, rollout, rollout.n_samples)
    assert stream.finish(rollout)
    with pytest.raises(DexlfdError, match="could not be rendered: RuntimeError: the scene broke"):
        stream.result()
    assert not (tmp_path / "a.npy").exists() and not (tmp_path / "b.npy").exists()


def test_a_stopped_stream_ends_its_process_and_leaves_no_video(
    tmp_path: Path, stream_parts
) -> None:
    rollout = _rollout()
    stream = stream_parts.VideoStream.start(_Scene(delay_s=0.05), tmp_path / "v.npy", 12.0,
                                            payload=True)  # fmt: skip
    _feed(stream, rollout, 1500)
    stream.stop()
    assert not stream._process.is_alive() and stream._process.exitcode == 0
    assert not (tmp_path / "v.npy").exists()


def test_no_stream_from_a_process_with_an_opengl_context(
    tmp_path: Path, monkeypatch, caplog
) -> None:
    """Its fork would hang at the first frame: the video is rendered after the simulation."""
    from dexlfd.viz import robot_video_stream

    monkeypatch.setattr(robot_video_stream, "context_made", lambda: True)
    with caplog.at_level(logging.INFO, logger="dexlfd"):
        stream = robot_video_stream.VideoStream.start(_Scene(), tmp_path / "v.npy", 12.0,
                                                      payload=True)  # fmt: skip
    assert stream is None
    assert any("after the simulation: this process has an OpenGL context" in r.getMessage()
               for r in caplog.records)  # fmt: skip


def test_a_render_process_that_hangs_never_blocks_the_simulation_and_is_killed_after_it(
    tmp_path: Path, stream_parts, monkeypatch, caplog
) -> None:
    """Alive but stuck at its first frame: the loop's hand-overs return, its pipe never
    fills; after the simulation the wait for it ends, and the video is left to the rollout."""
    import multiprocessing

    monkeypatch.setattr(stream_parts, "STALL_S", 0.5)  # [s] the injected short timeout
    rollout = _rollout(n=120_000)  # 120 s: 1440 frames, ~4x what the pipe's buffer holds
    hung = _Scene(gate=multiprocessing.get_context("fork").Event())  # never set
    stream = stream_parts.VideoStream.start(hung, tmp_path / "v.npy", 12.0, payload=True)
    _feed(stream, rollout, rollout.n_samples, every=1000)  # returns: nothing blocks
    assert len(stream._sent) == stream_parts.BACKLOG_FRAMES  # the rest waits for the child
    assert stream.finish(rollout)
    with caplog.at_level(logging.WARNING, logger="dexlfd"):
        assert stream.result() is None  # the caller renders the video from the rollout
    said = [r.getMessage() for r in caplog.records if "drew no frame" in r.getMessage()]
    assert said == ["the robot video is rendered after the simulation: its render process "
                    "drew no frame in 0.5 s (killed)"]  # fmt: skip
    assert not stream._process.is_alive() and stream._process.exitcode == -signal.SIGKILL
    assert not (tmp_path / "v.npy").exists()


def test_frames_beyond_the_backlog_are_sent_as_the_child_draws(
    tmp_path: Path, stream_parts
) -> None:
    """A child behind by more than the backlog still gets every frame of the replay."""
    import multiprocessing

    rollout = _rollout(n=30_000)  # 30 s: 360 frames
    gate = multiprocessing.get_context("fork").Event()
    stream = stream_parts.VideoStream.start(_Scene(gate=gate), tmp_path / "v.npy", 12.0,
                                            payload=True)  # fmt: skip
    _feed(stream, rollout, rollout.n_samples, every=1000)
    assert stream.finish(rollout)
    assert len(stream._sent) == stream_parts.BACKLOG_FRAMES  # the child has drawn none yet
    gate.set()
    assert stream.result() == tmp_path / "v.npy"
    got = np.load(tmp_path / "v.npy", allow_pickle=False)
    assert got.shape[0] == 360 and np.array_equal(got, _replayed(rollout, 12.0))


def test_a_child_is_stalled_only_after_drawing_nothing_for_the_whole_timeout(
    stream_parts,
) -> None:
    """Lock-step: frames now and then keep it waited for, however long in all."""
    stall = stream_parts.STALL_S
    watch = stream_parts._Progress(0, 100.0)
    assert not watch.stalled(0, 100.0 + stall)  # exactly the timeout: not yet
    assert watch.stalled(0, 100.0 + stall + 0.1)
    watch = stream_parts._Progress(0, 0.0)
    for i in range(1, 20):  # a frame every 0.9 timeouts: 17 timeouts in all
        assert not watch.stalled(i, 0.9 * stall * i)
    assert not watch.stalled(19, 0.9 * stall * 19 + stall)
    assert watch.stalled(19, 0.9 * stall * 19 + stall + 0.1)
