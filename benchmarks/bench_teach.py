"""`dexlfd teach` on the real recordings, and its wall time against `record` alone.

1. Every real recording that holds a pick-and-place (the MediaPipe landmark recordings
   ``../shared/data/landmarks/*.npz`` and the videos ``../shared/data/videos/lfo_*.webm``;
   or under ``$DEXLFD_SHARED/data``) goes through ``dexlfd teach`` with its defaults
   (no intrinsics: an ideal 60 deg camera is assumed; no extrinsics: the task frame is
   found from the demonstrations). Per recording it prints: completed (exit 0: the object
   was placed), the placement error [mm], the tilt [deg], the set-down speed, the
   robot's pick-to-place distance against the person's annotated travel (the mean over
   the recording's pick-and-places), the carry's lift in the plan against the
   demonstrated lift, how far the held object's planned height climbs back after its
   top (0: it comes down onto the place once) and the seconds taken.
2. Wall time: ``teach`` against ``record`` alone on a 10 s 1080p clip, each a fresh
   process. No 1080p 10 s video with a whole pick-and-place is available: the clip is
   the longest real video, ``lfo_place_can.webm`` (640x360, 30 fps), frames 230-829
   every second frame, upscaled to 1920x1080 (bicubic) and written at 30 fps with
   OpenCV (300 frames, 10 s, the person twice as fast), so that it holds the grasp
   (f258) and the release (f791). It is written into the run's folder (a temporary
   one unless ``--out``). ``--rounds N`` times it N times after a warm-up round
   (``record`` then ``teach`` each round, the ratio taken round by round);
   ``--compare SRC`` also times another checkout's ``src`` folder (e.g. ``git archive
   main``), its rounds interleaved with this one's.

Run with the venv's python (takes minutes: MediaPipe over the videos, a simulation and
a video per recording)::

    MUJOCO_GL=egl PYTHONPATH=src python benchmarks/bench_teach.py [--only NAME] [--no-timing]
        [--rounds N] [--compare OTHER/src]
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

SHARED = Path(os.environ.get("DEXLFD_SHARED", Path(__file__).resolve().parents[2] / "shared"))
DATA = SHARED / "data"

# the person's annotation (../shared/data/README.md): object travel [m] per pick-and-place
TRAVEL: dict[str, list[float]] = {
    "landmarks/breakfast.npz": [0.20, 0.22, 0.32],
    "landmarks/rearrange.npz": [0.35, 0.40],
    "landmarks/llama.npz": [0.25],
    "landmarks/plush_toy.npz": [0.28],
    "landmarks/bagging.npz": [0.38],
    "videos/lfo_place_can.webm": [0.35],
    "videos/lfo_throw_can.webm": [0.35],
    "videos/lfo_shelf_can.webm": [0.33],
}
# several recordings taught together (two cameras, one task frame each, one model)
TOGETHER: dict[str, list[str]] = {
    "breakfast+rearrange": ["landmarks/breakfast.npz", "landmarks/rearrange.npz"],
}
CLIP = ("videos/lfo_place_can.webm", 230, 830, 2)  # source, first, stop, step
CLIP_SIZE = (1920, 1080)  # [px] the clip's frames, upscaled


def _children_cpu() -> float:
    """CPU seconds (user + system) of this process's finished children so far."""
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def _dexlfd(*args: str, src: str | None = None) -> tuple[int, float, str, float]:
    """Run ``dexlfd ARGS`` in a fresh process; (exit code, seconds, last stderr line, CPU s).

    The CPU seconds are the process's and its children's (the video's render process).
    ``src``: the ``src`` folder of the dexlfd to run (default: the ``PYTHONPATH``'s).
    """
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    if src is not None:
        env["PYTHONPATH"] = src
    t0, c0 = time.perf_counter(), _children_cpu()
    proc = subprocess.run([sys.executable, "-m", "dexlfd", *args, "-q"], capture_output=True,
                          text=True, env=env, check=False)  # fmt: skip
    lines = proc.stderr.strip().splitlines()
    cpu = _children_cpu() - c0
    return proc.returncode, time.perf_counter() - t0, lines[-1] if lines else "", cpu


def teach_row(rel: str, out: Path) -> dict:
    """``dexlfd teach`` on a recording (or :data:`TOGETHER` ones); figures from ``teach.json``."""
    rels = TOGETHER.get(rel, [rel])
    code, seconds, err, _ = _dexlfd("teach", *(str(DATA / r) for r in rels), "-o", str(out),
                                 "--fresh")  # fmt: skip
    row: dict = {"recording": rel, "exit": code, "seconds": round(seconds, 1)}
    path = out / "teach.json"
    if not path.is_file():
        row["error"] = err
        return row
    rec = json.loads(path.read_text())
    v = rec["placement"]
    travel = [v for r in rels for v in TRAVEL[r]]
    row.update(
        placed=v["ok"],
        failure=v.get("failure"),
        error_mm=None if v["error_m"] is None else round(1e3 * v["error_m"], 1),
        tilt_deg=None if v["tilt_deg"] is None else round(v["tilt_deg"], 1),
        set_down_mps=v["set_down_speed_mps"],
        demos=len(rec["demonstrations"]),
        robot_pick_to_place_m=rec["pick_to_place_m"],
        annotated_travel_m=round(sum(travel) / len(travel), 3),
        plan_lift_m=rec["lift_m"]["plan"],
        demonstrated_lift_m=rec["lift_m"]["demonstrated"],
        up_camera=rec["task_frame"]["up_camera"],
        up_deg_sigma=rec["task_frame"]["uncertainty"].get("up_deg"),
        carry_climbs_back_mm=_climbs_back_mm(out / "plan.npz"),
    )
    return row


def _climbs_back_mm(path: Path) -> float | None:
    """How far [mm] the held object's planned height climbs back, at most, after its top.

    0 when the carry comes down onto the place once; a dip under a height the carry
    climbs back to before the place is a second set-down.
    """
    import numpy as np

    if not path.is_file():
        return None
    with np.load(path, allow_pickle=False) as plan:
        held = np.flatnonzero(plan["grasp"])
        z = plan["position"][held[0] : held[-1] + 1, 2] if held.size else np.zeros(1)
    tail = z[int(np.argmax(z)) :]
    return round(1e3 * float((np.maximum.accumulate(tail[::-1])[::-1] - tail).max()), 1)


def write_clip(path: Path) -> Path:
    """The 10 s 1080p clip of :data:`CLIP` (OpenCV, mp4v), for the wall-time comparison."""
    import cv2

    rel, first, stop, step = CLIP
    cap = cv2.VideoCapture(str(DATA / rel))
    fps = cap.get(cv2.CAP_PROP_FPS) or 30.0
    writer = None
    i = 0
    while i < stop:
        ok, frame = cap.read()
        if not ok:
            break
        if i >= first and (i - first) % step == 0:
            if writer is None:
                fourcc = cv2.VideoWriter.fourcc(*"mp4v")
                writer = cv2.VideoWriter(str(path), fourcc, fps, CLIP_SIZE)
            writer.write(cv2.resize(frame, CLIP_SIZE, interpolation=cv2.INTER_CUBIC))
        i += 1
    cap.release()
    if writer is not None:
        writer.release()
    return path


def timing(folder: Path, clip: Path | None = None, src: str | None = None) -> dict:
    """Seconds (wall and CPU) of ``record`` alone and of ``teach`` on the 10 s clip.

    With the load average before each, and ``teach``'s stages (wall and CPU seconds,
    from its manifest; a background stage's CPU is its own process's). ``src``: the
    dexlfd to time (:func:`_dexlfd`).
    """
    folder.mkdir(parents=True, exist_ok=True)
    clip = clip or write_clip(folder / "clip_10s_1080p.mp4")
    load = [round(os.getloadavg()[0], 2)]
    rec_code, rec_s, _, rec_cpu = _dexlfd("record", str(clip), "-o", str(folder / "record.npz"),
                                          src=src)  # fmt: skip
    load.append(round(os.getloadavg()[0], 2))
    teach_code, teach_s, err, teach_cpu = _dexlfd("teach", str(clip), "-o", str(folder / "teach"),
                                                  "--fresh", src=src)  # fmt: skip
    load.append(round(os.getloadavg()[0], 2))
    try:
        manifest = json.loads((folder / "teach" / "manifest.json").read_text())
    except (OSError, ValueError):
        manifest = {}
    stages = {k: [round(v["seconds"], 1), round(v.get("cpu_seconds", float("nan")), 1)]
              for k, v in manifest.items() if "seconds" in v}  # fmt: skip
    return {
        "stages_wall_cpu_s": stages, "load_avg_1min": load,
        "clip": f"{CLIP[0]} frames {CLIP[1]}-{CLIP[2] - 1} every {CLIP[3]}, 300 frames, "
        f"upscaled to {CLIP_SIZE[0]}x{CLIP_SIZE[1]}",
        "record_s": round(rec_s, 1), "record_cpu_s": round(rec_cpu, 1), "record_exit": rec_code,
        "teach_s": round(teach_s, 1), "teach_cpu_s": round(teach_cpu, 1), "teach_exit": teach_code,
        "ratio": round(teach_s / rec_s, 2), "cpu_ratio": round(teach_cpu / max(rec_cpu, 1e-9), 2),
        "teach_error": err if teach_code else None,
    }  # fmt: skip


def timing_rounds(folder: Path, rounds: int, compare: str | None) -> dict:
    """:func:`timing` ``rounds`` times after a warm-up, interleaved with ``compare``'s.

    The median of the rounds' ratios (teach / record, wall and CPU) per code.
    """
    import statistics

    clip = write_clip(folder / "clip_10s_1080p.mp4")
    codes = {"this": None, **({"compare": compare} if compare else {})}
    runs: dict[str, list[dict]] = {name: [] for name in codes}
    for r in range(rounds + 1):
        for name, src in codes.items():
            row = timing(folder / name, clip, src)
            print(json.dumps({"round": r or "warm-up", "code": name, **row}), flush=True)
            if r:
                runs[name].append(row)
    return {
        name: {
            "rounds": len(rows),
            "ratio_median": statistics.median(row["ratio"] for row in rows),
            "cpu_ratio_median": statistics.median(row["cpu_ratio"] for row in rows),
            "load_avg_1min": [row["load_avg_1min"] for row in rows],
        }
        for name, rows in runs.items()
    }


def main() -> int:
    """Print one JSON line per recording, then the timing."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--only", help="one recording (a name such as breakfast)")
    ap.add_argument("--no-timing", action="store_true", help="skip the wall-time comparison")
    ap.add_argument("--out", help="keep the runs' folders here (default: a temporary folder)")
    ap.add_argument("--rounds", type=int, default=0,
                    help="time the clip this many rounds after a warm-up round")  # fmt: skip
    ap.add_argument("--compare", metavar="SRC",
                    help="with --rounds: also time the dexlfd in this src folder, "
                    "interleaved")  # fmt: skip
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(args.out or tmp)
        root.mkdir(parents=True, exist_ok=True)
        for rel in [*TRAVEL, *TOGETHER]:
            if args.only and args.only not in rel:
                continue
            if not all((DATA / r).is_file() for r in TOGETHER.get(rel, [rel])):
                print(json.dumps({"recording": rel, "skipped": "not found"}))
                continue
            print(json.dumps(teach_row(rel, root / Path(rel).stem.replace("+", "_"))), flush=True)
        if not args.no_timing and (DATA / CLIP[0]).is_file():
            if args.rounds > 0:
                summary = timing_rounds(root, args.rounds, args.compare)
                print(json.dumps({"timing_rounds": summary}), flush=True)
            else:
                print(json.dumps({"timing": timing(root)}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
