"""Landmark recordings: every frame's raw hand-tracker output, kept to re-process offline.

A landmark recording is what MediaPipe Hands reported on each frame of a video, in
the tracker's own order and labels, with no image: ``dexlfd record VIDEO
--save-landmarks L.npz`` writes one and ``dexlfd record L.npz`` runs everything after
the tracker again (hand choice, lifting with any intrinsics, motion, trim, quality)
in seconds. The format (arrays of an ``.npz``; frame ``i``, hand slot ``h``):

=================  ==============  =========================================================
``t_s``            (n,)            frame time [s], strictly increasing
``image_xyz``      (n, m, 21, 3)   normalised image landmarks: x of the width, y of the
                                   height (top-left corner 0), z MediaPipe's relative depth
``world_xyz_m``    (n, m, 21, 3)   MediaPipe's metric world landmarks [m]
``label_selfie``   (n, m) int8     MediaPipe's handedness as reported: 0 "Left", 1 "Right"
                                   in its selfie convention (on an unmirrored image "Left"
                                   is the person's right hand); -1 for an empty slot
``label_score``    (n, m)          that label's confidence in [0, 1]
``frame_size_px``  (2,) int        the tracked frames' (width, height) [px]
=================  ==============  =========================================================

``m`` is the number of hand slots (2 with ``--max-hands 2``); an empty slot holds
label -1 and NaN. Files holding only these arrays (no ``meta``) load, e.g. written by
another program. What dexlfd writes adds ``format_version`` (2), ``meta`` (JSON,
``kind`` ``"landmark_recording"``: provenance only, the source and the tracker's
settings), the typed ``facts`` (JSON, checked on load, each optional):

``native_size_px``  the video's ``(width, height)`` [px] before any resizing, at which
                    ``--intrinsics`` are read
``intrinsics``      the source's own pinhole camera (e.g. a RealSense's): ``width``,
                    ``height``, ``fx``, ``fy``, ``cx``, ``cy`` [px], ``approximate``
``scene_changes``   per pick-and-place, the scene before the grasp and after the
                    release at both spots (:mod:`dexlfd.capture.scene_change`)

(a version-1 file kept them in ``meta``; they are lifted from there on load) and,
where known, the optional array

``camera_motion``  (n, 4)          the background's motion since the previous frame
                                   (:mod:`dexlfd.capture.camera_motion`): ``dx_px``,
                                   ``dy_px`` [px at ``frame_size_px``], ``log_scale``
                                   (ln of the zoom factor), ``rotation_rad``; NaN where it
                                   could not be measured (the first frame)
``depth_m``        (n, m, 21)      an RGB-D source's depth at each landmark [m] (the patch
                                   median of the aligned depth image, NaN at holes), so
                                   the depth models re-process it too
``redetected``     (n, m) bool     the hand of that slot was found again in a crop around
                                   its predicted place after the tracker lost it
                                   (:mod:`dexlfd.capture.redetection`); absent: none was
``carry_cue``      (n, m)          fraction of the pixels beside the hand that moved with
                                   it since the previous frame
                                   (:mod:`dexlfd.capture.carry_cue`), NaN where unmeasured

The depth images themselves are not stored: a replayed RGB-D recording keeps the
patch size it was sampled with. The ``intrinsics`` fact (the source's own camera
intrinsics, e.g. a RealSense's) is used on replay unless ``--intrinsics`` is given.
Loading checks every array and raises :class:`~dexlfd.errors.InvalidFile` with one
line naming the file and the array; nothing is ever unpickled.
"""

from __future__ import annotations

import json
import logging
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.capture.camera_models import Intrinsics
from dexlfd.capture.scene_change import SceneChange
from dexlfd.capture.tracking import HandObservation
from dexlfd.errors import InvalidFile, InvalidInput
from dexlfd.io._facts import Fact, facts_member
from dexlfd.io._npz import ArraySpec, check_arrays, read_npz, save_npz
from dexlfd.io.demonstration_facts import CameraIntrinsics
from dexlfd.io.plausibility import MAX_STEP_S

__all__ = [
    "LANDMARK_KIND",
    "LANDMARK_VERSION",
    "LandmarkFacts",
    "LandmarkRecording",
    "load_landmark_recording",
    "observations_at",
    "save_landmark_recording",
    "selfie_code",
]

logger = logging.getLogger(__name__)

LANDMARK_KIND = "landmark_recording"
LANDMARK_VERSION = 2  # 2: native_size_px and intrinsics are typed facts, not meta
N_LANDMARKS = 21
# frames of a hand video are at most this far apart [s]: what a demonstration's loader
# accepts; a larger median step is a unit slip or a time-lapse
MAX_FRAME_STEP_S = MAX_STEP_S
MAX_WORLD_M = 0.5  # [m] a world landmark from the hand's centre: a hand is ~0.2 m long
MAX_FRAME_SIDE_PX = 16384  # [px] a frame's width or height: 16K, twice an 8K video's width
SELFIE_LABELS = ("left", "right")  # label_selfie code 0, 1 (MediaPipe's "Left", "Right")

SPECS: dict[str, ArraySpec] = {
    "t_s": ArraySpec(("n",), unit="s"),
    "image_xyz": ArraySpec(("n", "m", N_LANDMARKS, 3), nan="any"),
    "world_xyz_m": ArraySpec(("n", "m", N_LANDMARKS, 3), nan="any", unit="m"),
    "label_selfie": ArraySpec(("n", "m"), kind="i"),
    "label_score": ArraySpec(("n", "m"), nan="any"),
    "frame_size_px": ArraySpec((2,), kind="i", unit="px"),
    "camera_motion": ArraySpec(("n", 4), nan="any", required=False),
    "depth_m": ArraySpec(("n", "m", N_LANDMARKS), nan="any", unit="m", required=False),
    "redetected": ArraySpec(("n", "m"), kind="b", required=False),
    "carry_cue": ArraySpec(("n", "m"), nan="any", required=False),
}


@dataclass(frozen=True)
class LandmarkFacts(Fact):
    """The typed facts of a landmark recording file (module docstring)."""

    native_size_px: tuple[int, int] | None = field(default=None, metadata={"unit": "px"})
    intrinsics: CameraIntrinsics | None = None
    scene_changes: tuple[SceneChange, ...] = ()


@dataclass(frozen=True, eq=False)
class LandmarkRecording:
    """A checked landmark recording (module docstring: the arrays and their meaning).

    Construction checks shapes, labels, NaN where a hand is claimed, the time axis
    and the frame size, raising :class:`~dexlfd.errors.InvalidInput`; the arrays
    become read-only. ``native_size_px`` is the video's ``(width, height)`` [px]
    before any resizing (None: not resized, or not known); ``intrinsics`` the source's
    own camera (None: not known). ``meta`` keeps provenance only.
    """

    t_s: FloatArray
    image_xyz: FloatArray
    world_xyz_m: FloatArray
    label_selfie: np.ndarray
    label_score: FloatArray
    frame_size_px: np.ndarray
    camera_motion: FloatArray | None = None
    depth_m: FloatArray | None = None
    redetected: np.ndarray | None = None
    carry_cue: FloatArray | None = None
    native_size_px: tuple[int, int] | None = None
    intrinsics: Intrinsics | None = None
    scene_changes: tuple[SceneChange, ...] = ()
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        native = self.native_size_px
        if native is not None:
            if len(native) != 2 or not all(
                int(v) == v and 0 < v <= MAX_FRAME_SIDE_PX for v in native
            ):
                raise InvalidInput(
                    f"LandmarkRecording: native_size_px must be a positive (width, height) "
                    f"of at most {MAX_FRAME_SIDE_PX} px, got {native}"
                )
            object.__setattr__(self, "native_size_px", (int(native[0]), int(native[1])))
        if self.intrinsics is not None and not isinstance(self.intrinsics, Intrinsics):
            raise InvalidInput("LandmarkRecording: intrinsics must be an Intrinsics or None")
        checked = _checked_arrays(
            {name: getattr(self, name) for name in SPECS}, "LandmarkRecording", InvalidInput
        )
        for name, arr in checked.items():
            if name == "label_selfie":
                arr = arr.astype(np.int8)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "meta", dict(self.meta))

    @property
    def n_frames(self) -> int:
        """Number of frames."""
        return int(self.t_s.shape[0])

    @property
    def size(self) -> tuple[int, int]:
        """``(width, height)`` [px] of the tracked frames."""
        return int(self.frame_size_px[0]), int(self.frame_size_px[1])

    @property
    def hands_per_frame(self) -> np.ndarray:
        """(n,) hands the tracker reported in each frame."""
        return (self.label_selfie >= 0).sum(axis=1)


def _checked_arrays(
    arrays: dict[str, Any], where: str, err: type[InvalidFile] | type[InvalidInput]
) -> dict[str, np.ndarray]:
    """:func:`check_arrays` plus the rules of this format, per hand slot."""
    out = check_arrays(arrays, SPECS, where, err)
    t = out["t_s"]
    if t.size == 0:
        raise err(f"{where}: array 't_s' is empty (no frames)")
    if not np.isfinite(t).all():
        raise err(f"{where}: array 't_s' contains NaN or inf")
    if t.size > 1 and not (np.diff(t) > 0).all():
        i = int(np.argmax(~(np.diff(t) > 0)))
        raise err(
            f"{where}: array 't_s' must be strictly increasing, but frame {i + 1} "
            f"({t[i + 1]:g} s) does not come after frame {i} ({t[i]:g} s)"
        )
    if t.size >= 3 and float(np.median(np.diff(t))) > MAX_FRAME_STEP_S:
        step = float(np.median(np.diff(t)))
        raise err(
            f"{where}: array 't_s' has a median frame step of {step:.4g} s "
            f"({1.0 / step:.3g} frames/s); frame times must be in seconds of a video at "
            f">= {1.0 / MAX_FRAME_STEP_S:g} frame/s (milliseconds? a time-lapse?)"
        )
    size = out["frame_size_px"]
    if (size <= 0).any() or (size > MAX_FRAME_SIDE_PX).any():
        raise err(
            f"{where}: array 'frame_size_px' must be a positive (width, height) of at most "
            f"{MAX_FRAME_SIDE_PX} px, got {size.tolist()}"
        )
    labels = out["label_selfie"]
    bad = ~np.isin(labels, (-1, 0, 1))
    if bad.any():
        i, h = (int(x) for x in np.argwhere(bad)[0])
        raise err(
            f"{where}: array 'label_selfie' must hold -1 (no hand), 0 (Left) or 1 (Right), "
            f"got {labels[i, h]} at frame {i}, slot {h}"
        )
    claimed = labels >= 0
    for name in ("image_xyz", "world_xyz_m"):
        a = out[name]
        if np.isinf(a).any():
            raise err(f"{where}: array {name!r} contains inf")
        if name == "world_xyz_m" and (np.abs(a[claimed]) > MAX_WORLD_M).any():
            i, h = (int(x) for x in np.argwhere(claimed & (np.abs(a) > MAX_WORLD_M).any((2, 3)))[0])
            raise err(
                f"{where}: array 'world_xyz_m' reaches {np.nanmax(np.abs(a[i, h])):.4g} m from "
                f"the hand's centre at frame {i}, slot {h}; MediaPipe's world landmarks are "
                f"metres around the hand, within {MAX_WORLD_M:g} m (millimetres?)"
            )
        holes = claimed & ~np.isfinite(a).all(axis=(2, 3))
        if holes.any():
            i, h = (int(x) for x in np.argwhere(holes)[0])
            raise err(
                f"{where}: array {name!r} has NaN at frame {i}, slot {h}, where a hand is "
                "claimed (label_selfie != -1)"
            )
    score = out["label_score"]
    bad_score = claimed & ~((score >= 0) & (score <= 1))
    if bad_score.any():
        i, h = (int(x) for x in np.argwhere(bad_score)[0])
        raise err(
            f"{where}: array 'label_score' must be in [0, 1] where a hand is claimed, got "
            f"{score[i, h]} at frame {i}, slot {h}"
        )
    motion = out.get("camera_motion")
    if motion is not None and np.isinf(motion).any():
        raise err(f"{where}: array 'camera_motion' contains inf")
    depth = out.get("depth_m")
    if depth is not None and (np.isinf(depth).any() or (depth < 0).any()):
        raise err(f"{where}: array 'depth_m' must be >= 0 [m] or NaN (no reading)")
    return out


def load_landmark_recording(path: str | os.PathLike[str]) -> LandmarkRecording:
    """Read and check a landmark recording (with or without ``meta``/``format_version``).

    Raises
    ------
    InvalidFile
        One line naming ``path`` and the array: a missing file, not an ``.npz``, a
        missing array, a wrong shape or type, NaN where a hand is claimed, a label
        outside {-1, 0, 1}, a time axis that does not increase, a zero frame size, or
        a ``meta`` of another kind or a newer ``format_version``.
    """
    path = Path(path)
    arrays = read_npz(path, "a landmark recording")
    meta: dict[str, Any] = {}
    version = 1  # a file without format_version: only the arrays, or version 1's meta
    if "meta" in arrays:
        try:
            meta = json.loads(str(arrays.pop("meta")))
        except (ValueError, RecursionError) as exc:
            raise InvalidFile(f"{path}: array 'meta' is not JSON: {exc}") from exc
        if not isinstance(meta, dict):
            raise InvalidFile(f"{path}: array 'meta' must be a JSON object")
        if meta.get("kind", LANDMARK_KIND) != LANDMARK_KIND:
            raise InvalidFile(
                f"{path}: is a {meta.get('kind')!r} file, expected a landmark recording"
            )
    if "format_version" in arrays:
        try:
            version = int(arrays.pop("format_version"))
        except (TypeError, ValueError) as exc:
            raise InvalidFile(f"{path}: array 'format_version' is not an integer") from exc
        if not 1 <= version <= LANDMARK_VERSION:
            raise InvalidFile(
                f"{path}: landmark recording format_version {version} is not supported "
                f"(this dexlfd reads 1..{LANDMARK_VERSION}); upgrade dexlfd"
            )
    facts = _read_facts(arrays, meta, version, str(path))
    checked: dict[str, Any] = _checked_arrays(arrays, str(path), InvalidFile)
    try:
        return LandmarkRecording(**checked, **facts, meta=meta)
    except InvalidInput as exc:
        raise InvalidFile(f"{path}: {exc}") from exc


def _read_facts(
    arrays: dict[str, Any], meta: dict[str, Any], version: int, where: str
) -> dict[str, Any]:
    """``native_size_px`` and ``intrinsics``: ``facts`` checked, or version 1's ``meta``."""
    if version < 2:
        return _facts_from_v1_meta(meta, where)
    facts = LandmarkFacts.from_json(facts_member(arrays, where), f"{where}: facts")
    K = facts.intrinsics
    try:
        intrinsics = None if K is None else Intrinsics(**asdict(K))
    except InvalidInput as exc:
        raise InvalidFile(f"{where}: facts.intrinsics: {exc}") from exc
    return {
        "native_size_px": facts.native_size_px,
        "intrinsics": intrinsics,
        "scene_changes": facts.scene_changes,
    }


def _facts_from_v1_meta(meta: dict[str, Any], where: str) -> dict[str, Any]:
    """A version-1 file's ``native_size_px`` and ``intrinsics``, taken out of its ``meta``.

    That version never checked them: an unusable size is ignored (the frames' size is
    used), unusable intrinsics are ignored with a warning.
    """
    native = meta.pop("native_size_px", None)
    if not (
        isinstance(native, list)
        and len(native) == 2
        and all(isinstance(v, int) and v > 0 for v in native)
    ):
        native = None
    K = meta.pop("intrinsics", None)
    intrinsics = None
    if isinstance(K, dict):
        try:
            intrinsics = Intrinsics(
                **{k: K[k] for k in ("width", "height", "fx", "fy", "cx", "cy")},
                approximate=bool(K.get("approximate", False)),
            )
        except (KeyError, TypeError, InvalidInput):
            logger.warning("%s: meta['intrinsics'] is unreadable: ignored", where)
    return {
        "native_size_px": None if native is None else (native[0], native[1]),
        "intrinsics": intrinsics,
    }


def save_landmark_recording(path: str | os.PathLike[str], rec: LandmarkRecording) -> Path:
    """Write ``rec`` atomically (with ``format_version``, ``meta`` and the typed facts)."""
    arrays = {name: getattr(rec, name) for name in SPECS if getattr(rec, name) is not None}
    K = rec.intrinsics
    facts = LandmarkFacts(
        native_size_px=rec.native_size_px,
        intrinsics=None
        if K is None
        else CameraIntrinsics(K.width, K.height, K.fx, K.fy, K.cx, K.cy, K.approximate),
        scene_changes=tuple(rec.scene_changes),
    )
    # the facts only: a version-1 reader would take stale copies left in meta
    meta = {k: v for k, v in rec.meta.items() if k not in ("native_size_px", "intrinsics")}
    facts_json = {k: v for k, v in facts.to_json().items() if v not in (None, [])}
    return save_npz(path, LANDMARK_KIND, LANDMARK_VERSION, arrays, meta, facts_json)


def selfie_code(obs: HandObservation, mirrored: bool) -> int:
    """``label_selfie`` of ``obs``: the label MediaPipe's legacy API gives that image.

    ``obs.handedness`` names the person's hand; on an unmirrored image (``mirrored``
    False) the selfie label is the other one. The inverse of :func:`observations_at`.
    """
    hand = obs.handedness
    if not mirrored:
        hand = {"left": "right", "right": "left"}.get(hand, hand)
    return SELFIE_LABELS.index(hand) if hand in SELFIE_LABELS else 0


def observations_at(rec: LandmarkRecording, i: int, mirrored: bool) -> list[HandObservation]:
    """The hands of frame ``i`` as the tracker reported them (its order).

    Labels name the person's hand as :class:`~dexlfd.capture.tracking.HandObservation`
    does: the selfie label swapped unless ``mirrored`` (the frames were a mirrored
    preview), the convention of :class:`~dexlfd.capture.tracking.MediaPipeHands`.
    """
    w, h = rec.size
    out = []
    for slot in range(rec.label_selfie.shape[1]):
        code = int(rec.label_selfie[i, slot])
        if code < 0:
            continue
        hand = SELFIE_LABELS[code]
        if not mirrored:
            hand = "right" if hand == "left" else "left"
        xyz = rec.image_xyz[i, slot]
        out.append(
            HandObservation(
                uv_px=xyz[:, :2] * np.array([w, h], dtype=np.float64),
                z_rel=xyz[:, 2].copy(),
                world_m=rec.world_xyz_m[i, slot].copy(),
                handedness=hand,
                score=float(rec.label_score[i, slot]),
                depth_m=None if rec.depth_m is None else rec.depth_m[i, slot].copy(),
                redetected=bool(rec.redetected is not None and rec.redetected[i, slot]),
                carry=np.nan if rec.carry_cue is None else float(rec.carry_cue[i, slot]),
            )
        )
    return out
