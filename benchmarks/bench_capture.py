"""Capture speed on the real hand video: our pipeline vs raw MediaPipe, same frames, same run.

Prints, for full resolution (1280x720) and 640x360:
* raw MediaPipe Hands (legacy API, same settings) on pre-decoded frames [ms/frame];
* ours: HandCapture + OnlineMotion per frame (track, choose hand, lift, pose) [ms/frame],
  median and p99 latency, and the overhead over raw MediaPipe;
* end-to-end ``record`` (decode + track + lift + motion + save) fps vs raw decode+MediaPipe fps.
Median of REPEATS alternating runs.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

VIDEO = Path(__file__).resolve().parents[2] / "shared" / "data" / "human_hand_video.mp4"
if len(sys.argv) > 1:
    VIDEO = Path(sys.argv[1])
REPEATS = 3


def decode(width: int | None) -> list[np.ndarray]:
    from dexlfd.capture import open_source

    with open_source(VIDEO, resize_width=width) as src:
        return [f.rgb for f in src]


def interleaved(frames: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame times of raw MediaPipe and of ours, run back to back on each frame.

    Two independent tracker instances see the same frames; alternating them frame by
    frame gives both the same CPU contention (the machine is shared).
    """
    import mediapipe as mp

    from dexlfd.capture import CaptureConfig, Frame, HandCapture, LiftConfig
    from dexlfd.motion import OnlineMotion

    hands = mp.solutions.hands.Hands(static_image_mode=False, max_num_hands=1, model_complexity=1)
    cap = HandCapture(CaptureConfig(lift=LiftConfig(model="assumed_depth")))
    online = OnlineMotion(cap)
    raw = np.empty(len(frames))
    mine = np.empty(len(frames))
    inner = []  # time spent inside MediaPipe during our calls
    mp_process = cap.tracker._hands.process  # type: ignore[attr-defined]

    def timed(img):  # noqa: ANN001, ANN202
        t0 = time.perf_counter()
        res = mp_process(img)
        inner.append(time.perf_counter() - t0)
        return res

    cap.tracker._hands.process = timed  # type: ignore[attr-defined]
    for i, f in enumerate(frames):
        fr = Frame(i, i / 30, f)
        for k in (0, 1) if i % 2 else (1, 0):
            t0 = time.perf_counter()
            if k == 0:
                hands.process(f)
                raw[i] = time.perf_counter() - t0
            else:
                online.process(fr)
                mine[i] = time.perf_counter() - t0
    hands.close()
    cap.close()
    global LAST_OWN
    LAST_OWN = mine - np.array(inner)
    return raw, mine


LAST_OWN = np.zeros(0)


def raw_end_to_end(width: int | None) -> float:
    import cv2
    import mediapipe as mp

    t0 = time.perf_counter()
    hands = mp.solutions.hands.Hands(static_image_mode=False, max_num_hands=1, model_complexity=1)
    cap = cv2.VideoCapture(str(VIDEO))
    n = 0
    while True:
        ok, bgr = cap.read()
        if not ok:
            break
        if width:
            bgr = cv2.resize(
                bgr, (width, bgr.shape[0] * width // bgr.shape[1]), interpolation=cv2.INTER_AREA
            )
        hands.process(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
        n += 1
    cap.release()
    hands.close()
    return n / (time.perf_counter() - t0)


def record_end_to_end(width: int | None) -> float:
    from dexlfd.cli import main

    with tempfile.TemporaryDirectory() as tmp:
        argv = ["record", str(VIDEO), "-o", f"{tmp}/d.npz", "-q"]
        if width:
            argv += ["--resize-width", str(width)]
        t0 = time.perf_counter()
        assert main(argv) == 0
        return 621 / (time.perf_counter() - t0)


def main() -> None:
    if not VIDEO.is_file():
        sys.exit(f"video not found: {VIDEO}")
    import logging

    logging.getLogger("dexlfd").setLevel(logging.WARNING)
    for width, label in [(None, "1280x720"), (640, "640x360")]:
        frames = decode(width)
        raw, mine, own = [], [], []
        for _ in range(REPEATS):
            r_, m_ = interleaved(frames)
            raw.append(r_)
            mine.append(m_)
            own.append(LAST_OWN)
        r = np.median([np.median(x) for x in raw]) * 1e3
        m = np.median([np.median(x) for x in mine]) * 1e3
        r99 = np.median([np.percentile(x, 99) for x in raw]) * 1e3
        m99 = np.median([np.percentile(x, 99) for x in mine]) * 1e3
        rt = np.median([x.sum() for x in raw])
        mt = np.median([x.sum() for x in mine])
        print(f"== {label}, {len(frames)} frames, median of {REPEATS} runs")
        print(f"raw MediaPipe          : median {r:6.2f} ms  p99 {r99:6.2f} ms  total {rt:5.2f} s")
        print(f"ours (track+lift+pose) : median {m:6.2f} ms  p99 {m99:6.2f} ms  total {mt:5.2f} s")
        print(
            f"per-frame overhead     : {100 * (mt / rt - 1):+5.1f} % (total), "
            f"{m - r:+.2f} ms median"
        )
        o_med = np.median([np.median(x) for x in own]) * 1e3
        o_sum = np.median([x.sum() for x in own])
        print(
            f"our code outside MediaPipe: median {o_med:.3f} ms/frame = "
            f"{100 * o_sum / rt:.1f} % of raw MediaPipe time (noise-free overhead)"
        )
        fr, fo = [], []
        for k in range(REPEATS):  # alternate the order, so both see the same load
            if k % 2:
                fo.append(record_end_to_end(width))
            fr.append(raw_end_to_end(width))
            if not k % 2:
                fo.append(record_end_to_end(width))
        print(
            f"end-to-end fps         : raw decode+MediaPipe {np.median(fr):5.1f}, "
            f"dexlfd record {np.median(fo):5.1f} "
            f"({100 * (np.median(fr) / np.median(fo) - 1):+.1f} % time)"
        )


if __name__ == "__main__":
    main()
