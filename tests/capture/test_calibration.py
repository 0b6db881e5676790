from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from dexlfd.capture.calibration import load_extrinsics, load_intrinsics, save_extrinsics
from dexlfd.cli import main
from dexlfd.errors import InvalidInput

K_TRUE = np.array([[910.0, 0.0, 641.3], [0.0, 905.0, 358.7], [0.0, 0.0, 1.0]])


# ---------------------------------------------------------------- intrinsics files


def test_intrinsics_formats_agree(tmp_path: Path) -> None:
    want = (910.0, 905.0, 641.3, 358.7)
    np.save(tmp_path / "K.npy", K_TRUE)
    (tmp_path / "K.json").write_text(json.dumps({"K": K_TRUE.tolist(), "image_size": [1280, 720]}))
    (tmp_path / "f.json").write_text(
        json.dumps({"fx": 910, "fy": 905, "cx": 641.3, "cy": 358.7, "width": 1280, "height": 720})
    )
    fs = cv2.FileStorage(str(tmp_path / "cv.yaml"), cv2.FILE_STORAGE_WRITE)
    fs.write("camera_matrix", K_TRUE)
    fs.write("image_width", 1280)
    fs.write("image_height", 720)
    fs.release()
    (tmp_path / "ros.yaml").write_text(
        "image_width: 1280\nimage_height: 720\ncamera_name: webcam\ncamera_matrix:\n"
        "  rows: 3\n  cols: 3\n  data: [910.0, 0.0, 641.3, 0.0, 905.0, 358.7, 0.0, 0.0, 1.0]\n"
    )
    assert load_intrinsics("910,905,641.3,358.7") == (want, None)
    assert load_intrinsics(str(tmp_path / "K.npy")) == (want, None)
    for name in ("K.json", "f.json", "cv.yaml", "ros.yaml"):
        assert load_intrinsics(str(tmp_path / name)) == (want, (1280, 720)), name


def test_intrinsics_bad_inputs_name_the_flag(tmp_path: Path) -> None:
    np.save(tmp_path / "bad.npy", np.eye(4))
    (tmp_path / "bad.json").write_text('{"focal": 3}')
    (tmp_path / "x.txt").write_text("1 2 3")
    np.save(tmp_path / "neg.npy", np.diag([-1.0, 1.0, 1.0]))
    cases = {
        "1,2,3": "expected fx,fy,cx,cy",
        str(tmp_path / "missing.npy"): "no such file",
        str(tmp_path / "bad.npy"): "expected a 3x3 camera matrix K, got shape \\(4, 4\\)",
        str(tmp_path / "bad.json"): "no camera matrix",
        str(tmp_path / "x.txt"): "unknown format",
        str(tmp_path / "neg.npy"): "need fx > 0",
    }
    for spec, why in cases.items():
        with pytest.raises(InvalidInput, match=f"^--intrinsics.*{why}"):
            load_intrinsics(spec)


# ---------------------------------------------------------------- extrinsics files


def _T() -> np.ndarray:
    c, s = np.cos(0.3), np.sin(0.3)
    T = np.eye(4)
    T[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
    T[:3, 3] = [0.5, -0.2, 0.8]
    return T


def test_extrinsics_round_trip_npy_and_text(tmp_path: Path) -> None:
    T = _T()
    save_extrinsics(tmp_path / "T.npy", T)
    np.testing.assert_allclose(load_extrinsics(tmp_path / "T.npy"), T, atol=1e-15)
    np.savetxt(tmp_path / "T.txt", T, fmt="%.6f")  # rounded: re-orthonormalised on load
    A = load_extrinsics(tmp_path / "T.txt")
    np.testing.assert_allclose(A, T, atol=2e-6)
    np.testing.assert_allclose(A[:3, :3] @ A[:3, :3].T, np.eye(3), atol=1e-12)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["T.npy", "T.txt"]  # no temp left


@pytest.mark.parametrize(
    ("name", "make", "why"),
    [
        ("demo.npz", lambda p: np.savez(p, T=_T()), "a .npz archive, expected a single 4x4"),
        ("shape.npy", lambda p: np.save(p, np.eye(3)), "got shape \\(3, 3\\)"),
        ("nan.npy", lambda p: np.save(p, np.where(_T() == 1, np.nan, _T())), "NaN"),
        ("scaled.npy", lambda p: np.save(p, np.diag([2.0, 2, 2, 1])), "not orthonormal"),
        ("mirror.npy", lambda p: np.save(p, np.diag([1.0, -1, 1, 1])), "det -1"),
        ("row.npy", lambda p: np.save(p, np.vstack([_T()[:3], [0, 0, 1, 1]])), "last row"),
        ("text.txt", lambda p: p.write_text("1 0 0\n0 1 0\n"), "got shape \\(2, 3\\)"),
        ("garbage.npy", lambda p: p.write_bytes(b"not numpy"), "cannot read a .npy array"),
        ("missing.npy", lambda p: None, "no such file"),
    ],
)
def test_bad_extrinsics_give_one_line_naming_the_file(
    tmp_path: Path, name: str, make, why: str
) -> None:
    path = tmp_path / name
    make(path)
    with pytest.raises(InvalidInput, match=f"^--extrinsics {path}: .*{why}") as err:
        load_extrinsics(path)
    assert "\n" not in str(err.value)


def test_record_with_a_npz_extrinsics_fails_cleanly(tmp_path: Path, capsys) -> None:
    np.savez(tmp_path / "demo.npz", T=_T())
    argv = ["record", str(tmp_path / "none.mp4"), "-o", str(tmp_path / "d.npz")]
    assert main([*argv, "--extrinsics", str(tmp_path / "demo.npz")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--extrinsics" in err[0] and ".npz archive" in err[0]
    assert not (tmp_path / "d.npz").exists()
