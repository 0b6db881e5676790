"""The real sample video ships inside the package and the demo finds it there."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import zipfile
from importlib import resources
from pathlib import Path

import pytest

import dexlfd.data
from dexlfd.data import SAMPLE_FILES, sample_path
from dexlfd.data import hand_video as packaged_video
from dexlfd.errors import InvalidInput

REPO = Path(__file__).resolve().parents[2]


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_packaged_video_is_the_real_recording_byte_for_byte(shared_data: Path) -> None:
    hand_video = shared_data / "human_hand_video.mp4"
    assert _sha256(packaged_video()) == _sha256(hand_video)
    packaged_licence = (
        sample_path("human_hand_video.mp4").parent / SAMPLE_FILES["human_hand_video.mp4"]
    )
    assert (
        packaged_licence.read_text()
        == (hand_video.parent / "licenses" / "dex-retargeting-LICENSE").read_text()
    )


def test_sample_is_found_through_importlib_resources_inside_the_package() -> None:
    path = packaged_video()
    via_resources = resources.files("dexlfd.data") / "human_hand_video.mp4"
    assert Path(str(via_resources)) == path
    assert path.parent == Path(dexlfd.data.__file__).parent
    text = (path.parent / "README.md").read_text()
    assert "Yuzhe Qin" in text and "MIT" in text
    assert "Copyright (c) 2023 Yuzhe Qin" in (path.parent / "LICENSE-human_hand_video").read_text()


def test_unknown_sample_is_a_clear_error() -> None:
    with pytest.raises(InvalidInput, match="unknown sample 'nope.mp4'"):
        sample_path("nope.mp4")


def test_demo_real_video_stage_uses_the_packaged_file() -> None:
    from dexlfd.apps.demo import DemoConfig

    cfg = DemoConfig()
    assert cfg.real_video == packaged_video()
    # nothing outside the installed package is looked at
    src = (REPO / "src" / "dexlfd" / "apps" / "demo.py").read_text()
    assert "shared" not in src and "parents[" not in src


@pytest.mark.slow
def test_installed_wheel_alone_carries_the_sample(tmp_path: Path) -> None:
    """Build the wheel, install it into an empty folder and ask it for its sample."""
    import shutil

    # build from a copy: setuptools writes build/ and *.egg-info next to the sources,
    # and a test writes only under its temporary folder
    project = tmp_path / "project"
    project.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(REPO / name, project / name)
    skip = shutil.ignore_patterns("__pycache__", "*.egg-info", "*.nbi", "*.nbc")
    shutil.copytree(REPO / "src", project / "src", ignore=skip)
    wheels = tmp_path / "wheels"
    built = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheels), str(project)],
        capture_output=True, text=True, check=False, timeout=600,
    )  # fmt: skip
    if built.returncode != 0:
        pytest.skip(f"cannot build the wheel here: {built.stderr.strip().splitlines()[-1:]}")
    (wheel,) = wheels.glob("dexlfd-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    for name in ("human_hand_video.mp4", "LICENSE-human_hand_video", "README.md"):
        assert f"dexlfd/data/{name}" in names
    assert "dexlfd/apps/templates/demo_report.ini" in names  # the demo report's prose
    target = tmp_path / "site"
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(target),
         str(wheel)],
        check=True, capture_output=True, timeout=600,
    )  # fmt: skip
    code = (
        "import dexlfd, hashlib; from dexlfd.apps.demo import DemoConfig; "
        "p = DemoConfig().real_video; "
        "print(dexlfd.__file__); print(p); print(hashlib.sha256(p.read_bytes()).hexdigest())"
    )
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "DEXLFD_SHARED")}
    env["PYTHONPATH"] = str(target)
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
        check=True, timeout=300,
    ).stdout.split()  # fmt: skip
    pkg, video, digest = Path(out[0]), Path(out[1]), out[2]
    assert pkg.is_relative_to(target) and video.is_relative_to(target)
    assert digest == _sha256(packaged_video())
