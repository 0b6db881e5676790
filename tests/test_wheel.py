"""A wheel built from the checkout, installed with its core dependencies only, runs the demo.

Slow (a fresh environment from the package index, ~1 GB, then the whole demo):
``make test-wheel`` runs it; ``make test`` leaves it out (marker ``wheel``).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

pytestmark = [pytest.mark.slow, pytest.mark.wheel]


def _run(cmd: list[str], **kw) -> subprocess.CompletedProcess[str]:
    return subprocess.run(cmd, capture_output=True, text=True, **kw)


def _source_copy(dest: Path) -> Path:
    """The checkout's files (tracked and new, not ignored), so the build writes only here."""
    out = _run(["git", "-C", str(REPO), "ls-files", "-z", "--cached", "--others",
                "--exclude-standard"], timeout=60)  # fmt: skip
    if out.returncode != 0:
        pytest.skip(f"not a git checkout: {out.stderr.strip()}")
    for rel in filter(None, out.stdout.split("\0")):
        src = REPO / rel
        if src.is_file():
            (dest / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / rel)
    return dest


def test_wheel_in_a_fresh_core_environment_runs_the_demo(tmp_path: Path) -> None:
    src = _source_copy(tmp_path / "src")
    dist = tmp_path / "dist"
    built = _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(dist),
                  str(src)], timeout=900)  # fmt: skip
    assert built.returncode == 0, built.stderr[-2000:]
    (wheel,) = dist.glob("dexlfd-*.whl")
    import zipfile

    names = set(zipfile.ZipFile(wheel).namelist())
    shipped = ["models/hand_landmarker_full.task", "models/LICENSE-mediapipe", "panda/LICENSE",
               "panda/urdf/panda.urdf", "human_hand_video.mp4"]  # fmt: skip
    for member in shipped:
        assert f"dexlfd/data/{member}" in names, member

    venv = tmp_path / "venv"
    base = getattr(sys, "_base_executable", sys.executable)
    assert _run([base, "-m", "venv", str(venv)], timeout=300).returncode == 0
    py = venv / "bin" / "python"
    inst = _run([str(py), "-m", "pip", "install", "-q", str(wheel)], timeout=1800)
    assert inst.returncode == 0, inst.stderr[-2000:]
    # the core only: no extra came along
    extras = [
        "ray",
        "rerun",
        "pyarrow",
        "imageio_ffmpeg",
        "rosbags",
        "pylibfranka",
        "panda_py",
        "cyclonedds",
    ]
    probe = f"import importlib.util as u; print([m for m in {extras!r} if u.find_spec(m)])"
    assert _run([str(py), "-c", probe], timeout=120).stdout.strip() == "[]"

    # as a user runs it: no MUJOCO_GL, no display, no source tree on the path
    drop = ("MUJOCO_GL", "PYOPENGL_PLATFORM", "DISPLAY", "WAYLAND_DISPLAY", "PYTHONPATH")
    env = {k: v for k, v in os.environ.items() if k not in drop}
    run = _run([str(venv / "bin" / "dexlfd"), "demo", "-o", str(tmp_path / "demo")],
               cwd=tmp_path, env=env, timeout=1800)  # fmt: skip
    assert run.returncode == 0, run.stderr[-3000:]
    manifest = json.loads((tmp_path / "demo" / "manifest.json").read_text())
    assert (tmp_path / "demo" / "report.html").is_file()
    assert (tmp_path / "demo" / "robot.mp4").stat().st_size > 10_000
    assert "pip install 'dexlfd[video]'" in run.stderr  # MPEG-4 fallback, said once
    assert "pip install 'dexlfd[ros]'" in run.stderr  # bags skipped, CSV written
    assert (tmp_path / "demo" / "export" / "rollout_100hz.csv").is_file()
    assert "Traceback" not in run.stderr
    assert manifest
