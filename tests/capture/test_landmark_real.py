"""The real landmark recordings (MediaPipe on real pick-and-place videos) through the CLI."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from dexlfd.cli import main
from dexlfd.io import load_demonstration
from dexlfd.io.model import load_model

# ../shared/data beside the checkout (DEXLFD_SHARED overrides ../shared, as in conftest)
SHARED = Path(
    os.environ.get("DEXLFD_SHARED", Path(__file__).resolve().parents[2] / ".." / "shared")
)
LANDMARKS = SHARED / "data" / "landmarks"
NAMES = ("bagging", "breakfast", "llama", "plush_toy", "rearrange")


@pytest.fixture
def landmark_files() -> list[Path]:
    files = [LANDMARKS / f"{name}.npz" for name in NAMES]
    missing = [f.name for f in files if not f.is_file()]
    if missing:
        pytest.skip(f"real landmark recordings not found in {LANDMARKS}: {', '.join(missing)}")
    return files


@pytest.mark.integration
def test_the_real_recordings_go_through_record_and_learn(
    landmark_files: list[Path], tmp_path: Path, capsys
) -> None:
    out = tmp_path / "demos"
    argv = ["record", *map(str, landmark_files), "-o", f"{out}/", "--camera-pose", "front"]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "recorded 5 of 5 video(s)" in err and "Traceback" not in err
    assert err.count("camera motion cannot be checked") == 5  # no camera_motion in them
    demos = {}
    written = []
    for f in landmark_files:
        # one file per pick-and-place: NAME.npz, or NAME-1.npz, NAME-2.npz, ...
        mine = sorted(out.glob(f"{f.stem}.npz")) or sorted(out.glob(f"{f.stem}-*.npz"))
        assert mine, f.stem
        written += mine
        demo = load_demonstration(mine[0])
        with np.load(f, allow_pickle=False) as raw:
            t_s, size = raw["t_s"], raw["frame_size_px"].tolist()
        rec_n = int(t_s.size)
        assert demo.meta["capture"]["source_kind"] == "landmarks"
        assert 0 < demo.n_samples <= rec_n
        # the recording's time axis is kept (trim only cuts)
        assert np.isin(np.round(demo.t, 9), np.round(t_s, 9)).all()
        K = demo.meta["capture"]["intrinsics"]
        assert [K["width"], K["height"]] == size and K["approximate"]
        assert demo.quality.recording_frames == rec_n
        assert demo.meta["capture"]["camera_motion"] == {"checked": False, "moving": None}
        assert "camera_motion" not in demo.extras
        demos[f.stem] = demo
    model = tmp_path / "model.npz"
    # bagging loses the chips hand for 1.5 s while it drops them into the bag (a person sees it)
    argv = ["learn", *map(str, written), "--max-gap-s", "2", "-o", str(model)]
    assert main(argv) == 0
    assert load_model(model).mean.shape[1] == 8
