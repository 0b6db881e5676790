"""`dexlfd record` on the real landmark recordings: the figures a person can check.

Each real MediaPipe landmark recording (``../shared/data/landmarks``, or
``$DEXLFD_SHARED/data/landmarks``; MediaPipe's output on real pick-and-place videos with a
person's annotation) goes through ``record``'s own pipeline with its defaults
(:func:`dexlfd.apps.record.record_demonstration`: hand choice, whole-recording pose,
motion, phases, one demonstration per pick-and-place, verdicts). Per file it prints:

- the demonstrations found against the annotated count, and each one's verdict;
- per annotated grasp, the frame IoU with the grasp of the demonstration that holds it
  (target >= 0.8), and the grasp's start and end error in frames (found - annotated);
- object travel (the wrist's displacement from the grasp to the release) over the
  annotated travel (target 0.7x-1.4x; the hand-held camera of ``rearrange`` moves, so its
  travel is not judged);
- the frame-to-frame wrist step p99 and max over seen consecutive frames (targets
  <= 2.5 cm and <= 6 cm) and the largest orientation step [deg];
- the lift of each grasp found: the palm's rise above the picture's line from the grasp
  to the release [hand lengths] (under 0.5 it is a drag, not a pick-and-place);
- on the videos (with the carry cue), the grasp IoU found by the pixels alone, the
  skeleton's closure switched off (a hand that never reads closed, as in a rim pinch);
- the frames where a lost hand was found again by the crop search (videos only);
- the camera's pitch of the task frame estimated from the pick-and-places found, with
  each run's angle to that up (runs of one camera must agree);
- the seconds taken (landmark file to demonstrations).

The real videos with pixels (``../shared/data/videos``) are tracked once (their
landmark recordings cached in ``$DEXLFD_BENCH_CACHE``, default a ``dexlfd-bench`` folder
in the temporary folder) and then measured alike.

No intrinsics are known: an ideal camera of the default field of view is assumed, so the
metric figures carry that assumption. Run with the venv's python::

    PYTHONPATH=src python benchmarks/bench_real_recordings.py
    PYTHONPATH=src python benchmarks/bench_real_recordings.py --speed  # 1080p speed ratio
    PYTHONPATH=src python benchmarks/bench_real_recordings.py --scene-cost  # the scene cue's
    PYTHONPATH=src python benchmarks/bench_real_recordings.py --hand-depth 1  # whole hand
"""

from __future__ import annotations

import logging
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from dexlfd.apps.record import RecordConfig, record_demonstration
from dexlfd.intervals import true_runs
from dexlfd.rotations import quat_angle

SHARED = Path(os.environ.get("DEXLFD_SHARED", Path(__file__).resolve().parents[2] / "shared"))
DATA = SHARED / "data" / "landmarks"
VIDEOS = SHARED / "data" / "videos"
# the videos' tracker output, made once per machine (MediaPipe over ~2700 frames, ~2 min)
CACHE = Path(os.environ.get("DEXLFD_BENCH_CACHE", Path(tempfile.gettempdir()) / "dexlfd-bench"))

# the person's annotation: grasp frames (close -> last closed) and object travel [m]
ANNOTATION: dict[str, dict] = {
    "breakfast": {"grasps": [(26, 74), (94, 132), (152, 197)], "travel": [0.20, 0.22, 0.32]},
    "rearrange": {"grasps": [(30, 104), (146, 214)], "travel": None},  # moving camera
    "llama": {"grasps": [(35, 104)], "travel": [0.25]},
    "plush_toy": {"grasps": [(34, 61)], "travel": [0.28]},
    "bagging": {"grasps": [(132, 212)], "travel": [0.38]},
}
# the videos with pixels (annotated by eye before any tracker ran): file, grasps, travel;
# the card slide's pinch is never released, so it holds no pick-and-place
VIDEO_ANNOTATION: dict[str, dict] = {
    "lfo_place_can": {"file": "lfo_place_can.webm", "grasps": [(258, 790)], "travel": [0.35]},
    "lfo_shelf_can": {"file": "lfo_shelf_can.webm", "grasps": [(74, 768)], "travel": [0.33]},
    "lfo_throw_can": {"file": "lfo_throw_can.webm", "grasps": [(206, 506)], "travel": [0.35]},
    "hudor_card_slide": {"file": "hudor_card_slide.mp4", "grasps": [], "travel": []},
}


def video_landmarks(name: str) -> Path:
    """The landmark recording of video ``name``: recorded once into CACHE, then reused."""
    from dexlfd.capture.landmark_recording import save_landmark_recording

    out = CACHE / f"{name}_landmarks.npz"
    if not out.is_file():
        CACHE.mkdir(parents=True, exist_ok=True)
        video = VIDEOS / VIDEO_ANNOTATION[name]["file"]
        res = record_demonstration(str(video), RecordConfig(), keep_landmarks=True)
        save_landmark_recording(out, res.landmarks)
    return out


def iou(a: tuple[int, int], b: tuple[int, int]) -> float:
    """Frame IoU of two inclusive frame ranges."""
    inter = min(a[1], b[1]) - max(a[0], b[0]) + 1
    return max(inter, 0) / (max(a[1], b[1]) - min(a[0], b[0]) + 1)


def lift_of(demo, a: int, b: int) -> float:  # type: ignore[no-untyped-def]
    """The palm's rise [hand lengths] over the line from grasp frame ``a`` to release ``b``
    (the demonstration's own frames): how far the object left its support."""
    from dexlfd.motion.grasp_evidence import lift_evidence

    uv = demo.extras.get("uv_px")
    if uv is None:
        return float("nan")
    length = float(np.nanmedian(np.linalg.norm(uv[:, 9] - uv[:, 0], axis=1)))
    return lift_evidence(uv, a, b + 1, np.asarray(demo.valid, bool), length)[0]


def pixels_only_iou(path: Path, ann: dict) -> list[float] | None:
    """Grasp IoU per annotated grasp with the skeleton's closure switched off: what the
    pixels alone (the carry cue and the lift) find; None without a carry cue."""
    import dexlfd.motion.demonstration as dm
    from dexlfd.motion.phases import hand_phases

    seen: list[tuple] = []
    real = dm.track_phases

    def spy(t, points, valid, **kw):  # type: ignore[no-untyped-def]
        seen.append((t, kw.get("uv_px"), valid, kw.get("carry")))
        return real(t, points, valid, **kw)

    dm.track_phases = spy  # type: ignore[assignment]
    try:
        record_demonstration(str(path), RecordConfig())
    finally:
        dm.track_phases = real  # type: ignore[assignment]
    t, uv, valid, carry = seen[0]
    if carry is None or uv is None:
        return None
    ph = hand_phases(t, np.zeros(t.size, bool), uv, valid, carry=carry)
    pp = [(e.grasp_start, e.release - 1) for e in ph.pick_and_places if e.release is not None]
    return [max((iou(g, f) for f in pp), default=0.0) for g in ann["grasps"]]


def grasp_of(demo) -> tuple[tuple[int, int], float, float] | None:  # type: ignore[no-untyped-def]
    """The demonstration's (longest) grasp in the recording's frames, the travel [m] and
    the lift [hand lengths]."""
    runs = true_runs(np.asarray(demo.grasp, dtype=bool))
    if not runs:
        return None
    a, b = max(runs, key=lambda r: r[1] - r[0])  # the earlier of equal runs
    b -= 1
    first = int((demo.source_frames or (0, 0))[0])
    p, v = demo.position, demo.valid
    seen = np.flatnonzero(v)
    ia = seen[np.argmin(np.abs(seen - a))]
    ib = seen[np.argmin(np.abs(seen - b))]
    return (first + a, first + b), float(np.linalg.norm(p[ib] - p[ia])), lift_of(demo, a, b)


def steps(demos) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[no-untyped-def]
    """Wrist steps [m] and orientation steps [deg] between seen consecutive frames."""
    dp, dq = [], []
    for d in demos:
        both = d.valid[1:] & d.valid[:-1]
        dp.append(np.linalg.norm(np.diff(d.position, axis=0), axis=1)[both])
        dq.append(np.degrees(quat_angle(d.quaternion[1:], d.quaternion[:-1]))[both])
    return np.concatenate(dp), np.concatenate(dq)


def run(name: str, path: Path, ann: dict) -> dict:
    """The figures of one recording (a landmark file) against its annotation ``ann``."""
    t0 = time.perf_counter()
    res = record_demonstration(str(path), RecordConfig())
    elapsed = time.perf_counter() - t0
    demos = list(res.demos)
    found = [grasp_of(d) if d.quality.pick_and_place else None for d in demos]
    ious, travel, start_err, end_err, lifts = [], [], [], [], []
    for k, g in enumerate(ann["grasps"]):
        cands = [f for f in found if f is not None]
        best = max(cands, key=lambda f: iou(g, f[0]), default=None)
        ious.append(0.0 if best is None else iou(g, best[0]))
        if best is not None:
            lifts.append(best[2])
            start_err.append(best[0][0] - g[0])
            end_err.append(best[0][1] - g[1])
        if ann["travel"] is not None:
            travel.append(float("nan") if best is None else best[1] / ann["travel"][k])
    dp, dq = steps(demos)
    from dexlfd.capture.landmark_recording import load_landmark_recording
    from dexlfd.motion import estimate_task_frame

    pnp = [d for d in demos if d.quality.pick_and_place]
    pitch = "-"
    if pnp:  # the camera's pitch from the pick-and-places' lifts, each run's angle to up
        fr = estimate_task_frame(pnp, names=[f"{name}-{k}" for k in range(len(pnp))])
        pitch = (
            f"{fr.details['camera_pitch_deg']:.0f} ("
            + ", ".join(
                f"{r['angle_to_up_deg']:.0f}{'' if r['kept'] else ' not used'}"
                for r in fr.details["runs"]
            )
            + ")"
        )

    again = load_landmark_recording(path).redetected
    return {
        "name": name,
        "recovered": None if again is None else int(again.any(axis=1).sum()),
        "found": len([f for f in found if f is not None]),
        "usable": sum(d.quality.usable for d in demos),
        "expected": len(ann["grasps"]),
        "verdicts": [
            "usable" if d.quality.usable else "; ".join(d.quality.warnings) for d in demos
        ],
        "notes": [n for d in demos for n in d.quality.notes],
        "iou": ious,
        "start_err": start_err,
        "end_err": end_err,
        "travel": travel,
        "lift": lifts,
        "pixels_iou": pixels_only_iou(path, ann),
        "step_p99_cm": 100 * float(np.percentile(dp, 99)) if dp.size else float("nan"),
        "step_max_cm": 100 * float(dp.max()) if dp.size else float("nan"),
        "turn_max_deg": float(dq.max()) if dq.size else float("nan"),
        "seconds": elapsed,
        "pitch": pitch,
    }


def _print(r: dict) -> bool:
    good = (
        r["found"] == r["expected"]
        and r["usable"] == r["expected"]
        and min(r["iou"], default=1.0) >= 0.8
        and all(0.7 <= x <= 1.4 for x in r["travel"])
    )
    travel = ", ".join(f"{x:.2f}" for x in r["travel"]) or "not judged"
    errs = ", ".join(f"{a:+d}/{b:+d}" for a, b in zip(r["start_err"], r["end_err"], strict=True))
    print(
        f"{r['name']}: {r['found']}/{r['expected']} ({r['usable']} usable) | "
        + (", ".join(f"{x:.2f}" for x in r["iou"]) or "-")
        + f" | {errs or '-'} | {travel} | "
        + (", ".join(f"{x:.1f}" for x in r["lift"]) or "-")
        + " | "
        + (
            "-"
            if r["pixels_iou"] is None
            else ", ".join(f"{x:.2f}" for x in r["pixels_iou"]) or "-"
        )
        + f" | {r['step_p99_cm']:.1f}/{r['step_max_cm']:.1f} | "
        f"{r['turn_max_deg']:.0f} | {r['recovered'] if r['recovered'] is not None else '-'} | "
        f"{r['pitch']} | {r['seconds']:.2f} {'OK' if good else 'MISS'}"
    )
    for k, v in enumerate(r["verdicts"], start=1):
        print(f"  demonstration {k}: {v}")
    for note in dict.fromkeys(r["notes"]):
        print(f"  note: {note}")
    return good


def lift_1080p(tmp: str, first: int = 150, n: int = 120) -> Path:
    """Frames ``first``.. of the shelf video (its fast lift, which the tracker loses for 9
    frames) upscaled from 640x360 to 1920x1080: a 1080p clip where re-detection works."""
    out = Path(tmp) / "shelf_lift_1080p.mp4"
    return upscaled_1080p(VIDEOS / "lfo_shelf_can.webm", first, n, out)


def upscaled_1080p(video: Path, first: int, n: int, out: Path) -> Path:
    """Frames ``first`` .. ``first + n`` of ``video`` upscaled to 1920x1080 (30 fps) in ``out``."""
    import cv2

    cap = cv2.VideoCapture(str(video))
    cap.set(cv2.CAP_PROP_POS_FRAMES, first)
    vw = cv2.VideoWriter(str(out), cv2.VideoWriter.fourcc(*"mp4v"), 30.0, (1920, 1080))
    for _ in range(n):
        ok, bgr = cap.read()
        if not ok:
            break
        vw.write(cv2.resize(bgr, (1920, 1080), interpolation=cv2.INTER_CUBIC))
    cap.release()
    vw.release()
    return out


def speed(repeats: int = 3) -> None:
    """``record`` fps at 1080p over decode + MediaPipe alone, alternating in one run."""
    from bench_landmarks import raw_fps
    from dexlfd.cli import main as cli

    def record_fps(video: Path, redetect: bool) -> float:
        with tempfile.TemporaryDirectory() as out:
            argv = ["record", str(video), "-o", f"{out}/d.npz", "-q"]
            argv += [] if redetect else ["--no-redetect"]
            t0 = time.perf_counter()
            cli(argv)
            return 120 / (time.perf_counter() - t0)

    with tempfile.TemporaryDirectory() as tmp:
        video = lift_1080p(tmp)
        raw, on, off = [], [], []
        for k in range(repeats):
            order = (0, 1, 2) if k % 2 == 0 else (2, 1, 0)
            for what in order:
                if what == 0:
                    raw.append(raw_fps(video, 2))
                elif what == 1:
                    on.append(record_fps(video, True))
                else:
                    off.append(record_fps(video, False))
        r, a, b = np.median(raw), np.median(on), np.median(off)
        print(
            f"1080p (shelf lift upscaled, 120 frames, 2 hands), median of {repeats}: "
            f"decode+MediaPipe {r:.1f} fps; record {a:.1f} fps (ratio {a / r:.2f}); "
            f"record --no-redetect {b:.1f} fps (ratio {b / r:.2f})"
        )


def scene_cost(first: int = 170, n: int = 470) -> None:
    """The scene before/after cue's seconds at 1080p against decode + MediaPipe.

    Frames ``first``.. of the throw video (a whole pick-and-place: grasp ~206, release
    ~507) upscaled to 1920x1080; the cue of its episode measured on them (the hand's
    landmarks from the cached 640x360 tracking, scaled), against decode + MediaPipe
    over the same clip (median of 3). Its share of ``record``'s time is what it costs
    the speed ratio.
    """

    from bench_landmarks import raw_fps
    from dexlfd.capture.scene_change import measure_scene_changes

    rec = record_demonstration(str(video_landmarks("lfo_throw_can")), RecordConfig())
    spans = [grasp_of(d)[0] for d in rec.demos if d.quality.pick_and_place]  # type: ignore[index]
    with np.load(video_landmarks("lfo_throw_can"), allow_pickle=False) as z:
        img = z["image_xyz"][first : first + n]
    x = img[:, :, 0, 0]
    slot = np.argmin(np.where(np.isnan(x), np.inf, x), axis=1)  # the image-left hand
    uv = img[np.arange(len(img)), slot, :, :2] * (1920, 1080)
    valid = np.isfinite(uv).all(axis=(1, 2))
    episodes = [(a - first, b + 1 - first) for a, b in spans]
    with tempfile.TemporaryDirectory() as tmp:
        out = upscaled_1080p(VIDEOS / "lfo_throw_can.webm", first, n, Path(tmp) / "throw.mp4")
        cue_s = []
        for _ in range(3):
            t0 = time.perf_counter()
            changes = measure_scene_changes(out, uv, valid, episodes, (1920, 1080))
            cue_s.append(time.perf_counter() - t0)
        raw = np.median([raw_fps(out, 2) for _ in range(3)])
    cue = float(np.median(cue_s))
    base = n / raw
    print(
        f"scene cue at 1080p ({n} frames, {len(episodes)} episode(s)): {cue:.2f} s "
        f"({', '.join(str(c.verdict) for c in changes)}); decode+MediaPipe {base:.1f} s "
        f"({raw:.1f} fps): the cue costs {100 * cue / base:.1f} % of it"
    )


def hand_depth(weight: float) -> None:
    """Every pose estimate of this run with ``depth_hand_weight=weight``."""
    from dataclasses import replace

    import dexlfd.capture.recording_pose as rp

    base = rp.RecordingPoseConfig
    rp.RecordingPoseConfig = lambda *a, **k: replace(base(*a, **k), depth_hand_weight=weight)  # type: ignore[misc,assignment]


def main() -> int:
    if "--hand-depth" in sys.argv:
        hand_depth(float(sys.argv[sys.argv.index("--hand-depth") + 1]))
    if not DATA.is_dir():
        print(f"no real landmark recordings at {DATA}: nothing to measure")
        return 0
    logging.disable(logging.WARNING)  # the verdicts are printed below
    ok = True
    print(
        "file: found/expected (usable) | grasp IoU | start/end error [frames] | travel ratio | "
        "lift [hand lengths] | grasp IoU from the pixels alone | step p99/max [cm] | "
        "turn [deg] | frames re-detected | task-frame camera pitch (runs' angle to up) [deg] | s"
    )
    for name, ann in ANNOTATION.items():
        ok &= _print(run(name, DATA / f"{name}.npz", ann))
    if VIDEOS.is_dir():
        print(f"videos (their tracker output cached in {CACHE}):")
        for name, ann in VIDEO_ANNOTATION.items():
            ok &= _print(run(name, video_landmarks(name), ann))
    return 0 if ok else 1


if __name__ == "__main__":
    if "--speed" in sys.argv or "--scene-cost" in sys.argv:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        speed() if "--speed" in sys.argv else scene_cost()
        sys.exit(0)
    sys.exit(main())
