"""Landmark recordings and camera-motion check: re-processing time and the tracking overhead.

Prints:
* per real landmark recording (``../shared/data/landmarks/*.npz``, skipped when absent):
  ``record FILE.npz`` wall time with the defaults, with other ``--intrinsics`` and with
  another ``--fov-deg`` (re-processing without the video), and the verdict line;
* the camera-motion estimate (``capture/camera_motion.py``) on real videos with still
  cameras (the packaged hand video, the two-camera pair if present): background shift,
  zoom and rotation extents and the ``moving`` verdict (must be False);
* ``record`` speed at 1920x1080 (the packaged video upscaled, 2 hands tracked as
  ``record`` does) as a ratio to decode + MediaPipe alone in the same run, alternating
  the two (median of REPEATS), and the estimator's own cost per frame at 1080p beside
  MediaPipe's, interleaved on the same frames (robust to the machine's load).

Run: ``PYTHONPATH=src python benchmarks/bench_landmarks.py [--no-speed]``.
"""

from __future__ import annotations

import logging
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

# ../shared/data beside the checkout; DEXLFD_SHARED overrides ../shared (as in the tests)
SHARED = Path(
    os.environ.get("DEXLFD_SHARED", Path(__file__).resolve().parents[1] / ".." / "shared")
)
SHARED = SHARED / "data"
REPEATS = 3
N_1080 = 120


def reprocess() -> None:
    from dexlfd.cli import main as cli

    files = sorted((SHARED / "landmarks").glob("*.npz"))
    if not files:
        print(f"(no landmark recordings in {SHARED / 'landmarks'})")
        return
    print("== record FILE.npz (re-processing a landmark recording, no video) [s]")
    with tempfile.TemporaryDirectory() as tmp:
        from dexlfd.io import load_demonstration

        for f in files:
            times, verdicts = [], []
            for extra in ([], ["--intrinsics", "800,800,320,240"], ["--fov-deg", "45"]):
                t0 = time.perf_counter()
                cli(["record", str(f), "-o", f"{tmp}/{f.stem}.npz", "-q", *extra])
                times.append(time.perf_counter() - t0)
                verdicts.append(load_demonstration(f"{tmp}/{f.stem}.npz").quality)
            q = verdicts[0]  # the defaults'
            verdict = "usable" if q.usable else "NOT USABLE: " + "; ".join(q.warnings)
            print(
                f"{f.stem:10s} defaults {times[0]:.2f}, --intrinsics {times[1]:.2f}, "
                f"--fov-deg 45 {times[2]:.2f} | {verdict}"
            )


def still_cameras() -> None:
    from dexlfd.apps.record import RecordConfig, record_demonstration
    from dexlfd.data import hand_video

    print("== camera motion on real videos filmed by still cameras (moving must be False)")
    videos = [str(hand_video())]
    videos += [str(p) for p in sorted(SHARED.glob("mimicplay_play_cam*.mp4"))]
    for v in videos:
        try:
            res = record_demonstration(v, RecordConfig(trim=False))
        except Exception as exc:  # noqa: BLE001 - a figure, not a test
            print(f"{Path(v).name}: {exc}")
            continue
        c = res.demo.meta["capture"]["camera_motion"]
        print(
            f"{Path(v).name:26s} moving={c['moving']}, shift {100 * c['shift_extent']:.2f} % "
            f"of the width, zoom {100 * c['zoom_extent']:.2f} %, rotation "
            f"{c['rotation_extent_deg']:.2f} deg, measured in {100 * c['frames_measured']:.0f} "
            f"% of frames, moving frames {c['moving_frames']}"
        )


def upscaled(tmp: str, n: int = N_1080) -> Path:
    import cv2

    from dexlfd.data import hand_video

    out = Path(tmp) / "hand_1080p.mp4"
    cap = cv2.VideoCapture(str(hand_video()))
    vw = cv2.VideoWriter(str(out), cv2.VideoWriter.fourcc(*"mp4v"), 30.0, (1920, 1080))
    for _ in range(n):
        ok, bgr = cap.read()
        if not ok:
            break
        vw.write(cv2.resize(bgr, (1920, 1080), interpolation=cv2.INTER_LINEAR))
    cap.release()
    vw.release()
    return out


def raw_fps(video: Path, n_hands: int = 2) -> float:
    """Decode + the hand tracker alone (``record``'s tracker and settings), frames per second."""
    import cv2

    from dexlfd.capture.tracking import TrackerConfig, make_tracker

    t0 = time.perf_counter()
    tracker = make_tracker(TrackerConfig(max_num_hands=n_hands))
    cap = cv2.VideoCapture(str(video))
    n = 0
    while True:
        ok, bgr = cap.read()
        if not ok:
            break
        tracker.detect(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), n / 30.0)
        n += 1
    cap.release()
    tracker.close()
    return n / (time.perf_counter() - t0)


def record_fps(video: Path, n: int, motion: bool = True) -> float:
    """``record`` frames per second; ``motion=False``: the camera-motion check switched off."""
    from dexlfd.capture import camera_motion
    from dexlfd.cli import main as cli

    update = camera_motion.CameraMotionEstimator.update_grey  # what record's tap calls
    if not motion:  # each frame an unmeasured row, no image work past the shared grey copy

        def skip(self: camera_motion.CameraMotionEstimator, *args: object) -> None:
            self.rows.append(camera_motion.NAN_ROW)

        camera_motion.CameraMotionEstimator.update_grey = skip  # type: ignore[method-assign]
    try:
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            assert cli(["record", str(video), "-o", f"{tmp}/d.npz", "-q"]) == 0
            return n / (time.perf_counter() - t0)
    finally:
        camera_motion.CameraMotionEstimator.update_grey = update  # type: ignore[method-assign]


def estimator_share(video: Path) -> tuple[float, float]:
    """Median ms/frame of MediaPipe (2 hands) and of CameraMotionEstimator.update on the
    same decoded 1080p frames, interleaved frame by frame (the same CPU contention)."""
    from dexlfd.capture import open_source
    from dexlfd.capture.camera_motion import CameraMotionEstimator
    from dexlfd.capture.tracking import TrackerConfig, make_tracker

    with open_source(video) as src:
        frames = [f.rgb for f in src]
    tracker = make_tracker(TrackerConfig(max_num_hands=2))
    est = CameraMotionEstimator()
    t_mp, t_est = [], []
    for i, rgb in enumerate(frames):
        t0 = time.perf_counter()
        hands = tracker.detect(rgb, i / 30.0)
        t1 = time.perf_counter()
        boxes = [h.uv_px for h in hands]
        t2 = time.perf_counter()
        est.update(rgb, boxes)
        t_mp.append(t1 - t0)
        t_est.append(time.perf_counter() - t2)
    tracker.close()
    return 1e3 * float(np.median(t_mp)), 1e3 * float(np.median(t_est))


def speed() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        video = upscaled(tmp)
        raw, rec, off = [], [], []
        for k in range(REPEATS):
            for what in ("raw", "rec", "off") if k % 2 == 0 else ("off", "rec", "raw"):
                if what == "raw":
                    raw.append(raw_fps(video))
                elif what == "rec":
                    rec.append(record_fps(video, N_1080))
                else:
                    off.append(record_fps(video, N_1080, motion=False))
        r, p, q = (float(np.median(x)) for x in (raw, rec, off))
        print(f"== 1920x1080 ({N_1080} frames, upscaled), 2 hands, median of {REPEATS} runs")
        print(f"decode+MediaPipe {r:5.1f} fps; record {p:5.1f} fps (ratio {p / r:.2f}); record "
              f"with the camera-motion check off {q:5.1f} fps (ratio {q / r:.2f})")  # fmt: skip
        mp_ms, est_ms = estimator_share(video)
        share = 100 * est_ms / mp_ms
        print(f"interleaved on the same frames: MediaPipe {mp_ms:.1f} ms/frame, camera-motion "
              f"estimate {est_ms:.2f} ms/frame ({share:.1f} % of MediaPipe)")  # fmt: skip


if __name__ == "__main__":
    logging.getLogger("dexlfd").setLevel(logging.ERROR)
    reprocess()
    still_cameras()
    if "--no-speed" not in sys.argv:
        speed()
