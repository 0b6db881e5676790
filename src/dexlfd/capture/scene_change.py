"""The scene before and after a grasp: the object gone from where it was picked, there where put.

A hand that picks an object up and puts it down elsewhere changes the picture at two
places: where the object was picked it is gone, where it was released it now stands.
A flat press, a hook on an edge or a hover moves nothing: both places look as they did.
Per pick-and-place episode, :func:`measure_scene_changes` compares two image patches:

* the *pick* patch, around the thumb and the first fingers' tips over the grasp's
  first frames, and the *place* patch, the same over the last frames before the
  release; each a square of ``patch_hands`` hand lengths (wrist to middle fingertip);
* each patch in a frame *before* the grasp and a frame *after* the release in which
  the hand is clear of it: every landmark, and the forearm (``forearm_hands`` hand
  lengths back from the wrist, away from the fingers), at least ``clear_hands`` hand
  lengths outside it; the last such frame before the grasp and the first after the
  release. A hand that never clears a patch leaves it unmeasured (None);
* the change of a patch is ``1 - ZNCC`` of the two grey patches (zero-normalised
  cross-correlation: a change of lighting or exposure is no change), damped where
  neither patch has texture well above the video's noise (``noise_grey``,
  :func:`patch_change`); a spot with no texture in either frame is unmeasured (a plain
  object on a plain support of its shade could come and go unseen).

A patch *changed* above ``min_change``. The verdict (:attr:`SceneChange.verdict`):
``"moved"`` when both changed, ``"nothing moved"`` when both were measured and neither
changed (never a pick-and-place), ``"partial"`` otherwise (an object dropped from a
height lands away from the release point), None when a patch was not measured.
Each episode costs at most four frame reads (two when the snapshots coincide). The
results are typed facts of the landmark recording (``scene_changes``), so replaying
it, which has no pixels, keeps them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.intervals import true_runs
from dexlfd.io._facts import Fact

if TYPE_CHECKING:
    from dexlfd.capture.keypoints import KeypointSeries
    from dexlfd.capture.landmark_recording import LandmarkRecording
    from dexlfd.io import Demonstration

__all__ = [
    "SceneChange",
    "SceneChangeConfig",
    "clear_frame",
    "grasp_span",
    "grey_frames",
    "measure_scene_changes",
    "patch_change",
    "scene_evidence",
    "with_scene_evidence",
]

_FRAME = {"unit": "frame"}
MIN_CHANGE = 0.15  # 1 - ZNCC above which a patch changed [-]
_TIPS = (4, 8, 12)  # thumb, index and middle fingertips: the object lies between them


@dataclass(frozen=True, slots=True)
class SceneChangeConfig:
    """Settings of :func:`measure_scene_changes`."""

    patch_hands: float = 1.0  # a patch's side [hand lengths]
    clear_hands: float = 0.25  # the hand this far outside a patch: clear of it [hand lengths]
    forearm_hands: float = 2.0  # the forearm behind the wrist [hand lengths]
    spot_frames: int = 6  # frames after the grasp / before the release that place a patch
    min_change: float = MIN_CHANGE  # 1 - ZNCC above which a patch changed [-]
    noise_grey: float = 3.0  # the video's grey noise: texture below it is none [grey levels]


@dataclass(frozen=True)
class SceneChange(Fact):
    """One episode's scene before and after (module docstring); frames of the recording."""

    grasp_frame: int = field(metadata=_FRAME)
    release_frame: int = field(metadata=_FRAME)
    pick_px: tuple[float, float] = field(metadata={"unit": "px"})
    place_px: tuple[float, float] = field(metadata={"unit": "px"})
    patch_px: float = field(metadata={"unit": "px"})
    pick_frames: tuple[int, int] | None = field(default=None, metadata=_FRAME)
    place_frames: tuple[int, int] | None = field(default=None, metadata=_FRAME)
    pick_change: float | None = None  # 1 - ZNCC [-]
    place_change: float | None = None
    min_change: float = MIN_CHANGE  # what "changed" meant when measured

    @property
    def verdict(self) -> str | None:
        """``"moved"``, ``"nothing moved"``, ``"partial"`` or None (not measured)."""
        a, b = self.pick_change, self.place_change
        if a is None and b is None:
            return None
        changed = [c is not None and c > self.min_change for c in (a, b)]
        if all(changed):
            return "moved"
        if a is not None and b is not None and not any(changed):
            return "nothing moved"
        return "partial"

    def describe(self) -> str:
        """One line for a verdict's notes or warnings."""

        def part(c: float | None) -> str:
            return "not seen with the hand away" if c is None else f"change {c:.2f}"

        return (
            f"the scene at the pick spot ({part(self.pick_change)}) and the place spot "
            f"({part(self.place_change)}) between before the grasp and after the release, "
            f"frames {self.grasp_frame}-{self.release_frame}"
        )


def clear_frame(
    uv_px: FloatArray,
    valid: BoolArray,
    centre: FloatArray,
    half: float,
    frames: range,
    hand_len: float,
    cfg: SceneChangeConfig,
) -> int | None:
    """The first frame of ``frames`` in which the seen hand and forearm clear the patch."""
    margin = half + cfg.clear_hands * hand_len
    along = np.linspace(0.0, 1.0, 12)[:, None]
    for i in frames:
        if not valid[i]:
            continue
        pts = uv_px[i]
        wrist = pts[0]
        back = wrist - pts[9]
        norm = float(np.linalg.norm(back))
        if not np.isfinite(pts).all() or norm <= 0:
            continue
        arm = wrist + along * (cfg.forearm_hands * hand_len / norm) * back
        every = np.vstack([pts, arm])
        if np.all(np.max(np.abs(every - centre), axis=1) > margin):
            return int(i)
    return None


def patch_change(a: np.ndarray, b: np.ndarray, noise_grey: float) -> float | None:
    """``1 - ZNCC`` of two grey patches, damped where neither has texture above the noise.

    ``(1 - ZNCC) * v / (v + noise_grey**2)`` with ``v`` the larger of the two patches'
    variances: a change of lighting or exposure (gain and offset) is no change. None
    when the patches cannot be compared (empty, different shapes) or neither has a grey
    std of twice the noise: a plain object on a plain support of its shade could have
    come or gone unseen, so such a spot never says that nothing moved.
    """
    if a.size == 0 or a.shape != b.shape:
        return None
    a = a.astype(np.float64)
    b = b.astype(np.float64)
    va, vb = float(a.var()), float(b.var())
    v = max(va, vb)
    if v < (2.0 * noise_grey) ** 2:
        return None
    if min(va, vb) <= 0.0:
        return float(v / (v + noise_grey**2))  # texture appeared or vanished
    zncc = float(np.mean((a - a.mean()) * (b - b.mean())) / np.sqrt(va * vb))
    return float(np.clip(1.0 - zncc, 0.0, 2.0) * v / (v + noise_grey**2))


# OpenCV's seek to frame f decodes from a keyframe at or before f - 16 (or the first
# frame): a frame this few ahead of the next one decoded is reached by decoding on
_SEEK_BACK = 16


def grey_frames(video: Path, frames: set[int], size: tuple[int, int]) -> dict[int, np.ndarray]:
    """The grey pictures of ``frames`` of ``video``, at ``size`` (width, height).

    A frame at most ``_SEEK_BACK`` frames ahead of the next one the decoder gives is
    decoded on to (no more frames decoded than a seek to it would), any other is
    seeked to.
    """
    import cv2

    out: dict[int, np.ndarray] = {}
    cap = cv2.VideoCapture(str(video))
    pos = 0  # the frame the next read gives
    try:
        for f in sorted(frames):
            if not pos <= f <= pos + _SEEK_BACK:
                cap.set(cv2.CAP_PROP_POS_FRAMES, f)
            else:
                while pos < f and cap.grab():
                    pos += 1
            ok, bgr = cap.read()
            pos = f + 1
            if not ok:
                continue
            if (bgr.shape[1], bgr.shape[0]) != size:
                bgr = cv2.resize(bgr, size, interpolation=cv2.INTER_AREA)
            out[f] = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
    finally:
        cap.release()
    return out


def _spot(uv_px: FloatArray, valid: BoolArray, frames: range) -> FloatArray | None:
    seen = [i for i in frames if 0 <= i < valid.size and valid[i]]
    if not seen:
        return None
    return np.asarray(np.mean(uv_px[seen][:, list(_TIPS)].reshape(-1, 2), axis=0))


def measure_scene_changes(
    video: str | Path,
    uv_px: FloatArray,
    valid: BoolArray,
    episodes: Sequence[tuple[int, int]],
    size: tuple[int, int],
    cfg: SceneChangeConfig | None = None,
) -> list[SceneChange]:
    """Per episode ``(grasp frame, release frame)``, the scene before and after.

    ``uv_px (n, 21, 2)`` and ``valid (n,)`` are the recorded hand per frame of
    ``video``, whose frames are read at ``size`` (the tracked frames' width, height).
    An episode whose spots cannot be placed (no seen frame) is left out.
    """
    cfg = cfg or SceneChangeConfig()
    uv = np.asarray(uv_px, dtype=np.float64)
    ok = np.asarray(valid, dtype=bool) & np.isfinite(uv).all(axis=(1, 2))
    n = ok.size
    if not ok.any():
        return []
    hand_len = float(np.median(np.linalg.norm(uv[ok, 12] - uv[ok, 0], axis=1)))
    half = 0.5 * cfg.patch_hands * hand_len
    plans = []
    for grasp, release in episodes:
        pick = _spot(uv, ok, range(grasp, grasp + cfg.spot_frames))
        place = _spot(uv, ok, range(release - cfg.spot_frames, release))
        if pick is None or place is None:
            continue
        snaps = [
            (
                clear_frame(uv, ok, c, half, range(grasp - 1, -1, -1), hand_len, cfg),
                clear_frame(uv, ok, c, half, range(release, n), hand_len, cfg),
            )
            for c in (pick, place)
        ]
        plans.append((grasp, release, pick, place, snaps))
    wanted = {f for p in plans for pair in p[4] for f in pair if f is not None}
    images = grey_frames(Path(video), wanted, size) if wanted else {}

    def change(c: FloatArray, pair: tuple[int | None, int | None]) -> float | None:
        a, b = pair
        if a is None or b is None or a not in images or b not in images:
            return None
        x0, y0 = (int(round(v - half)) for v in c)
        x1, y1 = (int(round(v + half)) for v in c)
        x0, y0 = max(x0, 0), max(y0, 0)
        return patch_change(images[a][y0:y1, x0:x1], images[b][y0:y1, x0:x1], cfg.noise_grey)

    out = []
    for grasp, release, pick, place, (pick_pair, place_pair) in plans:
        out.append(
            SceneChange(
                grasp_frame=int(grasp),
                release_frame=int(release),
                pick_px=(float(pick[0]), float(pick[1])),
                place_px=(float(place[0]), float(place[1])),
                patch_px=2.0 * half,
                pick_frames=None if None in pick_pair else pick_pair,  # type: ignore[arg-type]
                place_frames=None if None in place_pair else place_pair,  # type: ignore[arg-type]
                pick_change=change(pick, pick_pair),
                place_change=change(place, place_pair),
                min_change=cfg.min_change,
            )
        )
    return out


def grasp_span(demo: Demonstration) -> tuple[int, int] | None:
    """A demonstration's longest grasp as (first grasping, first open) recording frames."""
    runs = true_runs(np.asarray(demo.grasp, dtype=bool))
    if not runs:
        return None
    start, stop = max(runs, key=lambda r: r[1] - r[0])  # the earlier of equal runs
    first = int((demo.source_frames or (0, 0))[0])
    return first + start, first + stop


def with_scene_evidence(
    demos: Sequence[Demonstration], changes: Sequence[SceneChange], tolerance: int = 3
) -> list[Demonstration]:
    """The demonstrations' verdicts with the scene before and after as evidence.

    A pick-and-place whose grasp and release match a change's (within ``tolerance``
    frames) gets a note describing it; when nothing moved at either spot it is no
    pick-and-place (``quality.pick_and_place`` None) and not usable (a warning).
    Demonstrations without a matching change are returned as they are.
    """
    out = []
    for d in demos:
        q = d.quality
        span = grasp_span(d)
        match = None
        if q is not None and q.pick_and_place is not None and span is not None:
            match = next(
                (
                    c
                    for c in changes
                    if abs(c.grasp_frame - span[0]) <= tolerance
                    and abs(c.release_frame - span[1]) <= tolerance
                ),
                None,
            )
        if q is None or match is None or match.verdict is None:
            out.append(d)
            continue
        line = f"{match.verdict}: {match.describe()}"
        if match.verdict == "nothing moved":
            q = replace(q, usable=False, pick_and_place=None, warnings=(*q.warnings, line))
        else:
            q = replace(q, notes=(*q.notes, line))
        out.append(replace(d, quality=q))
    return out


def scene_evidence(
    source: Any,
    series: KeypointSeries,
    demos: Sequence[Demonstration],
    landmarks: LandmarkRecording | None,
    cfg: SceneChangeConfig | None = None,
) -> tuple[list[Demonstration], LandmarkRecording | None]:
    """The scene's evidence for ``demos``: measured on a video's frames, or replayed.

    A video file (``source.kind == "video"``) is read again at a few frames per
    pick-and-place; a landmark recording gives the changes it stored. Returns the
    demonstrations (:func:`with_scene_evidence`) and ``landmarks`` with the changes
    (to be saved with them). Any other source (no frames, a camera pair) changes nothing.
    """
    from dexlfd.capture.landmark_source import LandmarkFileSource

    changes: list[SceneChange] = []
    if isinstance(source, LandmarkFileSource) and source.recording is not None:
        changes = list(source.recording.scene_changes)
    elif getattr(source, "kind", "") == "video" and series.image_size is not None:
        spans = [
            s
            for d in demos
            if d.quality is not None and d.quality.pick_and_place is not None
            if (s := grasp_span(d)) is not None
        ]
        if spans:
            changes = measure_scene_changes(
                source.path, series.uv_px, series.valid, spans, series.image_size, cfg
            )
    if landmarks is not None and changes:
        landmarks = replace(landmarks, scene_changes=tuple(changes))
    return with_scene_evidence(demos, changes), landmarks
