"""Replay a real MediaPipe landmark recording through the capture stage (tests only).

The real recordings (``../shared/data/landmarks/*.npz``: MediaPipe Hands' output on real
pick-and-place videos, with a person's annotation) hold per frame up to two hands:
normalised image landmarks, metric world landmarks and selfie-convention labels. A
:class:`ReplayTracker` returns them frame by frame as a :class:`HandTracker` would, over
blank frames of the recorded size (:class:`BlankSource`), so everything after the tracker
(association, hand choice, lifting, motion, phases, verdict) runs as on the video.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from dexlfd.capture.frame_source import Frame, FrameSource
from dexlfd.capture.tracking import HandObservation

SHARED = Path(
    os.environ.get("DEXLFD_SHARED", Path(__file__).resolve().parents[2] / ".." / "shared")
)
LANDMARKS = SHARED / "data" / "landmarks"

# the person's annotation (../shared/data/README.md): grasp frames (close -> last closed) of
# the acting hand, and the number of pick-and-places
ANNOTATION = {
    "breakfast": [(26, 74), (94, 132), (152, 197)],
    "rearrange": [(30, 104), (146, 214)],
    "llama": [(35, 104)],
    "plush_toy": [(34, 61)],
    "bagging": [(132, 212)],  # the chips; the other hand holds the bag (never released)
}


def landmark_file(name: str) -> Path:
    """The real recording ``name``, or skip the test (with the reason) when it is absent."""
    path = LANDMARKS / f"{name}.npz"
    if not path.is_file():
        pytest.skip(f"real landmark recording not found at {path} (../shared/data/landmarks/)")
    return path


class ReplayTracker:
    """The hands MediaPipe reported in each frame of a landmark recording, in order."""

    def __init__(self, path: Path) -> None:
        with np.load(path, allow_pickle=False) as f:
            self.d = {k: f[k] for k in f.files}
        self.size = tuple(int(v) for v in self.d["frame_size_px"])
        self.i = 0

    def detect(self, rgb: np.ndarray, t: float) -> list[HandObservation]:
        w, h = self.size
        d, i = self.d, self.i
        self.i += 1
        out = []
        for s in range(d["label_selfie"].shape[1]):
            lab = int(d["label_selfie"][i, s])
            if lab < 0:
                continue
            uv = d["image_xyz"][i, s, :, :2] * [w, h]
            out.append(
                HandObservation(
                    uv,
                    d["image_xyz"][i, s, :, 2].copy(),
                    np.asarray(d["world_xyz_m"][i, s], dtype=np.float64),
                    "right" if lab == 0 else "left",  # unmirrored video: selfie labels swapped
                    float(d["label_score"][i, s]),
                )
            )
        return out

    def close(self) -> None:
        pass


class BlankSource(FrameSource):
    """Black frames of the recording's size at its times (the tracker is replayed)."""

    kind = "video"

    def __init__(self, tracker: ReplayTracker) -> None:
        super().__init__()
        self.t = tracker.d["t_s"]
        self.size = tracker.size
        self.description = "replayed landmark recording"
        self.n_frames = int(self.t.size)
        self.fps = float(1.0 / np.median(np.diff(self.t)))

    @property
    def native_size(self) -> tuple[int, int]:
        return self.size

    def frames(self) -> Iterator[Frame]:
        w, h = self.size
        black = np.zeros((h, w, 3), np.uint8)
        for i, t in enumerate(self.t):
            yield Frame(i, float(t), black)


def record_landmarks(name: str):
    """The whole recording of ``name`` as ``dexlfd record`` makes it, and its pieces.

    Returns ``(demo, demos)``: the untrimmed demonstration of the chosen hand and the
    demonstrations written (one per pick-and-place), with the record command's defaults.
    """
    from dataclasses import replace

    from dexlfd.apps.record import RecordConfig, capture_config, demonstrations_of, motion_config
    from dexlfd.capture import HandCapture, track_source
    from dexlfd.motion import demonstration_from_capture
    from dexlfd.motion.phases import track_actions

    tracker = ReplayTracker(landmark_file(name))
    source = BlankSource(tracker)
    cfg = RecordConfig()
    with source:
        ccfg = capture_config(source, cfg)
        with HandCapture(ccfg, source.intrinsics, tracker=tracker) as cap:
            series = track_source(source, capture=cap, hand="auto", judge=track_actions)
    hand = series.meta["hand_choice"]["hand"]
    demo = demonstration_from_capture(series, motion_config(cfg, hand, source.fps))
    demo = replace(
        demo,
        meta={
            **demo.meta,
            "recording": {"n_frames": demo.n_samples, "detection_rate": series.detection_rate},
        },
    )
    return demo, demonstrations_of(demo)


def iou(a: tuple[int, int], b: tuple[int, int]) -> float:
    """Frame IoU of two inclusive frame ranges."""
    inter = min(a[1], b[1]) - max(a[0], b[0]) + 1
    return max(inter, 0) / (max(a[1], b[1]) - min(a[0], b[0]) + 1)
