"""How far the object was carried, with its uncertainty: the grasp's first to last frame.

An RGB-only lift reads metres from the hand's apparent size, so a carried distance
carries two errors: the scale (every point of the recording is as much too near as the
hand is larger than MediaPipe's size prior: adults' hands spread
:data:`~dexlfd.motion.frame_evidence.HAND_LENGTH_REL_SD`), common to both ends, and each
end's own depth error (the smoother's ``depth_std``), which moves that end along its line
of sight. The depth's one full-size factor (``Capture.depth_scale``) adds its own
relative uncertainty to the scale's. :func:`carry_travel` adds them: the scale's as a
fraction of the distance, the depths' projected on the carry's direction.
"""

from __future__ import annotations

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.motion.frame_evidence import HAND_LENGTH_REL_SD

__all__ = ["carry_travel"]


def carry_travel(
    position: FloatArray,
    grasp: BoolArray,
    valid: BoolArray,
    depth_std: FloatArray | None = None,
    camera_origin: FloatArray | None = None,
    scale_sd: float = 0.0,
) -> tuple[float, float]:
    """``(distance, std)`` [m] from the longest grasp's first to its last seen frame.

    Parameters
    ----------
    position : ndarray, shape (n, 3)
        The wrist [m] (camera or base frame).
    grasp, valid : ndarray of bool, shape (n,)
    depth_std : ndarray, shape (n,), optional
        Each frame's depth standard deviation [m] (NaN: unknown, taken as 0).
    camera_origin : ndarray, shape (3,), optional
        The camera centre in ``position``'s frame (default the origin: camera frame).
    scale_sd : float
        A further relative 1-sigma of the common scale [-] (the depth's full-size
        factor, ``Capture.depth_scale_sd``), added to the hand size's.

    Returns ``(nan, nan)`` without a grasp seen at two frames.
    """
    p = np.asarray(position, dtype=np.float64)
    g = np.asarray(grasp, dtype=bool) & np.asarray(valid, dtype=bool)
    g &= np.isfinite(p).all(axis=1)
    edges = np.flatnonzero(np.diff(np.r_[0, np.asarray(grasp, dtype=np.int8), 0]))
    if edges.size < 2:
        return float("nan"), float("nan")
    starts, stops = edges[::2], edges[1::2]
    k = int(np.argmax(stops - starts))
    seen = np.flatnonzero(g[starts[k] : stops[k]]) + starts[k]
    if seen.size < 2:
        return float("nan"), float("nan")
    a, b = int(seen[0]), int(seen[-1])
    d = p[b] - p[a]
    dist = float(np.linalg.norm(d))
    u = d / dist if dist > 0 else np.zeros(3)
    origin = np.zeros(3) if camera_origin is None else np.asarray(camera_origin, float)
    var = (HAND_LENGTH_REL_SD**2 + float(scale_sd) ** 2) * dist**2
    for i in (a, b):
        s = 0.0 if depth_std is None else float(np.nan_to_num(depth_std[i], nan=0.0))
        sight = p[i] - origin
        n = float(np.linalg.norm(sight))
        if n > 0:
            var += (s * float(np.dot(u, sight / n))) ** 2
    return dist, float(np.sqrt(var))
