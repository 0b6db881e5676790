"""4x4 rigid transforms between the camera (or rig) frame and the robot base frame.

:func:`check_rigid_transform` validates one, :func:`apply_transform` maps points,
:func:`top_down_camera2base` is the thesis's camera at height H looking down (Eq. 4.9,
with y flipped to keep the frame right-handed: the printed Eq. (4.9) keeps image-down
as +y while z points up, a mirror image).
"""

from __future__ import annotations

import numpy as np

from dexlfd._types import FloatArray
from dexlfd._validation import check_positive
from dexlfd.errors import InvalidInput

__all__ = ["apply_transform", "check_rigid_transform", "top_down_camera2base"]


def check_rigid_transform(T: object, name: str = "camera2base", atol: float = 1e-6) -> FloatArray:
    """``T`` as a float ``(4, 4)`` rigid transform, or :class:`InvalidInput` saying why not.

    Checks: shape, finiteness, ``R R^T = I`` and ``det R = 1`` (to ``atol``), last
    row ``0 0 0 1``. ``name`` (a flag or file) starts the message.
    """
    try:
        A = np.asarray(T, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name}: expected a 4x4 numeric matrix") from None
    if A.shape != (4, 4):
        raise InvalidInput(f"{name}: expected a 4x4 rigid transform, got shape {A.shape}")
    if not np.isfinite(A).all():
        raise InvalidInput(f"{name}: the 4x4 transform contains NaN or inf")
    if not np.allclose(A[3], [0, 0, 0, 1], atol=atol):
        raise InvalidInput(f"{name}: last row must be 0 0 0 1, got {A[3].tolist()}")
    R = A[:3, :3]
    err = float(np.abs(R @ R.T - np.eye(3)).max())
    if err > atol:
        raise InvalidInput(
            f"{name}: the rotation block is not orthonormal (max |R R^T - I| = {err:.2g})"
        )
    det = float(np.linalg.det(R))
    if abs(det - 1.0) > atol:
        raise InvalidInput(f"{name}: the rotation block has det {det:.3g}, expected +1 (a mirror?)")
    return A


def top_down_camera2base(
    height_m: float = 1.0, xy_m: tuple[float, float] = (0.0, 0.0)
) -> FloatArray:
    """Camera looking straight down from ``height_m`` (thesis Eq. 4.9: ``z = H - d``).

    Camera x -> base x, camera y (image down) -> base -y, camera z (forward) -> base -z.
    """
    check_positive(height_m, "height_m")
    T = np.diag([1.0, -1.0, -1.0, 1.0])
    T[:3, 3] = [xy_m[0], xy_m[1], height_m]
    return T


def apply_transform(T: FloatArray, points: FloatArray) -> FloatArray:
    """Apply a 4x4 rigid transform to points ``(..., 3)``."""
    return points @ T[:3, :3].T + T[:3, 3]
