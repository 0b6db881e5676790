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


def _detailed_frame(h: int, w: int) -> np.ndarray:
    """Text and fine noise: what aliases when a frame is shrunk carelessly."""
    import cv2

    rng = np.random.default_rng(1)
    img = np.zeros((h, w, 3), np.uint8)
    for i in range(150):
        xy = (int(rng.integers(0, w - 100)), int(rng.integers(20, h)))
        colour = tuple(int(c) for c in rng.integers(0, 256, 3))
        cv2.putText(img, f"grasp {i}", xy, cv2.FONT_HERSHEY_SIMPLEX,
                    float(rng.uniform(0.5, 3.0)), colour, int(rng.integers(1, 4)))  # fmt: skip
    noise = cv2.GaussianBlur(rng.integers(0, 256, (h, w, 3), dtype=np.uint8), (0, 0), 1.0)
    return cv2.addWeighted(img, 0.7, noise, 0.3, 0)


def _psnr(a: np.ndarray, b: np.ndarray) -> float:
    return float(10 * np.log10(255.0**2 / np.mean((a.astype(float) - b) ** 2)))


def test_a_shrunk_frame_looks_like_the_area_resize_not_an_aliased_one() -> None:
    import cv2

    from dexlfd.apps.teach_sources import SNAPSHOT_WIDTH_PX, shrink_for_snapshot

    rgb = _detailed_frame(1080, 1920)
    area = cv2.resize(rgb, (SNAPSHOT_WIDTH_PX, 360), interpolation=cv2.INTER_AREA)
    small = shrink_for_snapshot(rgb)
    assert small.shape == area.shape
    aliased = cv2.resize(rgb, (SNAPSHOT_WIDTH_PX, 360), interpolation=cv2.INTER_LINEAR)
    assert _psnr(aliased, area) < 28.0  # the reference tells a careless shrink apart
    assert _psnr(small, area) > 32.0
    half = _detailed_frame(720, 1280)  # by exactly two: the area resize itself
    want = cv2.resize(half, (SNAPSHOT_WIDTH_PX, 360), interpolation=cv2.INTER_AREA)
    np.testing.assert_array_equal(shrink_for_snapshot(half), want)


def test_a_kept_frame_keeps_its_colours() -> None:
    import cv2

    from dexlfd.apps.teach_sources import _encode_snapshot

    rgb = np.zeros((1080, 1920, 3), np.uint8)
    rgb[..., 0] = 200  # red
    rgb[:, :960, 2] = 150  # the left half also blue
    img = cv2.imdecode(np.frombuffer(_encode_snapshot(rgb) or b"", np.uint8), cv2.IMREAD_COLOR)
    b, g, r = (float(img[:, 400:, c].mean()) for c in range(3))  # decoded as BGR, right part
    assert r > 190 and g < 10 and b < 10
    assert abs(float(img[:, :200, 0].mean()) - 150) < 10  # blue on the left
