"""Printed calibration boards: the spec (ChArUco, AprilGrid, checkerboard) and its images.

:class:`BoardSpec` parses and validates ``kind:COLSxROWS,LEN[,LEN][,DICT]``;
:func:`board_image` draws the pattern, :func:`print_board` writes a printable PNG with
a legend, :func:`render_board_view` shows the board through an ideal pinhole camera
(tests and benchmarks with a known pose).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd._validation import check_positive
from dexlfd.capture.camera_models import Intrinsics
from dexlfd.capture.transforms import check_rigid_transform
from dexlfd.errors import InvalidInput
from dexlfd.io._atomic import atomic_write

__all__ = [
    "BOARD_HELP",
    "BoardSpec",
    "board_image",
    "dictionary_id",
    "print_board",
    "render_board_view",
    "to_board_frame",
]


# dictionary names accepted in a board spec -> OpenCV constants (resolved lazily)
_DICTS = (
    "4X4_50", "4X4_100", "4X4_250", "4X4_1000", "5X5_50", "5X5_100", "5X5_250", "5X5_1000",
    "6X6_50", "6X6_100", "6X6_250", "6X6_1000", "7X7_50", "7X7_100", "7X7_250", "7X7_1000",
    "ARUCO_ORIGINAL", "APRILTAG_16h5", "APRILTAG_25h9", "APRILTAG_36h10", "APRILTAG_36h11",
)  # fmt: skip
_DEFAULT_DICT = {"charuco": "4X4_50", "aprilgrid": "APRILTAG_36h11"}
# a printable (or wall-sized) calibration board: squares up to 0.5 m, at most 100 per side
MAX_BOARD_LENGTH_M = 0.5
MAX_BOARD_SQUARES = 100
MAX_PRINT_PIXELS = 200_000_000  # a printed board's PNG (an A0 page at 600 dpi is 70 MP)
BOARD_HELP = (
    "charuco:COLSxROWS,SQUARE_M,MARKER_M[,DICT] (squares; default DICT 4X4_50), "
    "aprilgrid:COLSxROWS,MARKER_M,GAP_M[,DICT] (markers; default APRILTAG_36h11) or "
    "checkerboard:COLSxROWS,SQUARE_M (squares, one count even; whole board in view)"
)


def dictionary_id(name: str) -> int:
    """The OpenCV constant of a marker dictionary name (``"4X4_50"``)."""
    import cv2

    return int(getattr(cv2.aruco, f"DICT_{name}"))


@dataclass(frozen=True, slots=True)
class BoardSpec:
    """A printed calibration board (sizes in metres).

    ``cols x rows`` are squares (``charuco``, ``checkerboard``) or markers
    (``aprilgrid``); ``square_m`` is the square side (the marker side for
    ``aprilgrid``); ``marker_m`` the ChArUco marker side (the gap between markers
    for ``aprilgrid``; unused for ``checkerboard``).

    Board frame (what ``board2base`` places in the robot base frame): origin at
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
        if max(self.cols, self.rows) > MAX_BOARD_SQUARES:
            raise InvalidInput(
                f"board size {self.cols}x{self.rows}: at most {MAX_BOARD_SQUARES} per side"
            )
        for what, length in (("square/marker", self.square_m), ("marker/gap", self.marker_m)):
            if length > MAX_BOARD_LENGTH_M:
                raise InvalidInput(
                    f"board {what} length {length:g} m: lengths are in metres, at most "
                    f"{MAX_BOARD_LENGTH_M:g} m ({length / 1000:g} if you meant millimetres)"
                )
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
    def parse(cls, text: str, name: str = "board_spec") -> BoardSpec:
        """``kind:COLSxROWS,LEN[,LEN][,DICT]`` (see :data:`BOARD_HELP`).

        Errors start with ``name`` (the caller's parameter).
        """
        kind, _, rest = text.partition(":")
        kind = kind.strip().lower()
        parts = [p.strip() for p in rest.split(",")] if rest else []
        n_len = 1 if kind == "checkerboard" else 2
        if kind not in ("charuco", "aprilgrid", "checkerboard") or not (
            n_len + 1 <= len(parts) <= n_len + (kind != "checkerboard") + 1
        ):
            raise InvalidInput(f"{name}: expected {BOARD_HELP}; got {text!r}")
        try:
            cols, rows = (int(v) for v in parts[0].lower().split("x"))
            lengths = [float(v) for v in parts[1 : 1 + n_len]]
        except ValueError:
            raise InvalidInput(f"{name}: expected {BOARD_HELP}; got {text!r}") from None
        dictionary = (
            parts[1 + n_len].upper().removeprefix("DICT_") if len(parts) > 1 + n_len else ""
        )
        if dictionary.startswith("APRILTAG_"):
            dictionary = "APRILTAG_" + dictionary.removeprefix("APRILTAG_").lower()
        try:
            return cls(kind, cols, rows, lengths[0], lengths[1] if n_len == 2 else 0.0, dictionary)
        except InvalidInput as exc:
            raise InvalidInput(f"{name} {text}: {exc}") from None

    @property
    def size_m(self) -> tuple[float, float]:
        """Width and height of the pattern [m]."""
        if self.kind == "aprilgrid":
            step = self.square_m + self.marker_m
            return self.cols * step - self.marker_m, self.rows * step - self.marker_m
        return self.cols * self.square_m, self.rows * self.square_m

    def describe(self) -> str:
        """The spec in the syntax of :meth:`parse`."""
        if self.kind == "checkerboard":
            return f"checkerboard:{self.cols}x{self.rows},{self.square_m:g}"
        size = f"{self.cols}x{self.rows}"
        return f"{self.kind}:{size},{self.square_m:g},{self.marker_m:g},{self.dictionary}"

    def opencv_board(self) -> Any:
        """The ``cv2.aruco`` board (None for a checkerboard)."""
        import cv2

        if self.kind == "checkerboard":
            return None
        d = cv2.aruco.getPredefinedDictionary(dictionary_id(self.dictionary))
        if self.kind == "charuco":
            return cv2.aruco.CharucoBoard((self.cols, self.rows), self.square_m, self.marker_m, d)
        return cv2.aruco.GridBoard((self.cols, self.rows), self.square_m, self.marker_m, d)


def to_board_frame(points_cv: FloatArray, spec: BoardSpec) -> FloatArray:
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
    Hm = Ks.matrix @ np.column_stack([T[:3, 0], T[:3, 1], T[:3, 3]]) @ A
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
        raise InvalidInput(f"{p}: a printable board image must end in .png")
    check_positive(dpi, "dpi")
    px_per_m = dpi / 0.0254
    margin = max(20, round(0.015 * px_per_m))  # 15 mm quiet zone
    w_px = spec.size_m[0] * px_per_m + 2 * margin
    h_px = spec.size_m[1] * px_per_m + 2 * margin + max(60, round(0.02 * px_per_m))
    if w_px * h_px > MAX_PRINT_PIXELS:
        raise InvalidInput(
            f"dpi {dpi:g}: the {spec.size_m[0] * 1000:.0f} x {spec.size_m[1] * 1000:.0f} mm "
            f"board would be {w_px:.0f} x {h_px:.0f} px; at most {MAX_PRINT_PIXELS / 1e6:.0f} "
            "megapixels are written (lower the dpi)",
            param="dpi",
        )
    if min(spec.size_m) * px_per_m < 8 * max(spec.cols, spec.rows):
        raise InvalidInput(
            f"dpi {dpi:g}: too few pixels for a {spec.cols}x{spec.rows} board "
            "(at least 8 per square)",
            param="dpi",
        )
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
    atomic_write(p, lambda fh: Image.fromarray(img).save(fh, format="PNG", dpi=(dpi, dpi)))
    return p
