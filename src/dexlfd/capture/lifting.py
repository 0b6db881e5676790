"""Pixels (+ depth) -> metres in the robot base frame: the choice of 3-D lifting model.

This module picks a model per :class:`LiftConfig` and maps its points into the
base frame; the models' math lives in :mod:`dexlfd.capture.camera_models` (pinhole,
angle, two webcams) and :mod:`dexlfd.capture.rgb_lifting` (RGB only).

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

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from dexlfd._params import param
from dexlfd._types import FloatArray
from dexlfd._validation import check_positive
from dexlfd.capture.camera_models import (
    AngleModel,
    Intrinsics,
    TwoWebcamModel,
    deproject_angle,
    deproject_pinhole,
    lift_two_webcams,
)
from dexlfd.capture.rgb_lifting import PnPConfig, PnPTracker, lift_assumed_depth, lift_world_fit
from dexlfd.capture.transforms import apply_transform, check_rigid_transform
from dexlfd.errors import InvalidInput

__all__ = [
    "DEPTH_MODELS",
    "LIFT_MODELS",
    "RGB_MODELS",
    "LiftConfig",
    "LiftInput",
    "lift",
    "robust_depth",
]


@dataclass(frozen=True, slots=True)
class LiftInput:
    """What one frame offers the lifting models (any may be ``None``)."""

    uv_px: FloatArray  # (21, 2) landmarks in the (top) image [px]
    depth_m: FloatArray | None = None  # (21,) depth per landmark [m], NaN = hole
    uv2_px: FloatArray | None = None  # (21, 2) landmarks in the side image [px]
    world_m: FloatArray | None = None  # (21, 3) MediaPipe world landmarks [m]
    # (width, height) of the image [px]; the angle and two-webcam models are scaled to
    # it (None: their own width_px x height_px, the thesis's 640x480)
    size_px: tuple[int, int] | None = None


def _identity() -> FloatArray:
    return np.eye(4)


@dataclass(frozen=True, slots=True)
class LiftConfig:
    """Choice and parameters of the lifting model and the camera-to-base transform."""

    model: str = "pinhole"  # key of LIFT_MODELS
    intrinsics: Intrinsics | None = None  # needed by pinhole, assumed_depth, world_fit
    angle: AngleModel = field(default_factory=AngleModel)
    two_webcams: TwoWebcamModel = field(default_factory=TwoWebcamModel)
    assumed_wrist_depth_m: float = param(
        0.5,
        "wrist depth of --lift assumed_depth (RGB only)",
        unit="m",
        lo=0.05,
        hi=10.0,
        flag="--assumed-depth-m",
    )  # RGB-only "assumed_depth" [m]
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


# ---------------------------------------------------------------- registry


def _need_intrinsics(cfg: LiftConfig) -> Intrinsics:
    if cfg.intrinsics is None:
        raise InvalidInput(
            f"lift model {cfg.model!r} needs camera intrinsics (LiftConfig.intrinsics, or an "
            "assumed field of view); none were given"
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
    m = cfg.angle if inp.size_px is None else cfg.angle.at_size(*inp.size_px)
    return deproject_angle(inp.uv_px, _need_depth(inp, cfg), m)


def _two(inp: LiftInput, cfg: LiftConfig) -> FloatArray:
    if inp.uv2_px is None:
        raise InvalidInput("lift model 'two_webcams' needs landmarks from the side camera")
    m = cfg.two_webcams if inp.size_px is None else cfg.two_webcams.at_size(*inp.size_px)
    return lift_two_webcams(inp.uv_px, inp.uv2_px, m)


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
