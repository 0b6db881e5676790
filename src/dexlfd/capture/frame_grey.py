"""One frame's small grey copies, each made once for every pixel cue that reads it.

The camera-motion estimate (:mod:`dexlfd.capture.camera_motion`) and the carry cue
(:mod:`dexlfd.capture.carry_cue`) both read a grey copy of the frame shrunk by
OpenCV's linear resize (at 1920x1080 both the same 640x360 one). Shrinking a 1080p
RGB frame costs more than either cue's own work on most frames, so
:class:`FrameGrey` makes each size once per frame and hands the same array to both.

A linear resize by an odd whole factor ``k`` in both directions samples exactly the
source pixel ``k * i + (k - 1) / 2`` (weights 1 and 0), the pixel OpenCV's
nearest-exact resize takes, so :func:`linear_shrink` takes that one there (1920x1080
-> 640x360: ``k = 3``), bit-identical to ``cv2.resize(..., INTER_LINEAR)`` and about
half its cost; any other size is resized linearly.
"""

from __future__ import annotations

import numpy as np

__all__ = ["FrameGrey", "linear_shrink"]


def linear_shrink(rgb: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """``cv2.resize(rgb, size, interpolation=cv2.INTER_LINEAR)``, ``size`` = (width, height).

    Without interpolating when the image shrinks by the same odd whole factor in both
    directions (module docstring); the same result.
    """
    h, w = rgb.shape[:2]
    sw, sh = size
    if (sw, sh) == (w, h):
        return rgb
    import cv2

    k = w // sw if sw > 0 else 0
    if k > 1 and k % 2 == 1 and w == k * sw and h == k * sh:
        # nearest-exact takes pixel floor((i + 0.5) * k) = k * i + (k - 1) / 2
        return cv2.resize(rgb, (sw, sh), interpolation=cv2.INTER_NEAREST_EXACT)
    return cv2.resize(rgb, (sw, sh), interpolation=cv2.INTER_LINEAR)


class FrameGrey:
    """Grey copies of one RGB frame (H, W, 3) uint8 at the sizes asked for, each made once.

    ``linear(size)`` is ``cvtColor(cv2.resize(rgb, size, INTER_LINEAR), RGB2GRAY)``
    (no resize at the frame's own size). Not shared between threads while it fills.
    """

    def __init__(self, rgb: np.ndarray) -> None:
        self.rgb = rgb
        self._grey: dict[tuple[int, int], np.ndarray] = {}

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) of the frame [px]."""
        return int(self.rgb.shape[1]), int(self.rgb.shape[0])

    def linear(self, size: tuple[int, int]) -> np.ndarray:
        """The grey frame linearly shrunk to ``size`` = (width, height) [px]."""
        key = (int(size[0]), int(size[1]))
        grey = self._grey.get(key)
        if grey is None:
            import cv2

            small = linear_shrink(np.ascontiguousarray(self.rgb), key)
            grey = cv2.cvtColor(small, cv2.COLOR_RGB2GRAY)
            self._grey[key] = grey
        return grey
