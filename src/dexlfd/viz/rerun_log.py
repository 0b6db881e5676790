"""Log demonstrations, plans and rollouts to a rerun ``.rrd`` file (``--rerun FILE.rrd``).

:class:`RerunLog` writes one recording to a file, never to a viewer or over the
network: open the file later with ``rerun FILE.rrd``. One method per data kind:

* :meth:`RerunLog.capture_frame` - a camera image (JPEG) and its 2-D hand landmarks;
* :meth:`RerunLog.demonstration` - 3-D hand keypoints, end-effector pose, gripper, grasp;
* :meth:`RerunLog.teleop_frame` - one teleoperation frame (image, hand, target pose);
* :meth:`RerunLog.plan` - the planned path and pose, and the learned model's mean
  with its ±2σ position tube (ellipsoids of the GMR covariance, Eq. 4.19);
* :meth:`RerunLog.obstacles` - the plan's obstacle boxes;
* :meth:`RerunLog.rollout` - the robot's TCP path and pose, reference, gripper, joints,
  and the arm itself: the packaged Panda URDF loaded with rerun's own URDF support
  (``rerun.urdf.UrdfTree``; the collision meshes drawn, the visual ``.dae`` meshes are
  not shipped) and each joint's transform per sample (``compute_transform_columns``).

Everything time-varying is on ONE timeline, ``time`` (a duration in seconds,
each record's own ``t``); paths, obstacles and the tube are static. Entity
paths (``name`` defaults in brackets)::

    camera/image                 EncodedImage (JPEG)         per frame
    camera/image/hand(/skeleton) Points2D [px] (LineStrips2D) per frame with a hand
    world/<demo>/hand(/skeleton) Points3D [m] (LineStrips3D)  per valid sample
    world/<demo>/ee              Transform3D (pose)          per valid sample
    world/<plan>/path            LineStrips3D                static
    world/<plan>/target          Transform3D                 per sample
    world/model/mean, world/model/tube   LineStrips3D, Ellipsoids3D (±2σ)  static
    world/obstacles              Boxes3D                     static
    world/<robot>/tcp_path       LineStrips3D                static
    world/<robot>/tcp, .../reference     Transform3D         per sample
    <robot>/panda/visual_geometries/...  Mesh3D (the URDF)    static
    <robot>/joints/<joint>               Transform3D (frames <robot>/panda_link*)  per sample
    plots/gripper/<name>, plots/grasp/<name>, plots/joints/<robot>   Scalars

The base frame is z-up, metres. The file is written to a temporary file beside
the target and renamed by :meth:`RerunLog.close` (a failed run leaves nothing).
"""

from __future__ import annotations

import logging
import os
import weakref
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd.capture.tracking import HAND_CONNECTIONS
from dexlfd.errors import InvalidFile, InvalidInput
from dexlfd.io import Demonstration, LearnedModel, Plan, Rollout
from dexlfd.io._atomic import discard, put_in_place, temp_file

__all__ = ["TIMELINE", "RerunLog", "open_rerun", "write_rerun"]

logger = logging.getLogger(__name__)

TIMELINE = "time"  # the one timeline: duration since each record's start [s]
_BONES = np.array(HAND_CONNECTIONS)  # (21, 2) landmark index pairs of the skeleton
_TUBE_ELLIPSOIDS = 60  # ±2σ ellipsoids along the model mean


def _rr() -> Any:
    from dexlfd._extras import import_extra

    return import_extra("rerun", "rerun recording (.rrd logging)")


def _discard(path: str) -> None:
    discard(Path(path))


def _time(t: Any) -> Any:
    return _rr().TimeColumn(TIMELINE, duration=np.asarray(t, dtype=np.float64))


class RerunLog:
    """One rerun recording written to ``path`` (``.rrd``), atomically.

    Parameters
    ----------
    path
        Target file; its folder must exist. Replaced only by :meth:`close` with
        ``ok=True``; if the object is dropped without that, the temporary file is removed.
    application_id
        Rerun application id (the viewer groups recordings by it).
    jpeg_quality
        JPEG quality of logged camera images, 1..100.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        application_id: str = "dexlfd",
        jpeg_quality: int = 80,
    ) -> None:
        rr = _rr()
        self.path = Path(path)
        if self.path.suffix != ".rrd":
            raise InvalidInput(
                f"rerun recording {self.path}: expected a .rrd file name", param="rerun"
            )
        folder = self.path.parent if str(self.path.parent) else Path(".")
        if not folder.is_dir():
            raise InvalidFile(
                f"rerun recording {self.path}: folder {folder} does not exist", param="rerun"
            )
        if not 1 <= jpeg_quality <= 100:
            raise InvalidInput(f"jpeg_quality must be in 1..100, got {jpeg_quality}")
        self.jpeg_quality = int(jpeg_quality)
        self._tmp = tmp = temp_file(self.path)
        self._cleanup = weakref.finalize(self, _discard, str(tmp))
        self.rec = rr.RecordingStream(application_id)
        self.rec.save(str(self._tmp))
        self._closed = False
        self.n_frames = 0
        self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)

    # ------------------------------------------------------------------ helpers
    def _check_open(self) -> None:
        if self._closed:
            raise InvalidInput(f"RerunLog({self.path}) is closed")

    def _send(self, entity: str, t: Any, columns: Any) -> None:
        self.rec.send_columns(entity, indexes=[_time(t)], columns=columns)

    def _points(self, entity: str, t: Any, pts: np.ndarray, ok: np.ndarray, dim: int) -> None:
        """Per-time hands (n, 21, dim): landmarks at ``entity``, skeleton at ``.../skeleton``.

        Rows without ``ok`` or with a non-finite landmark are left out. The
        skeleton is logged as line segments, not through an AnnotationContext
        (which older rerun-sdk releases could not serialise under numpy < 2).
        """
        rr = _rr()
        ok = np.asarray(ok, bool) & np.isfinite(pts).all(axis=(1, 2))
        if not ok.any():
            return
        sel = np.asarray(pts[ok], dtype=np.float64)
        n = sel.shape[0]
        t_ok = np.asarray(t)[ok]
        points, strips = (
            (rr.Points2D, rr.LineStrips2D) if dim == 2 else (rr.Points3D, rr.LineStrips3D)
        )
        cols = points.columns(positions=sel.reshape(-1, dim)).partition(np.full(n, 21))
        self._send(entity, t_ok, cols)
        segments = list(sel[:, _BONES].reshape(-1, 2, dim))  # (n * bones) segments of 2 points
        cols = strips.columns(strips=segments).partition(np.full(n, len(_BONES)))
        self._send(f"{entity}/skeleton", t_ok, cols)

    def _poses(self, entity: str, t: Any, pos: np.ndarray, quat: np.ndarray) -> None:
        """Per-time poses (xyzw quaternions, like rerun's); non-finite rows are left out."""
        rr = _rr()
        ok = np.isfinite(pos).all(axis=1) & np.isfinite(quat).all(axis=1)
        if not ok.any():
            return
        self._send(
            entity,
            np.asarray(t)[ok],
            rr.Transform3D.columns(translation=pos[ok], quaternion=quat[ok]),
        )
        self.rec.log(entity, rr.TransformAxes3D(axis_length=0.08), static=True)

    def _scalars(self, entity: str, t: Any, values: np.ndarray) -> None:
        v = np.asarray(values, dtype=np.float64)
        ok = np.isfinite(v) if v.ndim == 1 else np.isfinite(v).all(axis=1)
        if ok.any():
            self._send(entity, np.asarray(t)[ok], _rr().Scalars.columns(scalars=v[ok]))

    def _path(self, entity: str, xyz: np.ndarray, color: Sequence[int]) -> None:
        xyz = np.asarray(xyz, dtype=np.float64)
        xyz = xyz[np.isfinite(xyz).all(axis=1)]
        if xyz.shape[0] >= 2:
            self.rec.log(entity, _rr().LineStrips3D([xyz], colors=[color]), static=True)

    # ------------------------------------------------------------------ data kinds
    def camera(self, t: float, rgb: np.ndarray, uv_px: np.ndarray | None = None) -> None:
        """One camera image (H, W, 3) uint8 RGB at ``t`` [s], with 21 landmarks [px] or None."""
        import cv2

        rr = _rr()
        self._check_open()
        img = np.asarray(rgb)
        if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
            raise InvalidInput(f"rgb must be an (H, W, 3) uint8 image, got {img.shape} {img.dtype}")
        ok, jpeg = cv2.imencode(
            ".jpg",
            cv2.cvtColor(np.ascontiguousarray(img), cv2.COLOR_RGB2BGR),
            [cv2.IMWRITE_JPEG_QUALITY, self.jpeg_quality],
        )
        if not ok:  # pragma: no cover - OpenCV encodes any uint8 RGB image
            raise InvalidInput(f"image at t={t} s: JPEG encoding failed")
        blob = rr.EncodedImage.columns(blob=[jpeg.tobytes()], media_type=["image/jpeg"])
        self._send("camera/image", [float(t)], blob)
        if uv_px is not None:
            uv = np.asarray(uv_px, dtype=np.float64)[None]
            self._points("camera/image/hand", [float(t)], uv, np.array([True]), 2)
        self.n_frames += 1

    def capture_frame(self, frame: Any, keypoints: Any = None) -> None:
        """One captured frame and its tracking result (a ``track_source`` ``on_frame`` callback).

        Parameters
        ----------
        frame
            :class:`~dexlfd.capture.Frame`: ``t`` [s] and ``rgb`` (H, W, 3) uint8.
        keypoints
            :class:`~dexlfd.capture.FrameKeypoints` of that frame (``uv_px`` [px]), or None.
        """
        seen = keypoints is not None and keypoints.n_hands > 0
        self.camera(frame.t, frame.rgb, keypoints.uv_px if seen else None)

    def teleop_frame(self, step: Any) -> None:
        """One teleoperation frame: image, 2-D/3-D hand, target TCP pose and gripper.

        ``step`` is a :class:`~dexlfd.apps.teleop.TeleopFrame` (the
        ``on_frame`` argument of ``run_teleop``).
        """
        pose = step.pose
        kp = pose.keypoints
        self.capture_frame(step.frame, kp)
        t = [float(step.frame.t)]
        self._points("world/hand/hand", t, np.asarray(kp.keypoints)[None], np.array([kp.valid]), 3)
        if pose.valid:
            self._poses("world/hand/ee", t, pose.position[None], pose.quaternion[None])
            self._scalars("plots/gripper/hand", t, np.array([pose.gripper]))
        target = step.target
        self._poses("world/target", t, np.asarray(target.position)[None],
                    np.asarray(target.quaternion)[None])  # fmt: skip
        self._scalars("plots/gripper/target", t, np.array([float(target.gripper)]))

    def demonstration(self, demo: Demonstration, name: str = "demo") -> None:
        """3-D hand keypoints, end-effector pose [m], gripper [m] and grasp of ``demo``."""
        self._check_open()
        self._points(f"world/{name}/hand", demo.t, demo.keypoints, demo.valid, 3)
        self._poses(f"world/{name}/ee", demo.t, demo.position, demo.quaternion)
        self._path(f"world/{name}/path", demo.position, (80, 160, 255))
        self._scalars(f"plots/gripper/{name}", demo.t, demo.gripper)
        self._scalars(f"plots/grasp/{name}", demo.t, demo.grasp.astype(np.float64))

    def plan(self, plan: Plan, model: LearnedModel | None = None, name: str = "plan") -> None:
        """The plan's path and pose over time; with ``model`` also its mean and ±2σ tube.

        The tube is drawn as ellipsoids along the GMR mean position whose
        half-axes are 2σ along the eigenvectors of the 3 x 3 position covariance.
        """
        rr = _rr()
        self._check_open()
        self._path(f"world/{name}/path", plan.position, (255, 140, 0))
        self._poses(f"world/{name}/target", plan.t, plan.position, plan.quaternion)
        self._scalars(f"plots/gripper/{name}", plan.t, plan.gripper)
        self.obstacles(plan)
        if model is None:
            return
        mean = model.mean[:, :3]
        self._path("world/model/mean", mean, (160, 160, 160))
        idx = np.unique(np.linspace(0, mean.shape[0] - 1, _TUBE_ELLIPSOIDS).round().astype(int))
        cov = model.cov[idx][:, :3, :3]
        eigval, eigvec = np.linalg.eigh(0.5 * (cov + np.swapaxes(cov, 1, 2)))
        eigvec[:, :, 2] *= np.sign(np.linalg.det(eigvec))[:, None]  # a proper rotation
        from dexlfd.rotations import quat_from_matrix

        self.rec.log(
            "world/model/tube",
            rr.Ellipsoids3D(
                centers=mean[idx],
                half_sizes=2.0 * np.sqrt(np.maximum(eigval, 0.0)),
                quaternions=quat_from_matrix(eigvec),
                colors=[(160, 160, 160, 60)],
                fill_mode=rr.components.FillMode.Solid,
            ),
            static=True,
        )

    def obstacles(self, plan: Plan) -> None:
        """The obstacles and supports of a plan as boxes (spheres as their bounding cube)."""
        from dexlfd.geometry import half_extents
        from dexlfd.robot import plan_world

        boxes = plan_world(plan)
        if not boxes:
            return
        self.rec.log(
            "world/obstacles",
            _rr().Boxes3D(
                centers=[b.center for b in boxes],
                half_sizes=[half_extents(b) for b in boxes],
                colors=[(200, 60, 60, 120)],
            ),
            static=True,
        )

    def robot_model(self, rollout: Rollout, name: str = "robot") -> None:
        """The Panda drawn from its URDF, its 9 joints moving as in ``rollout``.

        Loaded with rerun's URDF support under the entity ``name`` and the frame prefix
        ``name/`` (several robots stay apart); the joints are logged per sample as
        transforms between the URDF's link frames, the fingers at half the opening.
        """
        import re
        import tempfile

        from dexlfd.robot.description import panda_urdf_text

        rr = _rr()
        # the collision meshes (.stl, shipped) as the visuals (the .dae are not shipped)
        text = re.sub(r"<collision>(.*?)</collision>", r"<visual>\1</visual>",
                      panda_urdf_text(fixed_fingers=False), flags=re.S)  # fmt: skip
        with tempfile.TemporaryDirectory() as tmp:
            urdf = Path(tmp) / "panda.urdf"
            urdf.write_text(text)
            tree = rr.urdf.UrdfTree.from_file_path(
                urdf, name, frame_prefix=f"{name}/",
                static_transform_entity_path=f"{name}/tf_static",
            )  # fmt: skip
            tree.log_urdf_to_recording(self.rec)
        t = rollout.t - rollout.t[0]
        values = {f"panda_joint{j + 1}": rollout.q[:, j] for j in range(rollout.q.shape[1])}
        half = 0.5 * np.asarray(rollout.gripper, dtype=np.float64)
        values.update(panda_finger_joint1=half, panda_finger_joint2=half)
        for joint in tree.joints():
            if joint.joint_type == "fixed" or joint.name not in values:
                continue
            cols = joint.compute_transform_columns(values[joint.name].tolist(), clamp=False)
            self._send(f"{name}/joints/{joint.name}", t, cols)

    def rollout(self, rollout: Rollout, name: str = "robot") -> None:
        """The robot's TCP path and pose, its reference, gripper [m] and joints [rad].

        With the arm drawn from the URDF (:meth:`robot_model`).
        """
        self._check_open()
        t = rollout.t - rollout.t[0]
        self.robot_model(rollout, name)
        self._path(f"world/{name}/tcp_path", rollout.ee_position, (40, 200, 80))
        self._poses(f"world/{name}/tcp", t, rollout.ee_position, rollout.ee_quaternion)
        self._poses(f"world/{name}/reference", t, rollout.ref_position, rollout.ref_quaternion)
        self._scalars(f"plots/gripper/{name}", t, rollout.gripper)
        self._scalars(f"plots/joints/{name}", t, rollout.q)

    # ------------------------------------------------------------------ file
    def close(self, ok: bool = True) -> Path | None:
        """Flush and finish the file; rename it into place when ``ok`` (else discard it)."""
        if self._closed:
            return self.path if ok else None
        self._closed = True
        self.rec.flush()  # blocks until everything is written (no timeout by default)
        self.rec.disconnect()
        if not ok:
            self._cleanup()
            return None
        put_in_place(self._tmp, self.path)
        self._cleanup.detach()
        logger.info("wrote %s (%.1f MB)", self.path, self.path.stat().st_size / 1e6)
        return self.path

    def __enter__(self) -> RerunLog:
        return self

    def __exit__(self, exc_type: object, *exc: object) -> None:
        self.close(ok=exc_type is None)


def open_rerun(path: str | os.PathLike[str] | None) -> RerunLog | None:
    """A :class:`RerunLog` writing ``path`` (a ``.rrd`` file), or None when ``path`` is None."""
    return None if path is None else RerunLog(path)


def write_rerun(
    path: str | os.PathLike[str],
    *,
    demonstrations: Sequence[tuple[str, Demonstration]] = (),
    plan: Plan | None = None,
    model: LearnedModel | None = None,
    rollouts: Sequence[tuple[str, Rollout]] = (),
) -> Path:
    """Write records that already exist to one ``.rrd`` file (named demonstrations/rollouts)."""
    with RerunLog(path) as log:
        for name, demo in demonstrations:
            log.demonstration(demo, name)
        if plan is not None:
            log.plan(plan, model)
        for name, ro in rollouts:
            log.rollout(ro, name)
    return log.path
