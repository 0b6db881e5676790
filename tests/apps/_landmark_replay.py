"""The real MediaPipe landmark recordings and their annotation, for the record tests.

The real recordings (``../shared/data/landmarks/*.npz``: MediaPipe Hands' output on real
pick-and-place videos, with a person's annotation) are a source of ``dexlfd record``
itself (:mod:`dexlfd.capture.landmark_source`), so everything after the tracker
(association, hand choice, whole-recording pose, motion, phases, verdict) runs as on
the video.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

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


def record_landmarks(name: str):
    """The real recording ``name`` through ``dexlfd record``'s own pipeline (its defaults).

    Returns ``(t_s, demos)``: the recording's frame times and the demonstrations
    :func:`~dexlfd.apps.record.record_demonstration` makes of it (one per pick-and-place,
    on the recording's clock).
    """
    from dexlfd.apps.record import RecordConfig, record_demonstration

    path = landmark_file(name)
    with np.load(path, allow_pickle=False) as f:
        t_s = np.asarray(f["t_s"], dtype=np.float64)
    return t_s, list(record_demonstration(str(path), RecordConfig()).demos)


def iou(a: tuple[int, int], b: tuple[int, int]) -> float:
    """Frame IoU of two inclusive frame ranges."""
    inter = min(a[1], b[1]) - max(a[0], b[0]) + 1
    return max(inter, 0) / (max(a[1], b[1]) - min(a[0], b[0]) + 1)
