"""Pixels (+ depth) -> metres: the 3-D lifting models of the capture stage.

Models (registry :data:`LIFT_MODELS`, chosen by ``LiftConfig.model``):

``"pinhole"``
    Standard pinhole deprojection with the camera's intrinsics and a depth per
    landmark (RGB-D, e.g. RealSense aligned depth): ``X = (u - c_x) Z / f_x``.
``"angle"``
    The thesis's depth-camera model, Eq. (4.9): ``X = d tan((u - W/2) theta_x / W)``,
    the same with y; ``Z = d``. It treats the pixel offset as proportional to the
    view angle, which differs from the pinhole model away from the centre and the
    edges (centimetres at 0.5 m, cf. Table 4.1).
``"two_webcams"``
    The thesis's two-webcam method, Eqs. (4.1)-(4.8): a top and a side camera,
    no depth sensor.
``"assumed_depth"``
    RGB only: MediaPipe's metric, hand-centred world landmarks placed so that the
    wrist sits at an assumed depth on its pixel's ray. An APPROXIMATION
    (absolute depth unknown); the file's meta says so.
``"world_fit"``
    RGB only: the translation of the world landmarks that best reprojects them
    onto the detected pixels (linear least squares), i.e. depth from apparent hand
    size. Also an APPROXIMATION (depends on the assumed intrinsics and MediaPipe's
    hand-size prior).
``"pnp"``
    RGB only, the default for plain video: the rigid pose (rotation and
    translation) of MediaPipe's metric world landmarks that best reprojects
    them onto their image landmarks (Perspective-n-Point on the 21 pairs,
    OpenCV's SQPnP plus a Levenberg-Marquardt refinement from the previous
    frame's pose), gated in time (:class:`PnPTracker`). The wrist's depth
    follows the hand's apparent size, so a hand moving 20 cm moves ~20 cm at
    any distance. Metric only as far as the intrinsics and MediaPipe's
    hand-size prior are right (an APPROXIMATION; a real hand 10 % larger than
    the prior reads 10 % nearer).

Pixel coordinates ``uv_px`` are continuous with the image's top-left *corner*
at (0, 0) (``u = x_norm * width`` of MediaPipe's normalised landmarks), so the
thesis's image centre is ``W/2``. :class:`Intrinsics` uses the OpenCV/RealSense
convention (the *centre* of the top-left pixel is (0, 0)); the half-pixel shift
is applied here.

Frames: "pinhole", "angle", "assumed_depth" and "world_fit" return camera
optical-frame points (x right, y down, z forward); "two_webcams" returns the
thesis's rig frame of Eq. (4.8). ``LiftConfig.camera2base`` (4x4) then maps
them into the robot base frame; :func:`top_down_camera2base` is the thesis's
camera at height H looking down (Eq. 4.9, with y flipped to keep the frame
right-handed: the printed Eq. (4.9) keeps image-down as +y while z points up,
a mirror image).

References
----------
.. [1] Thesis, Section 4.1, Eqs. (4.1)-(4.9); Table 4.1.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from dexlfd._types import FloatArray
from dexlfd._validation import check_positive
from dexlfd.errors import InvalidInput

__all__ = [
    "AngleModel",
    "Intrinsics",
    "LIFT_MODELS",
    "LiftConfig",
    "LiftInput",
    "PnPConfig",
    "PnPTracker",
    "RGB_MODELS",
    "TwoWebcamModel",
    "apply_transform",
    "check_rigid_transform",
    "deproject_angle",
    "deproject_pinhole",
    "lift",
    "fit_hand_pose",
    "lift_assumed_depth",
    "lift_two_webcams",
    "lift_world_fit",
    "project_angle",
    "project_pinhole",
    "project_two_webcams",
    "robust_depth",
    "top_down_camera2base",
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


@dataclass(frozen=True, slots=True)
class AngleModel:
    """Parameters of the thesis's depth-camera angle model, Eq. (4.9)."""

    width_px: int = 640  # X
    height_px: int = 480  # Y
    fov_x_deg: float = 69.0  # theta_x (RealSense D435i RGB)
    fov_y_deg: float = 42.0  # theta_y

    def __post_init__(self) -> None:
        for name in ("width_px", "height_px", "fov_x_deg", "fov_y_deg"):
            check_positive(getattr(self, name), name)


@dataclass(frozen=True, slots=True)
class TwoWebcamModel:
    """Parameters of the thesis's two-webcam rig, Eqs. (4.1)-(4.8) (thesis values)."""

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


@dataclass(frozen=True, slots=True)
class LiftInput:
    """What one frame offers the lifting models (any may be ``None``)."""

    uv_px: FloatArray  # (21, 2) landmarks in the (top) image [px]
    depth_m: FloatArray | None = None  # (21,) depth per landmark [m], NaN = hole
    uv2_px: FloatArray | None = None  # (21, 2) landmarks in the side image [px]
    world_m: FloatArray | None = None  # (21, 3) MediaPipe world landmarks [m]


def _identity() -> FloatArray:
    return np.eye(4)


@dataclass(frozen=True, slots=True)
class PnPConfig:
    """Plausibility gates of the ``"pnp"`` lift (:class:`PnPTracker`).

    MediaPipe's world landmarks are roughly camera-aligned: on the shared real video
    the fitted rotation is 12 deg (median) from identity, 16 deg at the 95th
    percentile, while the mirror-ambiguous flips of a near-planar hand are > 140 deg.
    """

    max_rotation_deg: float = 75.0  # largest accepted world-landmark -> camera rotation [deg]
    max_depth_step: float = 0.2  # largest relative depth change between accepted frames [-]
    max_rms_rel: float = 0.15  # largest reprojection RMS over the hand's pixel diagonal [-]
    reset_after: int = 5  # consecutive gated frames after which the gate trusts the fit again

    def __post_init__(self) -> None:
        if not 0 < self.max_rotation_deg <= 180:
            raise InvalidInput(f"max_rotation_deg must be in (0, 180], got {self.max_rotation_deg}")
        check_positive(self.max_depth_step, "max_depth_step")
        check_positive(self.max_rms_rel, "max_rms_rel")
        if int(self.reset_after) < 1:
            raise InvalidInput(f"reset_after must be >= 1, got {self.reset_after}")


@dataclass(frozen=True, slots=True)
class LiftConfig:
    """Choice and parameters of the lifting model and the camera-to-base transform."""

    model: str = "pinhole"  # key of LIFT_MODELS
    intrinsics: Intrinsics | None = None  # needed by pinhole, assumed_depth, world_fit
    angle: AngleModel = field(default_factory=AngleModel)
    two_webcams: TwoWebcamModel = field(default_factory=TwoWebcamModel)
    assumed_wrist_depth_m: float = 0.5  # RGB-only "assumed_depth" [m]
    pnp: PnPConfig = field(default_factory=PnPConfig)  # gates of the RGB-only "pnp" model
    depth_patch_px: int = 5  # side of the square patch for the robust depth [px]
    depth_range_m: tuple[float, float] = (0.1, 10.0)  # valid depth readings [m]
    camera2base: FloatArray = field(default_factory=_identity)  # 4x4, model frame -> base

    def __post_init__(self) -> None:
        if self.model not in LIFT_MODELS:
            raise InvalidInput(
                f"lift model must be one of {sorted(LIFT_MODELS)}, got {self.model!r}"
            )
        check_positive(self.assumed_wrist_depth_m, "assumed_wrist_depth_m")
        if int(self.depth_patch_px) < 1 or int(self.depth_patch_px) % 2 == 0:
            raise InvalidInput(f"depth_patch_px must be odd and >= 1, got {self.depth_patch_px}")
        lo, hi = self.depth_range_m
        if not 0 <= lo < hi:
            raise InvalidInput(f"depth_range_m must satisfy 0 <= lo < hi, got {self.depth_range_m}")
        object.__setattr__(self, "camera2base", check_rigid_transform(self.camera2base))

    @property
    def approximate(self) -> bool:
        """True when absolute depth is assumed rather than measured."""
        return self.model in RGB_MODELS


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


# ---------------------------------------------------------------- depth per landmark


def robust_depth(
    depth_m: FloatArray,
    uv_px: FloatArray,
    patch_px: int = 5,
    depth_range_m: tuple[float, float] = (0.1, 10.0),
) -> FloatArray:
    """Median of the valid depths in a square patch around each landmark.

    Depth sensors leave holes (0) and NaN; readings outside ``depth_range_m``
    are ignored as well. A landmark outside the image or with no valid reading
    in its patch gets NaN.

    Parameters
    ----------
    depth_m : ndarray, shape (H, W)
        Depth image aligned to the colour image [m].
    uv_px : ndarray, shape (k, 2)
        Landmark pixels, corner convention (module docstring).
    patch_px : int
        Odd side length of the patch [px].
    depth_range_m : (float, float)
        Accepted depth readings [m].

    Returns
    -------
    ndarray, shape (k,)
        Depth [m] or NaN.
    """
    D = np.asarray(depth_m)
    h, w = D.shape
    uv = np.asarray(uv_px, dtype=np.float64)
    r = int(patch_px) // 2
    out = np.full(uv.shape[0], np.nan)
    finite = np.isfinite(uv).all(axis=1)
    cols = np.floor(np.where(finite, uv[:, 0], -1)).astype(int)
    rows = np.floor(np.where(finite, uv[:, 1], -1)).astype(int)
    inside = finite & (cols >= 0) & (cols < w) & (rows >= 0) & (rows < h)
    if not inside.any():
        return out
    dy, dx = np.mgrid[-r : r + 1, -r : r + 1]
    rr = np.clip(rows[inside, None, None] + dy, 0, h - 1)
    cc = np.clip(cols[inside, None, None] + dx, 0, w - 1)
    # clipped indices repeat border pixels; mask them out so no reading counts twice
    in_img = (
        (rows[inside, None, None] + dy >= 0)
        & (rows[inside, None, None] + dy < h)
        & (cols[inside, None, None] + dx >= 0)
        & (cols[inside, None, None] + dx < w)
    )
    vals = D[rr, cc].astype(np.float64)
    lo, hi = depth_range_m
    ok = in_img & np.isfinite(vals) & (vals >= lo) & (vals <= hi)
    vals = np.where(ok, vals, np.nan).reshape(vals.shape[0], -1)
    has = ok.reshape(ok.shape[0], -1).any(axis=1)
    med = np.full(vals.shape[0], np.nan)
    if has.any():
        med[has] = np.nanmedian(vals[has], axis=1)
    out[inside] = med
    return out


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


# ---------------------------------------------------------------- RGB only


def lift_assumed_depth(
    uv_px: FloatArray, world_m: FloatArray, K: Intrinsics, wrist_depth_m: float
) -> FloatArray:
    """World landmarks placed with the wrist at ``wrist_depth_m`` on its pixel's ray.

    MediaPipe's world landmarks are metric and camera-aligned but centred on the
    hand; the wrist's pixel and an assumed depth fix the translation. APPROXIMATE.
    """
    uv = np.asarray(uv_px, dtype=np.float64)
    W = np.asarray(world_m, dtype=np.float64)
    wrist = deproject_pinhole(uv[0], np.asarray(wrist_depth_m, dtype=np.float64), K)
    return wrist + (W - W[0])


def lift_world_fit(uv_px: FloatArray, world_m: FloatArray, K: Intrinsics) -> FloatArray:
    """Translate the world landmarks so they reproject onto the detected pixels.

    Solves ``f_x (X_k + T_x) = (u_k - c_x)(Z_k + T_z)`` and the same in y for
    ``T`` by linear least squares (algebraic error), i.e. depth from the hand's
    apparent size. APPROXIMATE (intrinsics and MediaPipe's hand-size prior).
    """
    uv = np.asarray(uv_px, dtype=np.float64)
    W = np.asarray(world_m, dtype=np.float64)
    du = uv[:, 0] - 0.5 - K.cx
    dv = uv[:, 1] - 0.5 - K.cy
    n = uv.shape[0]
    A = np.zeros((2 * n, 3))
    A[:n, 0] = K.fx
    A[:n, 2] = -du
    A[n:, 1] = K.fy
    A[n:, 2] = -dv
    b = np.concatenate([du * W[:, 2] - K.fx * W[:, 0], dv * W[:, 2] - K.fy * W[:, 1]])
    T, *_ = np.linalg.lstsq(A, b, rcond=None)
    return W + T


def _rotation_angle_deg(R: FloatArray) -> float:
    return math.degrees(math.acos(max(-1.0, min(1.0, (float(np.trace(R)) - 1.0) / 2.0))))


def fit_hand_pose(
    uv_px: FloatArray,
    world_m: FloatArray,
    K: Intrinsics,
    guess: tuple[FloatArray, FloatArray] | None = None,
    max_rotation_deg: float = 75.0,
) -> tuple[FloatArray, FloatArray, float] | None:
    """Rigid pose ``(R, t)`` of the world landmarks that best reprojects them (PnP).

    Minimises the reprojection error of ``x_cam = R X_world + t`` over the
    landmark pairs. Candidates: OpenCV's SQPnP (global), a Levenberg-Marquardt
    refinement of ``guess`` (the previous frame's pose: keeps the same branch
    of the near-planar hand's two-fold ambiguity), or without a guess one of
    ``(I, t_lin)`` (:func:`lift_world_fit`'s translation). Those with the hand in front of the
    camera and ``R`` within ``max_rotation_deg`` of identity (world landmarks are
    roughly camera-aligned) compete on RMS reprojection error.

    Parameters
    ----------
    uv_px : ndarray, shape (k, 2)
        Image landmarks [px], corner convention; ``k >= 4``.
    world_m : ndarray, shape (k, 3)
        MediaPipe world landmarks [m] (hand-centred, metric).
    K : Intrinsics
    guess : (R, t), optional
        Initial pose (rotation matrix, translation [m]), e.g. the previous frame's.
    max_rotation_deg : float
        Plausibility bound on the rotation [deg].

    Returns
    -------
    (R, t, rms_px) or None
        Rotation ``(3, 3)``, translation ``(3,)`` [m], RMS reprojection error [px];
        None when no finite plausible pose exists.
    """
    import cv2

    uv = np.asarray(uv_px, dtype=np.float64)
    W = np.asarray(world_m, dtype=np.float64)
    ok = np.isfinite(uv).all(axis=1) & np.isfinite(W).all(axis=1)
    if ok.sum() < 4:
        return None
    obj = np.ascontiguousarray(W[ok])
    img = np.ascontiguousarray(uv[ok] - 0.5)  # OpenCV: pixel centres at integers
    Km = np.array([[K.fx, 0.0, K.cx], [0.0, K.fy, K.cy], [0.0, 0.0, 1.0]])
    seeds: list[tuple[FloatArray, FloatArray]] = []
    try:
        found, r, t = cv2.solvePnP(obj, img, Km, np.zeros(5), flags=cv2.SOLVEPNP_SQPNP)
        if found:
            seeds.append((_vec(r), _vec(t)))
    except cv2.error:
        pass
    if guess is not None:
        rg = _vec(cv2.Rodrigues(np.asarray(guess[0], dtype=np.float64))[0])
        seeds.append(_refine(obj, img, Km, rg, _vec(guess[1])))
    else:
        t_lin = lift_world_fit(uv[ok], W[ok], K)[0] - W[ok][0]
        if np.isfinite(t_lin).all() and t_lin[2] > 0:
            seeds.append(_refine(obj, img, Km, np.zeros(3), t_lin))
    best: tuple[FloatArray, FloatArray, float] | None = None
    for r, t in seeds:
        if not (np.isfinite(r).all() and np.isfinite(t).all()):
            continue
        R = np.asarray(cv2.Rodrigues(r)[0], dtype=np.float64)
        P = obj @ R.T + t
        if (P[:, 2] <= 0).any() or _rotation_angle_deg(R) > max_rotation_deg:
            continue
        proj = np.column_stack([K.fx * P[:, 0] / P[:, 2] + K.cx, K.fy * P[:, 1] / P[:, 2] + K.cy])
        rms = float(np.sqrt(np.mean(np.sum((proj - img) ** 2, axis=1))))
        if best is None or rms < best[2]:
            best = (R, t.copy(), rms)
    return best


def _refine(
    obj: FloatArray, img: FloatArray, Km: FloatArray, r: FloatArray, t: FloatArray
) -> tuple[FloatArray, FloatArray]:
    import cv2

    r1, t1 = r.reshape(3, 1).copy(), t.reshape(3, 1).copy()
    try:
        r2, t2 = cv2.solvePnPRefineLM(obj, img, Km, np.zeros(5), r1, t1)
    except cv2.error:
        return np.full(3, np.nan), np.full(3, np.nan)
    return _vec(r2), _vec(t2)


def _vec(a: object) -> FloatArray:
    return np.asarray(a, dtype=np.float64).ravel()


class PnPTracker:
    """The ``"pnp"`` lift over a stream: per-frame PnP, seeded and gated by the past.

    Each frame's pose comes from :func:`fit_hand_pose` with the last accepted pose
    as a seed. A fit is *gated* when its reprojection RMS exceeds
    ``max_rms_rel`` of the hand's pixel diagonal, or its depth differs from the
    last accepted one by more than ``max_depth_step`` (relative): the hand then
    keeps its fitted rotation and its ray but the last accepted depth. After
    ``reset_after`` consecutive gated frames the fit is trusted again (the hand
    really moved). Without any plausible fit the frame is NaN (the motion stage
    treats it as a gap). ``counts`` tallies ``fitted``, ``gated`` and ``failed``.
    """

    def __init__(self, cfg: PnPConfig | None = None) -> None:
        self.cfg = cfg or PnPConfig()
        self._pose: tuple[FloatArray, FloatArray] | None = None
        self._gated_run = 0
        self.counts = {"fitted": 0, "gated": 0, "failed": 0}
        self.last_rms_px = math.nan

    def reset(self) -> None:
        """Forget the past (e.g. after the hand was lost)."""
        self._pose = None
        self._gated_run = 0

    def lift(self, uv_px: FloatArray, world_m: FloatArray, K: Intrinsics) -> FloatArray:
        """Camera-frame landmarks ``(21, 3)`` [m] of one frame (NaN when no fit)."""
        W = np.asarray(world_m, dtype=np.float64)
        uv = np.asarray(uv_px, dtype=np.float64)
        fit = fit_hand_pose(uv, W, K, self._pose, self.cfg.max_rotation_deg)
        if fit is None:
            self.counts["failed"] += 1
            self.last_rms_px = math.nan
            return np.full(W.shape, np.nan)
        R, t, rms = fit
        self.last_rms_px = rms
        finite = np.isfinite(uv).all(axis=1)
        span = uv[finite].max(axis=0) - uv[finite].min(axis=0)
        diag = float(np.hypot(*span))
        gated = False
        if self._pose is not None and self._gated_run < self.cfg.reset_after:
            z_prev = float(self._pose[1][2])
            if (
                abs(t[2] - z_prev) > self.cfg.max_depth_step * z_prev
                or rms > self.cfg.max_rms_rel * diag
            ):
                t = t * (z_prev / t[2])  # same ray, the last accepted depth
                gated = True
        if gated:
            self._gated_run += 1
            self.counts["gated"] += 1
        else:
            self._gated_run = 0
            self.counts["fitted"] += 1
        self._pose = (R, t)
        return W @ R.T + t


# ---------------------------------------------------------------- registry


def _need_intrinsics(cfg: LiftConfig) -> Intrinsics:
    if cfg.intrinsics is None:
        raise InvalidInput(
            f"lift model {cfg.model!r} needs camera intrinsics (LiftConfig.intrinsics, "
            "CLI --intrinsics or --fov-deg); none were given"
        )
    return cfg.intrinsics


def _need_depth(inp: LiftInput, cfg: LiftConfig) -> FloatArray:
    if inp.depth_m is None:
        raise InvalidInput(f"lift model {cfg.model!r} needs a depth image (an RGB-D source)")
    return inp.depth_m


def _need_world(inp: LiftInput, cfg: LiftConfig) -> FloatArray:
    if inp.world_m is None:
        raise InvalidInput(f"lift model {cfg.model!r} needs MediaPipe world landmarks")
    return inp.world_m


def _pinhole(inp: LiftInput, cfg: LiftConfig) -> FloatArray:
    return deproject_pinhole(inp.uv_px, _need_depth(inp, cfg), _need_intrinsics(cfg))


def _angle(inp: LiftInput, cfg: LiftConfig) -> FloatArray:
    return deproject_angle(inp.uv_px, _need_depth(inp, cfg), cfg.angle)


def _two(inp: LiftInput, cfg: LiftConfig) -> FloatArray:
    if inp.uv2_px is None:
        raise InvalidInput("lift model 'two_webcams' needs landmarks from the side camera")
    return lift_two_webcams(inp.uv_px, inp.uv2_px, cfg.two_webcams)


def _assumed(inp: LiftInput, cfg: LiftConfig) -> FloatArray:
    return lift_assumed_depth(
        inp.uv_px, _need_world(inp, cfg), _need_intrinsics(cfg), cfg.assumed_wrist_depth_m
    )


def _fit(inp: LiftInput, cfg: LiftConfig) -> FloatArray:
    return lift_world_fit(inp.uv_px, _need_world(inp, cfg), _need_intrinsics(cfg))


def _pnp(inp: LiftInput, cfg: LiftConfig) -> FloatArray:
    # a single frame: no past to seed or gate with (see PnPTracker for streams)
    return PnPTracker(cfg.pnp).lift(inp.uv_px, _need_world(inp, cfg), _need_intrinsics(cfg))


LIFT_MODELS: dict[str, Callable[[LiftInput, LiftConfig], FloatArray]] = {
    "pinhole": _pinhole,
    "angle": _angle,
    "two_webcams": _two,
    "assumed_depth": _assumed,
    "world_fit": _fit,
    "pnp": _pnp,
}

# models whose input includes a depth image
DEPTH_MODELS = ("pinhole", "angle")
# RGB-only models placing MediaPipe's world landmarks (need intrinsics, may assume them)
RGB_MODELS = ("assumed_depth", "world_fit", "pnp")


def lift(inp: LiftInput, cfg: LiftConfig, tracker: PnPTracker | None = None) -> FloatArray:
    """Landmarks of one frame in the robot base frame ``(21, 3)`` [m] (NaN where unknown).

    ``tracker`` carries the ``"pnp"`` model's state from frame to frame (one per
    stream); without it each frame is fitted on its own.
    """
    if cfg.model == "pnp" and tracker is not None:
        points = tracker.lift(inp.uv_px, _need_world(inp, cfg), _need_intrinsics(cfg))
    else:
        points = LIFT_MODELS[cfg.model](inp, cfg)
    return apply_transform(cfg.camera2base, points)
