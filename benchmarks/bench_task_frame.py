"""The task frame from the demonstrations: errors against known cameras, real recordings.

1. **Synthetic scenes, known camera.** Three pick-and-places on a table (picks and
   places spread over 40 x 40 cm), a person-like motion: reach, close, hold, lift
   12 cm along a direction slanted 5-15 deg from vertical (random azimuth), carry
   over an arc, set down along another slanted direction, hold, open, retreat. A
   camera pitched 20-70 deg down, turned -40..40 deg, 0.6-0.9 m from the table's
   centre (ideal 640x480, 60 deg horizontal field of view). Two noise paths:

   - ``keypoint``: the TCP in the camera frame plus 3 mm noise (no lifting);
   - ``pixel``: a synthetic hand (:func:`dexlfd.datasets.demonstration_with_hand`)
     projected to pixels with 1.5 px noise, its world landmarks (hand-centred, 3 mm
     noise) and the real RGB lifting (:func:`estimate_recording_pose`), the motion
     stage, the true grasp channel;
   - ``pixel-per-frame``: the same, lifted frame by frame (:class:`PnPTracker`) instead
     of over the whole recording (what ``record`` uses): which part of the error is
     the whole-recording smoother's.

   Per tilt (5 seeds): "up" angle error [deg] (mean, max), the camera pitch error
   [deg], the estimate's own 1-sigma up_deg, and the scale error [%]: the pick-to-place
   distances in the task frame (scale 1.0, as reported) over the true ones, minus 1.
2. **Real landmark recordings** (MediaPipe on real videos, ``record`` defaults, no
   extrinsics): per recording the pick-and-places' up directions (angle of each run
   to the estimate, used or not), their largest pairwise angle [deg], the camera
   pitch [deg], its height over the table [m], the grasp-to-release travel [m], the
   table RMS [m], the 1-sigma up and scale, MediaPipe's hand length [m].
3. **Real videos** recorded by ``dexlfd record VIDEO -o DIR/`` (MediaPipe over the video,
   minutes each: a one-off; pass ``--videos DIR``): the same figures, with the grasp
   detector's grasp and with the person's annotated grasp frames.

``--reach-sweep`` adds the up error against the lift's reach (``lifts.MAX_REACH_M``).
Run: ``python benchmarks/bench_task_frame.py [--seeds 5] [--videos DIR] [--reach-sweep]``;
absent files are skipped. Results of a run are kept in ``benchmarks/task_frame_results.md``.
"""

from __future__ import annotations

import argparse
import logging
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "capture"))

from landmark_files import DATA  # noqa: E402

from dexlfd.capture import Intrinsics  # noqa: E402
from dexlfd.capture.camera_models import project_pinhole  # noqa: E402
from dexlfd.capture.recording_pose import estimate_recording_pose  # noqa: E402
from dexlfd.capture.rgb_lifting import PnPTracker  # noqa: E402
from dexlfd.datasets.hands import demonstration_with_hand  # noqa: E402
from dexlfd.io import Demonstration, load_demonstration  # noqa: E402
from dexlfd.motion import (  # noqa: E402
    MotionConfig,
    TaskFrame,
    apply_frame,
    demonstration_from_keypoints,
    estimate_task_frame,
    lift_events,
)
from dexlfd.rotations import quat_multiply  # noqa: E402
from dexlfd.trajectory import minimum_jerk  # noqa: E402

CAMERA = "camera (no extrinsics: x right, y down, z forward)"
RATE_HZ = 30.0
TABLE_Z = 0.0
K = Intrinsics.from_fov(640, 480, 60.0)
PIXEL_NOISE_PX = 1.5
TCP_NOISE_M = 0.003
WORLD_NOISE_M = 0.003
# the person's annotation of the videos: frame of the close, first frame open again
VIDEO_GRASPS = {
    "lfo_place_can": (258, 791),
    "lfo_shelf_can": (74, 769),
    "lfo_throw_can": (206, 507),
}
REAL = ("breakfast", "rearrange", "llama", "plush_toy", "bagging")


def _slanted(rng: np.random.Generator, slant_deg: float) -> np.ndarray:
    s, a = np.radians(slant_deg), rng.uniform(0, 2 * np.pi)
    return np.array([np.sin(s) * np.cos(a), np.sin(s) * np.sin(a), np.cos(s)])


def person_pick_place(
    rng: np.random.Generator, pick: np.ndarray, place: np.ndarray
) -> Demonstration:
    """One person-like pick-and-place in the base frame (z up), TCP level."""
    lift_top = pick + 0.12 * _slanted(rng, rng.uniform(5, 15))
    down_top = place + 0.12 * _slanted(rng, rng.uniform(5, 15))
    start = pick + np.array([-0.12, 0.05, 0.15])
    # (duration [s], from, to, arc height [m]); the grasp closes at the first hold
    segments = [
        (1.0, start, pick, 0.0),
        (0.4, pick, pick, 0.0),
        (0.5, pick, lift_top, 0.0),
        (1.2, lift_top, down_top, 0.05),
        (0.5, down_top, place, 0.0),
        (0.4, place, place, 0.0),
        (0.8, place, place + np.array([-0.1, 0.0, 0.15]), 0.0),
    ]
    pos, grasp = [], []
    for k, (dur, a, b, arc) in enumerate(segments):
        u = np.arange(int(round(dur * RATE_HZ))) / (dur * RATE_HZ)
        s = minimum_jerk(u)[0][:, None]
        pos.append(a + (b - a) * s + arc * np.sin(np.pi * s) * np.array([0.0, 0.0, 1.0]))
        grasp.append(np.full(u.size, 1 <= k <= 5))
    p = np.concatenate(pos)
    g = np.concatenate(grasp)
    n = p.shape[0]
    yaw = np.linspace(0.0, rng.uniform(-0.4, 0.4), n)
    q_yaw = np.stack([np.zeros(n), np.zeros(n), np.sin(yaw / 2), np.cos(yaw / 2)], 1)
    q = quat_multiply(q_yaw, np.array([1.0, 0.0, 0.0, 0.0]))  # gripper down
    return Demonstration(
        np.arange(n) / RATE_HZ, np.full((n, 21, 3), np.nan), np.ones(n, bool), p, q,
        np.where(g, 0.04, 0.08), g, {"source": "synthetic"}, frame="panda_base",
    )  # fmt: skip


def camera_to_base(pitch_deg: float, yaw_deg: float, distance_m: float) -> np.ndarray:
    """OpenCV camera (x right, y down, z forward) looking at the table's centre."""
    th, ps = np.radians(pitch_deg), np.radians(yaw_deg)
    z = np.array([np.cos(th) * np.cos(ps), np.cos(th) * np.sin(ps), -np.sin(th)])
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, :3] = np.stack([x, np.cross(z, x), z], axis=1)
    T[:3, 3] = np.array([0.0, 0.0, TABLE_Z]) - distance_m * z
    return T


def _keypoint_path(demo: Demonstration, T: np.ndarray, rng: np.random.Generator) -> Demonstration:
    cam = apply_frame(demo, np.linalg.inv(T), frame_name=CAMERA)
    noisy = cam.position + rng.normal(0.0, TCP_NOISE_M, cam.position.shape)
    return replace(cam, position=noisy)


def _ray_rotation(p: np.ndarray) -> np.ndarray:
    """Smallest rotations ``(n, 3, 3)`` taking the optical axis onto the rays to ``p``."""
    d = p / np.linalg.norm(p, axis=1, keepdims=True)
    v = np.cross([0.0, 0.0, 1.0], d)
    c = d[:, 2]
    V = np.zeros((len(d), 3, 3))
    V[:, 0, 1], V[:, 0, 2], V[:, 1, 2] = -v[:, 2], v[:, 1], -v[:, 0]
    V -= np.transpose(V, (0, 2, 1))
    return np.eye(3) + V + (V @ V) / (1.0 + c)[:, None, None]


def _pixel_path(
    demo: Demonstration, T: np.ndarray, rng: np.random.Generator, per_frame: bool = False
) -> Demonstration:
    hand = demonstration_with_hand(demo, rng)
    cam = apply_frame(hand, np.linalg.inv(T), frame_name=CAMERA)
    kp = cam.keypoints
    uv = project_pinhole(kp, K)[0] + rng.normal(0.0, PIXEL_NOISE_PX, kp.shape[:2] + (2,))
    centre = kp[:, [0, 5, 9, 13, 17]].mean(axis=1)
    # MediaPipe's world landmarks are hand-centred in axes turned so that the viewing ray
    # through the palm is their z (the lifting turns them back)
    world = np.einsum("nji,nkj->nki", _ray_rotation(centre), kp - centre[:, None])
    world = world + rng.normal(0.0, WORLD_NOISE_M, world.shape)
    valid = np.ones(kp.shape[0], bool)
    extras = {}
    if per_frame:  # the per-frame lift, each frame alone
        tracker = PnPTracker()
        lifted_kp = np.stack([tracker.lift(uv[i], world[i], K) for i in range(len(uv))])
    else:  # what `record` uses on a video: all frames together
        pose = estimate_recording_pose(demo.t, uv, world, valid, K)
        lifted_kp, extras = pose.keypoints, {"depth_std": pose.depth_std}
    cfg = MotionConfig(mount="top_grasp", grasp_method="absolute", max_gap_s=0.0)
    meta = {**cam.meta, "capture": {"depth": "approximate", "lift_model": "pnp"}}
    lifted = demonstration_from_keypoints(demo.t, lifted_kp, valid, cfg, meta=meta, extras=extras)
    return replace(lifted, grasp=demo.grasp)


def _travel(demo: Demonstration) -> float:
    (e,) = lift_events(demo)
    return float(np.linalg.norm(e.release_point - e.grasp_point))


def scene_errors(seed: int, pitch: float, path: str) -> tuple[float, float, float, float]:
    """Up error [deg], pitch error [deg], reported up_deg, median scale error [%]."""
    rng = np.random.default_rng(seed)
    T = camera_to_base(pitch, rng.uniform(-40, 40), rng.uniform(0.6, 0.9))
    demos = []
    for _ in range(3):
        pick = np.array([*rng.uniform(-0.2, 0.2, 2), TABLE_Z])
        place = np.array([*rng.uniform(-0.2, 0.2, 2), TABLE_Z])
        demos.append(person_pick_place(rng, pick, place))
    if path == "keypoint":
        cam = [_keypoint_path(d, T, rng) for d in demos]
    else:
        cam = [_pixel_path(d, T, rng, per_frame=path == "pixel-per-frame") for d in demos]
    frame = estimate_task_frame(cam)
    up_true = T[:3, :3].T @ np.array([0.0, 0.0, 1.0])
    err = float(np.degrees(np.arccos(np.clip(frame.up_camera @ up_true, -1, 1))))
    task = [apply_frame(c, frame.camera_to_task, frame.scale) for c in cam]
    ratio = [_travel(t) / _travel(d) - 1.0 for t, d in zip(task, demos, strict=True)]
    return (
        err,
        abs(frame.details["camera_pitch_deg"] - pitch),
        frame.uncertainty["up_deg"],
        100 * float(np.median(np.abs(ratio))),
    )


def synthetic(seeds: int) -> None:
    print("## Synthetic scenes, known camera (3 pick-and-places each, lifts slanted 5-15 deg)")
    print()
    print("| path | tilt [deg] | up error mean / max [deg] | pitch error mean [deg] | "
          "reported up_deg | scale error median [%] |")  # fmt: skip
    print("|---|---|---|---|---|---|")
    for path in ("keypoint", "pixel", "pixel-per-frame"):
        for pitch in (20, 30, 40, 50, 60, 70):
            r = np.array([scene_errors(s, pitch, path) for s in range(seeds)])
            print(
                f"| {path} | {pitch} | {r[:, 0].mean():.1f} / {r[:, 0].max():.1f} | "
                f"{r[:, 1].mean():.1f} | {r[:, 2].mean():.1f} | {np.median(r[:, 3]):.1f} |"
            )
    print()


def describe(name: str, demos: list[Demonstration]) -> None:
    """One line of figures for the pick-and-places of one camera."""
    frame: TaskFrame = estimate_task_frame(demos, names=[f"{name}-{k}" for k in range(len(demos))])
    d, u = frame.details, frame.uncertainty
    runs = d["runs"]
    ups = np.array([r["up_camera"] for r in runs])
    pair = np.degrees(np.arccos(np.clip(ups @ ups.T, -1.0, 1.0)))
    travel = [
        float(np.linalg.norm(e.release_point - e.grasp_point))
        for dm in demos
        for e in lift_events(dm)
        if np.isfinite(e.release_point).all() and np.isfinite(e.grasp_point).all()
    ]
    per_run = ", ".join(
        f"{r['angle_to_up_deg']:.0f}{'' if r['kept'] else ' (not used)'}" for r in runs
    )
    print(
        f"| {name} | {len(runs)} | {per_run} | {pair.max():.0f} | {d['camera_pitch_deg']:.0f} | "
        f"{d['camera_height_m']:.2f} | {' '.join(f'{x:.2f}' for x in travel)} | "
        f"{u['table_m']:.3f} | {u['up_deg']:.1f} | {100 * u['scale_rel']:.0f} | "
        f"{d['hand_length_m']:.3f} | {'fused' if d['plane']['used'] else d['plane']['reason']} |"
    )


def real(videos: Path | None) -> None:
    from dexlfd.apps.record import RecordConfig, record_demonstration

    print("## Real recordings (one camera each, no extrinsics)")
    print()
    print("| recording | runs | each run's angle to up [deg] | largest pairwise [deg] | "
          "pitch [deg] | camera height [m] | travel [m] | table RMS [m] | up_deg | "
          "scale_rel [%] | hand [m] | plane |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name in REAL:
        f = DATA / f"{name}.npz"
        if f.is_file():
            describe(name, list(record_demonstration(str(f), RecordConfig()).demos))
    if videos is not None:
        for stem in ("lfo_place_can", "lfo_shelf_can", "lfo_throw_can"):
            files = sorted(videos.glob(f"{stem}.npz")) or sorted(videos.glob(f"{stem}-*.npz"))
            if files:
                demos = [load_demonstration(p) for p in files]
                describe(stem, demos)
                # the person's grasp frames (data README), in place of the detector's
                close, release = VIDEO_GRASPS[stem]
                frames = [np.round(d.t * d.meta["capture"]["fps"]).astype(int) for d in demos]
                annotated = [
                    replace(d, grasp=(f >= close) & (f < release))
                    for d, f in zip(demos, frames, strict=True)
                ]
                describe(f"{stem}, annotated grasp", annotated)
    print()


def reach_sweep(seeds: int) -> None:
    """Up error [deg] against ``lifts.MAX_REACH_M`` (RGB depth noise vs corners)."""
    from dexlfd.motion import lifts

    default = lifts.MAX_REACH_M
    print("## Reach of the lift / set-down (`lifts.MAX_REACH_M`): mean up error [deg]")
    print()
    print(
        "| reach [m] | pixel 20 | pixel 40 | pixel 60 | keypoint 20 | keypoint 40 | keypoint 60 |"
    )
    print("|---|---|---|---|---|---|---|")
    for reach in (0.06, 0.10, 0.15, 0.20):
        lifts.MAX_REACH_M = reach
        cells = [
            np.mean([scene_errors(s, pitch, path)[0] for s in range(seeds)])
            for path in ("pixel", "keypoint")
            for pitch in (20, 40, 60)
        ]
        print(f"| {reach:.2f} | " + " | ".join(f"{c:.1f}" for c in cells) + " |")
    lifts.MAX_REACH_M = default
    print()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--videos", type=Path, help="folder of `dexlfd record` outputs of videos")
    ap.add_argument("--reach-sweep", action="store_true", help="also sweep lifts.MAX_REACH_M")
    args = ap.parse_args()
    logging.basicConfig(level=logging.ERROR)
    synthetic(args.seeds)
    if args.reach_sweep:
        reach_sweep(args.seeds)
    real(args.videos)


if __name__ == "__main__":
    main()
