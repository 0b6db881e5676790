"""``teach``'s frame stage: every demonstration moved into one base-aligned frame.

Each source (one camera) gets its task frame (:mod:`dexlfd.motion.task_frame`: z up,
origin on the grasp plane under the mean pick, x the camera's optical axis made
horizontal): estimated from its own pick-and-places, or, for demonstrations already in
the robot's base frame (recorded with ``--extrinsics``/``--camera-pose``), the base
frame itself moved to their mean pick (method ``"extrinsics"``). Then one task-to-base
transform, a translation, puts the demonstrated pick at the robot's pick and the table
under the object (the grasp plane minus the object's half height) on the robot's table.
Every demonstration goes through its own source's frame and that one translation, so
calibrated and uncalibrated recordings are never mixed: all end in the base frame.

Where the robot picks (``--pick``; default :data:`DEFAULT_PICK_XY` at the object's
height over the table, or where pick and place both are within the Panda's top-down
reach (:mod:`dexlfd.plan.reach`), the carry centred nearest :data:`CENTRE_XY`, when a
long demonstrated carry would otherwise end out of it, or the demonstrated pick when
every source is calibrated) and places (``--place``; default the demonstrated
displacement from pick to place, in the task frame, applied at the new pick, never
under the robot's table) are decided here, each checked against the Panda's reach in
one line.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.io import Demonstration
from dexlfd.panda import FINGER_MAX, TABLE_Z, check_workspace, workspace_violation

if TYPE_CHECKING:
    from dexlfd.motion.task_frame import TaskFrame

__all__ = [
    "DEFAULT_PICK_XY",
    "Placement",
    "demonstrated_events",
    "frame_of_calibrated",
    "is_calibrated",
    "object_size_from_aperture",
    "placement_targets",
    "task_to_base",
]

logger = logging.getLogger(__name__)

DEFAULT_PICK_XY = (0.5, -0.15)  # [m] in front of the robot, slightly to its right
CENTRE_XY = (0.5, 0.0)  # [m] a long carry is centred here instead
MIN_OBJECT_M = 0.02  # [m] the smallest object edge the Franka Hand is given
MAX_OBJECT_M = 2 * FINGER_MAX  # [m] the Franka Hand opens to 8 cm


def is_calibrated(demo: Demonstration) -> bool:
    """True when ``demo`` is in the robot's base frame (recorded with extrinsics)."""
    return demo.frame == "panda_base"


def demonstrated_events(demo: Demonstration, name: str) -> tuple[int, int]:
    """Sample indices (grasp, release) of ``demo``'s pick-and-place; InvalidInput if none."""
    from dexlfd.learn.events import demonstration_events

    found = demonstration_events(demo.t, demo.grasp)
    if isinstance(found, str):
        raise InvalidInput(f"{name}: no pick-and-place: {found}")
    k_close, k_open = found
    k_open = min(k_open, demo.n_samples - 1)
    valid = np.flatnonzero(demo.valid)
    if valid.size == 0:
        raise InvalidInput(f"{name}: the hand is never seen")
    # the nearest seen samples (a grasp may close in a tracking gap)
    k_close = int(valid[np.argmin(np.abs(valid - k_close))])
    k_open = int(valid[np.argmin(np.abs(valid - k_open))])
    return k_close, k_open


def _rigid(R: FloatArray, p: FloatArray) -> FloatArray:
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


def frame_of_calibrated(demos: Sequence[Demonstration], names: Sequence[str]) -> TaskFrame:
    """The task frame of demonstrations already in the base frame (method ``"extrinsics"``).

    z is the base's z, x the base's x, the origin the mean pick; scale 1. Its
    uncertainty is the spread of the picks' heights (the grasp plane) only: the
    camera's calibration is taken as exact.
    """
    from dexlfd.motion.task_frame import TaskFrame

    picks = np.array(
        [d.position[demonstrated_events(d, n)[0]] for d, n in zip(demos, names, strict=True)]
    )
    origin = picks.mean(axis=0)
    return TaskFrame(
        method="extrinsics",
        camera_to_task=_rigid(np.eye(3), -origin),
        up_camera=np.array([0.0, 0.0, 1.0]),
        scale=1.0,
        uncertainty={"up_deg": 0.0, "scale_rel": 0.0, "table_m": float(picks[:, 2].std())},
        n_events=2 * len(demos),
    )


def task_to_base(pick_base: Sequence[float]) -> FloatArray:
    """The task-to-base transform: the task origin (the demonstrated pick) onto ``pick_base``.

    A translation: the task frame's z is up like the base's, and its x (away from the
    camera) becomes the base's x (away from the robot), as if the robot stood where the
    camera stood.
    """
    return _rigid(np.eye(3), np.asarray(pick_base, dtype=np.float64))


def object_size_from_aperture(demos: Sequence[Demonstration]) -> tuple[float, float, float]:
    """A cube the hand held: its edge the median gripper opening while grasping [m].

    Clipped to what the Franka Hand can hold (:data:`MIN_OBJECT_M`..:data:`MAX_OBJECT_M`).
    """
    held = np.concatenate([d.gripper[d.grasp & d.valid] for d in demos])
    held = held[np.isfinite(held)]
    edge = float(np.median(held)) if held.size else 0.06
    edge = float(np.clip(edge, MIN_OBJECT_M, MAX_OBJECT_M))
    return edge, edge, edge


@dataclass(frozen=True, slots=True)
class Placement:
    """Where the robot picks and places, and what the demonstrations did [m, base frame]."""

    pick: tuple[float, float, float]
    pick_yaw: float | None  # [rad]; None: the demonstrated heading
    place: tuple[float, float, float]
    place_yaw: float | None
    displacement_task: tuple[float, float, float]  # demonstrated place - pick, task frame
    demonstrated_lift_m: float  # mean rise of the hand over the pick while carrying
    object_size: tuple[float, float, float]
    defaults: tuple[str, ...]  # which of pick/place were defaults

    def to_dict(self) -> dict[str, Any]:
        """JSON-able (yaws in degrees)."""
        d = dataclasses.asdict(self)
        for k in ("pick_yaw", "place_yaw"):
            d[k.replace("_yaw", "_yaw_deg")] = None if d[k] is None else float(np.degrees(d[k]))
            del d[k]
        return d


def _demonstrated(task_demos: Sequence[Demonstration], names: Sequence[str]) -> tuple[
    FloatArray, float
]:  # fmt: skip
    """Mean displacement pick -> place and mean lift over the pick while carried [m]."""
    moves, lifts = [], []
    for demo, name in zip(task_demos, names, strict=True):
        a, b = demonstrated_events(demo, name)
        p = demo.position
        moves.append(p[b] - p[a])
        carried = p[a : b + 1, 2]
        lifts.append(float(np.nanmax(carried) - p[a, 2]))
    return np.mean(moves, axis=0), float(np.mean(lifts))


def _demonstrated_place(
    pick: FloatArray, displacement: FloatArray, size: Any, *, say: bool = True
) -> FloatArray:
    """The pick moved by the demonstrated displacement, never under the robot's table.

    ``say``: log the move onto the table (off where a candidate pick is only tried).
    """
    place = pick + displacement
    floor = TABLE_Z + size[2] / 2  # the object standing on the robot's table
    if place[2] < floor:  # set down lower than it was picked, but under the table
        logger.log(
            logging.INFO if say else logging.DEBUG,
            "the demonstrated place is %.3f m below the pick: set down on the table "
            "(z = %.3f m) instead", -displacement[2], floor,
        )  # fmt: skip
        place[2] = floor
    return place


def _default_pick(
    size: Any, displacement: FloatArray | None, calibrated_pick: FloatArray | None
) -> FloatArray:
    """Where the object is taken to be: :data:`DEFAULT_PICK_XY`, or the calibrated pick.

    When the demonstrated place would then be out of the Panda's top-down reach
    (``displacement`` given), the pick moves to where pick and place both are (and the
    approach above each): of those, the one whose carry is centred nearest
    :data:`CENTRE_XY` (:func:`_centred_pick`).
    """
    if calibrated_pick is not None:
        return np.asarray(calibrated_pick, dtype=np.float64)
    z = TABLE_Z + size[2] / 2
    pick = np.array([*DEFAULT_PICK_XY, z])
    if displacement is None:
        return pick
    place = _demonstrated_place(pick, displacement, size, say=False)
    if _top_down_fits(np.stack([pick, place])).all():
        return pick
    centred = _centred_pick(pick, displacement, size)
    if centred is not None:
        logger.info(
            "the demonstrated place from %s would be out of the top-down reach: the default "
            "pick is %s (pick and place both within reach, centred near %s)",
            DEFAULT_PICK_XY, np.round(centred, 3).tolist(), CENTRE_XY,
        )  # fmt: skip
        return centred
    return pick


_GRID_M = 0.01  # [m] the candidate picks' spacing


def _top_down_fits(points: FloatArray) -> np.ndarray:
    """Per point (n, 3) [m]: within the top-down reach, the approach above it too."""
    from dexlfd.plan.config import PlanConfig
    from dexlfd.plan.reach import RADIUS_MARGIN, top_down_radius

    points = np.atleast_2d(points)
    r = np.hypot(points[:, 0], points[:, 1])
    ok = np.ones(points.shape[0], dtype=bool)
    for dz in (0.0, PlanConfig().approach):
        lo, hi = top_down_radius(points[:, 2] + dz)
        ok &= (r >= lo + RADIUS_MARGIN) & (r <= hi - RADIUS_MARGIN)
    return ok


def _centred_pick(pick: FloatArray, displacement: FloatArray, size: Any) -> FloatArray | None:
    """The pick at the object's height whose pick and place both fit, carry nearest the centre.

    Candidates on a :data:`_GRID_M` grid; None when none fits.
    """
    xs = np.arange(-0.3, 0.9, _GRID_M)
    ys = np.arange(-0.85, 0.85 + _GRID_M / 2, _GRID_M)
    gx, gy = (a.ravel() for a in np.meshgrid(xs, ys))
    picks = np.stack([gx, gy, np.full(gx.shape, pick[2])], axis=1)
    places = picks + displacement
    places[:, 2] = np.maximum(places[:, 2], TABLE_Z + size[2] / 2)  # as _demonstrated_place
    fits = _top_down_fits(picks) & _top_down_fits(places)
    mid = picks[:, :2] + displacement[:2] / 2
    far = np.linalg.norm(mid - np.asarray(CENTRE_XY), axis=1)
    for k in np.flatnonzero(fits)[np.argsort(far[fits], kind="stable")]:
        if workspace_violation(np.stack([picks[k], places[k]])) is None:
            return np.asarray(picks[k], dtype=np.float64)
    return None


def placement_targets(
    task_demos: Sequence[Demonstration],
    names: Sequence[str],
    *,
    pick: tuple[float, ...] | None,
    place: tuple[float, ...] | None,
    object_size: tuple[float, float, float] | None,
    calibrated_pick: FloatArray | None = None,
) -> Placement:
    """The robot's pick and place from the flags and the demonstrations (module docstring).

    ``task_demos`` are in the task frame. ``pick``/``place``: ``(x, y, z[, yaw_deg])``
    or None. ``calibrated_pick``: the demonstrated mean pick in the base frame, the
    default pick when every source is calibrated.

    Raises
    ------
    InvalidInput
        A pick or place outside the Panda's workspace (naming its reach).
    """
    size = object_size or object_size_from_aperture(task_demos)
    displacement, lift = _demonstrated(task_demos, names)
    defaults = []
    pick_yaw = None
    if pick is None:
        defaults.append("pick")
        p_pick = _default_pick(size, displacement if place is None else None, calibrated_pick)
    else:
        p_pick = np.asarray(pick[:3], dtype=np.float64)
        pick_yaw = None if len(pick) < 4 else float(np.radians(pick[3]))
    check_workspace(p_pick, "--pick" if pick is not None else "the default pick (--pick)")
    if place is None:
        defaults.append("place")
        p_place = _demonstrated_place(p_pick, displacement, size)
        place_yaw = None
        what = (
            f"the demonstrated place (the pick + {np.round(displacement, 3).tolist()} m; "
            "give --place)"
        )
    else:
        p_place = np.asarray(place[:3], dtype=np.float64)
        place_yaw = None if len(place) < 4 else float(np.radians(place[3]))
        what = "--place"
    check_workspace(p_place, what)
    return Placement(
        pick=tuple(float(v) for v in p_pick),  # type: ignore[arg-type]
        pick_yaw=pick_yaw,
        place=tuple(float(v) for v in p_place),  # type: ignore[arg-type]
        place_yaw=place_yaw,
        displacement_task=tuple(float(v) for v in displacement),  # type: ignore[arg-type]
        demonstrated_lift_m=lift,
        object_size=tuple(float(v) for v in size),  # type: ignore[arg-type]
        defaults=tuple(defaults),
    )
