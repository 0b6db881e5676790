"""Camera models: pixels <-> metres for a pinhole camera, the thesis's angle model and rig.

:class:`Intrinsics` (pinhole, OpenCV/RealSense convention), :class:`AngleModel`
(thesis Eq. 4.9) and :class:`TwoWebcamModel` (thesis Eqs. 4.1-4.8), each with its
deprojection (pixels + depth -> camera-frame points) and its inverse projection.

Pixel coordinates ``uv_px`` are continuous with the image's top-left *corner*
at (0, 0) (``u = x_norm * width`` of MediaPipe's normalised landmarks), so the
thesis's image centre is ``W/2``. :class:`Intrinsics` uses the OpenCV/RealSense
convention (the *centre* of the top-left pixel is (0, 0)); the half-pixel shift
is applied here.

References
----------
.. [1] Thesis, Section 4.1, Eqs. (4.1)-(4.9); Table 4.1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dexlfd._types import FloatArray
from dexlfd._validation import check_positive
from dexlfd.errors import InvalidInput

__all__ = [
    "AngleModel",
    "Intrinsics",
    "TwoWebcamModel",
    "deproject_angle",
    "deproject_pinhole",
    "lift_two_webcams",
    "project_angle",
    "project_pinhole",
    "project_two_webcams",
    "two_webcams_side_depth",
]


@dataclass(frozen=True, slots=True)
class Intrinsics:
    """Pinhole intrinsics (OpenCV/RealSense convention; distortion not modelled).

    ``fx, fy`` focal lengths [px]; ``cx, cy`` principal point [px] where the centre
    of the top-left pixel is (0, 0); ``width, height`` image size [px].
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    approximate: bool = False  # True when assumed (e.g. from a guessed field of view)

    def __post_init__(self) -> None:
        for name in ("width", "height", "fx", "fy"):
            check_positive(getattr(self, name), name)
        for name in ("cx", "cy"):
            if not math.isfinite(getattr(self, name)):
                raise InvalidInput(f"{name} must be finite, got {getattr(self, name)}")

    @classmethod
    def from_fov(
        cls, width: int, height: int, hfov_deg: float, vfov_deg: float | None = None
    ) -> Intrinsics:
        """Ideal camera with the principal point at the centre and the given field of view.

        With ``vfov_deg`` omitted the pixels are square (``fy = fx``). Marked approximate.
        """
        check_positive(hfov_deg, "hfov_deg")
        if not hfov_deg < 180:
            raise InvalidInput(f"hfov_deg must be < 180, got {hfov_deg}")
        fx = (width / 2) / math.tan(math.radians(hfov_deg) / 2)
        fy = fx if vfov_deg is None else (height / 2) / math.tan(math.radians(vfov_deg) / 2)
        return cls(width, height, fx, fy, (width - 1) / 2, (height - 1) / 2, approximate=True)

    def check_centred(self, what: str) -> None:
        """Refuse a principal point far from the image's centre (``what`` names the source).

        A real camera's lies near the centre; one outside the middle half of the frames
        (e.g. a 10x10 px image's K on 1080p frames) belongs to another image size and
        would lift every hand to a wrong place.
        """
        w, h = self.width, self.height
        mid_x, mid_y = (w - 1) / 2, (h - 1) / 2
        if abs(self.cx - mid_x) > w / 4 or abs(self.cy - mid_y) > h / 4:
            raise InvalidInput(
                f"{what}: the principal point ({self.cx:g}, {self.cy:g}) px is far from the "
                f"centre of the {w}x{h} px frames ({mid_x:g}, {mid_y:g}): intrinsics of another "
                "image size? (give fx,fy,cx,cy at the video's size, or a file with its size)"
            )

    def scaled(self, width: int, height: int) -> Intrinsics:
        """The same camera at another resolution (e.g. a downscaled stream)."""
        sx, sy = width / self.width, height / self.height
        return Intrinsics(
            width,
            height,
            self.fx * sx,
            self.fy * sy,
            (self.cx + 0.5) * sx - 0.5,
            (self.cy + 0.5) * sy - 0.5,
            self.approximate,
        )

    def as_dict(self) -> dict[str, float | int | bool]:
        """JSON-able form for file meta."""
        return {
            "width": self.width,
            "height": self.height,
            "fx": self.fx,
            "fy": self.fy,
            "cx": self.cx,
            "cy": self.cy,
            "approximate": self.approximate,
        }

    @property
    def matrix(self) -> FloatArray:
        """The 3x3 camera matrix ``K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]``."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])


@dataclass(frozen=True, slots=True)
class AngleModel:
    """Parameters of the thesis's depth-camera angle model, Eq. (4.9).

    ``width_px``, ``height_px`` are the thesis's 640x480; the fields of view span the
    whole image at any resolution, so frames of another size use :meth:`at_size`
    (the lifting does, from each frame's size).
    """

    width_px: int = 640  # X
    height_px: int = 480  # Y
    fov_x_deg: float = 69.0  # theta_x (RealSense D435i RGB)
    fov_y_deg: float = 42.0  # theta_y

    def __post_init__(self) -> None:
        for name in ("width_px", "height_px", "fov_x_deg", "fov_y_deg"):
            check_positive(getattr(self, name), name)

    def at_size(self, width: int, height: int) -> AngleModel:
        """The same camera for ``width`` x ``height`` [px] frames (same fields of view)."""
        if (width, height) == (self.width_px, self.height_px):
            return self
        return AngleModel(int(width), int(height), self.fov_x_deg, self.fov_y_deg)


@dataclass(frozen=True, slots=True)
class TwoWebcamModel:
    """Parameters of the thesis's two-webcam rig, Eqs. (4.1)-(4.8) (thesis values).

    The pixel parameters (``width_px``, ``height_px``, the origin pixel) are at the
    thesis's 640x480; :meth:`at_size` gives the rig for frames of another size (both
    cameras' images at that size; the lifting scales a side image of another size
    to the top image's).
    """

    H: float = 0.60  # distance between the cameras along z [m]
    D: float = 0.35  # distance between the cameras along x [m]
    width_px: int = 640  # X
    height_px: int = 480  # Y
    fov_x_deg: float = 66.0  # theta_x
    fov_y_deg: float = 57.0  # theta_y
    x_origin_px: float = 520.0  # origin pixel in the top image
    y_origin_px: float = 130.0
    H_top: float = 1.0  # height of the top camera [m]

    def __post_init__(self) -> None:
        for name in ("H", "D", "width_px", "height_px", "fov_x_deg", "fov_y_deg", "H_top"):
            check_positive(getattr(self, name), name)

    def at_size(self, width: int, height: int) -> TwoWebcamModel:
        """The same rig for ``width`` x ``height`` [px] frames: pixel parameters scaled.

        Eqs. (4.4), (4.5) and (4.8) read pixels only as fractions of the image
        (``x / X``), so scaling ``X``, ``Y`` and the origin pixel with the image keeps
        every lifted point.
        """
        if (width, height) == (self.width_px, self.height_px):
            return self
        from dataclasses import replace

        sx, sy = width / self.width_px, height / self.height_px
        return replace(
            self,
            width_px=int(width),
            height_px=int(height),
            x_origin_px=self.x_origin_px * sx,
            y_origin_px=self.y_origin_px * sy,
        )


# ---------------------------------------------------------------- pinhole


def deproject_pinhole(uv_px: FloatArray, z_m: FloatArray, K: Intrinsics) -> FloatArray:
    """Camera-frame points ``(k, 3)`` [m] from pixels (corner convention) and depths [m]."""
    uv = np.asarray(uv_px, dtype=np.float64)
    z = np.asarray(z_m, dtype=np.float64)
    x = (uv[..., 0] - 0.5 - K.cx) / K.fx * z
    y = (uv[..., 1] - 0.5 - K.cy) / K.fy * z
    return np.stack([x, y, z], axis=-1)


def project_pinhole(points_m: FloatArray, K: Intrinsics) -> tuple[FloatArray, FloatArray]:
    """Inverse of :func:`deproject_pinhole`: pixels ``(k, 2)`` and depths ``(k,)``."""
    p = np.asarray(points_m, dtype=np.float64)
    z = p[..., 2]
    u = K.fx * p[..., 0] / z + K.cx + 0.5
    v = K.fy * p[..., 1] / z + K.cy + 0.5
    return np.stack([u, v], axis=-1), z


# ---------------------------------------------------------------- thesis angle model


def deproject_angle(uv_px: FloatArray, d_m: FloatArray, m: AngleModel) -> FloatArray:
    """Eq. (4.9) in the camera frame: ``(d tan(a_x), d tan(a_y), d)`` [m].

    ``a_x = (x_p - X/2) theta_x / X``; with :func:`top_down_camera2base` the
    third coordinate becomes ``H - d`` as printed.
    """
    uv = np.asarray(uv_px, dtype=np.float64)
    d = np.asarray(d_m, dtype=np.float64)
    ax = (uv[..., 0] - m.width_px / 2) / m.width_px * math.radians(m.fov_x_deg)  # (4.9)
    ay = (uv[..., 1] - m.height_px / 2) / m.height_px * math.radians(m.fov_y_deg)  # (4.9)
    return np.stack([d * np.tan(ax), d * np.tan(ay), d], axis=-1)


def project_angle(points_m: FloatArray, m: AngleModel) -> tuple[FloatArray, FloatArray]:
    """Inverse of :func:`deproject_angle`: pixels ``(k, 2)`` and depths ``(k,)``."""
    p = np.asarray(points_m, dtype=np.float64)
    d = p[..., 2]
    u = m.width_px / 2 + np.arctan(p[..., 0] / d) * m.width_px / math.radians(m.fov_x_deg)
    v = m.height_px / 2 + np.arctan(p[..., 1] / d) * m.height_px / math.radians(m.fov_y_deg)
    return np.stack([u, v], axis=-1), d


# ---------------------------------------------------------------- thesis two webcams


def lift_two_webcams(
    uv_top_px: FloatArray, uv_side_px: FloatArray, m: TwoWebcamModel
) -> FloatArray:
    """Eqs. (4.1)-(4.8): 3-D points in the rig frame from the top and side images.

    Parameters
    ----------
    uv_top_px : ndarray, shape (k, 2)
        ``(x_top, y_top)`` in the top camera image [px].
    uv_side_px : ndarray, shape (k, 2)
        ``(x_side, y_side)`` in the side camera image [px]; only ``y_side`` is used.
    m : TwoWebcamModel

    Returns
    -------
    ndarray, shape (k, 3)
        ``(x_h, y_h, z_h)`` [m] of Eq. (4.8); NaN where the rig is degenerate
        (``1 - tan a tan b`` near 0, or a point at or above the top camera).
    """
    top = np.asarray(uv_top_px, dtype=np.float64)
    side = np.asarray(uv_side_px, dtype=np.float64)
    tx, ty = math.radians(m.fov_x_deg), math.radians(m.fov_y_deg)
    X, Y = m.width_px, m.height_px
    a = np.tan((Y / 2 - side[..., 1]) / Y * ty)  # (4.4): d2 = d3 a
    b = np.tan((top[..., 0] - X / 2) / X * tx)  # (4.5): d4 = d1 b
    den = 1.0 - a * b
    with np.errstate(divide="ignore", invalid="ignore"):
        d1 = np.where(np.abs(den) > 1e-9, (m.H - m.D * a) / den, np.nan)  # (4.6)
    d1 = np.where(d1 > 0, d1, np.nan)
    x_h = d1 * np.tan((m.x_origin_px - top[..., 0]) / X * tx)  # (4.8)
    y_h = d1 * np.tan((m.y_origin_px - top[..., 1]) / Y * ty)  # (4.8)
    z_h = m.H_top - d1  # (4.8)
    return np.stack([x_h, y_h, z_h], axis=-1)


def two_webcams_side_depth(
    uv_top_px: FloatArray, uv_side_px: FloatArray, m: TwoWebcamModel
) -> FloatArray:
    """``d3`` of Eq. (4.7): depth of the points seen by the side camera [m]."""
    top = np.asarray(uv_top_px, dtype=np.float64)
    side = np.asarray(uv_side_px, dtype=np.float64)
    tx, ty = math.radians(m.fov_x_deg), math.radians(m.fov_y_deg)
    a = np.tan((m.height_px / 2 - side[..., 1]) / m.height_px * ty)
    b = np.tan((top[..., 0] - m.width_px / 2) / m.width_px * tx)
    return (m.D - m.H * b) / (1.0 - a * b)  # (4.7)


def project_two_webcams(points_m: FloatArray, m: TwoWebcamModel) -> tuple[FloatArray, FloatArray]:
    """Inverse of :func:`lift_two_webcams`: top pixels ``(k, 2)`` and side pixels ``(k, 2)``.

    Follows the same relations backwards: ``d1 = H_top - z_h`` (4.8), ``x_top``
    and ``y_top`` from (4.8), ``d4 = d1 tan(.)`` (4.5), ``d3 = D - d4`` (4.2),
    ``d2 = H - d1`` (4.1) and ``y_side`` from ``d2 = d3 tan(.)`` (4.4). The side
    image's ``x_side`` is not used by the method and is returned as ``X/2``.
    """
    p = np.asarray(points_m, dtype=np.float64)
    tx, ty = math.radians(m.fov_x_deg), math.radians(m.fov_y_deg)
    X, Y = m.width_px, m.height_px
    d1 = m.H_top - p[..., 2]
    x_top = m.x_origin_px - np.arctan(p[..., 0] / d1) * X / tx
    y_top = m.y_origin_px - np.arctan(p[..., 1] / d1) * Y / ty
    d4 = d1 * np.tan((x_top - X / 2) / X * tx)
    d3 = m.D - d4
    d2 = m.H - d1
    y_side = Y / 2 - np.arctan(d2 / d3) * Y / ty
    top = np.stack([x_top, y_top], axis=-1)
    side = np.stack([np.full_like(y_side, X / 2), y_side], axis=-1)
    return top, side
