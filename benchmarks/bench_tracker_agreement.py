"""The default tracker (Tasks API, packaged bundle) against the legacy tracker's landmarks.

On all 621 frames of the packaged real video (1280 x 720): detection counts, the
landmark pixel distance to the legacy MediaPipe Hands of mediapipe 0.10.21
(median, p95, max), handedness labels and the time per frame. The legacy landmarks
are the recording in ``tests/capture/data`` (made with mediapipe 0.10.21, which
cannot be installed beside numpy 2); where the legacy tracker is installed it is
run too and compared with that recording.

    python benchmarks/bench_tracker_agreement.py
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from dexlfd.capture import MediaPipeTasksHands, TrackerConfig, open_source
from dexlfd.data import hand_video

REPO = Path(__file__).resolve().parents[1]
LEGACY = REPO / "tests" / "capture" / "data" / "legacy_landmarks_human_hand_video.npz"


def _track(tracker) -> tuple[np.ndarray, list[str], list[float]]:
    uv, labels, dt = [], [], []
    with open_source(hand_video()) as src, tracker:
        for i, frame in enumerate(src):
            t0 = time.perf_counter()
            hands = tracker.detect(frame.rgb, i / 30.0)
            dt.append(time.perf_counter() - t0)
            uv.append(hands[0].uv_px if hands else np.full((21, 2), np.nan))
            labels.append(hands[0].handedness if hands else "")
    return np.array(uv), labels, dt


def _report(name: str, uv: np.ndarray, labels: list[str], dt: list[float], ref: np.ndarray):
    seen = np.isfinite(uv[:, 0, 0])
    both = seen & np.isfinite(ref[:, 0, 0])
    err = np.linalg.norm(uv[both] - ref[both], axis=2)
    ms = 1e3 * np.asarray(dt)
    print(
        f"{name}: hand in {seen.sum()}/{len(uv)} frames (legacy {np.isfinite(ref[:, 0, 0]).sum()});"
        f" landmark distance to legacy median {np.median(err):.3f} px, p95"
        f" {np.percentile(err, 95):.3f} px, max {err.max():.2f} px;"
        f" labels {sorted(set(labels))}; {np.median(ms):.1f} ms/frame median"
        f" (p90 {np.percentile(ms, 90):.1f}, first {ms[0]:.0f})"
    )


def main() -> None:
    import cv2
    import mediapipe

    rec = np.load(LEGACY, allow_pickle=False)
    legacy = rec["uv_px"]
    print(f"reference: {rec['tracker']}")
    print(
        f"now: mediapipe {mediapipe.__version__}, opencv {cv2.__version__}, numpy {np.__version__}"
    )
    _report("mediapipe-tasks (packaged full bundle)", *_track(MediaPipeTasksHands()), legacy)
    try:
        from dexlfd.capture import MediaPipeHands

        live = MediaPipeHands(TrackerConfig(backend="mediapipe"))
    except ImportError:
        print("legacy tracker not installed (mediapipe 0.10.21): compared with the recording only")
        return
    _report("mediapipe legacy (live)", *_track(live), legacy)


if __name__ == "__main__":
    main()
