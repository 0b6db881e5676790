"""The robot video rendered while the rollout is simulated: :class:`VideoStream`.

:func:`~dexlfd.viz.robot_video.render_rollout_video` replays a finished rollout. A
stream renders the same frames as the simulation records their samples: a forked
child draws each frame once its sample is simulated (every
:data:`~dexlfd.control.loop.SAMPLES_EVERY` ticks :func:`~dexlfd.control.track` hands
the samples recorded so far to :meth:`VideoStream.rows`, which sends the few the
frames show: 12 a second of simulated time at 12 fps), so on two
cores the video is made during the simulation instead of after it. When the
rollout is finished (or stopped early) :meth:`VideoStream.finish` sends the frames
left from the rollout itself: each frame is the sample
:func:`~dexlfd.viz.robot_video.frame_samples` picks from the finished rollout, the
same sample a replay would show (checked: a stream whose frames would differ is
dropped, and the video is rendered from the rollout as before).

A fork of a process that made an OpenGL context hangs at its first frame (Mesa's
worker threads are not in the child, :mod:`dexlfd._gl`): :meth:`VideoStream.start`
then returns None and says why, and the caller renders the video after the
simulation. A child that dies (or fails) is an error of :meth:`VideoStream.result`,
never a hang; :meth:`VideoStream.stop` ends it and removes its partial video.

A child that hangs alive (its OpenGL context stuck, say) never blocks the
simulation: at most :data:`BACKLOG_FRAMES` frames wait for it in the pipe (the rest
are sent as it draws them), so a send always fits the pipe's buffer. Once the
simulation has ended, :meth:`VideoStream.result` waits for the child only while it
draws: a child that drew no frame (nor finished its video) for :data:`STALL_S`
seconds is killed, said in one line, and the caller renders the video from the
rollout. The child counts the frames it drew in shared memory.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._gl import context_made
from dexlfd.errors import DexlfdError
from dexlfd.io import Rollout
from dexlfd.io._atomic import remove_strays_of
from dexlfd.io.video import VideoWriter
from dexlfd.viz.robot_video import Scene, frame_samples, payload_start

__all__ = ["VideoStream"]

logger = logging.getLogger(__name__)


_STOP_WAIT_S = 5.0  # [s] a child asked to stop gets this long before it is terminated
#: frames sent that the child has not drawn yet, at most (~240 bytes each in the pipe,
#: whose buffer holds ~90 kB): 10 s of video at 12 fps
BACKLOG_FRAMES = 120
#: [s] after the simulation, a child that draws no frame this long is taken as hung: a
#: frame takes milliseconds, its first (the scene, the OpenGL context) under a second
STALL_S = 60.0
_POLL_S = 0.05  # [s] how often a waiting result looks at the child's progress


class VideoStream:
    """A child process rendering a rollout's video from its samples as they come.

    Made by :meth:`start`; fed by :meth:`rows` (the samples recorded so far, any
    number of times) and :meth:`finish` (the finished rollout); :meth:`result` waits
    for the video; :meth:`stop` abandons it.
    """

    def __init__(self, path: Path, fps: float, payload: bool, process: Any, conn: Any,
                 drawn: Any) -> None:  # fmt: skip
        self.path, self.fps, self.payload = path, float(fps), payload
        self._process, self._conn, self._drawn = process, conn, drawn
        self._sent: list[int] = []  # the sample each frame sent so far shows
        self._broken: str | None = None  # why the child cannot be fed any more
        self._finished = False
        # the finished rollout's frames not sent yet (the backlog was full), and the end
        self._rest: tuple[dict[str, np.ndarray], list[int]] | None = None
        self._ended = False

    @classmethod
    def start(cls, scene: Scene, path: Path, fps: float, *, payload: bool) -> VideoStream | None:
        """Start the child that writes the video to ``path``; None when it could not draw.

        ``payload``: the rollout has the object's pose (``payload_position`` and
        ``payload_quaternion``); the scene then shows the object where it is.
        """
        if context_made():
            logger.info("the robot video is rendered after the simulation: this process "
                        "has an OpenGL context, a fork of it could not draw")  # fmt: skip
            return None
        ctx = multiprocessing.get_context("fork")
        here, there = ctx.Pipe(duplex=True)
        drawn = ctx.RawValue("q", 0)  # the frames the child drew (written by it alone)
        process = ctx.Process(target=_child, name="dexlfd-video-stream", daemon=True,
                              args=(scene, Path(path), float(fps), there, here, drawn))  # fmt: skip
        process.start()
        there.close()
        return cls(Path(path), fps, payload, process, here, drawn)

    def rows(self, recorded: dict[str, np.ndarray]) -> None:
        """Send the frames whose samples are among ``recorded`` (the rows so far).

        ``recorded``: ``t`` [s], ``q``, ``gripper`` (and with the object
        ``payload_position``, ``payload_quaternion``), one row per sample from the first.
        A frame is sent once the first sample at or after its time is recorded and
        fewer than :data:`BACKLOG_FRAMES` wait for the child (else with a later call).
        """
        t = recorded["t"]
        if self._broken is not None or self._finished or t.shape[0] == 0:
            return
        # the frames up to the last sample recorded (later ones may show samples to come)
        self._send(recorded, frame_samples(t, self.fps)[len(self._sent) :].tolist())

    def finish(self, rollout: Rollout) -> bool:
        """Send the frames left from the finished ``rollout``; False: the stream is dropped.

        Dropped (stopped, with a warning) when its child failed or when a frame already
        sent shows another sample than the replay of ``rollout`` would: the caller then
        renders the video from the rollout. Frames beyond the backlog are sent by
        :meth:`result`, as the child draws.
        """
        idx = frame_samples(rollout.t, self.fps).tolist()
        has_payload = {"payload_position", "payload_quaternion"} <= rollout.extras.keys()
        if self._broken is None and (idx[: len(self._sent)] != self._sent
                                     or has_payload != self.payload):  # fmt: skip
            self._broken = "its frames were not those of the finished rollout"
        if self._broken is None and not self._process.is_alive():  # not sent to: not seen
            self._broken = self._why_ended()
        if self._broken is None:
            rows = {"t": rollout.t, "q": rollout.q, "gripper": rollout.gripper}
            if self.payload:
                rows["payload_position"] = rollout.extras["payload_position"]
                rows["payload_quaternion"] = rollout.extras["payload_quaternion"]
            self._rest = (rows, idx[len(self._sent) :])
            self._send_rest()
        if self._broken is not None:
            logger.warning("the robot video is rendered after the simulation: %s", self._broken)
            self.stop()
            return False
        self._finished = True
        return True

    def result(self) -> Path | None:
        """Wait for the child to write the video; raises DexlfdError if it failed or died.

        None (said in one line; the child killed, its partial video removed) when it
        drew nothing for :data:`STALL_S` seconds while alive: render it from the rollout.
        """
        if not self._finished:
            raise DexlfdError("the robot video's stream was not finished")
        try:
            # the frames left, then the child's answer (a message, or its death's EOF)
            if not (self._wait(self._send_rest) and self._wait(self._conn.poll)):
                self._process.kill()
                self._process.join()
                remove_strays_of(self.path)
                logger.warning("the robot video is rendered after the simulation: its render "
                               "process drew no frame in %g s (killed)", STALL_S)  # fmt: skip
                return None
            try:
                message = self._conn.recv()
            except (EOFError, OSError):
                self._process.join()
                raise DexlfdError(f"the robot video's render process died (exit code "
                                  f"{self._process.exitcode})") from None  # fmt: skip
            if message[0] != "ok":
                raise DexlfdError(f"the robot video could not be rendered: {message[1]}")
            return self.path
        finally:
            self.stop()

    def stop(self) -> None:
        """End the child (asked first, so that it removes its partial video) and wait."""
        if self._process.is_alive():
            with contextlib.suppress(OSError):  # it is ending, or has ended
                self._conn.send(("stop", None))
            self._process.join(_STOP_WAIT_S)
            if self._process.is_alive():
                self._process.terminate()
                self._process.join(_STOP_WAIT_S)
            if self._process.is_alive():  # SIGTERM handled, or blocked
                self._process.kill()
        self._process.join()
        self._conn.close()

    def _wait(self, done: Callable[[], bool]) -> bool:
        """Wait until ``done()`` (True), or until the child drew nothing for STALL_S (False)."""
        watch = _Progress(self._drawn.value, time.monotonic())
        while not done():
            if not self._process.is_alive():
                return True  # its exit code, or its message, is the answer
            self._conn.poll(_POLL_S)  # woken early by the child's message
            if watch.stalled(self._drawn.value, time.monotonic()):
                return False
        return True

    def _send_rest(self) -> bool:
        """Send what the backlog has room for of the frames left, then the end; True: all sent."""
        if self._rest is not None and self._broken is None:
            rows, ks = self._rest
            ks = ks[self._send(rows, ks) :]
            self._rest = (rows, ks) if ks else None
        if self._rest is None and self._broken is None and not self._ended:
            self._ended = self._tell(None)  # the end: the child closes the video
        return self._ended or self._broken is not None

    def _send(self, rows: dict[str, np.ndarray], ks: list[int]) -> int:
        """Send the first samples ``ks`` of ``rows`` the backlog has room for; their count."""
        ks = ks[: max(0, BACKLOG_FRAMES - (len(self._sent) - self._drawn.value))]
        if not ks:
            return 0
        t = rows["t"]
        first = None
        if not self._sent:  # the scene is made at the first sample
            first = (np.array(rows["q"][0]), self._payload(rows, 0, start=True))
        frames = [(np.array(rows["q"][k]), float(rows["gripper"][k]), self._payload(rows, k),
                   t[k] - t[0]) for k in ks]  # fmt: skip
        if not self._tell((first, frames)):
            return 0
        self._sent.extend(ks)
        return len(ks)

    def _payload(self, rows: dict[str, np.ndarray], k: int, start: bool = False) -> Any:
        if not self.payload:
            return None
        pos, quat = np.array(rows["payload_position"][k]), np.array(rows["payload_quaternion"][k])
        return payload_start(pos, quat) if start else (pos, quat)

    def _tell(self, message: Any) -> bool:
        """Send ``message`` to the child; False (the stream broken) when it is gone."""
        try:
            self._conn.send(("frames", message))
        except OSError:  # a dead child: the simulation goes on without it
            self._broken = self._why_ended()
            return False
        return True

    def _why_ended(self) -> str:
        """Why the child is gone: the error it sent, else its exit code."""
        try:
            kind, text = self._conn.recv() if self._conn.poll() else (None, None)
        except (EOFError, OSError):
            kind = text = None
        self._process.join(_STOP_WAIT_S)
        if kind == "error":
            return f"its render process failed: {text}"
        return f"its render process ended (exit code {self._process.exitcode})"


class _Progress:
    """The child's frames drawn, watched: stalled when none came for :data:`STALL_S`."""

    def __init__(self, drawn: int, now_s: float) -> None:
        self.drawn, self.since_s = drawn, now_s

    def stalled(self, drawn: int, now_s: float) -> bool:
        """Whether no frame was drawn for STALL_S up to ``now_s`` [s] (``drawn`` so far)."""
        if drawn != self.drawn:
            self.drawn, self.since_s = drawn, now_s
        return now_s - self.since_s > STALL_S


def _child(scene: Scene, path: Path, fps: float, conn: Any, other: Any,
           drawn: Any) -> None:  # pragma: no cover  # fmt: skip
    """In the child: draw the frames sent, write them to ``path``; report the outcome."""
    other.close()  # the parent's end: its death ends our reads
    # llvmpipe rasterizes in this thread: ~7 % less CPU a frame than with its worker
    # threads (the video keeps up with the simulation either way)
    os.environ.setdefault("LP_NUM_THREADS", "0")
    message: tuple[str, Any] | None = ("ok", None)
    try:
        with VideoWriter(path, fps, **scene.encoding) as writer:
            if not _draw(scene, conn, writer, drawn):
                raise _Stopped  # the partial video is removed
    except _Stopped:
        message = None
    except BaseException as exc:
        message = ("error", f"{type(exc).__name__}: {exc}")
    if message is not None:
        with contextlib.suppress(OSError):  # the parent is gone
            conn.send(message)
    conn.close()


def _draw(scene: Scene, conn: Any, writer: VideoWriter, drawn: Any) -> bool:  # pragma: no cover
    """Draw every frame sent until the end (True) or a stop (False)."""
    sim = None
    try:
        while True:
            try:
                kind, message = conn.recv()
            except EOFError:  # the parent is gone
                return False
            if kind == "stop":
                return False
            if message is None:
                return True
            first, frames = message
            if sim is None:
                sim = scene.sim(*first)
            for q, gripper, payload, t_s in frames:
                writer.write(scene.draw(sim, q, gripper, payload, t_s))
                drawn.value += 1
    finally:
        if sim is not None:
            sim.close()


class _Stopped(Exception):
    """The parent stopped the stream: the partial video is removed, nothing is reported."""
