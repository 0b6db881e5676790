"""A frame source: the context manager and iterator every capture source is.

:class:`Frame` is one captured frame (RGB, optional aligned depth, optional side
camera); :class:`FrameSource` the base class of the sources in
:mod:`dexlfd.capture.opencv_sources` and :mod:`dexlfd.capture.realsense`.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from dexlfd.capture.camera_models import Intrinsics
from dexlfd.errors import InvalidInput, SourceError

__all__ = ["Frame", "FrameSource"]


@dataclass(frozen=True, slots=True)
class Frame:
    """One captured frame.

    ``rgb`` (H, W, 3) uint8 in RGB order; ``depth_m`` (H, W) float32 depth aligned
    to ``rgb`` [m] (0 = no reading) or None; ``rgb2`` the side camera of a pair.
    """

    index: int
    t: float  # [s] since the first frame
    rgb: np.ndarray
    depth_m: np.ndarray | None = None
    rgb2: np.ndarray | None = None


class FrameSource:
    """Base class: context manager + iterator of frames.

    Attributes: ``kind`` (str), ``description`` (str), ``fps`` (float or None),
    ``n_frames`` (int or None when unknown), ``intrinsics`` (:class:`Intrinsics` of
    the colour stream or None), ``has_depth`` (bool), ``has_images`` (bool: False for
    a replayed landmark recording, whose frames carry a blank picture of the right size).
    """

    kind = "source"
    has_depth = False
    has_images = True

    def __init__(self, max_frames: int | None = None) -> None:
        if max_frames is not None and int(max_frames) < 1:
            raise InvalidInput(f"max_frames must be >= 1, got {max_frames}")
        self.max_frames = None if max_frames is None else int(max_frames)
        self.description = self.kind
        self.fps: float | None = None
        self.n_frames: int | None = None
        self.intrinsics: Intrinsics | None = None
        self._open = False

    @property
    def native_size(self) -> tuple[int, int] | None:
        """(width, height) [px] of the frames as decoded, before resizing; None if unknown."""
        return None

    def open(self) -> None:
        """Acquire the device or file."""
        self._open = True

    def close(self) -> None:
        """Release the device or file (idempotent)."""
        self._open = False

    def __enter__(self) -> FrameSource:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def frames(self) -> Iterator[Frame]:
        """Yield frames until the source ends or ``max_frames`` were read."""
        raise NotImplementedError

    def __iter__(self) -> Iterator[Frame]:
        if not self._open:
            raise SourceError(f"{self.description}: use 'with source:' before iterating")
        return self.frames()

    def _limit(self, n: int | None) -> int | None:
        if self.max_frames is None:
            return n
        return self.max_frames if n is None else min(n, self.max_frames)
