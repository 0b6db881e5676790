"""The simulated tick's cost with and without the robot video drawn meanwhile.

``teach``'s simulate stage hands the samples recorded so far to a
:class:`~dexlfd.viz.robot_video_stream.VideoStream` every
:data:`~dexlfd.control.loop.SAMPLES_EVERY` ticks, and its child draws the frames. This
times :func:`dexlfd.apps.teach_robot.simulate_plan` on a teach run's ``plan.npz``
(``--plan``): CPU microseconds per tick of this process (the stream's child is another
process: its CPU is printed apart), without the stream and with it, ``--rounds`` times
each, interleaved; with it, the CPU of the hand-overs alone (per tick of the loop) and
the wait for the video once the simulation has ended. Run it with another checkout's
``src`` first in ``PYTHONPATH`` for the tick before the change (it then times no stream).

    MUJOCO_GL=egl PYTHONPATH=src python benchmarks/bench_teach_stream.py --plan OUT/plan.npz
"""

from __future__ import annotations

import argparse
import json
import resource
import tempfile
import time
from pathlib import Path


def _once(plan, cfg, size, streamed: bool, folder: Path) -> dict[str, float]:
    from dexlfd.apps.teach_robot import simulate_plan

    stream = None
    if streamed:
        from dexlfd.apps.teach import _video_settings
        from dexlfd.apps.teach_robot import stream_video

        frame = {"summary": {"placement": {"object_size": list(size)}}}
        stream = stream_video(plan, folder / "robot.mp4", **_video_settings(cfg, frame))
    calls: list[float] = []  # CPU seconds of each hand-over

    def hand_over(rows: dict) -> None:
        c = time.process_time()
        stream.rows(rows)
        calls.append(time.process_time() - c)

    kw = {} if stream is None else {"samples": hand_over}
    c0, t0 = time.process_time(), time.perf_counter()
    kids0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    rollout = simulate_plan(plan, cfg, size, **kw)
    cpu, wall = time.process_time() - c0, time.perf_counter() - t0
    tail = 0.0
    if stream is not None:
        t1 = time.perf_counter()
        stream.finish(rollout)
        stream.result()
        tail = time.perf_counter() - t1
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    child = kids.ru_utime + kids.ru_stime - kids0.ru_utime - kids0.ru_stime
    n = rollout.n_samples
    median = sorted(calls)[len(calls) // 2] if calls else None
    return {"tick_cpu_us": round(1e6 * cpu / n, 1), "tick_wall_us": round(1e6 * wall / n, 1),
            "hand_overs": len(calls), "hand_over_cpu_us_per_tick": round(1e6 * sum(calls) / n, 2),
            "hand_over_first_ms": round(1e3 * calls[0], 2) if calls else None,
            "hand_over_median_us": None if median is None else round(1e6 * median, 1),
            "video_after_s": round(tail, 2), "child_cpu_s": round(child, 2)}  # fmt: skip


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plan", required=True, help="a teach run's plan.npz")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--object-size", type=float, nargs=3, default=(0.06, 0.06, 0.06))
    args = ap.parse_args()
    from dexlfd.apps.teach import TeachConfig
    from dexlfd.io import load_plan

    try:
        from dexlfd.apps.teach_robot import stream_video  # noqa: F401

        modes = [False, True]
    except ImportError:  # a checkout before the stream
        modes = [False]
    plan, cfg = load_plan(Path(args.plan)), TeachConfig(sources=())
    with tempfile.TemporaryDirectory() as tmp:
        _once(plan, cfg, tuple(args.object_size), False, Path(tmp))  # warm-up
        for r in range(args.rounds):
            for streamed in modes:
                row = _once(plan, cfg, tuple(args.object_size), streamed, Path(tmp))
                print(json.dumps({"round": r, "stream": streamed, **row}), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
