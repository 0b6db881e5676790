"""Whole-recording RGB hand pose vs today's per-frame PnP lift, on real landmark recordings.

For each real MediaPipe landmark recording (the acting hand picked per frame by the test
helper's simple rule; no intrinsics known: an ideal camera with the default 60 deg
horizontal field of view) this prints, before (``PnPTracker`` frame by frame) and after
(``estimate_recording_pose`` over the whole recording):

- frame-to-frame wrist step p99 and max [cm] (targets <= 2.5 and <= 6);
- ``frozen``: fraction of 10-frame spans whose depth changes < 3 mm while the palm's
  image size changes > 10 % (the hand moved in depth, the depth did not follow);
- the largest and 99th-percentile frame-to-frame palm turn [deg] (target <= 30 where
  the hand does not turn; no frame of these clips turns 30 deg in 1/30 s);
- wrist travel between each annotated grasp and release over the annotated object
  travel (target 0.6-1.6; the hand-held camera of ``rearrange`` moves: not judged);
- after: the median depth uncertainty [cm], the orientation frames set, and the
  estimator's time (median of 5 runs) [ms].

Run: ``python benchmarks/bench_recording_pose.py`` (skips files that are absent).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "capture"))

from landmark_files import (  # noqa: E402
    NAMES,
    frozen_fraction,
    load_acting_hand,
    orientation_steps_deg,
    path,
    per_frame_pnp,
    travel_ratios,
    wrist_steps,
)

from dexlfd.capture import Intrinsics  # noqa: E402
from dexlfd.capture.recording_pose import estimate_recording_pose  # noqa: E402


def figures(kp: np.ndarray, hand) -> str:  # type: ignore[no-untyped-def]
    """One line of figures for camera-frame keypoints ``kp``."""
    steps = wrist_steps(kp) * 100
    turns = orientation_steps_deg(kp)
    travel = travel_ratios(kp, hand)
    judged = "" if hand.judge_travel else " (not judged)"
    return (
        f"step p99 {np.percentile(steps, 99):5.1f} max {steps.max():5.1f} cm | "
        f"frozen {frozen_fraction(kp, hand.uv_px):4.2f} | "
        f"turn max {turns.max():5.1f} p99 {np.percentile(turns, 99):5.1f} deg | "
        f"travel {' '.join(f'{r:4.2f}' for r in travel)}{judged}"
    )


def main() -> None:
    for name in NAMES:
        if not path(name).is_file():
            print(f"{name}: file absent, skipped")
            continue
        hand = load_acting_hand(name)
        K = Intrinsics.from_fov(*hand.size, 60.0)
        before = per_frame_pnp(hand)
        times = []
        for _ in range(5):
            t0 = time.perf_counter()
            est = estimate_recording_pose(
                hand.t, hand.uv_px, hand.world_m, hand.valid, K, hand.score
            )
            times.append(time.perf_counter() - t0)
        n = hand.t.size
        print(
            f"{name} ({n} frames, {hand.size[0]}x{hand.size[1]}, hand in {hand.valid.mean():.0%})"
        )
        print(f"  before: {figures(before, hand)}")
        print(f"  after:  {figures(est.keypoints, hand)}")
        std = est.depth_std[hand.valid]
        print(
            f"          depth std median {np.median(std) * 100:.1f} cm (p95 "
            f"{np.percentile(std, 95) * 100:.1f}), orientation set in "
            f"{est.orientation_set.sum()}/{hand.valid.sum()} frames, "
            f"{np.median(times) * 1000:.0f} ms"
        )


if __name__ == "__main__":
    main()
