r"""``dexlfd calibrate``: camera -> robot base transform from an image of a printed board.

Examples
--------
    dexlfd calibrate --print-board board.png --board charuco:7x5,0.04,0.03
    dexlfd calibrate table.jpg --board charuco:7x5,0.04,0.03 \
        --board-pose 0.45,-0.15,0,0,0,90 --intrinsics K.yaml -o camera2base.npy
    dexlfd record hand.mp4 --intrinsics K.yaml --extrinsics camera2base.npy -o demo.npz
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import Any

from dexlfd._commands._common import bounded_float, output_file, progress
from dexlfd._commands._fields import add_params
from dexlfd._commands._outputs import check_outputs
from dexlfd.errors import InvalidInput

logger = logging.getLogger(__name__)

MAX_RMS_PX = 100.0  # largest --max-rms-px [px]: beyond it no fit is rejected
MAX_DPI = 4800.0  # largest --dpi [dots per inch]: beyond any printer


HELP = "camera -> robot base transform from a printed board (writes --extrinsics)"


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    from dexlfd.capture.board import BOARD_HELP

    p: argparse.ArgumentParser = sub.add_parser(
        name,
        help=HELP,
        description="Find the camera's pose in the robot base frame from one image or a "
        "video of a printed board lying at a known pose; or print such a board.",
    )
    p.add_argument(
        "source", nargs="?", metavar="IMAGE_OR_VIDEO", help="image or video of the board"
    )
    p.add_argument("--board", required=True, metavar="SPEC", help=BOARD_HELP + "; lengths [m]")
    p.add_argument(
        "--board-pose",
        metavar="X,Y,Z,ROLL,PITCH,YAW|FILE",
        help="the board frame in the robot base frame: x,y,z [m] (within 5 m of the base) "
        "and roll,pitch,yaw [deg] (each within -360..360; R = Rz(yaw) Ry(pitch) Rx(roll)), "
        "or a 4x4 .npy; board frame: origin at the pattern's bottom-left corner as "
        "printed, x right, y up, z out of the page",
    )
    p.add_argument(
        "--intrinsics",
        metavar="FX,FY,CX,CY|FILE",
        help="camera intrinsics: fx,fy,cx,cy [px] at the image's size, or a K file "
        "(.npy, .json, OpenCV/ROS .yaml/.xml); the same as for record",
    )
    from dexlfd.capture import CaptureConfig

    guess = "the camera's distance is only as right as this guess"
    add_params(p, CaptureConfig, ["assumed_hfov_deg"], notes={"assumed_hfov_deg": guess})
    p.add_argument("-o", "--output", help="extrinsics file to write (.npy, camera->base 4x4)")
    p.add_argument(
        "--max-frames",
        type=int,
        default=30,
        help="video: frames used, spread evenly (default: %(default)s)",
    )
    p.add_argument(
        "--min-corners", type=int, default=6, help="fewest board corners accepted (default 6)"
    )
    p.add_argument(
        "--max-rms-px",
        type=bounded_float(0.0, MAX_RMS_PX, lo_open=True, unit="px"),
        default=3.0,
        help="largest accepted reprojection RMS [px] (default: %(default)s); "
        f"accepted (0, {MAX_RMS_PX:g}]",
    )
    p.add_argument(
        "--print-board",
        metavar="PNG",
        help="instead: write a printable image of --board here (print at 100 %%)",
    )
    p.add_argument(
        "--dpi",
        type=bounded_float(0.0, MAX_DPI, lo_open=True, unit="dpi"),
        default=300.0,
        help="resolution of --print-board [dots per inch] (default: %(default)s); "
        f"accepted (0, {MAX_DPI:g}]",
    )
    return p


def run(args: argparse.Namespace) -> int:
    """Print a board, or calibrate and write the extrinsics file."""
    from dexlfd.capture.board import BoardSpec
    from dexlfd.capture.calibration_files import save_extrinsics

    spec = BoardSpec.parse(args.board, "--board")
    if args.print_board:
        return _print_board(args, spec)
    out = _check_calibrate_args(args)
    res = _calibrate(args, spec)
    save_extrinsics(out, res.camera2base)
    x, y, z = res.camera2base[:3, 3]
    view = res.camera2base[:3, 2]  # the optical axis in the base frame
    board_dist = float((res.board2camera[:3, 3] ** 2).sum() ** 0.5)
    logger.info(
        "wrote %s: reprojection RMS %.2f px over %d corners (%d of %d image(s)); camera at "
        "(%.3f, %.3f, %.3f) m in the base frame looking along (%.2f, %.2f, %.2f), board "
        "%.2f m away%s",
        out,
        res.rms_px,
        res.n_points,
        res.n_frames,
        res.n_images,
        x,
        y,
        z,
        *view,
        board_dist,
        "; intrinsics ASSUMED (--fov-deg)" if res.intrinsics.approximate else "",
    )
    return 0


def _print_board(args: argparse.Namespace, spec: Any) -> int:
    """``--print-board``: write the printable board image."""
    from dexlfd.capture.board import print_board

    out = output_file(args.print_board, "--print-board", ".png")
    if args.source:
        raise InvalidInput("--print-board writes a board; give no IMAGE_OR_VIDEO with it")
    print_board(spec, out, args.dpi)
    w, h = spec.size_m
    logger.info(
        "wrote %s: %s, pattern %.0f x %.0f mm at %g dpi; print at 100 %% (no 'fit to "
        "page') and check a square with a ruler",
        out,
        spec.describe(),
        w * 1000,
        h * 1000,
        args.dpi,
    )
    return 0


def _check_calibrate_args(args: argparse.Namespace) -> Path:
    """The output file, once the flags a calibration needs are there and in range."""
    if not args.source:
        raise InvalidInput("calibrate: give IMAGE_OR_VIDEO (or --print-board PNG)")
    if not args.output:
        raise InvalidInput("-o/--output: required (the extrinsics .npy to write)")
    if not args.board_pose:
        raise InvalidInput("--board-pose: required (the board frame in the robot base frame)")
    # the output is never the input image, also through a symbolic or hard link
    (out,) = check_outputs([("-o/--output", args.output, ".npy")], inputs=[args.source])
    assert out is not None
    if args.max_frames < 1 or args.min_corners < 4:
        raise InvalidInput("--max-frames must be >= 1 and --min-corners >= 4")
    return out


def _calibrate(args: argparse.Namespace, spec: Any) -> Any:
    """The :class:`~dexlfd.capture.calibration.CameraPose` of the images and flags."""
    from dexlfd.capture import Intrinsics
    from dexlfd.capture.calibration import calibrate_camera, read_images
    from dexlfd.capture.calibration_files import load_board_pose, load_intrinsics

    board2base = load_board_pose(args.board_pose, "--board-pose")
    with progress(None, "calibrate: reading frames", quiet=args.quiet) as bar:

        def _tick(i: int, n: float) -> None:
            if bar.total is None and n > 0:  # the frames read: up to the last one used
                step = max(1, int(n) // args.max_frames)
                bar.total = min(int(n), (args.max_frames - 1) * step + 1)
                bar.refresh()
            bar.update(1)

        images = read_images(args.source, args.max_frames, _tick)
    K = None
    if args.intrinsics:
        (fx, fy, cx, cy), size = load_intrinsics(args.intrinsics, "--intrinsics")
        h, w = images[0].shape[:2]
        size = size or (w, h)
        K = Intrinsics(size[0], size[1], fx, fy, cx, cy)
    return calibrate_camera(
        images,
        spec,
        board2base,
        K,
        fov_deg=args.fov_deg,
        min_points=args.min_corners,
        max_rms_px=args.max_rms_px,
        source=str(args.source),
    )
