"""Calibration files: camera intrinsics, the camera -> base transform and the board pose.

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
    processed (resized frames); without one they must be for the full-size video.
Extrinsics, :func:`load_extrinsics` / :func:`save_extrinsics`
    A 4x4 rigid transform ``camera -> robot base`` (``p_base = T p_cam``, metres):
    a ``.npy`` file (what ``dexlfd calibrate`` writes) or a text file of 4 rows
    of 4 numbers. Shape, finiteness, orthonormality, ``det R = +1`` and the
    last row are checked.
Board pose, :func:`load_board_pose`
    The board frame in the robot base frame: ``x,y,z,roll,pitch,yaw`` [m, deg] or a
    4x4 file as for the extrinsics.

Errors name the caller's parameter (``name``); the CLI maps it to its flag.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.capture.transforms import check_rigid_transform
from dexlfd.errors import InvalidInput
from dexlfd.io._atomic import atomic_write
from dexlfd.io._npz import load_small_npy

__all__ = [
    "CameraIntrinsics",
    "load_board_pose",
    "load_extrinsics",
    "load_intrinsics",
    "pose_from_xyz_rpy",
    "save_extrinsics",
]

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
    fx, fy, cx, cy = float(M[0, 0]), float(M[1, 1]), float(M[0, 2]), float(M[1, 2])
    if not (min(fx, fy) >= MIN_FOCAL_PX and max(fx, fy) <= MAX_FOCAL_PX):
        raise InvalidInput(
            f"{where}: focal lengths fx={fx:g}, fy={fy:g} must be in pixels, "
            f"{MIN_FOCAL_PX:g}..{MAX_FOCAL_PX:g} (millimetres or a normalised K?)"
        )
    if not (0 <= cx <= MAX_FOCAL_PX and 0 <= cy <= MAX_FOCAL_PX):
        raise InvalidInput(
            f"{where}: the principal point cx={cx:g}, cy={cy:g} must be in pixels, inside the "
            "image (top-left corner 0, 0)"
        )
    return fx, fy, cx, cy


# a camera's focal length in pixels: a 120 px wide 120 deg view has 35 px, a narrow
# telephoto on an 8K sensor 1e5 px
MIN_FOCAL_PX = 10.0
MAX_FOCAL_PX = 1e6


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
    except RecursionError:
        raise InvalidInput(
            f"{where}: JSON nested too deeply (expected K or fx, fy, cx, cy)"
        ) from None
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


def load_intrinsics(spec: str, name: str = "intrinsics") -> CameraIntrinsics:
    """``(fx, fy, cx, cy)`` [px] and the image size they belong to (or None).

    ``spec`` is ``fx,fy,cx,cy`` or a file (module docstring). Errors start with ``name``
    (the caller's parameter).
    """
    path = Path(spec)
    if "," in spec and not path.exists():
        try:
            fx, fy, cx, cy = (float(v) for v in spec.split(","))
        except ValueError:
            raise InvalidInput(
                f"{name}: expected fx,fy,cx,cy [px] or a file, got {spec!r}"
            ) from None
        return _from_matrix([[fx, 0, cx], [0, fy, cy], [0, 0, 1]], f"{name} {spec}"), None
    where = f"{name} {path}"
    if not path.is_file():
        raise InvalidInput(f"{where}: no such file (expected fx,fy,cx,cy or a .npy/.json/.yaml)")
    suffix = path.suffix.lower()
    if suffix == ".npy":
        try:
            M = load_small_npy(path, 64)
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


def load_extrinsics(
    path: str | os.PathLike[str], name: str = "camera2base", what: str = "the camera"
) -> FloatArray:
    """The 4x4 ``camera -> base`` transform of a ``.npy`` or text file, checked rigid.

    Errors start with ``name`` (the caller's parameter) and the path.
    """
    p = Path(path)
    where = f"{name} {p}"
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
            T = load_small_npy(p, 64)
        else:
            T = np.loadtxt(p, ndmin=2)
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        kind = ".npy array" if suffix == ".npy" else "4x4 text matrix"
        raise InvalidInput(f"{where}: cannot read a {kind}: {str(exc).splitlines()[0]}") from None
    A = check_rigid_transform(T, where, atol=1e-4)  # rounding in a text file is fine
    U, _, Vt = np.linalg.svd(A[:3, :3])  # nearest rotation, so downstream checks hold
    A[:3, :3] = U @ Vt
    return _check_in_room(A, where, what)


def save_extrinsics(path: str | os.PathLike[str], T: FloatArray) -> Path:
    """Write a checked 4x4 transform as ``.npy`` atomically (temp file + rename)."""
    p = Path(path)
    if p.suffix.lower() != ".npy":
        raise InvalidInput(f"{p}: the extrinsics file must end in .npy")
    A = check_rigid_transform(T, str(p), atol=1e-6)
    atomic_write(p, lambda fh: np.save(fh, A))
    return p


MAX_ANGLE_DEG = 360.0  # [deg] largest roll, pitch or yaw of a pose given as numbers


def pose_from_xyz_rpy(values: Iterable[float]) -> FloatArray:
    """4x4 transform of ``x, y, z`` [m] and ``roll, pitch, yaw`` [deg].

    ROS/URDF convention: ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (fixed axes x, y, z).
    """
    from scipy.spatial.transform import Rotation

    v = np.asarray(list(values), dtype=np.float64)
    if v.shape != (6,) or not np.isfinite(v).all():
        raise InvalidInput(f"expected 6 finite numbers x,y,z,roll,pitch,yaw, got {v.tolist()}")
    if np.abs(v[3:]).max() > MAX_ANGLE_DEG:
        # beyond a full turn an angle is a slip (a unit, a digit), and at 1e17 deg and up
        # a double no longer holds which way it points
        raise InvalidInput(
            f"roll, pitch, yaw must be within -{MAX_ANGLE_DEG:g}..{MAX_ANGLE_DEG:g} deg, got "
            f"{v[3:].tolist()}"
        )
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("xyz", v[3:], degrees=True).as_matrix()
    T[:3, 3] = v[:3]
    return T


def load_board_pose(spec: str, name: str = "board2base") -> FloatArray:
    """The board frame in the robot base frame: ``x,y,z,roll,pitch,yaw`` or a 4x4 ``.npy``.

    Errors start with ``name`` (the caller's parameter).
    """
    if spec.lower().endswith((".npy", ".npz", ".txt")) or Path(spec).is_file():
        return load_extrinsics(spec, name, "the board")
    try:
        values = [float(v) for v in spec.split(",")]
    except ValueError:
        values = []
    if len(values) != 6:
        raise InvalidInput(
            f"{name}: expected x,y,z [m],roll,pitch,yaw [deg] or a 4x4 .npy file, got {spec!r}"
        )
    try:
        T = pose_from_xyz_rpy(values)
    except InvalidInput as exc:
        raise InvalidInput(f"{name}: {exc}") from None
    return _check_in_room(T, name, "the board")


# a camera or board that calibrates the robot's base frame stands in the robot's room
MAX_DISTANCE_M = 5.0


def _check_in_room(T: FloatArray, name: str, what: str) -> FloatArray:
    """Refuse a pose whose position reads like millimetres (more than 5 m from the base)."""
    d = float(np.linalg.norm(T[:3, 3]))
    if d > MAX_DISTANCE_M:
        x, y, z = T[:3, 3]
        raise InvalidInput(
            f"{name}: {what} is {d:g} m from the robot base (x,y,z = {x:g},{y:g},{z:g}); "
            f"positions are in metres (at most {MAX_DISTANCE_M:g} m): "
            f"{x / 1000:g},{y / 1000:g},{z / 1000:g} if you meant millimetres"
        )
    return T
