"""A robot-base-aligned task frame estimated from the demonstrations themselves.

A video recorded without extrinsics gives demonstrations in the **camera frame**
(x right, y down, z forward, metres through the hand's size). The planner needs a
frame whose z points up. :func:`estimate_task_frame` finds it from what the hand
did, without a calibration board; :func:`apply_frame` maps a demonstration into it.

**Task frame.** z is up (against gravity); the origin lies on the fitted table
plane (the grasp and release points), under the mean grasp TCP position; x is the
camera's optical axis projected onto the horizontal plane, pointing away from the
camera (when the camera looks straight down, the image's up direction projected
instead, noted in ``details["x_axis"]``); y = z × x. A robot standing where the
camera stood sees the task as the person did.

**Up.** People lift an object and set it down nearly vertically
(:mod:`dexlfd.motion.lifts`): each grasp run gives one up direction, the sum of
its unit lift and reversed set-down (their leans along the carry cancel); a side
pointing more than ``SIDE_DOWN_MARGIN_DEG`` down the image is left out (a slide or a
pull towards the camera: a lift leans along the carry, up to ~45 deg on the rendered
arcs, so a steep camera sees it point that far down the image, no further). The runs
are combined robustly: a weighted mean, runs more than ``OUTLIER_DEG`` from it
dropped, the mean taken again. A side's weight is its reach × straightness × the
share of its direction's variance that is lean (``LEAN_DEG``) rather than depth
error: an RGB-only depth errs by ``depth_error`` along the line of sight, which turns
a side by up to ``atan(depth_error / across)``, ``across`` the side's length square
to the line of sight (the part the pixels measured). A "lift" mostly along the line
of sight is mostly the depth's short-run motion and counts little; the pixels'
vertical motion is what an upright camera sees of a lift. The sign is the hand's: up
is where it lifts. An upright camera sees up in the image's upper half (−y), or
about along its optical axis when it looks straight down: a run whose up points
more than ``IMAGE_DOWN_MARGIN_DEG`` down the image (the hand slid or pulled the
object towards the camera more than it lifted it) is not used, unless no run
points up the image (then a warning). Cross-check: when the grasp and release
points spread over an area (not one line) and fit one plane within
``MAX_PLANE_RMS_M``, its normal is fused (by inverse variance) if it is within
``MAX_PLANE_ANGLE_DEG`` of the lifts; otherwise it is not forced (pick and place
may be at different heights: shelf to shelf, into a planter) and ``details`` says
why.

**Uncertainty.** ``up_deg`` combines the runs' lean (their spread, at least
``LEAN_DEG``, over the square root of their number) with the tilt that a depth
error gives a lift (:func:`~dexlfd.motion.frame_evidence.depth_error`: RGB-only
depth is read from the hand's size and errs by centimetres around a grasp;
systematic, so not averaged down); ``table_m`` is the RMS of the grasp and release
points' heights.

**Scale.** The RGB lifting is metric through MediaPipe's world landmarks (the
hand's size). The scale stays 1.0; its uncertainty combines the spread of adult
hand lengths (wrist to middle fingertip 0.185 m, 1-sigma ``HAND_LENGTH_REL_SD``)
with the spread of the recorded hand's length over the frames.

Demonstrations already in a base frame (``calibrate`` / ``--extrinsics``) give the
identity with ``method="extrinsics"``.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.capture.transforms import check_rigid_transform
from dexlfd.errors import InvalidInput
from dexlfd.io import Demonstration
from dexlfd.io.demonstration_facts import AppliedFrame
from dexlfd.motion.definition import euler_from_quat
from dexlfd.motion.frame_evidence import (
    MAX_PLANE_RMS_M,
    angle_deg,
    depth_angle,
    depth_error,
    hand_length,
    plane_check,
    scale_uncertainty,
)
from dexlfd.motion.lifts import LiftEvent, episode_up, lift_events
from dexlfd.rotations import quat_from_matrix, quat_multiply, quat_sign_continuous

__all__ = ["TASK_FRAME_METHODS", "TaskFrame", "apply_frame", "estimate_task_frame"]

_APPLIED = ("camera_to_base", "scale", "from_frame", "method")  # AppliedFrame's fields

logger = logging.getLogger(__name__)

TASK_FRAME_METHODS = ("extrinsics", "demonstrations")
OUTLIER_DEG = 30.0  # a grasp run's up this far from the consensus is dropped [deg]
LEAN_DEG = 10.0  # 1-sigma lean of one lift/set-down pair from vertical, at least [deg]
IMAGE_DOWN_MARGIN_DEG = 15.0  # up may point this far past the optical axis down the image
SIDE_DOWN_MARGIN_DEG = 45.0  # one side (lift or set-down) may point this far down the image
MIN_HORIZONTAL = 0.1  # optical axis' horizontal part below this: looking straight down


@dataclass(frozen=True, slots=True)
class TaskFrame:
    """Camera frame -> task frame (z up), with its provenance and uncertainty.

    ``p_task = camera_to_task @ [scale * p_camera, 1]``. ``details`` holds what the
    estimate saw (per grasp run up directions, the plane check, the camera's pitch).
    """

    method: str  # one of TASK_FRAME_METHODS
    camera_to_task: FloatArray  # (4, 4) rigid, applied after ``scale``
    up_camera: FloatArray  # (3,) unit, against gravity, camera frame
    scale: float  # factor on camera-frame positions [-]
    uncertainty: dict[str, float]  # "up_deg", "scale_rel", "table_m"
    n_events: int  # grasp + release events used
    details: dict[str, Any] = field(default_factory=dict)  # JSON-able

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (arrays as lists, NaN as None)."""
        return _json_clean(
            {
                "method": self.method,
                "camera_to_task": np.asarray(self.camera_to_task).tolist(),
                "up_camera": np.asarray(self.up_camera).tolist(),
                "scale": float(self.scale),
                "uncertainty": {k: float(v) for k, v in self.uncertainty.items()},
                "n_events": int(self.n_events),
                "details": self.details,
            }
        )


def _json_clean(value: Any) -> Any:
    """``value`` with NumPy scalars as Python numbers and non-finite floats as None."""
    if isinstance(value, dict):
        return {str(k): _json_clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_clean(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def _frame_of(demo: Demonstration) -> str:
    return demo.frame or ""


def _is_camera(frame: str) -> bool:
    return frame == "" or frame.startswith("camera")


def _check_one_camera(demos: Sequence[Demonstration], names: Sequence[str]) -> bool:
    """True when the demonstrations are in a camera frame; InvalidInput when mixed."""
    frames = [_frame_of(d) for d in demos]
    for name, frame in zip(names, frames, strict=True):
        if _is_camera(frame) != _is_camera(frames[0]) or (
            not _is_camera(frame) and frame != frames[0]
        ):
            raise InvalidInput(
                f"{name}: frame {frame!r} differs from {names[0]}'s {frames[0]!r}; "
                "a task frame needs demonstrations in one frame (one camera)"
            )
    if _is_camera(frames[0]):
        sizes = [_image_size(d) for d in demos]
        for name, size in zip(names, sizes, strict=True):
            if size is not None and sizes[0] is not None and size != sizes[0]:
                raise InvalidInput(
                    f"{name}: filmed at {size[0]}x{size[1]} px, {names[0]} at "
                    f"{sizes[0][0]}x{sizes[0][1]} px; a task frame needs one camera"
                )
    return _is_camera(frames[0])


def _image_size(demo: Demonstration) -> tuple[int, int] | None:
    K = None if demo.capture is None else demo.capture.intrinsics
    return None if K is None else (K.width, K.height)


def _robust_mean(
    dirs: FloatArray, w: FloatArray, allowed: np.ndarray
) -> tuple[FloatArray, np.ndarray]:
    """Weighted mean direction of the ``allowed`` unit rows of ``dirs``, outliers dropped.

    Starts from the allowed row with the least weighted angle to the others (a
    medoid), so one wild row cannot drag the first mean; then rows more than
    ``OUTLIER_DEG`` from the mean are dropped and the mean taken again. Returns the
    unit mean and the kept mask.
    """
    ang = np.arccos(np.clip(dirs @ dirs.T, -1.0, 1.0))
    cost = np.where(allowed, ang @ w, np.inf)
    start = int(np.argmin(cost))
    u, keep = dirs[start], np.arange(len(dirs)) == start
    for _ in range(3):
        near = np.degrees(np.arccos(np.clip(dirs @ u, -1.0, 1.0))) <= OUTLIER_DEG
        m = (w[allowed & near, None] * dirs[allowed & near]).sum(axis=0)
        if not (allowed & near).any() or np.linalg.norm(m) < 1e-12:
            break  # keep the last mean (at worst the medoid alone)
        keep, u = allowed & near, m / np.linalg.norm(m)
    return u, keep


def _axes(up: FloatArray) -> tuple[FloatArray, str]:
    """Task x in the camera frame: the optical axis made horizontal (or image up)."""
    candidates = (
        (np.array([0.0, 0.0, 1.0]), "optical axis"),
        (np.array([0.0, -1.0, 0.0]), "image up (the camera looks straight down)"),
    )
    for axis, what in candidates:
        h = axis - np.dot(axis, up) * up
        if np.linalg.norm(h) >= MIN_HORIZONTAL:
            return h / np.linalg.norm(h), what
    raise AssertionError("unreachable: optical axis and image up cannot both be vertical")


def _is_image_up(u: FloatArray, margin_deg: float = IMAGE_DOWN_MARGIN_DEG) -> bool:
    """True unless ``u`` points more than ``margin_deg`` down the image."""
    return bool(-u[1] > -np.sin(np.radians(margin_deg)))


def _run_up(event: LiftEvent, depth_err: float) -> tuple[FloatArray, float, int] | None:
    """One grasp run's up (unit), weight [m] and number of sides used (module docstring).

    A side (the lift, the reversed set-down) pointing more than
    ``SIDE_DOWN_MARGIN_DEG`` down the image is left out unless both are; the weight
    sums the used sides' reach × straightness × lean share, ``depth_err`` [m] the
    depth's 1-sigma along the line of sight.
    """
    sides = []
    for v, s, pt in (
        (event.lift, event.lift_straightness, event.grasp_point),
        (event.set_down, event.set_down_straightness, event.release_point),
    ):
        if not np.isfinite(v).all() or np.linalg.norm(v) < 1e-9:
            continue
        norm = float(np.linalg.norm(v))
        sight = pt / np.linalg.norm(pt) if np.isfinite(pt).all() else np.array([0.0, 0.0, 1.0])
        across = float(np.linalg.norm(np.cross(v, sight)))
        turn = np.arctan(depth_err / max(across, 1e-9)) if depth_err > 0 else 0.0
        lean = np.radians(LEAN_DEG)
        sides.append(
            (
                v / norm,
                norm * s * lean**2 / (lean**2 + turn**2),
                _is_image_up(v / norm, SIDE_DOWN_MARGIN_DEG),
            )
        )
    good = [x for x in sides if x[2]] or sides
    if not good:
        return None
    u = np.sum([x[0] for x in good], axis=0)
    if np.linalg.norm(u) < 1e-9:
        return None
    return u / np.linalg.norm(u), float(sum(x[1] for x in good)), len(good)


def _combine_up(
    events: list[LiftEvent], depth_err: float = 0.0
) -> tuple[FloatArray, dict[str, Any]]:
    """Up from the grasp runs, cross-checked with the table plane; and what was seen.

    The 1-sigma of up combines the runs' lean (their spread, at least ``LEAN_DEG``,
    over the square root of their number) with the tilt a depth error gives the
    lifts (systematic: not reduced by their number).
    """
    found = [(e, _run_up(e, depth_err)) for e in events]
    used = [(e, r) for e, r in found if r is not None]
    dirs = np.array([r[0] for _, r in used])
    w = np.array([r[1] for _, r in used])
    # an upright camera sees up pointing into the image's upper half (-y; about along
    # the optical axis for a camera looking straight down): a run whose "up" points
    # clearly down the image moved mostly sideways (a slide, a pull towards the
    # camera), not up; it is not used unless no run points up the image
    upright = -dirs[:, 1] > -np.sin(np.radians(IMAGE_DOWN_MARGIN_DEG))
    up, keep = _robust_mean(dirs, w, upright if upright.any() else np.ones_like(upright))
    ang = np.array([angle_deg(d, up) for d in dirs])
    spread = float(np.sqrt(np.average(ang[keep] ** 2, weights=w[keep] + 1e-12)))
    n_kept = int(keep.sum())
    pts = [e.grasp_point for e, _ in used] + [e.release_point for e, _ in used]
    pts_arr = np.array([p for p in pts if np.isfinite(p).all()]).reshape(-1, 3)
    sight = pts_arr.mean(axis=0) / np.linalg.norm(pts_arr.mean(axis=0))  # camera at 0
    moves = [np.linalg.norm(v) for (e, _), k in zip(used, keep, strict=True) if k
             for v in (e.lift, e.set_down) if np.isfinite(v).all()]  # fmt: skip
    tilt = depth_angle(depth_err, up, sight, float(np.mean(moves)))
    sigma_m = np.hypot(np.radians(max(spread, LEAN_DEG)) / np.sqrt(n_kept), tilt)
    normal, sigma_p, plane = plane_check(pts_arr, up)
    if normal is not None:
        spread_p = plane["spread_m"]
        sigma_p = np.hypot(sigma_p, depth_angle(depth_err, normal, sight, spread_p))
        wm, wp = 1.0 / sigma_m**2, 1.0 / sigma_p**2
        up = (wm * up + wp * normal) / np.linalg.norm(wm * up + wp * normal)
        sigma_m = 1.0 / np.sqrt(wm + wp)
    info = {
        "runs": [
            {
                "demo": e.demo,
                "grasp_index": e.grasp_index,
                "release_index": e.release_index,
                "up_camera": r[0].tolist(),
                "weight_m": r[1],
                "sides": r[2],
                "angle_to_up_deg": float(a),
                "kept": bool(k),
                "image_up": bool(ok),
            }
            for (e, r), a, k, ok in zip(used, ang, keep, upright, strict=True)
        ],
        "run_spread_deg": spread,
        "plane": plane,
        "up_deg_sigma": float(np.degrees(sigma_m)),
        "depth_error_m": depth_err,
        "n_events": sum(r[2] for (_, r), k in zip(used, keep, strict=True) if k),
    }
    return up, info


def estimate_task_frame(
    demos: Sequence[Demonstration], *, names: Sequence[str] | None = None
) -> TaskFrame:
    """The task frame of demonstrations filmed by one camera (module docstring).

    Parameters
    ----------
    demos : sequence of Demonstration
        All in one camera frame (``frame`` starting with ``"camera"``, or no
        ``frame`` at all), or all in one base frame (then the identity,
        ``method="extrinsics"``). Filmed at one image size when recorded
        (``capture.intrinsics``).
    names : sequence of str, optional
        Names for messages (default ``demonstration 1``, ...).

    Raises
    ------
    InvalidInput
        No demonstrations, demonstrations in different frames or cameras, or no
        grasp with a lift or a set-down to estimate up from.
    """
    if len(demos) == 0:
        raise InvalidInput("estimate_task_frame: no demonstrations given")
    if names is None:
        names = [f"demonstration {i + 1}" for i in range(len(demos))]
    names = list(names)
    if len(names) != len(demos):
        raise InvalidInput(f"names: expected {len(demos)} names, got {len(names)}")
    in_camera = _check_one_camera(demos, names)
    events = [e for i, d in enumerate(demos) for e in lift_events(d, i)]
    if not in_camera:
        z = np.array([p[2] for e in events for p in (e.grasp_point, e.release_point)])
        z = z[np.isfinite(z)]
        table_m = float(np.sqrt(np.mean((z - z.mean()) ** 2))) if z.size else float("nan")
        return TaskFrame(
            "extrinsics", np.eye(4), np.array([0.0, 0.0, 1.0]), 1.0,
            {"up_deg": 0.0, "scale_rel": 0.0, "table_m": table_m},
            sum(e.n_events for e in events), {"frame": _frame_of(demos[0])},
        )  # fmt: skip
    for e in events:
        if e.reason:
            logger.info("%s: grasp at sample %d: %s", names[e.demo], e.grasp_index, e.reason)
    if not any(episode_up(e) is not None for e in events):
        why = "; ".join(sorted({e.reason for e in events})) or "the hand never grasps"
        raise InvalidInput(
            f"{', '.join(names)}: no grasp with a lift or a release to find 'up' from ({why})"
        )
    up, info = _combine_up(events, depth_error(demos, events))
    return _build(demos, events, up, info)


def _build(
    demos: Sequence[Demonstration], events: list[LiftEvent], up: FloatArray, info: dict[str, Any]
) -> TaskFrame:
    """Frame axes, origin, uncertainty and checks from the estimated ``up``."""
    image_up = bool(-up[1] > -np.sin(np.radians(IMAGE_DOWN_MARGIN_DEG)))
    if not image_up:
        logger.warning(
            "task frame: the hands lift towards image-down (camera upside down, or a "
            "wrong lift); up is taken from the hands"
        )
    grasps = np.array([e.grasp_point for e in events if np.isfinite(e.grasp_point).all()])
    releases = np.array([e.release_point for e in events if np.isfinite(e.release_point).all()])
    pts = np.concatenate([grasps.reshape(-1, 3), releases.reshape(-1, 3)])
    heights = pts @ up
    table_m = float(np.sqrt(np.mean((heights - heights.mean()) ** 2)))
    pick = grasps.mean(axis=0) if grasps.size else pts.mean(axis=0)
    base_h = heights.mean() if table_m <= MAX_PLANE_RMS_M else float(np.dot(pick, up))
    origin = pick - (np.dot(pick, up) - base_h) * up
    x, x_from = _axes(up)
    R = np.stack([x, np.cross(up, x), up])  # rows: task axes in camera coordinates
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = -R @ origin
    hand_m, hand_rel = hand_length(demos)
    scale_rel, suggested = scale_uncertainty(hand_m, hand_rel)
    info.update(
        x_axis=x_from,
        camera_pitch_deg=float(np.degrees(np.arcsin(np.clip(-up[2], -1.0, 1.0)))),
        camera_height_m=float(-np.dot(origin, up)),
        image_up_agrees=image_up,
        hand_length_m=hand_m,
        hand_length_rel_spread=hand_rel,
        hand_scale_suggested=suggested,
        table_heights_m=(heights - base_h).tolist(),
    )
    unc = {"up_deg": info.pop("up_deg_sigma"), "scale_rel": scale_rel, "table_m": table_m}
    n_events = int(info.pop("n_events"))
    logger.info(
        "task frame from %d events: camera pitch %.0f deg, up +-%.1f deg, table RMS %.1f cm",
        n_events, info["camera_pitch_deg"], unc["up_deg"], 100 * table_m,
    )  # fmt: skip
    return TaskFrame("demonstrations", T, up, 1.0, unc, n_events, info)


def apply_frame(
    demo: Demonstration,
    camera_to_base: FloatArray,
    scale: float = 1.0,
    *,
    frame_name: str = "panda_base",
    provenance: dict[str, Any] | None = None,
) -> Demonstration:
    """``demo`` mapped by ``camera_to_base`` after scaling its positions by ``scale``.

    Keypoints and position: ``p' = R (scale p) + t``; quaternion ``q' = q_R ⊗ q``
    (sign-continuous); ``extras["euler"]`` recomputed from it; ``extras["depth_std"]``
    scaled; gripper and grasp unchanged; NaN stays NaN. ``frame`` becomes
    ``frame_name`` and ``task_frame`` records the transform, the previous frame and
    the ``provenance``'s ``method``; the rest of ``provenance`` (free text and
    figures) goes to ``meta["task_frame"]``.
    """
    T = check_rigid_transform(camera_to_base, "camera_to_base")
    if not (np.isfinite(scale) and scale > 0):
        raise InvalidInput(f"scale must be a finite number > 0, got {scale}")
    R, tr = T[:3, :3], T[:3, 3]
    position = scale * np.asarray(demo.position) @ R.T + tr
    keypoints = scale * np.asarray(demo.keypoints) @ R.T + tr
    q = quat_multiply(quat_from_matrix(R)[None], np.asarray(demo.quaternion))
    q = quat_sign_continuous(q / np.linalg.norm(q, axis=1, keepdims=True))
    extras = dict(demo.extras)
    if "euler" in extras:
        mount = "thesis" if demo.motion is None else demo.motion.mount
        extras["euler"] = euler_from_quat(q, mount)
    if "depth_std" in extras:
        extras["depth_std"] = scale * np.asarray(extras["depth_std"])
    meta = dict(demo.meta)
    rest = {k: v for k, v in (provenance or {}).items() if k not in _APPLIED}
    method = (provenance or {}).get("method")
    applied = AppliedFrame(
        camera_to_base=tuple(tuple(float(x) for x in row) for row in T),  # type: ignore[arg-type]
        scale=float(scale),
        from_frame=_frame_of(demo),
        method=None if method is None else str(method),
    )
    if rest:
        meta["task_frame"] = _json_clean(rest)
    else:
        meta.pop("task_frame", None)
    return replace(
        demo, position=position, keypoints=keypoints, quaternion=q, meta=meta, extras=extras,
        frame=frame_name, task_frame=applied,
    )  # fmt: skip
