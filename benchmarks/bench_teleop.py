"""Teleoperation on the real hand video: frame->command latency and loop speed vs real time.

Prints, for frames 640 px wide (as ``--resize-width-px 640``) and at full size (1280x720):

* latency from a frame's arrival (decoded) to its commanded pose (capture + motion +
  shaping) [ms]: median and p99 over the frames;
* the whole streaming loop (decode, capture, motion, shaping, one frame interval of the
  1 kHz NTSM-PD loop) as simulated seconds per wall second, without rendering
  (median of REPEATS runs) and with the side-by-side video (hand | 480x360 robot render,
  MUJOCO_GL=egl, llvmpipe), plus the CPU time per frame (the machine is shared: wall
  time includes waiting for a core).

Usage: ``python benchmarks/bench_teleop.py [VIDEO] [N_FRAMES]``.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

VIDEO = Path(__file__).resolve().parents[2] / "shared" / "data" / "human_hand_video.mp4"
if len(sys.argv) > 1:
    VIDEO = Path(sys.argv[1])
N_FRAMES = int(sys.argv[2]) if len(sys.argv) > 2 else 300
N_RENDER = min(N_FRAMES, 90)
REPEATS = 3


def run(width: int | None, n_frames: int, video: Path | None) -> dict[str, Any]:
    """One teleoperation run; returns the summary plus CPU seconds."""
    from dexlfd.apps.teleop import TeleopRunConfig, run_teleop, teleop_summary
    from dexlfd.capture import CaptureConfig, LiftConfig, open_source
    from dexlfd.capture.hand_capture import HandCapture
    from dexlfd.control import make_controller
    from dexlfd.motion.online import OnlineMotion
    from dexlfd.robot import perturbed_model

    T = np.eye(4)
    T[:3, :3] = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]]  # the CLI's "front" camera preset
    T[2, 3] = 1.0
    cfg = CaptureConfig(lift=LiftConfig(model="assumed_depth", camera2base=T))
    model = perturbed_model(0.1, np.random.default_rng(1))
    src = open_source(VIDEO, max_frames=n_frames, resize_width=width)
    writer = None
    with src, HandCapture(cfg, src.intrinsics, has_depth=False) as cap:
        if video is not None:
            from dexlfd.viz.teleop import SideBySideVideo

            writer = SideBySideVideo(video, src.fps or 30.0, 480, 360)
        c0 = time.process_time()
        res = run_teleop(
            src, OnlineMotion(cap), make_controller("ntsm-pd"), model,
            TeleopRunConfig(frame_interval_s=1.0 / (src.fps or 30.0)),
            rng=np.random.default_rng(2), on_frame=writer,
        )  # fmt: skip
        cpu = time.process_time() - c0
        if writer is not None:
            writer.close()
    s = teleop_summary(res)
    s["cpu_s"] = cpu
    s["lat"] = res.rollout.extras["frame_latency_s"]
    return s


def main() -> None:
    """Print the figures."""
    import logging

    logging.disable(logging.WARNING)
    print(f"video {VIDEO.name}, {N_FRAMES} frames ({N_FRAMES / 30:.1f} s at 30 fps)")
    run(640, 10, None)  # warm up (MediaPipe graph, MuJoCo model compile)
    for width, label in ((640, "640x360"), (None, "1280x720")):
        runs = [run(width, N_FRAMES, None) for _ in range(REPEATS)]
        lat = np.concatenate([r["lat"] for r in runs]) * 1e3
        speed = np.median([r["speed_vs_real_time"] for r in runs])
        cpu = np.median([r["cpu_s"] / r["frames"] for r in runs]) * 1e3
        print(
            f"{label:>9}: latency frame->command median {np.median(lat):5.1f} ms, "
            f"p99 {np.percentile(lat, 99):5.1f} ms (n={lat.size}); loop without rendering "
            f"{speed:4.2f}x real time (median of {REPEATS}), CPU {cpu:4.1f} ms/frame; "
            f"detection {runs[0]['detection_rate']:.0%}, tracking RMS "
            f"{1e3 * runs[0]['tracking_rms_m']:.1f} mm"
        )
    with tempfile.TemporaryDirectory() as tmp:
        r = run(640, N_RENDER, Path(tmp) / "sbs.mp4")
    print(
        f"  640x360 + side-by-side video (480x360 render), {N_RENDER} frames: "
        f"{r['speed_vs_real_time']:4.2f}x real time, CPU {1e3 * r['cpu_s'] / r['frames']:4.1f} "
        f"ms/frame, latency median {np.median(r['lat']) * 1e3:.1f} ms"
    )


if __name__ == "__main__":
    main()
