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
from dexlfd.data import SAMPLE_FILES, pick_place_video, sample_path
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


def _frame_digests(path: Path) -> list[str]:
    import cv2

    cap = cv2.VideoCapture(str(path))
    digests = []
    try:
        while True:
            ok, frame = cap.read()
            if not ok:
                return digests
            digests.append(hashlib.sha256(frame.tobytes()).hexdigest())
    finally:
        cap.release()


def test_packaged_pick_and_place_is_the_real_clip_cut_without_reencoding(
    shared_data: Path,
) -> None:
    """Frames 128-992 of the original, each decoding to the same pixels; licence kept."""
    original = shared_data / "videos" / "lfo_place_can.webm"
    if not original.is_file():
        pytest.skip(f"real video not found at {original}")
    packaged = pick_place_video()
    kept = _frame_digests(packaged)
    full = _frame_digests(original)
    assert len(full) == 1003 and len(kept) == 865
    assert kept == full[128:993]
    licence = packaged.parent / SAMPLE_FILES["lfo_place_can.webm"]
    assert (
        licence.read_text()
        == (shared_data / "licenses" / "symbolic-robot-teaching-interface-LICENSE").read_text()
    )
    assert packaged.stat().st_size < original.stat().st_size


def test_pick_and_place_sample_is_documented_and_licensed_beside_it() -> None:
    path = pick_place_video()
    assert path == sample_path("lfo_place_can.webm")
    assert path.parent == Path(dexlfd.data.__file__).parent
    licence = (path.parent / "LICENSE-lfo_place_can").read_text()
    assert "MIT License" in licence and "Copyright (c) Microsoft Corporation" in licence
    readme = (path.parent / "README.md").read_text()
    row = next(line for line in readme.splitlines() if line.startswith("| `lfo_place_can.webm`"))
    assert "Microsoft Corporation" in row and "Modified" in row and "865 frames" in row


def test_python_m_dexlfd_data_prints_the_sample_paths() -> None:
    run = [sys.executable, "-m", "dexlfd.data"]
    listed = subprocess.run(run, capture_output=True, text=True, check=True).stdout
    assert str(pick_place_video()) in listed and str(packaged_video()) in listed
    one = subprocess.run(
        [*run, "lfo_place_can.webm"], capture_output=True, text=True, check=True
    ).stdout
    assert one.strip() == str(pick_place_video())
    bad = subprocess.run([*run, "nope.webm"], capture_output=True, text=True, check=False)
    assert bad.returncode == 1
    assert bad.stderr.strip().splitlines() == [
        "error: unknown sample 'nope.webm': expected one of "
        "['human_hand_video.mp4', 'lfo_place_can.webm']"
    ]


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
    for name in (
        "human_hand_video.mp4", "LICENSE-human_hand_video", "README.md",
        "lfo_place_can.webm", "LICENSE-lfo_place_can",
    ):  # fmt: skip
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
