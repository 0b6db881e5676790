"""Captions on video frames; the H.264 MP4 writer is :mod:`dexlfd.io.video` (re-exported)."""

from __future__ import annotations

import numpy as np

__all__ = ["draw_caption"]


def draw_caption(frame: np.ndarray, text: str) -> np.ndarray:
    """A copy of RGB ``frame`` with ``text`` in white on a dark band along its top.

    The font scales with the frame's width so the caption stays readable at any
    size (about 45 characters fit across).
    """
    import cv2

    img = np.ascontiguousarray(frame, dtype=np.uint8).copy()
    h, w = img.shape[:2]
    scale = max(0.35, w / 1100.0)
    thick = max(1, round(w / 400))
    (_, th), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, thick)
    band = min(h, th + base + 2 * max(4, th // 2))
    img[:band] = (0.35 * img[:band]).astype(np.uint8)
    cv2.putText(img, text, (max(4, th // 2), band - base - max(2, th // 4)),
                cv2.FONT_HERSHEY_SIMPLEX, scale, (255, 255, 255), thick, cv2.LINE_AA)  # fmt: skip
    return img
