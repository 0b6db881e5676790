"""Throughput of the parallel engine: batch hand tracking and a Monte-Carlo payload study.

Runs each workload with 1 and 2 workers on the local process pool and on a local
Ray cluster, and prints wall time, speed-up over 1 local worker, and the
per-item costs measured inside the workers (wall and CPU seconds), which do not
depend on how busy the machine is. The engine overhead is the wall time beyond
the items' own (wall - sum of item wall times / workers): what scheduling,
pickling and starting workers cost. The Ray cluster is started once at the
beginning (its start time is printed) and reused by every Ray run, as the engine
does within one process.

    python benchmarks/bench_scale.py                        # 8 clips, 64 trials
    python benchmarks/bench_scale.py --clips 4 --trials 8   # quicker

The clips are cut from ``../shared/data/human_hand_video.mp4`` (skipped if absent)
into a temporary folder and tracked by the single-video record function.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd.engine import ItemOutcome, map_items

SHARED = Path(os.environ.get("DEXLFD_SHARED", Path(__file__).resolve().parents[2] / "shared"))
VIDEO = SHARED / "data" / "human_hand_video.mp4"


def cut_clips(video: Path, folder: Path, n: int, frames: int) -> list[Path]:
    """``n`` clips of ``frames`` frames each, evenly spaced through ``video`` (H.264)."""
    import cv2

    from dexlfd.io.video import VideoWriter

    cap = cv2.VideoCapture(str(video))
    total = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
    fps = cap.get(cv2.CAP_PROP_FPS) or 30.0
    starts = np.linspace(0, max(0, total - frames), n).astype(int)
    clips = []
    for i, start in enumerate(starts):
        cap.set(cv2.CAP_PROP_POS_FRAMES, int(start))
        path = folder / f"clip_{i}.mp4"
        with VideoWriter(path, fps) as writer:
            for _ in range(frames):
                ok, bgr = cap.read()
                if not ok:
                    break
                writer.write(bgr[:, :, ::-1])
        clips.append(path)
    cap.release()
    return clips


def track_clip(path: str) -> dict[str, float]:
    """One item of the batch: the single-video record function on one clip."""
    from dexlfd.apps.record import RecordConfig, record_demonstration

    res = record_demonstration(path, RecordConfig())
    return {"frames": res.n_frames, "detection_rate": res.detection_rate}


def run(label: str, fn: Any, items: list[Any], engine: str, workers: int) -> dict[str, Any]:
    t0 = time.perf_counter()
    out: list[ItemOutcome] = map_items(
        fn, items, labels=[str(i) for i in range(len(items))], engine=engine, workers=workers,
        desc=label, quiet=True,
    )  # fmt: skip
    wall = time.perf_counter() - t0
    failed = [o for o in out if not o.ok]
    if failed:
        raise SystemExit(f"{label}: {failed[0].label}: {failed[0].error}")
    return {
        "wall": wall,
        "values": [o.value for o in out],
        "item_wall": np.array([o.seconds for o in out]),
        "item_cpu": np.array([o.cpu_seconds for o in out]),
    }


def _noop(x: Any) -> Any:
    return x


def start_ray(workers: int) -> None:
    """Start the engine's local Ray cluster once (later calls reuse it) and time it."""
    t0 = time.perf_counter()
    map_items(_noop, [0], labels=["start"], engine="ray", workers=workers, quiet=True)
    print(f"ray: local cluster with {workers} CPUs started in {time.perf_counter() - t0:.1f} s "
          "(once per process; the runs below reuse it and its workers)")  # fmt: skip


def bench(name: str, fn: Any, items: list[Any], engines: list[str]) -> None:
    print(f"== {name}: {len(items)} items, load average {os.getloadavg()[0]:.1f}")
    base = None
    for engine in engines:
        for workers in (1, 2):
            r = run(f"{name} {engine} x{workers}", fn, items, engine, workers)
            base = base or r
            same = all(_same(a, b) for a, b in zip(r["values"], base["values"], strict=True))
            print(
                f"{engine:>5} x{workers}: {r['wall']:7.1f} s wall, {len(items) / r['wall']:6.2f} "
                f"items/s, speed-up {base['wall'] / r['wall']:4.2f}x | per item "
                f"{r['item_wall'].mean():.2f} ± {r['item_wall'].std():.2f} s wall, "
                f"{r['item_cpu'].mean():.2f} ± {r['item_cpu'].std():.2f} s CPU | engine overhead "
                f"{r['wall'] - r['item_wall'].sum() / workers:.1f} s | same results as local x1: "
                f"{same}"
            )


def _same(a: Any, b: Any) -> bool:
    return bool(a == b)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--clips", type=int, default=8)
    p.add_argument("--clip-frames", type=int, default=60, help="frames per clip (30 fps)")
    p.add_argument("--trials", type=int, default=64)
    p.add_argument("--engines", default="local,ray")
    args = p.parse_args()
    engines = [e for e in args.engines.split(",") if e]
    print(f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}")
    if "ray" in engines:
        start_ray(2)
    if args.clips and VIDEO.is_file():
        with tempfile.TemporaryDirectory() as tmp:
            clips = cut_clips(VIDEO, Path(tmp), args.clips, args.clip_frames)
            bench(f"track {args.clip_frames}-frame clips", track_clip, [str(c) for c in clips],
                  engines)  # fmt: skip
    elif args.clips:
        print(f"skipped batch tracking: {VIDEO} not found")
    if args.trials:
        import functools

        from dexlfd.experiments.payload import PayloadConfig
        from dexlfd.experiments.payload_montecarlo import MonteCarloConfig, run_trial
        from dexlfd.plan.moves import lift_plan

        # one controller on a 1 s lift: each trial simulates 2 x 1 s at 1 kHz
        plan = lift_plan(1.0, z_high=0.35, y_start=-0.05, y_end=0.05)
        base = PayloadConfig(controllers=("ntsm-pd-dob",), plan=plan, obstacles=())
        cfg = MonteCarloConfig(trials=args.trials, base=base)
        bench("payload Monte-Carlo trials", functools.partial(run_trial, cfg),
              list(range(args.trials)), engines)  # fmt: skip


if __name__ == "__main__":
    main()
