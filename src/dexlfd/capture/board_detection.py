"""Finding a printed board in an image and the board's pose relative to the camera.

:func:`detect_board` returns the board's corners (board frame [m] and pixels) in one
image; :func:`fit_board_pose` solves the planar PnP for the board -> camera transform.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.capture.board import BoardSpec, dictionary_id, to_board_frame
from dexlfd.capture.camera_models import Intrinsics
from dexlfd.errors import InvalidInput

__all__ = [
    "BoardDetection",
    "detect_board",
    "fit_board_pose",
    "gray_image",
    "other_dictionaries",
]


@dataclass(frozen=True, slots=True)
class BoardDetection:
    """Board points found in one image.

    ``board_m`` in the board frame [m] (:class:`BoardSpec`), ``image_px`` in OpenCV's
    pixel convention (the centre of the top-left pixel is (0, 0), like
    :class:`~dexlfd.capture.Intrinsics`); ``n_markers`` markers were decoded.
    """

    board_m: FloatArray  # (n, 3)
    image_px: FloatArray  # (n, 2)
    n_markers: int
    foreign_ids: int = 0  # decoded marker ids the board does not have (a wrong spec)


def gray_image(image: np.ndarray) -> np.ndarray:
    """A BGR(A) or grey ``uint8`` image as grey ``uint8``."""
    import cv2

    img = np.asarray(image)
    if img.ndim == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY if img.shape[2] == 3 else cv2.COLOR_BGRA2GRAY)
    if img.dtype != np.uint8:
        raise InvalidInput(f"board image must be 8-bit, got {img.dtype}")
    return img


def _marker_params() -> Any:
    import cv2

    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    return params


def detect_board(image: np.ndarray, spec: BoardSpec) -> BoardDetection:
    """The board's corners in one image (BGR or grey ``uint8``); possibly none.

    ChArUco: the chessboard corners between decoded markers (a partial view
    works); aprilgrid: the 4 corners of each decoded marker; checkerboard: all
    inner corners (the whole board must be visible) or none.
    """
    import cv2

    gray = gray_image(image)
    empty = BoardDetection(np.zeros((0, 3)), np.zeros((0, 2)), 0)
    if spec.kind == "checkerboard":
        size = (spec.cols - 1, spec.rows - 1)
        # the classic detector + saddle refinement is fast; the slower SB detector as fallback
        flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
        found, corners = cv2.findChessboardCorners(gray, size, flags=flags)
        if found:
            corners = _refine_corners(gray, np.asarray(corners, dtype=np.float64).reshape(-1, 2))
        else:
            found, corners = cv2.findChessboardCornersSB(gray, size, flags=0)
        if not found:
            return empty
        jj, ii = np.meshgrid(np.arange(size[0]), np.arange(size[1]))
        cv_pts = np.column_stack(
            [(jj.ravel() + 1) * spec.square_m, (ii.ravel() + 1) * spec.square_m, np.zeros(jj.size)]
        )
        img_pts = np.asarray(corners, dtype=np.float64).reshape(-1, 2)
        if not _first_square_is_dark(gray, img_pts, size):
            img_pts = img_pts[::-1].copy()  # OpenCV started at the other end: turn by 180 deg
        return BoardDetection(to_board_frame(cv_pts, spec), img_pts, 0)
    board = spec.opencv_board()
    n_ids = len(board.getIds())
    if spec.kind == "charuco":
        detector = cv2.aruco.CharucoDetector(board, cv2.aruco.CharucoParameters(), _marker_params())
        c_corners, c_ids, _, m_ids = detector.detectBoard(gray)
        n_markers = 0 if m_ids is None else len(m_ids)
        foreign = 0 if m_ids is None else int((np.asarray(m_ids) >= n_ids).sum())
        if c_ids is None or len(c_ids) == 0:
            return BoardDetection(empty.board_m, empty.image_px, n_markers, foreign)
        ids = np.asarray(c_ids).ravel()
        cv_pts = np.asarray(board.getChessboardCorners(), dtype=np.float64)[ids]
        img_pts = _refine_corners(gray, np.asarray(c_corners, dtype=np.float64).reshape(-1, 2))
        return BoardDetection(to_board_frame(cv_pts, spec), img_pts, n_markers, foreign)
    aruco = cv2.aruco.ArucoDetector(board.getDictionary(), _marker_params())
    m_corners, m_ids, _ = aruco.detectMarkers(gray)
    if m_ids is None or len(m_ids) == 0:
        return empty
    foreign = int((np.asarray(m_ids) >= n_ids).sum())
    obj, img = board.matchImagePoints(m_corners, m_ids)
    if obj is None or len(obj) == 0:
        return BoardDetection(empty.board_m, empty.image_px, len(m_ids), foreign)
    return BoardDetection(
        to_board_frame(np.asarray(obj), spec),
        np.asarray(img, dtype=np.float64).reshape(-1, 2),
        len(m_ids),
        foreign,
    )


def _first_square_is_dark(gray: np.ndarray, corners: FloatArray, size: tuple[int, int]) -> bool:
    """Whether the square beyond the first inner corner (the board's top-left one) is dark.

    The printed top-left square is black (:func:`board_image`); OpenCV may list the
    corners from either end. Compares the image at the centres of the squares
    diagonally outside the first and the last corner.
    """
    g = corners.reshape(size[1], size[0], 2)

    def outside(c: FloatArray, along_x: FloatArray, along_y: FloatArray) -> float:
        p = c - 0.5 * along_x - 0.5 * along_y
        r, k = int(round(p[1])), int(round(p[0]))
        if not (0 <= r < gray.shape[0] and 0 <= k < gray.shape[1]):
            return math.nan
        return float(gray[r, k])

    first = outside(g[0, 0], g[0, 1] - g[0, 0], g[1, 0] - g[0, 0])
    last = outside(g[-1, -1], g[-1, -2] - g[-1, -1], g[-2, -1] - g[-1, -1])
    if math.isnan(first) or math.isnan(last):
        return True
    return first <= last


def _refine_corners(gray: np.ndarray, corners: FloatArray) -> FloatArray:
    """Saddle-point refinement of chessboard corners (``cv2.cornerSubPix``).

    OpenCV 4.11's ``CharucoDetector`` returns corners shifted by +0.5 px in x and y
    (measured on a board image drawn with 100 px squares: 149.99 for the corner at
    149.5), i.e. ~0.4 mm at 1 m with a 900 px focal length; refining them again
    removes the shift. The window is a fifth of the smallest corner spacing.
    """
    import cv2

    if len(corners) < 2:
        return corners
    d = np.linalg.norm(corners[:, None] - corners[None], axis=2)
    np.fill_diagonal(d, np.inf)
    half = int(np.clip(0.2 * float(d.min(axis=1).min()), 2, 10))
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-3)
    pts = np.ascontiguousarray(corners, dtype=np.float32).reshape(-1, 1, 2)
    out = cv2.cornerSubPix(gray, pts, (half, half), (-1, -1), crit)
    return np.asarray(out, dtype=np.float64).reshape(-1, 2)


def other_dictionaries(gray: np.ndarray, spec: BoardSpec) -> list[str]:
    """Marker dictionaries (other than the spec's) with markers in the image: a hint."""
    import cv2

    found = []
    for name in ("4X4_50", "5X5_100", "6X6_250", "7X7_250", "ARUCO_ORIGINAL", "APRILTAG_36h11"):
        if name == spec.dictionary:
            continue
        d = cv2.aruco.getPredefinedDictionary(dictionary_id(name))
        _, ids, _ = cv2.aruco.ArucoDetector(d, cv2.aruco.DetectorParameters()).detectMarkers(gray)
        if ids is not None and len(ids) >= 2:
            found.append(name)
    return found


def fit_board_pose(
    board_m: FloatArray, image_px: FloatArray, K: Intrinsics
) -> tuple[FloatArray, FloatArray]:
    """Board -> camera transform ``(4, 4)`` and per-point reprojection errors [px].

    A planar PnP: OpenCV's IPPE gives the (up to two) candidate poses of the
    plane, the one with the smaller reprojection error is refined by
    Levenberg-Marquardt on all points. Distortion is not modelled.
    """
    import cv2

    obj = np.ascontiguousarray(board_m, dtype=np.float64)
    img = np.ascontiguousarray(image_px, dtype=np.float64)
    Km, dist = K.matrix, np.zeros(5)
    try:
        n, rvecs, tvecs, errs = cv2.solvePnPGeneric(obj, img, Km, dist, flags=cv2.SOLVEPNP_IPPE)
    except cv2.error as exc:
        raise InvalidInput(f"board pose: PnP failed ({str(exc).splitlines()[-1]})") from None
    if n == 0:
        raise InvalidInput("board pose: PnP found no solution (degenerate corner layout?)")
    best = int(np.argmin(np.asarray(errs).ravel()))
    r, t = cv2.solvePnPRefineLM(obj, img, Km, dist, rvecs[best], tvecs[best])
    proj, _ = cv2.projectPoints(obj, r, t, Km, dist)
    err = np.linalg.norm(np.asarray(proj).reshape(-1, 2) - img, axis=1)
    T = np.eye(4)
    T[:3, :3] = np.asarray(cv2.Rodrigues(r)[0], dtype=np.float64)
    T[:3, 3] = np.asarray(t, dtype=np.float64).ravel()
    return T, err
