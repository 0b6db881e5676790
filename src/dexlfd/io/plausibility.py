"""Physical plausibility of loaded files: units and ranges a file contract cannot express.

A file can satisfy its contract (names, shapes, finite values) and still be nonsense:
timestamps in milliseconds, positions in millimetres or scaled by 1e200, a negative
gripper opening. :func:`check_plausible` runs when a file is loaded
(:meth:`~dexlfd.io._record.Record._load`): impossible values raise
:class:`~dexlfd.errors.InvalidFile`, unlikely ones log a warning; both name the file.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable

import numpy as np

from dexlfd.errors import InvalidFile
from dexlfd.io._record import Record
from dexlfd.panda import CARTESIAN_LIMITS

__all__ = ["check_plausible"]

logger = logging.getLogger(__name__)

MAX_STEP_S = 1.0  # [s] median time step; hand video, learning and control run at >= 1 Hz
MIN_SAMPLES_FOR_STEP = 10  # a coarse grid of a few samples may have long steps
# ... but a demonstration is recorded at a camera's frame rate, however short it is
MIN_SAMPLES_FOR_STEP_BY_KIND = {"demonstration": 3}
MAX_SPAN_S = 3600.0  # [s] one hour: longer recordings or plans are a unit slip
MAX_POSITION_M = 10.0  # [m] from the base: beyond is not a tabletop task (mm? a scale?)
WARN_POSITION_M = 2.0  # [m] from the base: more than twice the Panda's reach (0.855 m)
HAND_MAX_OPENING_M = 0.30  # [m] thumb-index distance of a wide-open adult hand, generous
MAX_SPEED = CARTESIAN_LIMITS["translational_velocity"][0]  # [m/s] the Panda's end effector
OPENING_TOLERANCE_M = 0.01  # [m] regression (GMR) may undershoot 0 by a little


def check_plausible(record: Record, path: str | os.PathLike[str], warn: bool = True) -> None:
    """Raise InvalidFile for impossible values of ``record``, warn on unlikely ones.

    ``warn`` False: only the refusals (a writer checking what the loader will check).
    """
    where = str(path)
    _check_time(
        np.asarray(record.t),
        where,
        MIN_SAMPLES_FOR_STEP_BY_KIND.get(record.KIND, MIN_SAMPLES_FOR_STEP),
    )
    frame = getattr(record, "frame", None)  # a typed fact (a model's), else in meta
    if not isinstance(frame, str):
        meta = getattr(record, "meta", None)
        frame = str(meta.get("frame", "")) if isinstance(meta, dict) else ""
    origin = "the camera" if frame.startswith("camera") else "the base"
    for name, get in _POSITIONS.get(record.KIND, {}).items():
        _check_positions(get(record), where, name, origin, warn)
    opening = _OPENING.get(record.KIND)
    if opening is not None:
        _check_opening(opening(record), where, record.KIND, warn)
    if record.KIND == "plan" and warn:
        _check_speed(np.asarray(record.velocity), where)  # type: ignore[attr-defined]


def _check_time(t: np.ndarray, where: str, min_samples: int = MIN_SAMPLES_FOR_STEP) -> None:
    """Refuse time axes in milliseconds or in frame numbers (whole steps of 1 or more)."""
    if t.shape[0] < 2:
        return
    span = float(t[-1] - t[0])
    step = float(np.median(np.diff(t)))
    enough = t.shape[0] >= min_samples
    if (step > MAX_STEP_S and enough) or span > MAX_SPAN_S:
        raise InvalidFile(
            f"{where}: t spans {span:.4g} s with a median step of {step:.4g} s; timestamps "
            f"must be in seconds (steps <= {MAX_STEP_S:g} s, at most {MAX_SPAN_S:g} s): "
            "milliseconds?"
        )
    if enough and step >= 1.0 and np.all(t == np.round(t)):
        raise InvalidFile(
            f"{where}: t counts whole numbers ({t[0]:g}, {t[1]:g}, ... {t[-1]:g}) with a median "
            f"step of {step:g}: frame numbers? timestamps must be in seconds "
            "(frame number / frame rate)"
        )


def _check_positions(
    p: np.ndarray, where: str, name: str, origin: str = "the base", warn: bool = True
) -> None:
    """Metres, not millimetres; a warning beyond the workspace (base frame only)."""
    # largest coordinate, not the norm: squaring 1e200 would overflow
    r = np.abs(p.reshape(-1, 3)).max(axis=1)
    r = r[np.isfinite(r)]
    if not r.size:
        return
    far = float(r.max())
    if far > MAX_POSITION_M:
        raise InvalidFile(
            f"{where}: {name} reaches {far:.4g} m from {origin} along an axis; positions must "
            "be in metres "
            f"within {MAX_POSITION_M:g} m (millimetres, or a wrong scale?)"
        )
    if warn and far > WARN_POSITION_M and origin == "the base":  # a camera may stand far away
        logger.warning(
            "%s: %s reaches %.3g m from the base along an axis, beyond the robot's "
            "workspace (%g m)",
            where, name, far, WARN_POSITION_M,
        )  # fmt: skip


def _check_opening(g: np.ndarray, where: str, kind: str, warn: bool = True) -> None:
    g = g[np.isfinite(g)]
    if not g.size:
        return
    lo, hi = float(g.min()), float(g.max())
    if lo < -OPENING_TOLERANCE_M:
        raise InvalidFile(
            f"{where}: gripper opening down to {lo:.4g} m; an opening is a distance >= 0 m"
        )
    if warn and hi > HAND_MAX_OPENING_M:
        logger.warning(
            "%s: gripper opening up to %.3g m, wider than a hand opens (%g m); "
            "is the %s in metres?",
            where, hi, HAND_MAX_OPENING_M, kind,
        )  # fmt: skip


def _check_speed(v: np.ndarray, where: str) -> None:
    """Warn when a plan's velocity exceeds the Panda's Cartesian limit (a scale slip?).

    ``dexlfd plan`` writes plans within the limits; a faster one cannot be tracked.
    """
    fastest = float(np.abs(v).max(initial=0.0)) if np.isfinite(v).all() else float("inf")
    if fastest > MAX_SPEED:
        logger.warning(
            "%s: the plan's velocity reaches %.3g m/s along an axis, beyond the Panda's "
            "%g m/s: is it in m/s, and does it belong to the positions?",
            where, fastest, MAX_SPEED,
        )  # fmt: skip


_POSITIONS: dict[str, dict[str, Callable[[Record], np.ndarray]]] = {
    "demonstration": {
        "position": lambda r: r.position,  # type: ignore[attr-defined]
        "keypoints": lambda r: r.keypoints,  # type: ignore[attr-defined]
    },
    "model": {"mean position": lambda r: r.mean[:, :3]},  # type: ignore[attr-defined]
    "plan": {"position": lambda r: r.position},  # type: ignore[attr-defined]
    "rollout": {
        "ee_position": lambda r: r.ee_position,  # type: ignore[attr-defined]
        "ref_position": lambda r: r.ref_position,  # type: ignore[attr-defined]
    },
}
_OPENING: dict[str, Callable[[Record], np.ndarray]] = {
    "demonstration": lambda r: r.gripper,  # type: ignore[attr-defined]
    "model": lambda r: r.mean[:, 7],  # type: ignore[attr-defined]
    "plan": lambda r: r.gripper,  # type: ignore[attr-defined]
}
