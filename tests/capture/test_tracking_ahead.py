"""A tapped tracker told the next frame tracks it on a worker: the same calls, in order."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from dexlfd.capture.landmark_source import TrackerTap
from dexlfd.capture.tracking import HandObservation


class _Inner:
    """A tracker whose answer is the frame's time; notes the order and any overlap."""

    def __init__(self, quiet: int = 0, fail_at: float | None = None) -> None:
        self.calls: list[tuple[float, str]] = []
        self.quiet = quiet
        self.fail_at = fail_at
        self.busy = False
        self.overlapped = False
        self.closed_after: int | None = None  # calls made before close

    @property
    def starting_up(self) -> bool:
        return self.quiet > 0

    def detect(self, rgb: np.ndarray, t: float) -> list[HandObservation]:
        self.overlapped |= self.busy
        self.busy = True
        time.sleep(0.002)  # long enough for a second caller to overlap
        self.calls.append((t, threading.current_thread().name))
        self.busy = False
        if t == self.fail_at:
            raise ValueError(f"bad frame {t}")
        self.quiet -= 1
        uv = np.full((21, 2), float(rgb[0, 0, 0]))
        return [HandObservation(uv, np.zeros(21), np.zeros((21, 3)), "right", t)]

    def close(self) -> None:
        self.closed_after = len(self.calls)


def _run(inner: _Inner, n: int, announce: bool) -> list[float]:
    frames = [(np.full((4, 4, 3), i, np.uint8), i / 30) for i in range(n)]
    tap = TrackerTap(inner)
    out = []
    try:
        for i, (rgb, t) in enumerate(frames):
            if announce and i + 1 < n:
                tap.announce(*frames[i + 1])
            (hand,) = tap.detect(rgb, t)
            assert hand.uv_px[0, 0] == i  # this frame's answer
            out.append(hand.score)
    finally:
        tap.close()
    return out


def test_frames_announced_are_tracked_ahead_in_order_one_at_a_time() -> None:
    plain, ahead = _Inner(), _Inner(quiet=3)
    assert _run(ahead, 12, announce=True) == _run(plain, 12, announce=False)
    assert [t for t, _ in ahead.calls] == [t for t, _ in plain.calls] == [i / 30 for i in range(12)]
    assert not ahead.overlapped and ahead.closed_after == 12
    where = [name for _, name in ahead.calls]
    # while starting up (3 frames) on the caller's thread, then ahead on the worker
    assert all(not w.startswith("dexlfd-tracker") for w in where[:3])
    assert all(w.startswith("dexlfd-tracker") for w in where[3:])


def test_an_error_tracking_ahead_is_raised_at_its_frame() -> None:
    inner = _Inner(fail_at=5 / 30)
    seen: list[float] = []
    with pytest.raises(ValueError, match="bad frame"):
        seen = _run(inner, 10, announce=True)
    assert seen == [] and max(t for t, _ in inner.calls) == 5 / 30
    assert inner.closed_after == len(inner.calls)


def test_each_frame_is_announced_before_the_one_before_it_is_handed_on() -> None:
    from dexlfd.capture.frame_source import Frame
    from dexlfd.capture.source_tracking import _announced

    frames = [Frame(i, i / 30, np.full((2, 2, 3), i, np.uint8)) for i in range(4)]
    said: list[float] = []
    closed: list[bool] = []

    def source():
        try:
            yield from frames
        finally:
            closed.append(True)

    got = []
    for f in _announced(source(), lambda rgb, t: said.append(t)):
        got.append(f)
        assert said[-1] == frames[min(f.index + 1, 3)].t  # the next one, told first
    assert got == frames and said == [1 / 30, 2 / 30, 3 / 30] and closed == [True]
