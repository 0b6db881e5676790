"""Where `dexlfd record` writes: one file per pick-and-place, overlays and landmark
recordings next to a folder output, nothing left behind by a refused run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dexlfd.cli import main
from dexlfd.io import load_demonstration


def _noise_video(path: Path) -> Path:
    import cv2

    rng = np.random.default_rng(0)
    vw = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"mp4v"), 30.0, (160, 120))
    for _ in range(6):
        vw.write(rng.integers(0, 256, (120, 160, 3), dtype=np.uint8))
    vw.release()
    return path


def test_a_folder_output_with_an_overlay_file_and_landmarks_file(
    hand_video: Path, tmp_path: Path
) -> None:
    out, overlay, lms = tmp_path / "out", tmp_path / "x.mp4", tmp_path / "lm.npz"
    argv = ["record", str(hand_video), "-o", f"{out}/", "--overlay", str(overlay)]
    argv += ["--save-landmarks", str(lms), "--max-frames", "20", "--resize-width-px", "320"]
    assert main(argv) == 0
    assert overlay.stat().st_size > 0 and lms.stat().st_size > 0
    assert [p.name for p in out.iterdir()] == [f"{hand_video.stem}.npz"]
    # the same with folders: one file per SOURCE inside each
    ov_dir, lm_dir, out2 = tmp_path / "ov", tmp_path / "lms", tmp_path / "out2"
    argv = ["record", str(hand_video), "-o", f"{out2}/", "--overlay", f"{ov_dir}/"]
    argv += ["--save-landmarks", f"{lm_dir}/", "--max-frames", "20", "--resize-width-px", "320"]
    assert main(argv) == 0
    assert [p.name for p in ov_dir.iterdir()] == [f"{hand_video.stem}_overlay.mp4"]
    assert [p.name for p in lm_dir.iterdir()] == [f"{hand_video.stem}_landmarks.npz"]


def test_a_refused_or_failed_run_leaves_no_new_folder(tmp_path: Path, capsys) -> None:
    video = _noise_video(tmp_path / "noise.mp4")
    other = _noise_video(tmp_path / "other.mp4")
    # refused before any work: one overlay file for two SOURCEs
    argv = ["record", str(video), str(other), "-o", f"{tmp_path}/out/", "--overlay", "x.mp4"]
    assert main(argv) != 0
    err = capsys.readouterr().err
    assert "--overlay x.mp4: several SOURCEs write one file each" in err
    # failed while tracking (no hand in the video): the folders made for it are gone
    argv = ["record", str(video), "-o", f"{tmp_path}/out/", "--overlay", f"{tmp_path}/ov/"]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "no hand detected" in err and "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["noise.mp4", "other.mp4"]


def test_several_pick_and_places_with_a_file_output_are_numbered_files(
    shared_data: Path, tmp_path: Path, capsys
) -> None:
    src = shared_data / "landmarks" / "breakfast.npz"
    if not src.is_file():
        pytest.skip(f"{src} not found")
    out = tmp_path / "demo.npz"
    assert main(["record", str(src), "-o", str(out), "--camera-pose", "front"]) == 0
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["demo-1.npz", "demo-2.npz", "demo-3.npz"]
    starts = [load_demonstration(tmp_path / n).source_frames[0] for n in names]
    assert starts == sorted(starts)
    # a second run would write them again: refused before any work, files untouched
    before = (tmp_path / "demo-2.npz").read_bytes()
    assert main(["record", str(src), "-o", str(out)]) != 0
    err = capsys.readouterr().err
    assert "demo-1.npz" in err and "already exists" in err
    assert (tmp_path / "demo-2.npz").read_bytes() == before
