"""Camera calibration: the camera -> robot base transform from images of a board.

The board lies at a known pose in the robot base frame (``board2base``); its corners
found in the images (:mod:`dexlfd.capture.board_detection`) give the board -> camera
transform, hence ``camera2base = board2base inv(board2camera)``. The files it reads and
writes are in :mod:`dexlfd.capture.calibration_files`, the boards in
:mod:`dexlfd.capture.board`.
"""

from __future__ import annotations

import logging
import os
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.capture.board import BoardSpec
from dexlfd.capture.board_detection import (
    BoardDetection,
    detect_board,
    fit_board_pose,
    gray_image,
    other_dictionaries,
)
from dexlfd.capture.camera_models import Intrinsics
from dexlfd.capture.transforms import check_rigid_transform
from dexlfd.errors import InvalidInput

__all__ = ["CameraPose", "calibrate_camera", "read_images"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class CameraPose:
    """Result of :func:`calibrate_camera`."""

    camera2base: FloatArray  # (4, 4): p_base = T p_camera
    board2camera: FloatArray  # (4, 4)
    rms_px: float  # RMS reprojection error over the points used [px]
    n_points: int  # board corners used (all frames)
    n_frames: int  # images/frames in which the board was found
    n_images: int  # images/frames examined
    intrinsics: Intrinsics


def calibrate_camera(
    images: Iterable[np.ndarray],
    spec: BoardSpec,
    board2base: FloatArray,
    K: Intrinsics | None = None,
    *,
    fov_deg: float = 60.0,
    min_points: int = 6,
    max_rms_px: float = 3.0,
    source: str = "image",
) -> CameraPose:
    """Camera -> robot base from images of a board whose pose in the base is known.

    The board's points of every image are fitted together (a fixed camera and
    board); an image whose points disagree with the joint pose (RMS > 3x the
    median and > 1 px) is dropped once and the pose refitted.

    Parameters
    ----------
    images : iterable of ndarray
        BGR or grey ``uint8`` images of the same camera.
    spec : BoardSpec
    board2base : ndarray, shape (4, 4)
        The board frame in the robot base frame.
    K : Intrinsics, optional
        Camera intrinsics (rescaled to the images' size); default an ideal camera
        with ``fov_deg`` horizontal field of view (ASSUMED, logged).
    min_points : int
        Fewest board corners accepted (over all images).
    max_rms_px : float
        Largest accepted RMS reprojection error [px]; above it the board spec or
        intrinsics are wrong (or the camera moved).
    source : str
        Name of the input for messages.

    Raises
    ------
    InvalidInput
        No image, no board, too few corners, a poor fit (with a hint at the cause).
    """
    B = check_rigid_transform(board2base, "board2base", atol=1e-4)
    found = _detect_in_images(images, spec, source)
    dets = found.detections
    n_points = sum(len(d.board_m) for d in dets)
    if n_points < min_points:
        raise InvalidInput(
            f"{source}: only {n_points} board corner(s) found (need >= {min_points}): "
            "show more of the board"
        )
    K = _camera_intrinsics(K, found.size, fov_deg)
    dets, T, err = _fit_joint_pose(dets, K)
    rms = float(np.sqrt(np.mean(err**2)))
    n_used = len(err)
    if not rms <= max_rms_px:
        raise InvalidInput(
            f"{source}: the board fits poorly (reprojection RMS {rms:.2f} px > {max_rms_px:g} px "
            f"over {n_used} corners): check the board spec (COLSxROWS, lengths, DICT) and "
            "intrinsics, and that the camera and board did not move"
        )
    if T[2, 3] <= 0:
        raise InvalidInput(f"{source}: the fitted board is behind the camera (wrong board spec?)")
    camera2base = B @ np.linalg.inv(T)
    return CameraPose(camera2base, T, rms, n_used, len(dets), found.n_images, K)


@dataclass(frozen=True, slots=True)
class _Detections:
    """The board in a set of images: where it was found and what was seen."""

    detections: list[BoardDetection]  # images with board points, in order
    n_images: int
    size: tuple[int, int]  # (width, height) of the images [px]


def _detect_in_images(images: Iterable[np.ndarray], spec: BoardSpec, source: str) -> _Detections:
    """The board's points in every image; an error naming the likely cause if in none."""
    dets: list[BoardDetection] = []
    n_images, n_markers, foreign, size = 0, 0, 0, None
    hint_gray = None
    for image in images:
        gray = gray_image(image)
        n_images += 1
        size = (gray.shape[1], gray.shape[0])
        det = detect_board(gray, spec)
        n_markers = max(n_markers, det.n_markers)
        foreign = max(foreign, det.foreign_ids)
        if len(det.board_m):
            dets.append(det)
        elif hint_gray is None:
            hint_gray = gray
    if n_images == 0 or size is None:
        raise InvalidInput(f"{source}: no image to calibrate from")
    if not dets:
        what = f"no {spec.describe()} board found in {source} ({n_images} image(s))"
        if n_markers:
            raise InvalidInput(
                f"{what}: {n_markers} marker(s) of DICT_{spec.dictionary} decoded but no board "
                "corners matched; check COLSxROWS in the board spec"
                + (f" ({foreign} marker id(s) beyond this board's)" if foreign else "")
            )
        others = other_dictionaries(hint_gray, spec) if hint_gray is not None else []
        if others and spec.kind != "checkerboard":
            raise InvalidInput(
                f"{what}, but markers of {', '.join(others)} are: wrong DICT in the board spec?"
            )
        raise InvalidInput(f"{what}: is the whole pattern lit, sharp and in view?")
    return _Detections(dets, n_images, size)


def _camera_intrinsics(K: Intrinsics | None, size: tuple[int, int], fov_deg: float) -> Intrinsics:
    """``K`` at the images' size, or an ideal camera of ``fov_deg`` (ASSUMED, logged)."""
    if K is None:
        logger.warning(
            "calibrate: no intrinsics given, ASSUMING an ideal camera with %.0f deg horizontal "
            "field of view (fov_deg): the camera's distance is only as right as that guess",
            fov_deg,
        )
        return Intrinsics.from_fov(size[0], size[1], fov_deg)
    if (K.width, K.height) != size:
        return K.scaled(*size)
    return K


def _fit_joint_pose(
    dets: list[BoardDetection], K: Intrinsics
) -> tuple[list[BoardDetection], FloatArray, FloatArray]:
    """One board -> camera pose for all images; images disagreeing with it dropped once.

    An image disagrees when its RMS reprojection error exceeds 3x the median over the
    images and 1 px. Returns the images kept, the pose and the per-point errors [px].
    """
    obj = np.concatenate([d.board_m for d in dets])
    img = np.concatenate([d.image_px for d in dets])
    T, err = fit_board_pose(obj, img, K)
    if len(dets) <= 2:
        return dets, T, err
    owner = np.repeat(np.arange(len(dets)), [len(d.board_m) for d in dets])
    per = np.array([np.sqrt(np.mean(err[owner == i] ** 2)) for i in range(len(dets))])
    keep = per <= max(1.0, 3.0 * float(np.median(per)))
    if keep.all():
        return dets, T, err
    logger.warning("calibrate: %d image(s) disagree with the others, dropped", (~keep).sum())
    kept = [d for d, k in zip(dets, keep, strict=True) if k]
    obj = np.concatenate([d.board_m for d in kept])
    img = np.concatenate([d.image_px for d in kept])
    T, err = fit_board_pose(obj, img, K)
    return kept, T, err


# the largest image decoded for a calibration (a 100-megapixel camera's full frame)
MAX_IMAGE_PIXELS = 100_000_000


def _check_image_size(path: Path) -> None:
    """Refuse, from the file's header alone, an image larger than ``MAX_IMAGE_PIXELS``."""
    from PIL import Image

    limit = f"at most {MAX_IMAGE_PIXELS / 1e6:.0f} megapixels are decoded for a calibration"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(path) as im:
                w, h = im.size
    except Image.DecompressionBombError as exc:  # PIL's own bound, above ours
        raise InvalidInput(f"{path}: {exc}; {limit}") from None
    except (OSError, ValueError):
        return  # not an image PIL knows: OpenCV's own reading says what is wrong
    if w * h > MAX_IMAGE_PIXELS:
        raise InvalidInput(f"{path}: a {w}x{h} image ({w * h / 1e6:.0f} megapixels); {limit}")


def read_images(
    path: str | os.PathLike[str], max_frames: int = 30,
    callback: Callable[[int, float], None] | None = None,
) -> list[np.ndarray]:  # fmt: skip
    """An image file, or up to ``max_frames`` frames spread evenly over a video (BGR).

    ``callback(i, n)``: after each frame ``i`` of a video's ``n`` (its header's count;
    0 when unknown) is decoded or skipped, for a progress display.
    """
    import cv2

    p = Path(path)
    if not p.is_file():
        raise InvalidInput(f"{p}: no such file (expected an image or a video of the board)")
    if p.suffix.lower() in (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp", ".ppm"):
        _check_image_size(p)
        img = cv2.imread(str(p), cv2.IMREAD_COLOR)
        if img is None:
            raise InvalidInput(f"{p}: cannot read the image")
        return [img]
    cap = cv2.VideoCapture(str(p))
    try:
        if not cap.isOpened():
            raise InvalidInput(f"{p}: cannot open as an image or a video")
        n = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
        step = max(1, n // max_frames) if n > 0 else 1
        frames: list[np.ndarray] = []
        i = 0
        while len(frames) < max_frames:
            ok = cap.grab()
            if not ok:
                break
            if i % step == 0:
                ok, frame = cap.retrieve()
                if ok:
                    frames.append(frame)
            i += 1
            if callback is not None:
                callback(i, float(n))
    finally:
        cap.release()
    if not frames:
        raise InvalidInput(f"{p}: no frames could be decoded")
    return frames
