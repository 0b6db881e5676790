from __future__ import annotations

import json
import os
import re
from pathlib import Path

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dexlfd.capture import Intrinsics
from dexlfd.capture.board import BoardSpec, render_board_view
from dexlfd.capture.board_detection import detect_board
from dexlfd.capture.calibration import calibrate_camera
from dexlfd.capture.calibration_files import (
    load_extrinsics,
    load_intrinsics,
    pose_from_xyz_rpy,
    save_extrinsics,
)
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
        # the library names its parameter, the CLI (calibrate, record) passes its flag
        with pytest.raises(InvalidInput, match=f"^intrinsics.*{why}"):
            load_intrinsics(spec)
        with pytest.raises(InvalidInput, match=f"^--intrinsics.*{why}"):
            load_intrinsics(spec, "--intrinsics")


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
    with pytest.raises(InvalidInput, match=f"^camera2base {path}: .*{why}") as err:
        load_extrinsics(path)
    assert "\n" not in str(err.value)
    with pytest.raises(InvalidInput, match=f"^--extrinsics {path}: .*{why}"):
        load_extrinsics(path, "--extrinsics")  # as record names it


def test_record_with_a_npz_extrinsics_fails_cleanly(tmp_path: Path, capsys) -> None:
    np.savez(tmp_path / "demo.npz", T=_T())
    argv = ["record", str(tmp_path / "none.mp4"), "-o", str(tmp_path / "d.npz")]
    assert main([*argv, "--extrinsics", str(tmp_path / "demo.npz")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--extrinsics" in err[0] and ".npz archive" in err[0]
    assert not (tmp_path / "d.npz").exists()


# ---------------------------------------------------------------- boards: rendered views

K_CAM = Intrinsics(1280, 720, 910.0, 905.0, 641.3, 358.7)
CHARUCO = "charuco:7x5,0.04,0.03"
# the board lies on the table 0.45 m ahead of the robot, turned 90 deg (its x along base y)
BOARD2BASE = pose_from_xyz_rpy([0.45, -0.14, 0.0, 0.0, 0.0, 90.0])


def _board2camera(rpy_deg: tuple, centre: tuple, board: str = CHARUCO) -> np.ndarray:
    """Board -> camera with the board's centre at ``centre`` in the camera frame [m]."""
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("xyz", rpy_deg, degrees=True).as_matrix()
    w, h = BoardSpec.parse(board).size_m
    T[:3, 3] = np.asarray(centre) - T[:3, :3] @ [w / 2, h / 2, 0.0]
    return T


VIEWS = [  # printed side towards the camera (roll ~180 deg), 0.6-1.0 m, off-centre, tilted
    ((180.0, 0.0, 0.0), (0.0, 0.0, 0.6)),
    ((160.0, 15.0, 20.0), (0.08, 0.05, 0.8)),
    ((215.0, -20.0, -35.0), (-0.12, -0.06, 1.0)),
]


def _view(spec: BoardSpec, T: np.ndarray, rng: np.random.Generator, blur=1.0, noise=3.0):
    img = render_board_view(spec, K_CAM, T).astype(np.float64)
    img = cv2.GaussianBlur(img, (0, 0), blur) + rng.normal(0, noise, img.shape)
    return np.clip(img, 0, 255).astype(np.uint8)


def _errors(camera2base: np.ndarray, b2c_true: np.ndarray) -> tuple[float, float]:
    """Pose error of the board as the robot sees it through ``camera2base``.

    The largest position error over the board's corners [m] (a 0.28 x 0.20 m area)
    and the rotation error [deg] of ``camera2base @ board2camera_true`` against the
    board's true pose in the base frame.
    """
    E = camera2base @ b2c_true
    corners = np.array([[0, 0, 0, 1], [0.3, 0, 0, 1], [0, 0.2, 0, 1], [0.3, 0.2, 0, 1]]).T
    dt = float(np.linalg.norm((E @ corners - BOARD2BASE @ corners)[:3], axis=0).max())
    dR = Rotation.from_matrix(E[:3, :3].T @ BOARD2BASE[:3, :3]).magnitude()
    return dt, float(np.degrees(dR))


@pytest.mark.parametrize("view", range(len(VIEWS)))
@pytest.mark.parametrize("board", [CHARUCO, "aprilgrid:6x4,0.04,0.01"])
def test_camera_pose_from_a_rendered_board_within_2mm_1deg(
    rng: np.random.Generator, board: str, view: int
) -> None:
    spec = BoardSpec.parse(board)
    b2c = _board2camera(*VIEWS[view], board)
    res = calibrate_camera([_view(spec, b2c, rng)], spec, BOARD2BASE, K_CAM)
    dt, dR = _errors(res.camera2base, b2c)
    # ChArUco corners are chessboard saddle points (sub-pixel); an aprilgrid uses the marker
    # outlines, about twice as noisy: its tilted 1 m view is off by ~2.5 mm
    assert dt < (0.002 if board == CHARUCO else 0.003) and dR < 1.0
    assert res.rms_px < (0.5 if board == CHARUCO else 1.0) and res.n_frames == 1
    assert res.n_points == (24 if board == CHARUCO else 4 * 24)
    # the written transform maps the board's origin to where the user said it is
    origin_cam = res.board2camera[:3, 3]
    np.testing.assert_allclose(res.camera2base[:3, :3] @ origin_cam + res.camera2base[:3, 3],
                               BOARD2BASE[:3, 3], atol=1e-9)  # fmt: skip


def test_checkerboard_fallback(rng: np.random.Generator) -> None:
    spec = BoardSpec.parse("checkerboard:8x5,0.04")  # even x odd: not 180-degree symmetric
    b2c = _board2camera(*VIEWS[1], "checkerboard:8x5,0.04")
    res = calibrate_camera([_view(spec, b2c, rng)], spec, BOARD2BASE, K_CAM)
    dt, dR = _errors(res.camera2base, b2c)
    assert dt < 0.002 and dR < 1.0 and res.n_points == 7 * 4


def test_several_frames_are_fitted_together(rng: np.random.Generator) -> None:
    spec = BoardSpec.parse(CHARUCO)
    b2c = _board2camera(*VIEWS[2])
    frames = [_view(spec, b2c, rng, noise=6.0) for _ in range(4)]
    frames.append(np.full((720, 1280), 128, np.uint8))  # a frame without the board
    res = calibrate_camera(frames, spec, BOARD2BASE, K_CAM)
    assert (res.n_frames, res.n_images, res.n_points) == (4, 5, 96)
    dt, dR = _errors(res.camera2base, b2c)
    assert dt < 0.002 and dR < 1.0


def test_partial_board_works_with_enough_corners(rng: np.random.Generator) -> None:
    spec = BoardSpec.parse(CHARUCO)
    b2c = _board2camera(*VIEWS[1])
    img = _view(spec, b2c, rng)
    det = detect_board(img, spec)
    u_mid = np.median(det.image_px[:, 0])
    half = img.copy()
    half[:, : int(u_mid)] = 128  # hide the left half of the board
    res = calibrate_camera([half], spec, BOARD2BASE, K_CAM)
    assert 6 <= res.n_points < 24
    dt, dR = _errors(res.camera2base, b2c)
    assert dt < 0.003 and dR < 1.0
    # a sliver of the board: a clear error naming how many corners were found
    sliver = img.copy()
    sliver[:, : int(np.sort(det.image_px[:, 0])[-3]) - 5] = 128
    with pytest.raises(InvalidInput, match=r"only \d board corner\(s\) found \(need >= 6\)"):
        calibrate_camera([sliver], spec, BOARD2BASE, K_CAM)


def test_no_board_and_wrong_specs_are_named(rng: np.random.Generator) -> None:
    spec = BoardSpec.parse(CHARUCO)
    img = _view(spec, _board2camera(*VIEWS[1]), rng)
    blank = np.clip(rng.normal(128, 20, (720, 1280)), 0, 255).astype(np.uint8)
    with pytest.raises(InvalidInput, match="no charuco:7x5.* board found in image .*in view"):
        calibrate_camera([blank], spec, BOARD2BASE, K_CAM)
    with pytest.raises(InvalidInput, match="markers of 4X4_50 are: wrong DICT"):
        calibrate_camera([img], BoardSpec.parse(CHARUCO + ",6X6_250"), BOARD2BASE, K_CAM)
    with pytest.raises(InvalidInput, match="check COLSxROWS"):
        calibrate_camera([img], BoardSpec.parse("charuco:5x7,0.04,0.03"), BOARD2BASE, K_CAM)
    # wrong intrinsics (focal length off by 30 %): the fit is poor and says so, or the
    # camera ends up metres off; a 1 px RMS bound catches it
    bad_K = Intrinsics(1280, 720, 1200.0, 700.0, 500.0, 300.0)
    with pytest.raises(InvalidInput, match="fits poorly .*check the board spec"):
        calibrate_camera([img], spec, BOARD2BASE, bad_K, max_rms_px=1.0)


def test_board_spec_parsing() -> None:
    s = BoardSpec.parse("charuco:7x5,0.04,0.03,DICT_5X5_100")
    assert (s.cols, s.rows, s.square_m, s.marker_m, s.dictionary) == (7, 5, 0.04, 0.03, "5X5_100")
    assert BoardSpec.parse("aprilgrid:6x4,0.04,0.01,apriltag_36H11").dictionary == "APRILTAG_36h11"
    assert BoardSpec.parse("aprilgrid:6x4,0.04,0.01").size_m == pytest.approx((0.29, 0.19))
    bad = {
        "charuco:7x5,0.04": "expected charuco",
        "charuco:7,0.04,0.03": "expected charuco",
        "charuco:7x5,0.03,0.04": "marker length must be in",
        "charuco:7x5,0.04,0.03,9X9_5": "unknown marker dictionary",
        "charuco:12x12,0.04,0.03": "needs 72 markers, more than DICT_4X4_50",
        "hexboard:3x3,1": "expected charuco",
        "checkerboard:1x5,0.04": "too small",
    }
    for text, why in bad.items():
        with pytest.raises(InvalidInput, match=f"^board_spec.*{why}"):
            BoardSpec.parse(text)
        with pytest.raises(InvalidInput, match=f"^--board.*{why}"):
            BoardSpec.parse(text, "--board")  # as calibrate names it


def test_rpy_closed_form() -> None:
    T = pose_from_xyz_rpy([0.1, 0.2, 0.3, 0.0, 0.0, 90.0])
    np.testing.assert_allclose(T[:3, :3] @ [1, 0, 0], [0, 1, 0], atol=1e-15)  # yaw: x -> y
    T = pose_from_xyz_rpy([0, 0, 0, 90.0, 0.0, 0.0])
    np.testing.assert_allclose(T[:3, :3] @ [0, 1, 0], [0, 0, 1], atol=1e-15)  # roll: y -> z
    T = pose_from_xyz_rpy([0, 0, 0, 90.0, 0.0, 90.0])  # roll first, then yaw (fixed axes)
    np.testing.assert_allclose(T[:3, :3] @ [0, 1, 0], [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(T[:3, :3] @ [1, 0, 0], [0, 1, 0], atol=1e-15)


# ---------------------------------------------------------------- the command


def test_print_board_is_detectable_at_its_printed_scale(tmp_path: Path, capsys) -> None:
    out = tmp_path / "board.png"
    assert main(["calibrate", "--print-board", str(out), "--board", CHARUCO, "--dpi", "100"]) == 0
    assert "print at 100 %" in capsys.readouterr().err
    from PIL import Image

    with Image.open(out) as im:
        assert im.info["dpi"] == pytest.approx((100, 100), abs=0.1)
        img = np.asarray(im.convert("L"))
    det = detect_board(img, BoardSpec.parse(CHARUCO))
    assert len(det.board_m) == 24
    # neighbouring corners one square (40 mm) apart = 40/25.4*100 px
    px = np.linalg.norm(det.image_px[1] - det.image_px[0])
    assert px == pytest.approx(0.04 / 0.0254 * 100, rel=0.01)


def test_calibrate_command_writes_extrinsics_record_accepts(
    tmp_path: Path, rng: np.random.Generator, capsys, fake_progress
) -> None:
    spec = BoardSpec.parse(CHARUCO)
    b2c = _board2camera(*VIEWS[1])
    image = tmp_path / "table.png"
    cv2.imwrite(str(image), _view(spec, b2c, rng))
    np.save(tmp_path / "K.npy", K_TRUE)
    out = tmp_path / "T.npy"
    argv = ["calibrate", str(image), "--board", CHARUCO, "--board-pose", "0.45,-0.14,0,0,0,90"]
    assert main([*argv, "--intrinsics", str(tmp_path / "K.npy"), "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "reprojection RMS" in err and "over 24 corners" in err
    T = load_extrinsics(out)
    dt, dR = _errors(T, b2c)
    assert dt < 0.002 and dR < 1.0
    # a video of the same view works too (frames spread over it)
    video = tmp_path / "table.mp4"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), 10, (1280, 720))
    for _ in range(5):
        writer.write(cv2.cvtColor(_view(spec, b2c, rng), cv2.COLOR_GRAY2BGR))
    writer.release()
    out2 = tmp_path / "T2.npy"
    argv[1] = str(video)
    import dexlfd._commands.calibrate as calibrate

    bars = fake_progress(calibrate)
    assert main([*argv, "--intrinsics", "910,905,641.3,358.7", "-o", str(out2)]) == 0
    assert "(5 of 5 image(s))" in capsys.readouterr().err
    assert [(b.desc, b.total, b.n) for b in bars] == [("calibrate: reading frames", 5, 5)]
    dt, dR = _errors(load_extrinsics(out2), b2c)
    assert dt < 0.003 and dR < 1.0


def test_calibrate_command_bad_inputs(tmp_path: Path, rng: np.random.Generator, capsys) -> None:
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((480, 640), 200, np.uint8))
    out = tmp_path / "T.npy"
    base = ["calibrate", str(blank), "--board", CHARUCO, "-o", str(out)]
    cases = [
        ([*base, "--board-pose", "1,2,3"], "--board-pose: expected x,y,z"),
        ([*base, "--board-pose", "0,0,0,0,0,0"], "no charuco:7x5"),
        ([*base[:-1], str(tmp_path / "T.txt"), "--board-pose", "0,0,0,0,0,0"], "must end in .npy"),
        (["calibrate", str(tmp_path / "none.png"), "--board", CHARUCO, "-o", str(out),
          "--board-pose", "0,0,0,0,0,0"], "no such file"),
        (["calibrate", str(blank), "--board", "charuco:7x5", "-o", str(out),
          "--board-pose", "0,0,0,0,0,0"], "--board: expected"),
    ]  # fmt: skip
    for argv, why in cases:
        assert main(argv) == 1
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1 and why in lines[0], (argv, lines)
    assert not out.exists()


@pytest.mark.parametrize("link", ["same", "symlink", "hardlink"])
def test_calibrate_never_overwrites_its_input_image(tmp_path: Path, capsys, link: str) -> None:
    """-o naming the input image (directly, by a symbolic or by a hard link) is refused."""
    image = tmp_path / "board.npy"  # an image file whose name ends like the output's
    np.save(image, np.full((48, 64), 200, np.uint8))
    before = image.read_bytes()
    out = {"same": image, "symlink": tmp_path / "s.npy", "hardlink": tmp_path / "h.npy"}[link]
    if link == "symlink":
        out.symlink_to(image)
    elif link == "hardlink":
        os.link(image, out)
    argv = ["calibrate", str(image), "--board", CHARUCO, "--board-pose", "0,0,0,0,0,0",
            "-o", str(out)]  # fmt: skip
    assert main(argv) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "refusing to overwrite an input" in err[0], err
    assert image.read_bytes() == before


@pytest.mark.parametrize(
    "spec, why",
    [
        ("charuco:7x5,35,26", "lengths are in metres, at most 0.5 m (0.035 if you meant"),
        ("checkerboard:9x6,25", "lengths are in metres"),
        ("charuco:1000x5,0.035,0.026", "at most 100 per side"),
    ],
)
def test_board_in_millimetres_is_refused_before_any_allocation(spec: str, why: str) -> None:
    with pytest.raises(InvalidInput, match=re.escape(why)):
        BoardSpec.parse(spec, "--board")


def test_board_pose_in_millimetres_is_refused(tmp_path: Path) -> None:
    from dexlfd.capture.calibration_files import load_board_pose

    with pytest.raises(InvalidInput, match=r"board2base: the board is .* m from the robot base"):
        load_board_pose("400,-120,0,0,0,90")
    T = np.eye(4)
    T[:3, 3] = [400.0, 0.0, 0.0]
    np.save(tmp_path / "far.npy", T)
    with pytest.raises(InvalidInput, match="0.4,0,0 if you meant millimetres"):
        load_board_pose(str(tmp_path / "far.npy"))
    assert load_board_pose("0.4,-0.12,0,0,0,90")[0, 3] == pytest.approx(0.4)


def test_extrinsics_with_the_translation_in_millimetres_is_refused(tmp_path: Path) -> None:
    T = np.eye(4)
    T[:3, 3] = [600.0, 0.0, 1000.0]  # mm
    np.save(tmp_path / "T.npy", T)
    with pytest.raises(InvalidInput, match=r"the camera is .* m from the robot base.*0\.6,0,1 if"):
        load_extrinsics(tmp_path / "T.npy")
    T[:3, 3] /= 1000
    save_extrinsics(tmp_path / "ok.npy", T)
    np.testing.assert_allclose(load_extrinsics(tmp_path / "ok.npy"), T)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["T.npy", "ok.npy"]


@pytest.mark.parametrize(
    "w, h, why",
    [
        (30000, 30000, r"900000000 pixels.*at most 100 megapixels"),  # past PIL's own bound
        (12000, 10000, r"a 12000x10000 image \(120 megapixels\); at most 100 megapixels"),
    ],
)
def test_a_huge_image_is_refused_from_its_header(tmp_path: Path, w: int, h: int, why: str) -> None:
    """A huge PNG (small on disk: a header only) is refused before it is decoded."""
    import struct
    import zlib

    from dexlfd.capture.calibration import read_images

    def chunk(kind: bytes, data: bytes) -> bytes:
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    ihdr = struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)  # 8-bit grey
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IEND", b"")
    path = tmp_path / "huge.png"
    path.write_bytes(png)
    with pytest.raises(InvalidInput, match=r"huge\.png: .*" + why):
        read_images(path)


@pytest.mark.parametrize(
    "board, dpi, why",
    [
        ("checkerboard:9x6,0.025", "4800", "megapixels are written (lower the dpi)"),
        ("charuco:7x5,0.035,0.026", "1e-300", "too few pixels for a 7x5 board"),
    ],
)
def test_print_board_dpi_that_cannot_make_a_page_is_one_line(
    tmp_path: Path, capsys, board: str, dpi: str, why: str
) -> None:
    out = tmp_path / "b.png"
    assert main(["calibrate", "--print-board", str(out), "--board", board, "--dpi", dpi]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--dpi" in err[0] and why in err[0], err
    assert not out.exists()


@pytest.mark.parametrize(
    "spec, why",
    [
        ("0.5,0.5,0.048,0.032", "must be in pixels, 10..1e+06 (millimetres or a normalised K?)"),
        ("1e308,1e308,320,240", "must be in pixels"),
        ("600,600,-5,240", "principal point"),
    ],
)
def test_intrinsics_that_are_not_pixels_are_refused(spec: str, why: str) -> None:
    with pytest.raises(InvalidInput, match=re.escape(why)):
        load_intrinsics(spec)


@pytest.mark.parametrize("angles", ["0,0,1e308", "0,360.5,0", "-400,0,0"])
def test_board_pose_angles_beyond_a_full_turn_are_refused(angles: str) -> None:
    from dexlfd.capture.calibration_files import load_board_pose

    with pytest.raises(InvalidInput, match=r"board2base: roll, pitch, yaw must be within -360"):
        load_board_pose(f"0.4,0,0,{angles}")
    assert load_board_pose("0.4,0,0,0,0,-360")[0, 3] == pytest.approx(0.4)  # the ends: kept


def test_reading_a_video_reports_every_frame_it_decodes_or_skips(tmp_path: Path) -> None:
    """50 frames, 10 used: every 5th; the progress callback sees frames 1..46 of 50."""
    import cv2

    from dexlfd.capture.calibration import read_images

    video = tmp_path / "board.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 10, (64, 48))
    for k in range(50):
        writer.write(np.full((48, 64, 3), 5 * k, dtype=np.uint8))
    writer.release()
    seen: list[tuple[int, float]] = []
    frames = read_images(video, 10, lambda i, n: seen.append((i, n)))
    assert len(frames) == 10
    assert [int(f[0, 0, 0]) for f in frames] == pytest.approx([25 * j for j in range(10)], abs=3)
    assert [i for i, _ in seen] == list(range(1, 47))
    assert {n for _, n in seen} == {50.0}
