"""2-D hand tracking with MediaPipe's Tasks API ``HandLandmarker`` (backend "mediapipe-tasks").

The default implementation of :class:`~dexlfd.capture.tracking.HandTracker`
(21 landmarks). The Tasks API wants a ``hand_landmarker.task`` model bundle,
which MediaPipe normally downloads; dexlfd ships two in ``dexlfd/data/models``
(:func:`packaged_hand_landmarker`: ``full`` and ``lite``, Apache-2.0, licence
text beside them). They were built once by :func:`hand_landmarker_bundle` from
the hand models that the mediapipe 0.10.21 wheel ships for its legacy API: a
``.task`` is a zip archive holding ``hand_detector.tflite`` (the palm detector)
and ``hand_landmarks_detector.tflite`` (the landmark model), both already
carrying the TFLite metadata the Tasks graph reads. A user-supplied
``hand_landmarker.task`` can be passed instead (``task=``).

Measured on the packaged real video (621 frames, 1280 x 720;
``benchmarks/bench_tracker_agreement.py``): this backend finds the hand in the
same 621 frames as the legacy tracker of mediapipe 0.10.21, with landmark
pixels 0.06 px apart (median) on mediapipe 0.10.21 and 0.24 px on mediapipe
1.2.3 / numpy 2.

Handedness: unlike the legacy API, the Tasks API labels an unmirrored image
with the person's hand (the packaged video's right hand is "Right"), so labels
are swapped only when ``TrackerConfig.mirrored`` is True.

Video mode needs strictly increasing integer millisecond timestamps; a frame
time ``t`` that does not advance by at least 1 ms is moved 1 ms past the
previous one (the Tasks API would otherwise refuse the frame).
"""

from __future__ import annotations

import io
import logging
import os
import zipfile
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._stderr import native_stderr_silenced
from dexlfd.capture.tracking import (
    TRACKERS,
    HandObservation,
    MediaPipeTracker,
    TrackerConfig,
    observation_from_landmarks,
)
from dexlfd.errors import DependencyNotInstalled, InvalidFile, InvalidInput

__all__ = [
    "BUNDLE_MEMBERS",
    "PACKAGED_TASKS",
    "MediaPipeTasksHands",
    "hand_landmarker_bundle",
    "packaged_hand_landmarker",
]

logger = logging.getLogger(__name__)

#: member of a ``hand_landmarker.task`` -> (package, file) of the shipped model, per complexity
BUNDLE_MEMBERS: dict[int, dict[str, tuple[str, str]]] = {
    complexity: {
        "hand_detector.tflite": (
            "mediapipe.modules.palm_detection",
            f"palm_detection_{suffix}.tflite",
        ),
        "hand_landmarks_detector.tflite": (
            "mediapipe.modules.hand_landmark",
            f"hand_landmark_{suffix}.tflite",
        ),
    }
    for complexity, suffix in ((0, "lite"), (1, "full"))
}


#: model complexity -> the ``hand_landmarker.task`` shipped in ``dexlfd.data.models``
PACKAGED_TASKS: dict[int, str] = {0: "hand_landmarker_lite.task", 1: "hand_landmarker_full.task"}


def packaged_hand_landmarker(model_complexity: int = 1) -> bytes:
    """The ``hand_landmarker.task`` bundle shipped with dexlfd (zip bytes).

    Parameters
    ----------
    model_complexity
        0 for the lite models, 1 for the full ones (as ``TrackerConfig.model_complexity``).

    Raises
    ------
    InvalidFile
        The installation lacks the bundle (a broken or stripped install).
    """
    if model_complexity not in PACKAGED_TASKS:
        raise InvalidInput(f"model_complexity must be 0 or 1, got {model_complexity}")
    res = resources.files("dexlfd.data") / "models" / PACKAGED_TASKS[model_complexity]
    try:
        return res.read_bytes()
    except OSError as exc:
        raise InvalidFile(f"the hand model {res} is missing from the dexlfd installation") from exc


def hand_landmarker_bundle(model_complexity: int = 1) -> bytes:
    """A ``hand_landmarker.task`` (zip bytes) built from mediapipe 0.10.21's own models.

    How the packaged bundles were made (run with mediapipe 0.10.21 installed; the
    output is byte-identical on every run, see ``dexlfd/data/models/README.md``).

    Parameters
    ----------
    model_complexity
        0 for the lite models, 1 for the full ones (as ``TrackerConfig.model_complexity``).

    Returns
    -------
    bytes
        The bundle, for ``BaseOptions(model_asset_buffer=...)``.

    Raises
    ------
    DependencyNotInstalled
        The installed mediapipe does not ship the hand models (only 0.10.21 and
        older do; pass a ``hand_landmarker.task`` to :class:`MediaPipeTasksHands`).
    """
    if model_complexity not in BUNDLE_MEMBERS:
        raise InvalidInput(f"model_complexity must be 0 or 1, got {model_complexity}")
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED) as zf:
        for member, (package, name) in BUNDLE_MEMBERS[model_complexity].items():
            try:
                data = (resources.files(package) / name).read_bytes()
            except (ModuleNotFoundError, FileNotFoundError) as exc:
                raise DependencyNotInstalled(
                    "mediapipe==0.10.21", f"the hand model bundle (needs {package}/{name})"
                ) from exc
            # a fixed date: the same models give the same bytes (reproducible bundle)
            zf.writestr(zipfile.ZipInfo(member, date_time=(1980, 1, 1, 0, 0, 0)), data)
    return buf.getvalue()


def _read_task(path: str | os.PathLike[str]) -> bytes:
    """A user-supplied ``hand_landmarker.task``, checked to be a bundle with both models."""
    p = Path(path)
    if not p.is_file():
        raise InvalidFile(f"hand landmarker task {p}: no such file")
    data = p.read_bytes()
    try:
        names = set(zipfile.ZipFile(io.BytesIO(data)).namelist())
    except zipfile.BadZipFile as exc:
        raise InvalidFile(f"hand landmarker task {p}: not a zip archive (.task bundle)") from exc
    missing = sorted(set(BUNDLE_MEMBERS[1]) - names)
    if missing:
        raise InvalidFile(f"hand landmarker task {p}: missing {missing} (has {sorted(names)})")
    return data


class MediaPipeTasksHands(MediaPipeTracker):
    """MediaPipe Tasks ``HandLandmarker`` behind the :class:`HandTracker` interface.

    Parameters
    ----------
    cfg
        Tracker settings: ``static_image_mode`` selects the IMAGE running mode
        (else VIDEO, which tracks between frames), ``max_num_hands`` is
        ``num_hands``, ``min_detection_confidence`` the palm-detection threshold and
        ``min_tracking_confidence`` both the hand-presence and the tracking
        threshold (the legacy API's meaning of it).
    task
        A ``hand_landmarker.task`` file; default: the packaged bundle of
        ``cfg.model_complexity`` (:func:`packaged_hand_landmarker`).
    """

    def __init__(
        self, cfg: TrackerConfig | None = None, task: str | os.PathLike[str] | None = None
    ) -> None:
        self.cfg = cfg or TrackerConfig()
        try:
            from mediapipe.tasks.python import BaseOptions
            from mediapipe.tasks.python.vision import (
                HandLandmarker,
                HandLandmarkerOptions,
                RunningMode,
            )
        except ImportError as exc:  # pragma: no cover - mediapipe is a core dependency
            raise DependencyNotInstalled("mediapipe>=1.2", "hand tracking") from exc
        bundle = (
            packaged_hand_landmarker(self.cfg.model_complexity)
            if task is None
            else _read_task(task)
        )
        self.task = None if task is None else Path(task)
        self._video = not self.cfg.static_image_mode
        options = HandLandmarkerOptions(
            base_options=BaseOptions(model_asset_buffer=bundle),
            running_mode=RunningMode.VIDEO if self._video else RunningMode.IMAGE,
            num_hands=self.cfg.max_num_hands,
            min_hand_detection_confidence=self.cfg.min_detection_confidence,
            min_hand_presence_confidence=self.cfg.min_tracking_confidence,
            min_tracking_confidence=self.cfg.min_tracking_confidence,
        )
        with native_stderr_silenced():
            self._landmarker: Any = HandLandmarker.create_from_options(options)
        self._mp_image: Any = None
        self._last_ms: int | None = None
        self._closed = False
        self._quiet_calls = 3  # native start-up notes come with the first few hands

    def _timestamp_ms(self, t: float) -> int:
        ms = int(round(1e3 * float(t)))
        if self._last_ms is not None and ms <= self._last_ms:
            ms = self._last_ms + 1
        self._last_ms = ms
        return ms

    def detect(self, rgb: np.ndarray, t: float) -> list[HandObservation]:
        """Hands in one RGB frame (H, W, 3) uint8 at time ``t`` [s]."""
        img = self._checked_rgb(rgb)
        if not np.isfinite(t):
            raise InvalidInput(f"frame time must be finite, got {t}")
        import mediapipe as mp

        h, w = img.shape[:2]
        image = mp.Image(image_format=mp.ImageFormat.SRGB, data=np.ascontiguousarray(img))
        with native_stderr_silenced(self._quiet_calls > 0):
            if self._video:
                res = self._landmarker.detect_for_video(image, self._timestamp_ms(t))
            else:
                res = self._landmarker.detect(image)
        if not res.hand_landmarks:
            return []
        self._quiet_calls -= 1
        out = []
        worlds = res.hand_world_landmarks or [None] * len(res.hand_landmarks)
        for lms, wlms, cats in zip(res.hand_landmarks, worlds, res.handedness, strict=False):
            out.append(
                observation_from_landmarks(
                    lms, wlms or None, (w, h), cats[0].category_name, float(cats[0].score),
                    # the Tasks API names the hand of an unmirrored image
                    swap_label=self.cfg.mirrored,
                )
            )  # fmt: skip
        return out

    def _release(self) -> None:
        with native_stderr_silenced():  # mediapipe 1.x notes "DestroyAccelerator" at close
            self._landmarker.close()


TRACKERS["mediapipe-tasks"] = MediaPipeTasksHands  # selectable as TrackerConfig.backend
