"""The Tasks-API backend ("mediapipe-tasks", the default) against the legacy tracker.

The legacy tracker (mediapipe 0.10.21, numpy < 2) cannot be installed beside a
current mediapipe: its landmarks on the packaged video were recorded once
(``data/legacy_landmarks_human_hand_video.npz``, all 621 frames, with the
recording's versions in its ``tracker`` field) and the Tasks backend is checked
against that file; where the legacy tracker is installed it is run as well.
"""

from __future__ import annotations

import hashlib
import importlib.util
import io
import zipfile
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from dexlfd.capture import (
    CaptureConfig,
    LiftConfig,
    MediaPipeHands,
    MediaPipeTasksHands,
    TrackerConfig,
    open_source,
    track_source,
)
from dexlfd.capture.tracking import make_tracker
from dexlfd.capture.tracking_tasks import (
    BUNDLE_MEMBERS,
    PACKAGED_TASKS,
    hand_landmarker_bundle,
    packaged_hand_landmarker,
)
from dexlfd.errors import InvalidFile, InvalidInput

N_FRAMES = 120  # the first 4 s: open hand, a pinch, thumb on the middle finger
LEGACY = Path(__file__).with_name("data") / "legacy_landmarks_human_hand_video.npz"
# the checksums the data/models README gives
SHA256 = {
    1: "ef3f184fa8d5e6905ea4770282627d6937975119af763054312d05985c059bda",
    0: "289792129ee0ea8fdb6a128dc95b76b6a22f8f3f3780fe5af9b46f33239a9a76",
}


def _has_legacy_models() -> bool:
    """mediapipe 0.10.21 (legacy API and its model files) is installed."""
    try:
        if importlib.util.find_spec("mediapipe.python.solutions") is None:
            return False
        models = resources.files("mediapipe.modules.hand_landmark")
    except ModuleNotFoundError:
        return False
    return (models / "hand_landmark_full.tflite").is_file()


def _frames(video: Path, n: int = N_FRAMES) -> list[np.ndarray]:
    with open_source(video, max_frames=n) as src:
        return [f.rgb for f in src]


def _track(tracker, frames: list[np.ndarray]) -> tuple[np.ndarray, list[str]]:
    uv, labels = [], []
    with tracker:
        for i, rgb in enumerate(frames):
            hands = tracker.detect(rgb, i / 30.0)
            uv.append(hands[0].uv_px if hands else np.full((21, 2), np.nan))
            labels.append(hands[0].handedness if hands else "")
    return np.array(uv), labels


def test_packaged_bundles_hold_both_models_and_their_licence() -> None:
    models = resources.files("dexlfd.data") / "models"
    assert "Apache License" in (models / "LICENSE-mediapipe").read_text()
    for complexity in PACKAGED_TASKS:
        data = packaged_hand_landmarker(complexity)
        assert hashlib.sha256(data).hexdigest() == SHA256[complexity]
        zf = zipfile.ZipFile(io.BytesIO(data))
        assert set(zf.namelist()) == {"hand_detector.tflite", "hand_landmarks_detector.tflite"}
        for member in zf.namelist():
            assert zf.read(member)[4:8] == b"TFL3"  # a TFLite flatbuffer
    with pytest.raises(InvalidInput, match="model_complexity"):
        packaged_hand_landmarker(2)


@pytest.mark.skipif(not _has_legacy_models(), reason="needs mediapipe 0.10.21 (its own models)")
def test_packaged_bundles_are_rebuilt_byte_for_byte_from_the_legacy_wheel() -> None:
    for complexity, members in BUNDLE_MEMBERS.items():
        data = hand_landmarker_bundle(complexity)
        assert data == packaged_hand_landmarker(complexity)
        zf = zipfile.ZipFile(io.BytesIO(data))
        for member, (package, name) in members.items():
            assert zf.read(member) == (resources.files(package) / name).read_bytes()
    with pytest.raises(InvalidInput, match="model_complexity"):
        hand_landmarker_bundle(2)


def test_backend_is_the_default_and_selectable_by_name() -> None:
    assert TrackerConfig().backend == "mediapipe-tasks"
    tracker = make_tracker(TrackerConfig(backend="mediapipe-tasks"))
    try:
        assert isinstance(tracker, MediaPipeTasksHands)
        assert tracker.detect(np.zeros((90, 160, 3), np.uint8), 0.0) == []
        # a frame time that does not advance is moved past the previous one, not refused
        assert tracker.detect(np.zeros((90, 160, 3), np.uint8), 0.0) == []
        with pytest.raises(InvalidInput, match="uint8"):
            tracker.detect(np.zeros((90, 160), np.uint8), 0.1)
    finally:
        tracker.close()
    with pytest.raises(InvalidInput, match="after close"):
        tracker.detect(np.zeros((90, 160, 3), np.uint8), 0.2)


def test_bad_task_files_are_refused_with_the_reason(tmp_path: Path) -> None:
    with pytest.raises(InvalidFile, match="no such file"):
        MediaPipeTasksHands(task=tmp_path / "missing.task")
    (tmp_path / "text.task").write_text("not a bundle")
    with pytest.raises(InvalidFile, match="not a zip"):
        MediaPipeTasksHands(task=tmp_path / "text.task")
    with zipfile.ZipFile(tmp_path / "half.task", "w") as zf:
        zf.writestr("hand_detector.tflite", b"")
    with pytest.raises(InvalidFile, match="hand_landmarks_detector.tflite"):
        MediaPipeTasksHands(task=tmp_path / "half.task")


def _agree_with_legacy(tasks: np.ndarray, labels: list[str], legacy: np.ndarray) -> None:
    seen = np.isfinite(legacy[:, 0, 0])
    assert seen.all() and np.array_equal(seen, np.isfinite(tasks[:, 0, 0]))
    err = np.linalg.norm(tasks - legacy, axis=2)  # (frames, 21) [px] on 1280 x 720
    assert np.median(err) <= 1.0  # measured 0.06 px (mediapipe 0.10.21), 0.24 px (1.2.3)
    assert np.percentile(err, 95) <= 2.0
    # the person's right hand (each API's own label convention undone)
    assert set(labels) == {"right"}


@pytest.mark.slow
def test_same_landmarks_as_the_recorded_legacy_tracker_on_the_packaged_video(
    hand_video: Path,
) -> None:
    rec = np.load(LEGACY, allow_pickle=False)
    assert "legacy Hands" in str(rec["tracker"]) and rec["uv_px"].shape == (621, 21, 2)
    assert set(rec["handedness"].tolist()) == {"right"}
    frames = _frames(hand_video)
    tasks, labels = _track(MediaPipeTasksHands(), frames)
    _agree_with_legacy(tasks, labels, rec["uv_px"][:N_FRAMES])


@pytest.mark.slow
@pytest.mark.skipif(not _has_legacy_models(), reason="needs mediapipe 0.10.21 (legacy API)")
def test_same_landmarks_as_the_live_legacy_tracker(hand_video: Path) -> None:
    frames = _frames(hand_video)
    legacy, legacy_labels = _track(MediaPipeHands(TrackerConfig(backend="mediapipe")), frames)
    assert set(legacy_labels) == {"right"}
    np.testing.assert_allclose(
        legacy, np.load(LEGACY, allow_pickle=False)["uv_px"][:N_FRAMES], atol=1e-3
    )
    tasks, labels = _track(MediaPipeTasksHands(), frames)
    _agree_with_legacy(tasks, labels, legacy)


@pytest.mark.slow
def test_user_supplied_task_and_the_capture_session(hand_video: Path, tmp_path: Path) -> None:
    bundle = tmp_path / "hand_landmarker.task"
    bundle.write_bytes(packaged_hand_landmarker(1))
    frames = _frames(hand_video, 30)
    built, _ = _track(MediaPipeTasksHands(), frames)
    user, _ = _track(MediaPipeTasksHands(task=bundle), frames)
    np.testing.assert_array_equal(built, user)
    cfg = CaptureConfig(
        tracker=TrackerConfig(backend="mediapipe-tasks"), lift=LiftConfig(model="assumed_depth")
    )
    with open_source(hand_video, max_frames=30) as src:
        series = track_source(src, cfg)
    assert series.valid.all() and series.majority_hand == "right"
    np.testing.assert_allclose(series.uv_px, built, atol=1e-9)
