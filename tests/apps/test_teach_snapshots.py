"""``teach``'s record stage keeps each video frame small, encoded beside the tracker."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np


def test_kept_frames_are_shrunk_jpegs_of_the_frames_as_they_were_given() -> None:
    import cv2

    from dexlfd.apps.teach_sources import SNAPSHOT_WIDTH_PX, _encode_snapshot, _FrameKeeper

    rng = np.random.default_rng(0)
    originals = [rng.integers(0, 256, (1080, 1920, 3), dtype=np.uint8) for _ in range(12)]
    buffer = np.zeros_like(originals[0])  # a reader that reuses one buffer for every frame
    with _FrameKeeper() as keeper:
        for i, rgb in enumerate(originals):
            buffer[:] = rgb
            keeper.keep(SimpleNamespace(index=10 + i, rgb=buffer), None)
        buffer[:] = 0
        frames = keeper.frames()
    assert sorted(frames) == list(range(10, 22))
    for i, rgb in enumerate(originals):
        assert frames[10 + i] == _encode_snapshot(rgb)  # the frame given, not the buffer now
        img = cv2.imdecode(np.frombuffer(frames[10 + i], np.uint8), cv2.IMREAD_COLOR)
        assert img.shape == (360, SNAPSHOT_WIDTH_PX, 3)


def test_a_small_frame_is_kept_at_its_size() -> None:
    import cv2

    from dexlfd.apps.teach_sources import _FrameKeeper

    rgb = np.full((240, 320, 3), 90, dtype=np.uint8)
    with _FrameKeeper() as keeper:
        keeper.keep(SimpleNamespace(index=0, rgb=rgb), None)
        frames = keeper.frames()
    img = cv2.imdecode(np.frombuffer(frames[0], np.uint8), cv2.IMREAD_COLOR)
    assert img.shape == (240, 320, 3) and abs(int(img.mean()) - 90) <= 2
