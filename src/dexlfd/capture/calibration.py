"""Camera calibration: intrinsics and extrinsics files, and the camera pose from a board.

Files (the contract of ``record``/``teleop`` ``--intrinsics`` and ``--extrinsics``):

Intrinsics, :func:`load_intrinsics`
    ``fx,fy,cx,cy`` inline [px], or a file holding the 3x3 camera matrix ``K``
    (OpenCV convention: the centre of the top-left pixel is (0, 0)):

    - ``.npy``: the 3x3 ``K`` itself;
    - ``.json``: ``{"K": [[...], [...], [...]]}`` (also ``"camera_matrix"``) or
      ``{"fx": .., "fy": .., "cx": .., "cy": ..}``, optionally ``"width"`` and
      ``"height"`` (or ``"image_size": [w, h]``) of the image it belongs to;
    - ``.yaml``/``.yml``/``.xml``: an OpenCV ``FileStorage`` file (as written by
      OpenCV's calibration tools) or a ROS ``camera_info`` YAML, with a
      ``camera_matrix`` (or ``K``) node and optional ``image_width``/``image_height``.

    With an image size the intrinsics are rescaled to the frames actually
    processed (``--resize-width``); without one they must be for the full-size video.
Extrinsics, :func:`load_extrinsics` / :func:`save_extrinsics`
    A 4x4 rigid transform ``camera -> robot base`` (``p_base = T p_cam``, metres):
    a ``.npy`` file (what ``dexlfd calibrate`` writes) or a text file of 4 rows
    of 4 numbers. Shape, finiteness, orthonormality, ``det R = +1`` and the
    last row are checked.
"""

from __future__ import annotations

import json
import logging
import math
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd._validation import check_positive
from dexlfd.capture.lifting import Intrinsics, check_rigid_transform
from dexlfd.errors import InvalidInput

__all__ = [
    "BOARD_HELP",
    "BoardDetection",
    "BoardSpec",
    "CameraIntrinsics",
    "CameraPose",
    "board_image",
    "calibrate_camera",
    "detect_board",
    "fit_board_pose",
    "load_board_pose",
    "load_extrinsics",
    "load_intrinsics",
    "pose_from_xyz_rpy",
    "print_board",
    "read_images",
    "render_board_view",
    "save_extrinsics",
]

logger = logging.getLogger(__name__)

# (fx, fy, cx, cy) [px] and the (width, height) [px] they belong to, if known
CameraIntrinsics = tuple[tuple[float, float, float, float], tuple[int, int] | None]


def _from_matrix(K: object, where: str) -> tuple[float, float, float, float]:
    try:
        M = np.asarray(K, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidInput(f"{where}: the camera matrix is not numeric") from None
    if M.size == 9:
        M = M.reshape(3, 3)
    if M.shape != (3, 3):
        raise InvalidInput(f"{where}: expected a 3x3 camera matrix K, got shape {M.shape}")
    if not np.isfinite(M).all():
        raise InvalidInput(f"{where}: the camera matrix contains NaN or inf")
    if not (M[0, 0] > 0 and M[1, 1] > 0 and np.allclose(M[2], [0, 0, 1])):
        raise InvalidInput(
            f"{where}: not a camera matrix (need fx > 0, fy > 0 and a last row 0 0 1), "
            f"got {M.tolist()}"
        )
    return float(M[0, 0]), float(M[1, 1]), float(M[0, 2]), float(M[1, 2])


def _size(w: object, h: object, where: str) -> tuple[int, int] | None:
    if w is None and h is None:
        return None
    try:
        size = int(w), int(h)  # type: ignore[call-overload]
    except (TypeError, ValueError):
        raise InvalidInput(f"{where}: image width/height must be integers") from None
    if min(size) <= 0:
        raise InvalidInput(f"{where}: image size must be positive, got {size}")
    return size


def _json(path: Path, where: str) -> CameraIntrinsics:
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InvalidInput(f"{where}: cannot read JSON: {exc}") from None
    if not isinstance(data, dict):
        raise InvalidInput(f"{where}: expected a JSON object with K or fx, fy, cx, cy")
    size = _size(data.get("width"), data.get("height"), where)
    if size is None and "image_size" in data:
        pair = data["image_size"]
        if not isinstance(pair, list | tuple) or len(pair) != 2:
            raise InvalidInput(f"{where}: image_size must be [width, height]")
        size = _size(pair[0], pair[1], where)
    for key in ("K", "camera_matrix"):
        if key in data:
            return _from_matrix(data[key], where), size
    if all(k in data for k in ("fx", "fy", "cx", "cy")):
        K = [[data["fx"], 0, data["cx"]], [0, data["fy"], data["cy"]], [0, 0, 1]]
        return _from_matrix(K, where), size
    raise InvalidInput(f"{where}: no camera matrix (keys K, camera_matrix or fx, fy, cx, cy)")


def _filestorage(path: Path, where: str) -> CameraIntrinsics:
    import cv2

    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise InvalidInput(f"{where}: cannot read: {exc}") from None
    if path.suffix.lower() != ".xml" and not text.startswith("%YAML"):
        text = "%YAML:1.0\n" + text  # ROS camera_info files have no directive
    try:
        fs = cv2.FileStorage(text, cv2.FILE_STORAGE_READ | cv2.FILE_STORAGE_MEMORY)
    except (cv2.error, SystemError):
        raise InvalidInput(f"{where}: not an OpenCV/ROS calibration file") from None
    try:
        node = next(
            (fs.getNode(k) for k in ("camera_matrix", "K") if not fs.getNode(k).empty()), None
        )
        if node is None:
            raise InvalidInput(f"{where}: no camera_matrix (or K) entry")
        opencv_matrix = node.isMap() and not node.getNode("dt").empty()
        M: object = node.mat() if opencv_matrix else None
        if M is None:
            seq = node.getNode("data") if node.isMap() else node
            if not seq.isSeq():
                raise InvalidInput(f"{where}: camera_matrix is neither a matrix nor a list")
            M = [seq.at(i).real() for i in range(seq.size())]
        w, h = fs.getNode("image_width"), fs.getNode("image_height")
        size = None if w.empty() or h.empty() else _size(w.real(), h.real(), where)
        return _from_matrix(M, where), size
    finally:
        fs.release()


def load_intrinsics(spec: str, flag: str = "--intrinsics") -> CameraIntrinsics:
    """``(fx, fy, cx, cy)`` [px] and the image size they belong to (or None).

    ``spec`` is ``fx,fy,cx,cy`` or a file (module docstring). Errors name ``flag``.
    """
    path = Path(spec)
    if "," in spec and not path.exists():
        try:
            fx, fy, cx, cy = (float(v) for v in spec.split(","))
        except ValueError:
            raise InvalidInput(
                f"{flag}: expected fx,fy,cx,cy [px] or a file, got {spec!r}"
            ) from None
        return _from_matrix([[fx, 0, cx], [0, fy, cy], [0, 0, 1]], f"{flag} {spec}"), None
    where = f"{flag} {path}"
    if not path.is_file():
        raise InvalidInput(f"{where}: no such file (expected fx,fy,cx,cy or a .npy/.json/.yaml)")
    suffix = path.suffix.lower()
    if suffix == ".npy":
        try:
            M = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as exc:
            raise InvalidInput(f"{where}: cannot read a .npy array: {exc}") from None
        return _from_matrix(M, where), None
    if suffix == ".json":
        return _json(path, where)
    if suffix in (".yaml", ".yml", ".xml"):
        return _filestorage(path, where)
    raise InvalidInput(
        f"{where}: unknown format {suffix!r} (expected .npy, .json, .yaml/.yml/.xml)"
    )


def load_extrinsics(path: str | os.PathLike[str], flag: str = "--extrinsics") -> FloatArray:
    """The 4x4 ``camera -> base`` transform of a ``.npy`` or text file, checked rigid."""
    p = Path(path)
    where = f"{flag} {p}"
    if not p.is_file():
        raise InvalidInput(f"{where}: no such file (expected a 4x4 camera->base .npy or text)")
    suffix = p.suffix.lower()
    if suffix == ".npz":
        raise InvalidInput(
            f"{where}: a .npz archive, expected a single 4x4 array in a .npy file "
            "(as written by dexlfd calibrate) or a text file of 4 rows"
        )
    try:
        if suffix == ".npy":
            T = np.load(p, allow_pickle=False)
        else:
            T = np.loadtxt(p, ndmin=2)
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        kind = ".npy array" if suffix == ".npy" else "4x4 text matrix"
        raise InvalidInput(f"{where}: cannot read a {kind}: {str(exc).splitlines()[0]}") from None
    A = check_rigid_transform(T, where, atol=1e-4)  # rounding in a text file is fine
    U, _, Vt = np.linalg.svd(A[:3, :3])  # nearest rotation, so downstream checks hold
    A[:3, :3] = U @ Vt
    return A


def save_extrinsics(path: str | os.PathLike[str], T: FloatArray) -> Path:
    """Write a checked 4x4 transform as ``.npy`` atomically (temp file + rename)."""
    p = Path(path)
    if p.suffix.lower() != ".npy":
        raise InvalidInput(f"{p}: the extrinsics file must end in .npy")
    A = check_rigid_transform(T, str(p), atol=1e-6)
    tmp = p.with_name(f".{p.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as f:
            np.save(f, A)
        os.replace(tmp, p)
    finally:
        if tmp.exists():
            tmp.unlink()
    return p


# ---------------------------------------------------------------- boards

# dictionary names accepted in a board spec -> OpenCV constants (resolved lazily)
_DICTS = (
    "4X4_50", "4X4_100", "4X4_250", "4X4_1000", "5X5_50", "5X5_100", "5X5_250", "5X5_1000",
    "6X6_50", "6X6_100", "6X6_250", "6X6_1000", "7X7_50", "7X7_100", "7X7_250", "7X7_1000",
    "ARUCO_ORIGINAL", "APRILTAG_16h5", "APRILTAG_25h9", "APRILTAG_36h10", "APRILTAG_36h11",
)  # fmt: skip
_DEFAULT_DICT = {"charuco": "4X4_50", "aprilgrid": "APRILTAG_36h11"}
BOARD_HELP = (
    "charuco:COLSxROWS,SQUARE_M,MARKER_M[,DICT] (squares; default DICT 4X4_50), "
    "aprilgrid:COLSxROWS,MARKER_M,GAP_M[,DICT] (markers; default APRILTAG_36h11) or "
    "checkerboard:COLSxROWS,SQUARE_M (squares, one count even; whole board in view)"
)


def _dict_id(name: str) -> int:
    import cv2

    return int(getattr(cv2.aruco, f"DICT_{name}"))


@dataclass(frozen=True, slots=True)
class BoardSpec:
    """A printed calibration board (sizes in metres).

    ``cols x rows`` are squares (``charuco``, ``checkerboard``) or markers
    (``aprilgrid``); ``square_m`` is the square side (the marker side for
    ``aprilgrid``); ``marker_m`` the ChArUco marker side (the gap between markers
    for ``aprilgrid``; unused for ``checkerboard``).

    Board frame (what ``--board-pose`` gives in the robot base frame): origin at
    the pattern's bottom-left corner as printed (the page upright, the legend
    below the pattern), x along the bottom edge to the right, y up the left edge,
    z out of the printed side. A board lying face-up on the table has z up.
    """

    kind: str
    cols: int
    rows: int
    square_m: float
    marker_m: float = 0.0
    dictionary: str = ""

    def __post_init__(self) -> None:
        if self.kind not in ("charuco", "aprilgrid", "checkerboard"):
            raise InvalidInput(
                f"board kind must be charuco, aprilgrid or checkerboard, got {self.kind!r}"
            )
        least = 1 if self.kind == "aprilgrid" else 2
        if min(self.cols, self.rows) < least or self.cols * self.rows < 3:
            raise InvalidInput(f"board size {self.cols}x{self.rows} is too small")
        if not (self.square_m > 0 and math.isfinite(self.square_m)):
            raise InvalidInput(f"board square/marker length must be > 0 m, got {self.square_m}")
        if self.kind == "checkerboard" and (self.cols + self.rows) % 2 == 0:
            raise InvalidInput(
                f"checkerboard {self.cols}x{self.rows}: one of COLS, ROWS must be even and the "
                "other odd, else the board looks the same turned by 180 deg (pose ambiguous)"
            )
        if self.kind == "charuco" and not 0 < self.marker_m < self.square_m:
            raise InvalidInput(
                f"charuco marker length must be in (0, square length = {self.square_m}) m, "
                f"got {self.marker_m}"
            )
        if self.kind == "aprilgrid" and not self.marker_m > 0:
            raise InvalidInput(f"aprilgrid gap between markers must be > 0 m, got {self.marker_m}")
        if self.kind != "checkerboard":
            name = self.dictionary or _DEFAULT_DICT[self.kind]
            if name not in _DICTS:
                raise InvalidInput(
                    f"unknown marker dictionary {name!r}; one of {', '.join(_DICTS)}"
                )
            object.__setattr__(self, "dictionary", name)
            n_markers = (
                self.cols * self.rows // 2 if self.kind == "charuco" else self.cols * self.rows
            )
            capacity = int(name.rsplit("_", 1)[1]) if name[0].isdigit() else 0
            if capacity and n_markers > capacity:
                raise InvalidInput(
                    f"a {self.cols}x{self.rows} {self.kind} needs {n_markers} markers, "
                    f"more than DICT_{name} has ({capacity})"
                )

    @classmethod
    def parse(cls, text: str, flag: str = "--board") -> BoardSpec:
        """``kind:COLSxROWS,LEN[,LEN][,DICT]`` (see :data:`BOARD_HELP`)."""
        kind, _, rest = text.partition(":")
        kind = kind.strip().lower()
        parts = [p.strip() for p in rest.split(",")] if rest else []
        n_len = 1 if kind == "checkerboard" else 2
        if kind not in ("charuco", "aprilgrid", "checkerboard") or not (
            n_len + 1 <= len(parts) <= n_len + (kind != "checkerboard") + 1
        ):
            raise InvalidInput(f"{flag}: expected {BOARD_HELP}; got {text!r}")
        try:
            cols, rows = (int(v) for v in parts[0].lower().split("x"))
            lengths = [float(v) for v in parts[1 : 1 + n_len]]
        except ValueError:
            raise InvalidInput(f"{flag}: expected {BOARD_HELP}; got {text!r}") from None
        dictionary = (
            parts[1 + n_len].upper().removeprefix("DICT_") if len(parts) > 1 + n_len else ""
        )
        if dictionary.startswith("APRILTAG_"):
            dictionary = "APRILTAG_" + dictionary.removeprefix("APRILTAG_").lower()
        try:
            return cls(kind, cols, rows, lengths[0], lengths[1] if n_len == 2 else 0.0, dictionary)
        except InvalidInput as exc:
            raise InvalidInput(f"{flag} {text}: {exc}") from None

    @property
    def size_m(self) -> tuple[float, float]:
        """Width and height of the pattern [m]."""
        if self.kind == "aprilgrid":
            step = self.square_m + self.marker_m
            return self.cols * step - self.marker_m, self.rows * step - self.marker_m
        return self.cols * self.square_m, self.rows * self.square_m

    def describe(self) -> str:
        """The spec in the ``--board`` syntax."""
        if self.kind == "checkerboard":
            return f"checkerboard:{self.cols}x{self.rows},{self.square_m:g}"
        size = f"{self.cols}x{self.rows}"
        return f"{self.kind}:{size},{self.square_m:g},{self.marker_m:g},{self.dictionary}"

    def opencv_board(self) -> Any:
        """The ``cv2.aruco`` board (None for a checkerboard)."""
        import cv2

        if self.kind == "checkerboard":
            return None
        d = cv2.aruco.getPredefinedDictionary(_dict_id(self.dictionary))
        if self.kind == "charuco":
            return cv2.aruco.CharucoBoard((self.cols, self.rows), self.square_m, self.marker_m, d)
        return cv2.aruco.GridBoard((self.cols, self.rows), self.square_m, self.marker_m, d)


def _to_board_frame(points_cv: FloatArray, spec: BoardSpec) -> FloatArray:
    """OpenCV's board points (origin top-left, y down, z into the board) -> the board frame."""
    P = np.asarray(points_cv, dtype=np.float64).reshape(-1, 3)
    return np.column_stack([P[:, 0], spec.size_m[1] - P[:, 1], -P[:, 2]])


def board_image(spec: BoardSpec, px_per_m: float, margin_px: int = 0) -> np.ndarray:
    """The pattern as a grey ``uint8`` image, ``px_per_m`` pixels per metre, white margin.

    The pattern's top-left corner is at ``(margin_px, margin_px)`` (pixel corners).
    """
    import cv2

    w_m, h_m = spec.size_m
    w, h = round(w_m * px_per_m), round(h_m * px_per_m)
    if spec.kind == "checkerboard":
        sq = spec.square_m * px_per_m
        yy, xx = np.mgrid[0:h, 0:w]
        img = np.where(((xx // sq).astype(int) + (yy // sq).astype(int)) % 2 == 0, 0, 255)
        img = img.astype(np.uint8)
    else:
        img = spec.opencv_board().generateImage((w, h), marginSize=0, borderBits=1)
    m = int(margin_px)
    return np.asarray(cv2.copyMakeBorder(img, m, m, m, m, cv2.BORDER_CONSTANT, value=(255,)))


def render_board_view(
    spec: BoardSpec,
    K: Intrinsics,
    board2camera: FloatArray,
    *,
    background: int = 128,
    supersample: int = 2,
) -> np.ndarray:
    """A synthetic grey image of the board seen by an ideal pinhole camera.

    The board (with a 15 mm white margin) is warped by the exact plane-to-image
    homography ``K [r1 r2 t]`` at ``supersample`` times the resolution and area-
    averaged down. For tests and benchmarks with a known pose.
    """
    import cv2

    T = check_rigid_transform(board2camera, "board2camera")
    ss = int(supersample)
    Ks = K.scaled(K.width * ss, K.height * ss)
    px_per_m = 2.0 * ss * max(Ks.fx, Ks.fy) / max(float(T[2, 3]), 0.05)  # >= 2 texels/pixel
    margin = round(0.015 * px_per_m)
    tex = board_image(spec, px_per_m, margin)
    h_m = spec.size_m[1]
    # texture pixel centre (c, r) -> board frame: x = (c + 0.5 - m)/s, y = H - (r + 0.5 - m)/s
    A = np.array(
        [
            [1 / px_per_m, 0.0, (0.5 - margin) / px_per_m],
            [0.0, -1 / px_per_m, h_m - (0.5 - margin) / px_per_m],
            [0.0, 0.0, 1.0],
        ]
    )
    Hm = _camera_matrix(Ks) @ np.column_stack([T[:3, 0], T[:3, 1], T[:3, 3]]) @ A
    big = cv2.warpPerspective(
        tex,
        Hm,
        (Ks.width, Ks.height),
        flags=cv2.INTER_AREA,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=(background,),
    )
    return np.asarray(cv2.resize(big, (K.width, K.height), interpolation=cv2.INTER_AREA))


def print_board(spec: BoardSpec, path: str | os.PathLike[str], dpi: float = 300.0) -> Path:
    """A printable PNG of the board at ``dpi`` (stored in the file), with a legend.

    The legend names the spec, the printed square length to check with a ruler
    and the board frame's axes. Written atomically.
    """
    import cv2
    from PIL import Image

    p = Path(path)
    if p.suffix.lower() != ".png":
        raise InvalidInput(f"--print-board: {p} must end in .png")
    check_positive(dpi, "dpi")
    px_per_m = dpi / 0.0254
    margin = max(20, round(0.015 * px_per_m))  # 15 mm quiet zone
    img = board_image(spec, px_per_m, margin)
    legend_h = max(60, round(0.02 * px_per_m))
    img = np.asarray(cv2.copyMakeBorder(img, 0, legend_h, 0, 0, cv2.BORDER_CONSTANT, value=(255,)))
    bottom = margin + round(spec.size_m[1] * px_per_m)  # the pattern's bottom edge [px]
    scale = legend_h / 90
    what = "square" if spec.kind != "aprilgrid" else "marker"
    lines = [
        f"{spec.describe()}  |  print at 100 %: {what} = {spec.square_m * 1000:.1f} mm",
        "origin: bottom-left corner, x right, y up, z out of the page",
    ]
    for i, text in enumerate(lines):
        y = bottom + margin // 2 + round(legend_h * (0.45 + 0.4 * i))
        thick = max(1, round(scale * 2))
        cv2.putText(
            img, text, (margin, y), cv2.FONT_HERSHEY_SIMPLEX, scale, (0,), thick, cv2.LINE_AA
        )
    tmp = p.with_name(f".{p.name}.{os.getpid()}.tmp.png")
    try:
        Image.fromarray(img).save(tmp, dpi=(dpi, dpi))
        os.replace(tmp, p)
    finally:
        if tmp.exists():
            tmp.unlink()
    return p


# ---------------------------------------------------------------- detection and pose


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


def _gray(image: np.ndarray) -> np.ndarray:
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

    gray = _gray(image)
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
        return BoardDetection(_to_board_frame(cv_pts, spec), img_pts, 0)
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
        return BoardDetection(_to_board_frame(cv_pts, spec), img_pts, n_markers, foreign)
    aruco = cv2.aruco.ArucoDetector(board.getDictionary(), _marker_params())
    m_corners, m_ids, _ = aruco.detectMarkers(gray)
    if m_ids is None or len(m_ids) == 0:
        return empty
    foreign = int((np.asarray(m_ids) >= n_ids).sum())
    obj, img = board.matchImagePoints(m_corners, m_ids)
    if obj is None or len(obj) == 0:
        return BoardDetection(empty.board_m, empty.image_px, len(m_ids), foreign)
    return BoardDetection(
        _to_board_frame(np.asarray(obj), spec),
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


def _other_dictionaries(gray: np.ndarray, spec: BoardSpec) -> list[str]:
    """Marker dictionaries (other than the spec's) with markers in the image: a hint."""
    import cv2

    found = []
    for name in ("4X4_50", "5X5_100", "6X6_250", "7X7_250", "ARUCO_ORIGINAL", "APRILTAG_36h11"):
        if name == spec.dictionary:
            continue
        d = cv2.aruco.getPredefinedDictionary(_dict_id(name))
        _, ids, _ = cv2.aruco.ArucoDetector(d, cv2.aruco.DetectorParameters()).detectMarkers(gray)
        if ids is not None and len(ids) >= 2:
            found.append(name)
    return found


def _camera_matrix(K: Intrinsics) -> FloatArray:
    return np.array([[K.fx, 0.0, K.cx], [0.0, K.fy, K.cy], [0.0, 0.0, 1.0]])


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
    Km, dist = _camera_matrix(K), np.zeros(5)
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


def pose_from_xyz_rpy(values: Iterable[float]) -> FloatArray:
    """4x4 transform of ``x, y, z`` [m] and ``roll, pitch, yaw`` [deg].

    ROS/URDF convention: ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (fixed axes x, y, z).
    """
    from scipy.spatial.transform import Rotation

    v = np.asarray(list(values), dtype=np.float64)
    if v.shape != (6,) or not np.isfinite(v).all():
        raise InvalidInput(f"expected 6 finite numbers x,y,z,roll,pitch,yaw, got {v.tolist()}")
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("xyz", v[3:], degrees=True).as_matrix()
    T[:3, 3] = v[:3]
    return T


def load_board_pose(spec: str, flag: str = "--board-pose") -> FloatArray:
    """The board frame in the robot base frame: ``x,y,z,roll,pitch,yaw`` or a 4x4 ``.npy``."""
    if spec.lower().endswith((".npy", ".npz", ".txt")) or Path(spec).is_file():
        return load_extrinsics(spec, flag)
    try:
        values = [float(v) for v in spec.split(",")]
    except ValueError:
        values = []
    if len(values) != 6:
        raise InvalidInput(
            f"{flag}: expected x,y,z [m],roll,pitch,yaw [deg] or a 4x4 .npy file, got {spec!r}"
        )
    try:
        return pose_from_xyz_rpy(values)
    except InvalidInput as exc:
        raise InvalidInput(f"{flag}: {exc}") from None


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
    B = check_rigid_transform(board2base, "--board-pose", atol=1e-4)
    dets: list[BoardDetection] = []
    n_images, n_markers, foreign, size = 0, 0, 0, None
    hint_gray = None
    for image in images:
        gray = _gray(image)
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
    n_points = sum(len(d.board_m) for d in dets)
    if not dets:
        what = f"no {spec.describe()} board found in {source} ({n_images} image(s))"
        if n_markers:
            raise InvalidInput(
                f"{what}: {n_markers} marker(s) of DICT_{spec.dictionary} decoded but no board "
                "corners matched; check COLSxROWS in --board"
                + (f" ({foreign} marker id(s) beyond this board's)" if foreign else "")
            )
        others = _other_dictionaries(hint_gray, spec) if hint_gray is not None else []
        if others and spec.kind != "checkerboard":
            raise InvalidInput(
                f"{what}, but markers of {', '.join(others)} are: wrong DICT in --board?"
            )
        raise InvalidInput(f"{what}: is the whole pattern lit, sharp and in view?")
    if n_points < min_points:
        raise InvalidInput(
            f"{source}: only {n_points} board corner(s) found (need >= {min_points}): "
            "show more of the board"
        )
    if K is None:
        K = Intrinsics.from_fov(size[0], size[1], fov_deg)
        logger.warning(
            "calibrate: no --intrinsics, ASSUMING an ideal camera with %.0f deg horizontal "
            "field of view: the camera's distance is only as right as that guess",
            fov_deg,
        )
    elif (K.width, K.height) != size:
        K = K.scaled(*size)
    obj = np.concatenate([d.board_m for d in dets])
    img = np.concatenate([d.image_px for d in dets])
    T, err = fit_board_pose(obj, img, K)
    if len(dets) > 2:  # drop images that disagree with the joint pose, once
        owner = np.repeat(np.arange(len(dets)), [len(d.board_m) for d in dets])
        per = np.array([np.sqrt(np.mean(err[owner == i] ** 2)) for i in range(len(dets))])
        keep = per <= max(1.0, 3.0 * float(np.median(per)))
        if not keep.all():
            logger.warning(
                "calibrate: %d image(s) disagree with the others, dropped", (~keep).sum()
            )
            dets = [d for d, k in zip(dets, keep, strict=True) if k]
            obj = np.concatenate([d.board_m for d in dets])
            img = np.concatenate([d.image_px for d in dets])
            T, err = fit_board_pose(obj, img, K)
    rms = float(np.sqrt(np.mean(err**2)))
    if not rms <= max_rms_px:
        raise InvalidInput(
            f"{source}: the board fits poorly (reprojection RMS {rms:.2f} px > {max_rms_px:g} px "
            f"over {len(obj)} corners): check --board (COLSxROWS, lengths, DICT) and "
            "--intrinsics, and that the camera and board did not move"
        )
    if T[2, 3] <= 0:
        raise InvalidInput(f"{source}: the fitted board is behind the camera (wrong --board?)")
    camera2base = B @ np.linalg.inv(T)
    return CameraPose(camera2base, T, rms, len(obj), len(dets), n_images, K)


def read_images(path: str | os.PathLike[str], max_frames: int = 30) -> list[np.ndarray]:
    """An image file, or up to ``max_frames`` frames spread evenly over a video (BGR)."""
    import cv2

    p = Path(path)
    if not p.is_file():
        raise InvalidInput(f"{p}: no such file (expected an image or a video of the board)")
    if p.suffix.lower() in (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp", ".ppm"):
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
    finally:
        cap.release()
    if not frames:
        raise InvalidInput(f"{p}: no frames could be decoded")
    return frames
