"""The CPU of ``teach``'s robot video: per frame and in all, streamed and replayed.

Renders a teach run's video again from its folder (``--run``: ``plan.npz``,
``rollout.npz``, ``task_frame.json``) with ``teach``'s settings, each time in a fresh
process (a process that rendered cannot fork a renderer), the ways ``teach`` does:

- ``stream``: :func:`dexlfd.apps.teach_robot.stream_video`'s child fed the rollout's
  rows as the simulation hands them over (every
  :data:`~dexlfd.control.loop.SAMPLES_EVERY` samples, without simulating), then
  finished; the CPU is the child's and its encoder's (user + system).
- ``replay``: :func:`dexlfd.apps.teach_robot.render_video` (after the simulation):
  this process's CPU and its encoder's around the call.

Each is also run on the rollout's first sample alone (one frame): the fixed cost (a
process, the scene, the OpenGL context, the encoder's start), so that the per-frame
cost is ``(all - fixed) / (frames - 1)``. The modes alternate ``--rounds`` times; run
it with another checkout's ``src`` first in ``PYTHONPATH`` for the code before a change.

    MUJOCO_GL=egl PYTHONPATH=src python benchmarks/bench_robot_video.py --run OUT --rounds 3
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _cpu() -> float:
    """CPU seconds of this process and its waited-for children (user + system)."""
    me, kids = (resource.getrusage(w) for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def _one(run: Path, mode: str, frames: str, folder: Path) -> dict[str, float]:
    """In a fresh process: render the run's video once; its CPU and frame count."""
    import dataclasses

    import numpy as np

    from dexlfd.apps.teach import TeachConfig, _video_settings
    from dexlfd.apps.teach_robot import render_video, stream_video
    from dexlfd.control.loop import SAMPLES_EVERY
    from dexlfd.io import load_plan, load_rollout

    plan, rollout = load_plan(run / "plan.npz"), load_rollout(run / "rollout.npz")
    if frames == "one":  # the first sample alone: one frame
        n = rollout.n_samples
        cut = {
            f.name: v[:1]
            for f in dataclasses.fields(rollout)
            if isinstance(v := getattr(rollout, f.name), np.ndarray) and v.shape[:1] == (n,)
        }
        extras = {k: v[:1] for k, v in rollout.extras.items()}
        rollout = dataclasses.replace(rollout, extras=extras, **cut)
    frame = {"summary": json.loads((run / "task_frame.json").read_text())}
    settings = _video_settings(TeachConfig(sources=()), frame)
    path = folder / f"{mode}.mp4"
    c0, t0 = _cpu(), time.perf_counter()
    if mode == "stream":
        stream = stream_video(plan, path, **settings)
        assert stream is not None, "this process cannot fork a renderer"
        rows = {"t": rollout.t, "q": rollout.q, "gripper": rollout.gripper, **rollout.extras}
        for k in range(0, rollout.n_samples, SAMPLES_EVERY):
            stream.rows({name: v[: k + 1] for name, v in rows.items()})
        assert stream.finish(rollout)
        stream.result()
    else:
        render_video(rollout, plan, path, **settings)
    cpu, wall = _cpu() - c0, time.perf_counter() - t0
    import cv2

    cap = cv2.VideoCapture(str(path))
    n = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
    cap.release()
    return {"cpu_s": round(cpu, 3), "wall_s": round(wall, 3), "frames": n,
            "bytes": path.stat().st_size, "samples": int(np.asarray(rollout.t).size)}  # fmt: skip


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", required=True, help="a teach run's output folder")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--modes", nargs="+", default=["stream", "replay"],
                    choices=["stream", "replay"])  # fmt: skip
    ap.add_argument("--one", nargs=3, metavar=("MODE", "FRAMES", "FOLDER"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        mode, frames, folder = args.one
        print(json.dumps(_one(Path(args.run), mode, frames, Path(folder))))
        return 0
    rows: dict[tuple[str, str], list[dict[str, float]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.rounds):
            for mode in args.modes:
                for frames in ("all", "one"):
                    cmd = [sys.executable, __file__, "--run", args.run, "--one", mode, frames, tmp]
                    out = subprocess.run(cmd, env=os.environ, check=True, capture_output=True,
                                         text=True).stdout  # fmt: skip
                    row = json.loads(out.strip().splitlines()[-1])
                    rows.setdefault((mode, frames), []).append(row)
                    print(json.dumps({"round": r, "mode": mode, "frames": frames, **row}),
                          flush=True)  # fmt: skip
    for mode in args.modes:
        every, one = rows[(mode, "all")], rows[(mode, "one")]
        n = every[0]["frames"]
        per = sorted(
            1e3 * (a["cpu_s"] - b["cpu_s"]) / (n - 1) for a, b in zip(every, one, strict=True)
        )
        total = sorted(a["cpu_s"] for a in every)
        fixed = sorted(b["cpu_s"] for b in one)
        print(json.dumps({"mode": mode, "frames": n, "median_cpu_s": total[len(total) // 2],
                          "median_fixed_cpu_s": fixed[len(fixed) // 2],
                          "median_per_frame_ms": round(per[len(per) // 2], 2),
                          "per_frame_ms": [round(p, 2) for p in per]}))  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
