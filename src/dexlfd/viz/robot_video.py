"""Offscreen MP4 of a rollout replayed in the MuJoCo scene.

Needs an OpenGL context: on a machine without a display set ``MUJOCO_GL=egl``
(Mesa's llvmpipe works) before MuJoCo is imported. Frames go to
:class:`dexlfd.viz.video.VideoWriter` (H.264, browser-playable, atomic).

Shadows dominate the cost of software rendering: only the key light (the
scene's first) casts one, into a 2048 px map (MuJoCo's default is 4096 px for
every light). Measured with llvmpipe at 640x480: 2.7x less CPU per frame, and
the shadow that shows the object's height above the floor stays (a 1024 px map
costs 45 % less again but speckles the floor far from the light, so it stays 2048).
Two switches make a frame cheaper still (llvmpipe, 480x360, per frame: 35 ms of
CPU with both on): ``antialias=False`` renders without MuJoCo's 4x multisampling
(20 ms; the edges step a little), ``shadows=False`` without the shadow (8 ms;
3 ms with neither). A narrower shadow frustum (``vis.map.shadowscale``) with a
smaller map speckles the floor at the frustum's edge, in view, so it is not used.
Without the shadow, the floor's lighting (computed at the corners of its squares) and
the offscreen buffer's clearing are most of what is left: the video's floor has 0.1 m
squares (:data:`FLOOR_GRID_M`; the scene's 0.05 m) and the buffer the frame's size
(MuJoCo's default is 640x480), together 1.0-1.4 ms less CPU a 480x360 frame (of
2.8-3.2 ms to draw it; llvmpipe). The look is the same (the pixels differ by 0.4 of
255 on average, 9 at most; 0.2 m squares would show the floor's facets).

With ``workers > 1`` the frames are rendered in that many processes at once, each a
contiguous stretch of the rollout: child processes render theirs into shared memory
(nothing on disk) while this process renders and writes the first stretch, then
writes theirs in order. The children are new interpreters (``python -m
dexlfd.viz.robot_video``, their work pickled on stdin), not forks: an OpenGL context
does not survive a fork (a forked child of a process that had rendered hangs in
EGL), and multiprocessing's spawn would re-run a user's script without a main guard.
A child that fails is not fatal: its stretch is rendered here.
"""

from __future__ import annotations

import logging
import os
import pickle
import subprocess
import sys
from collections.abc import Callable
from multiprocessing import shared_memory
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd.errors import InvalidInput
from dexlfd.io import Rollout
from dexlfd.io.video import VideoWriter
from dexlfd.robot.plant import PlantConfig
from dexlfd.robot.robot_model import import_mujoco
from dexlfd.robot.sim import PandaSim
from dexlfd.viz.video import draw_caption

__all__ = ["Scene", "frame_samples", "payload_start", "render_rollout_video", "rollout_caption"]

logger = logging.getLogger(__name__)

SHADOW_MAP_PX = 2048  # shadow map size [px]
FLOOR_GRID_M = 0.1  # the floor's lit squares in the video [m] (the scene's: 0.05 m)


def rollout_caption(rollout: Rollout, plant: PlantConfig) -> str:
    """``"NTSM-PD, 1.2 kg object"``: the rollout's controller and the plant's object."""
    name = rollout.controller
    label = str(name).upper() if name else "controller"
    kg = float(plant.payload_kg or 0.0)
    return f"{label}, {kg:g} kg object" if kg > 0 else f"{label}, no object"


def render_rollout_video(
    rollout: Rollout,
    plant: PlantConfig,
    path: str | os.PathLike[str],
    *,
    fps: float = 30.0,
    width: int = 640,
    height: int = 480,
    callback: Callable[[int, float], None] | None = None,
    caption: str | None = "auto",
    workers: int = 1,
    shadows: bool = True,
    antialias: bool = True,
    fast_encode: bool = False,
) -> Path:
    """Replay ``rollout`` (joints, gripper, object pose) and write an MP4 at ``fps``.

    ``caption`` is written on every frame, followed by the rollout's time: by default
    (``"auto"``) :func:`rollout_caption` (the controller and the object), ``None`` for
    none. ``workers`` processes render at once (see the module docstring); the
    frames are the same. ``shadows`` (the key light's shadow) and ``antialias``
    (4x multisampling) cost most of a frame's CPU (see the module docstring); off,
    the frames are cheaper, of the same count and size. ``fast_encode``: x264's
    ``ultrafast`` preset with the YUV conversion in this process
    (:class:`~dexlfd.io.video.VideoWriter`'s ``preset`` and ``subsample_here``),
    ~1.7 ms less CPU a 480x360 frame for a ~3.5x larger file. Returns the written path. Raises
    :class:`~dexlfd.errors.InvalidFile` if the video cannot be written; an
    interrupted render leaves no partial file.
    """
    if not (np.isfinite(fps) and fps > 0):
        raise InvalidInput(f"fps must be > 0, got {fps!r}")
    if caption == "auto":
        caption = rollout_caption(rollout, plant)
    out = Path(path)
    idx = frame_samples(rollout.t, fps)
    n_frames = idx.shape[0]
    pos = rollout.extras.get("payload_position")
    quat = rollout.extras.get("payload_quaternion")
    payload_at = None if pos is None or quat is None else payload_start(pos[0], quat[0])
    frames = _Frames(rollout, plant, payload_at, caption, width, height, shadows=shadows,
                     antialias=antialias, fast_encode=fast_encode)  # fmt: skip
    chunks = [c for c in np.array_split(np.arange(n_frames), max(1, int(workers))) if c.size]
    children = [_spawn_render(frames, idx[c]) for c in chunks[1:]]
    written = 0
    try:
        with VideoWriter(out, fps, **frames.encoding) as writer:
            with frames.sim() as sim:
                for k in idx[chunks[0]]:
                    writer.write(frames.render(sim, int(k)))
                    if callback is not None:
                        callback(written, float(rollout.t[k]))
                    written += 1
            for chunk, child in zip(chunks[1:], children, strict=True):
                for k, frame in zip(idx[chunk], child.frames(frames), strict=True):
                    writer.write(frame)
                    if callback is not None:
                        callback(written, float(rollout.t[k]))
                    written += 1
    finally:
        for child in children:
            child.stop()
    return out


def frame_samples(t: np.ndarray, fps: float) -> np.ndarray:
    """The rollout's sample shown in each frame: one frame every ``1/fps`` s of ``t``.

    Frame ``j`` shows the first sample at or after ``t[0] + j / fps``, from the first
    sample to the last.
    """
    n_frames = max(1, int(np.floor((t[-1] - t[0]) * fps)) + 1)
    idx = np.searchsorted(t, t[0] + np.arange(n_frames) / fps)
    return np.clip(idx, 0, t.shape[0] - 1)


def payload_start(position: np.ndarray, quaternion: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where the object waits in the replayed scene: its first sampled pose."""
    from dexlfd.rotations import matrix_from_quat

    return position, matrix_from_quat(quaternion)


class Scene:
    """Draws a pose of the robot (and the object) as one video frame with its caption.

    ``caption`` (None: none) is followed by the time; ``shadows``, ``antialias`` and
    ``fast_encode`` as for :func:`render_rollout_video`. :meth:`sim` makes the scene at
    joints ``q0`` with the object waiting at ``payload_at`` (position, rotation matrix;
    None: the plant's); :attr:`encoding` is how its video is written.
    """

    def __init__(self, plant: PlantConfig, caption: str | None, width: int, height: int, *,
                 shadows: bool = True, antialias: bool = True,
                 fast_encode: bool = False) -> None:  # fmt: skip
        self.plant, self.caption, self.width, self.height = plant, caption, width, height
        self.shadows, self.antialias, self.fast_encode = shadows, antialias, fast_encode

    @property
    def encoding(self) -> dict[str, Any]:
        """The keywords of the video's :class:`~dexlfd.io.video.VideoWriter`."""
        return {"preset": "ultrafast", "subsample_here": True} if self.fast_encode else {}

    def sim(self, q0: np.ndarray, payload_at: Any) -> PandaSim:
        """The scene at joints ``q0``, the object waiting at ``payload_at``."""
        sim = PandaSim(self.plant, q0, payload_at=payload_at)
        model = sim.model
        model.vis.quality.shadowsize = SHADOW_MAP_PX
        model.light_castshadow[1:] = False  # the key light's shadow only
        if not self.shadows:
            model.light_castshadow[0] = False
        # read when the renderer is made (its first frame): the offscreen buffer of
        # the frame's size (the default 640x480 is cleared whole every frame)
        if not self.antialias:
            model.vis.quality.offsamples = 0
        model.vis.global_.offwidth, model.vis.global_.offheight = self.width, self.height
        mj = import_mujoco()
        floor = mj.mj_name2id(model, mj.mjtObj.mjOBJ_GEOM, "floor")
        model.geom_size[floor, 2] = FLOOR_GRID_M  # its quads are lit at their corners
        return sim

    def draw(self, sim: PandaSim, q: np.ndarray, gripper: float, payload: Any,
             t_s: float) -> np.ndarray:  # fmt: skip
        """The frame of joints ``q``, the finger opening and the object's pose.

        ``payload``: the object's (position, quaternion), or None; the caption shows the
        time ``t_s`` [s] since the start.
        """
        sim.set_pose(q, gripper, payload)
        frame = sim.render(self.width, self.height)
        if self.caption is not None:
            frame = draw_caption(frame, f"{self.caption}   t = {t_s:4.1f} s")
        return np.ascontiguousarray(frame, dtype=np.uint8)


class _Frames(Scene):
    """Renders the rollout's frame at sample ``k`` (the scene, the caption)."""

    def __init__(self, rollout: Rollout, plant: PlantConfig, payload_at: Any,
                 caption: str | None, width: int, height: int,
                 **switches: bool) -> None:  # fmt: skip
        super().__init__(plant, caption, width, height, **switches)
        self.rollout, self.payload_at = rollout, payload_at
        self.pos = rollout.extras.get("payload_position")
        self.quat = rollout.extras.get("payload_quaternion")

    def sim(self, q0: np.ndarray | None = None, payload_at: Any = None) -> PandaSim:
        return super().sim(self.rollout.q[0] if q0 is None else q0,
                           self.payload_at if payload_at is None else payload_at)  # fmt: skip

    def render(self, sim: PandaSim, k: int) -> np.ndarray:
        r = self.rollout
        payload = None if self.pos is None or self.quat is None else (self.pos[k], self.quat[k])
        return self.draw(sim, r.q[k], float(r.gripper[k]), payload, r.t[k] - r.t[0])


class _Child:
    """A process rendering samples ``ks`` into shared memory (``memory``)."""

    def __init__(self, ks: np.ndarray, memory: shared_memory.SharedMemory, process: Any) -> None:
        self.ks, self.memory, self.process = ks, memory, process

    def frames(self, frames: _Frames) -> Any:
        """The stretch's frames: the child's, or rendered here if the child failed."""
        code = self.process.wait()
        if code == 0:
            shape = (self.ks.shape[0], frames.height, frames.width, 3)
            yield from np.ndarray(shape, dtype=np.uint8, buffer=self.memory.buf)
            return
        err = self.process.stderr.read().decode(errors="replace").strip().splitlines()
        logger.warning("a video render process failed (exit code %s%s): rendering its %d "
                       "frames here", code, f": {err[-1]}" if err else "",
                       self.ks.shape[0])  # fmt: skip
        with frames.sim() as sim:
            for k in self.ks:
                yield frames.render(sim, int(k))

    def stop(self) -> None:
        """End the process (if still running) and free the shared memory."""
        if self.process.poll() is None:
            self.process.terminate()
        self.process.wait()
        self.process.stderr.close()
        self.memory.close()
        self.memory.unlink()


def _spawn_render(frames: _Frames, ks: np.ndarray) -> _Child:
    """Start a process that renders samples ``ks`` into a new shared memory block."""
    size = max(1, ks.shape[0] * frames.height * frames.width * 3)
    memory = shared_memory.SharedMemory(create=True, size=size)
    work = pickle.dumps((frames, ks, memory.name))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
    try:
        process = subprocess.Popen(
            [sys.executable, "-m", "dexlfd.viz.robot_video"], stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env, start_new_session=False,
        )  # fmt: skip
        assert process.stdin is not None
        process.stdin.write(work)
        process.stdin.close()
    except BaseException:
        memory.close()
        memory.unlink()
        raise
    return _Child(ks, memory, process)


def _render_into(frames: _Frames, ks: np.ndarray, name: str) -> None:  # pragma: no cover
    """In the child: render samples ``ks`` into shared memory ``name``, frame after frame."""
    from multiprocessing import resource_tracker

    memory = shared_memory.SharedMemory(name=name)
    # the parent owns the block: this process must not unlink it when it exits
    resource_tracker.unregister(memory._name, "shared_memory")  # type: ignore[attr-defined]
    try:
        out = np.ndarray((ks.shape[0], frames.height, frames.width, 3), dtype=np.uint8,
                         buffer=memory.buf)  # fmt: skip
        with frames.sim() as sim:
            for i, k in enumerate(ks):
                out[i] = frames.render(sim, int(k))
        del out
    finally:
        memory.close()


if __name__ == "__main__":  # pragma: no cover - a render process (_spawn_render)
    from dexlfd._gl import choose_gl_backend

    choose_gl_backend()
    _render_into(*pickle.loads(sys.stdin.buffer.read()))
