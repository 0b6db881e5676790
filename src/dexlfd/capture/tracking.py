"""2-D hand tracking: MediaPipe Hands (21 landmarks) behind a small interface.

:class:`HandTracker` is the interface (a Protocol): ``detect(rgb, t) ->
list[HandObservation]`` plus ``close()``. Two backends implement it:

- ``"mediapipe-tasks"`` (the default): MediaPipe's Tasks-API ``HandLandmarker``
  (:mod:`dexlfd.capture.tracking_tasks`) with the ``hand_landmarker.task``
  bundle that ships inside dexlfd (works offline, any current mediapipe).
- ``"mediapipe"``: :class:`MediaPipeHands`, the legacy
  ``mediapipe.solutions.hands``, which only mediapipe 0.10.21 and older have
  (numpy < 2); kept to compare against recordings made with it.

Handedness: the legacy API labels hands as if the image were mirrored (a
selfie view). For an ordinary, unmirrored camera or video its "Left" is the
person's right hand. ``TrackerConfig.mirrored=False`` (the default) swaps the
labels so they name the person's hand; set it to True for a mirrored preview.

With several hands in view :func:`select_hand` keeps one: the hand with the
preferred label (``TrackerConfig.hand``, "right" by default; "any" ignores the
label), and among those the highest handedness confidence.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any, Protocol, Self, runtime_checkable

import numpy as np

from dexlfd._params import param
from dexlfd._stderr import native_stderr_silenced
from dexlfd._types import FloatArray
from dexlfd.errors import DependencyNotInstalled, InvalidInput

__all__ = [
    "FINGER_CHAINS",
    "HAND_CONNECTIONS",
    "HandObservation",
    "HandTracker",
    "MediaPipeHands",
    "MediaPipeTracker",
    "TRACKERS",
    "TrackerConfig",
    "make_tracker",
    "select_hand",
]

logger = logging.getLogger(__name__)

# MediaPipe's skeleton (pairs of landmark indices), for drawing
HAND_CONNECTIONS: tuple[tuple[int, int], ...] = (
    (0, 1), (1, 2), (2, 3), (3, 4),
    (0, 5), (5, 6), (6, 7), (7, 8),
    (5, 9), (9, 10), (10, 11), (11, 12),
    (9, 13), (13, 14), (14, 15), (15, 16),
    (13, 17), (0, 17), (17, 18), (18, 19), (19, 20),
)  # fmt: skip

WRIST = 0
# each finger's joints from its base to its tip (MediaPipe numbering): the thumb (CMC, MCP,
# IP, tip), then the index, middle, ring and little fingers (MCP, PIP, DIP, tip); every
# chain hangs from the wrist
FINGER_CHAINS: tuple[tuple[int, int, int, int], ...] = (
    (1, 2, 3, 4), (5, 6, 7, 8), (9, 10, 11, 12), (13, 14, 15, 16), (17, 18, 19, 20),
)  # fmt: skip

HAND_CHOICES = ("right", "left", "any")


@dataclass(frozen=True, slots=True)
class HandObservation:
    """One detected hand in one image.

    Attributes
    ----------
    uv_px : ndarray, shape (21, 2)
        Landmark pixels, top-left image corner at (0, 0) [px].
    z_rel : ndarray, shape (21,)
        MediaPipe's relative depth (wrist-relative, image-width units) [-].
    world_m : ndarray, shape (21, 3)
        MediaPipe's metric world landmarks, hand-centred, camera-aligned [m].
    handedness : str
        "right" or "left": the person's hand (after the mirror correction).
    score : float
        Handedness confidence in [0, 1].
    depth_m : ndarray, shape (21,), optional
        Depth [m] at each landmark already sampled from an aligned depth image (NaN
        where there was none): a replayed RGB-D landmark recording. None (live
        trackers): the capture samples the frame's depth image itself.
    redetected : bool
        Found again in a crop around its predicted place after the tracker lost it
        (:mod:`dexlfd.capture.redetection`).
    carry : float
        Fraction of the pixels beside the hand that moved with it since the previous
        frame (:mod:`dexlfd.capture.carry_cue`); NaN: not measured.
    """

    uv_px: FloatArray
    z_rel: FloatArray
    world_m: FloatArray
    handedness: str
    score: float
    depth_m: FloatArray | None = None
    redetected: bool = False
    carry: float = float("nan")


@runtime_checkable
class HandTracker(Protocol):
    """A 2-D hand landmark detector for a stream of RGB frames."""

    def detect(self, rgb: np.ndarray, t: float) -> list[HandObservation]:
        """Hands in ``rgb`` (H, W, 3) uint8 at time ``t`` [s] (increasing within a stream)."""
        ...

    def close(self) -> None:
        """Release the model."""
        ...


@dataclass(frozen=True, slots=True)
class TrackerConfig:
    """Settings of the hand tracker."""

    backend: str = "mediapipe-tasks"  # key of TRACKERS
    static_image_mode: bool = False  # False: tracking mode for video
    max_num_hands: int = param(
        1,
        "hands tracked per frame (1 is faster but cannot choose)",
        lo=1,
        hi=4,
        integer=True,
        flag="--max-hands",
    )  # 2 to choose among two hands (about 2x slower)
    model_complexity: int = 1  # 0 lite, 1 full
    min_detection_confidence: float = 0.5
    min_tracking_confidence: float = 0.5
    mirrored: bool = False  # True if frames are mirrored (selfie preview)
    hand: str = "right"  # preferred hand: "right", "left" or "any"

    def __post_init__(self) -> None:
        if self.backend not in TRACKERS:
            raise InvalidInput(
                f"tracker backend must be one of {sorted(TRACKERS)}, got {self.backend!r}"
            )
        if self.max_num_hands < 1:
            raise InvalidInput(f"max_num_hands must be >= 1, got {self.max_num_hands}")
        if self.model_complexity not in (0, 1):
            raise InvalidInput(f"model_complexity must be 0 or 1, got {self.model_complexity}")
        for name in ("min_detection_confidence", "min_tracking_confidence"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise InvalidInput(f"{name} must be in [0, 1], got {getattr(self, name)}")
        if self.hand not in HAND_CHOICES:
            raise InvalidInput(f"hand must be one of {HAND_CHOICES}, got {self.hand!r}")


def select_hand(hands: list[HandObservation], prefer: str = "right") -> HandObservation | None:
    """The hand to follow: preferred label first, then highest confidence; None if empty."""
    if not hands:
        return None
    pool = [h for h in hands if prefer == "any" or h.handedness == prefer] or list(hands)
    return max(pool, key=lambda h: h.score)


_QUIET_HAND_FRAMES = 3  # frames with a hand after which MediaPipe's start-up notes are done


class MediaPipeTracker:
    """What both MediaPipe backends share: the closed state, the frame check, ``with``.

    A subclass sets ``self._closed = False`` once built and implements :meth:`_release`.
    """

    _closed = True
    _quiet_calls = 0  # frames with a hand to come while MediaPipe's start-up notes are muted

    @property
    def starting_up(self) -> bool:
        """True while :meth:`detect` mutes the native stderr (MediaPipe's start-up notes).

        The mute is process-wide (file descriptor 2): a detection run on another
        thread meanwhile would mute that thread's messages too.
        """
        return self._quiet_calls > 0

    def _checked_rgb(self, rgb: np.ndarray) -> np.ndarray:
        """``rgb`` as an (H, W, 3) uint8 array, or :class:`InvalidInput` (also after close)."""
        if self._closed:
            raise InvalidInput(f"{type(self).__name__}.detect called after close()")
        img = np.asarray(rgb)
        if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
            raise InvalidInput(f"rgb must be an (H, W, 3) uint8 image, got {img.shape} {img.dtype}")
        return img

    def _release(self) -> None:
        raise NotImplementedError

    def close(self) -> None:
        """Release the MediaPipe graph (idempotent)."""
        if not self._closed:
            self._release()
            self._closed = True

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class MediaPipeHands(MediaPipeTracker):
    """MediaPipe Hands (legacy solutions API, models bundled in mediapipe 0.10.21).

    Use as a context manager or call :meth:`close`. MediaPipe's native start-up
    log lines are silenced until a hand has been found in a few frames (see
    :func:`native_stderr_silenced`).
    """

    def __init__(self, cfg: TrackerConfig | None = None) -> None:
        self.cfg = cfg or TrackerConfig()
        try:
            from mediapipe.python.solutions import hands as mp_hands
        except ImportError as exc:  # mediapipe >= 0.10.30 has no legacy solutions API
            raise DependencyNotInstalled(
                "mediapipe==0.10.21",
                "the legacy tracker (backend 'mediapipe'; the default 'mediapipe-tasks' needs "
                "no extra package)",
            ) from exc
        with native_stderr_silenced():
            self._hands = mp_hands.Hands(
                static_image_mode=self.cfg.static_image_mode,
                max_num_hands=self.cfg.max_num_hands,
                model_complexity=self.cfg.model_complexity,
                min_detection_confidence=self.cfg.min_detection_confidence,
                min_tracking_confidence=self.cfg.min_tracking_confidence,
            )
        self._closed = False
        # the native start-up notes come until the landmark model has run a few times
        self._quiet_calls = _QUIET_HAND_FRAMES

    def detect(self, rgb: np.ndarray, t: float) -> list[HandObservation]:
        """Hands in one RGB frame (H, W, 3) uint8; ``t`` is unused by this backend."""
        img = self._checked_rgb(rgb)
        h, w = img.shape[:2]
        with native_stderr_silenced(self._quiet_calls > 0):
            res = self._hands.process(np.ascontiguousarray(img))
        if not res.multi_hand_landmarks:
            return []
        self._quiet_calls -= 1
        out = []
        worlds = res.multi_hand_world_landmarks or [None] * len(res.multi_hand_landmarks)
        for lms, wlms, hd in zip(
            res.multi_hand_landmarks, worlds, res.multi_handedness, strict=False
        ):
            cls = hd.classification[0]
            out.append(
                observation_from_landmarks(
                    lms.landmark, None if wlms is None else wlms.landmark, (w, h),
                    # the legacy API assumes a mirrored (selfie) image
                    cls.label, float(cls.score), swap_label=not self.cfg.mirrored,
                )
            )  # fmt: skip
        return out

    def _release(self) -> None:
        self._hands.close()


def observation_from_landmarks(
    landmarks: Any,
    world_landmarks: Any,
    size_px: tuple[int, int],
    label: str,
    score: float,
    *,
    swap_label: bool,
) -> HandObservation:
    """One :class:`HandObservation` from MediaPipe's landmarks (any backend).

    ``landmarks`` are 21 points with normalised ``x, y, z``; ``world_landmarks`` the
    21 metric hand-centred points, or None (then NaN). ``size_px`` is the image's
    (width, height). ``swap_label`` turns MediaPipe's "left"/"right" into the other,
    so labels name the person's hand on an unmirrored image.
    """
    w, h = size_px
    a = np.array([(p.x, p.y, p.z) for p in landmarks], dtype=np.float64)
    world = (
        np.array([(p.x, p.y, p.z) for p in world_landmarks], dtype=np.float64)
        if world_landmarks
        else np.full((21, 3), np.nan)
    )
    label = label.lower()
    if swap_label:
        label = {"left": "right", "right": "left"}.get(label, label)
    return HandObservation(
        uv_px=a[:, :2] * np.array([w, h]), z_rel=a[:, 2], world_m=world,
        handedness=label, score=score,
    )  # fmt: skip


TRACKERS: dict[str, type] = {"mediapipe": MediaPipeHands}


def make_tracker(cfg: TrackerConfig | None = None) -> HandTracker:
    """Build the tracker named by ``cfg.backend``."""
    cfg = cfg or TrackerConfig()
    tracker: HandTracker = TRACKERS[cfg.backend](cfg)
    return tracker


# registers "mediapipe-tasks" (the default backend) in TRACKERS; it imports this module's names
from dexlfd.capture import tracking_tasks as _tracking_tasks  # noqa: E402, F401
