"""Task structure on real MediaPipe recordings: demonstrations found and grasp IoU per file.

Reads the five real landmark recordings (MediaPipe Hands' output on real pick-and-place
videos, with a person's annotation of the grasp frames) from ``../shared/data/landmarks``
next to the repository (or ``$DEXLFD_SHARED/data/landmarks``), replays them through the
hand association and choice
(``capture.source_tracking``) and the motion stage's phases, and prints per file: the
hand chosen, the episodes found, each grasp's frames and its IoU with the annotated
grasp, the warnings, and the time taken; ``--sensitivity`` repeats it with one setting
changed at a time. Run with the venv's python::

    PYTHONPATH=src python benchmarks/bench_task_landmarks.py [--sensitivity]
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

from dexlfd.capture.association import HandAssociator
from dexlfd.capture.keypoints import FrameKeypoints
from dexlfd.capture.landmark_recording import load_landmark_recording, observations_at
from dexlfd.capture.source_tracking import _chosen_rows
from dexlfd.motion import GraspConfig, PhaseConfig
from dexlfd.motion.phases import track_actions, track_phases

# ../shared beside the checkout; DEXLFD_SHARED overrides it (e.g. from a git worktree)
SHARED = Path(os.environ.get("DEXLFD_SHARED", Path(__file__).resolve().parents[2] / "shared"))
DATA = SHARED / "data" / "landmarks"

# the person's annotation: acting hand's grasp frames (close -> last closed), expected
# pick-and-places, and the open idle hand that must never grasp (image x side)
ANNOTATION = {
    "breakfast": {"grasps": [(26, 74), (94, 132), (152, 197)], "n": 3, "idle": "right"},
    "rearrange": {"grasps": [(30, 104), (146, 214)], "n": 2, "idle": None},
    "llama": {"grasps": [(35, 104)], "n": 1, "idle": None},
    "plush_toy": {"grasps": [(34, 61)], "n": 1, "idle": "right"},
    "bagging": {"grasps": [(132, 212)], "n": 1, "idle": None, "two_hands": True},
}


def load_tracks(path: Path) -> tuple[np.ndarray, dict[int, dict[int, FrameKeypoints]], list[int]]:
    """Replay a landmark file through :class:`HandAssociator`: times, per-track rows, counts.

    The recording is read and its hands returned per frame by the capture stage's own
    reader (:mod:`dexlfd.capture.landmark_recording`; these videos are unmirrored); the
    rows' keypoints are the world landmarks (no lifting: the phases read no metric depth).
    """
    rec = load_landmark_recording(path)
    t = np.asarray(rec.t_s, dtype=np.float64)
    assoc = HandAssociator()
    per_track: dict[int, dict[int, FrameKeypoints]] = {}
    counts = []
    for i in range(t.size):
        hands = observations_at(rec, i, mirrored=False)
        for k, obs in assoc.update(hands, float(t[i])):
            per_track.setdefault(k, {})[i] = FrameKeypoints(
                float(t[i]), obs.world_m, True, obs.uv_px, obs.score, obs.handedness,
                len(hands), 0, obs,
            )  # fmt: skip
        counts.append(len(hands))
    return t, per_track, counts


def iou(a: tuple[int, int], b: tuple[int, int]) -> float:
    """Frame IoU of two inclusive frame ranges."""
    inter = max(0, min(a[1], b[1]) - max(a[0], b[0]) + 1)
    return inter / (max(a[1], b[1]) - min(a[0], b[0]) + 1 - 0 * inter) if inter else 0.0


def run(name: str, grasp_cfg: GraspConfig | None = None, cfg: PhaseConfig | None = None) -> dict:
    """Hand choice, episodes and grasp IoU of one recording (with these settings)."""
    t0 = time.perf_counter()
    t, per_track, counts = load_tracks(DATA / f"{name}.npz")

    def judge(t, uv, world, seen):  # track_actions with the settings under test
        ph, _ = track_phases(t, world, seen, world_m=world, uv_px=uv, grasp_cfg=grasp_cfg, cfg=cfg)
        kinds = [e.kind for e in ph.episodes]
        return kinds.count("pick_and_place"), len(kinds) - kinds.count("push")

    default = grasp_cfg is None and cfg is None
    rows, choice = _chosen_rows(
        list(t), per_track, counts, "auto", track_actions if default else judge
    )
    n = t.size
    uv = np.stack([r.uv_px for r in rows])
    world = np.stack([r.keypoints for r in rows])
    seen = np.array([r.valid for r in rows])
    phases, _ = track_phases(t, world, seen, world_m=world, uv_px=uv, grasp_cfg=grasp_cfg, cfg=cfg)
    elapsed = time.perf_counter() - t0
    found = [(e.grasp_start, (e.release or n) - 1) for e in phases.pick_and_places]
    ann = ANNOTATION[name]
    ious = [max((iou(g, f) for f in found), default=0.0) for g in ann["grasps"]]
    x = float(np.nanmedian(uv[:, 0, 0]))
    return {
        "name": name,
        "hand": f"{choice['hand']} (image x ~{x:.0f} px)",
        "episodes": [
            (e.kind, e.grasp_start, e.release, e.start, e.stop, e.reason) for e in phases.episodes
        ],  # fmt: skip
        "n_pick_and_place": len(found),
        "n_expected": ann["n"],
        "grasps": found,
        "iou": ious,
        "warning": choice.get("warning"),
        "tracks": [
            (a["track"], a["label"], round(a["seen"], 2), a["pick_and_places"], a["carries"])
            for a in choice["tracks"]
        ],
        "elapsed_s": elapsed,
    }


# one setting changed at a time: does the result hold beyond the values chosen?
SENSITIVITY = [
    ("stop_speed", PhaseConfig, (1.0, 2.0)),
    ("min_carry", PhaseConfig, (0.7, 1.5)),
    ("min_grasp_s", PhaseConfig, (0.3, 0.7)),
    ("stop_window_s", PhaseConfig, (0.1, 0.3)),
    ("close_above", GraspConfig, (0.45, 0.55)),
    ("open_below", GraspConfig, (0.3, 0.4)),
    ("min_curl_contrast_deg", GraspConfig, (5.0, 15.0)),
]


def _ok(r: dict) -> bool:
    return r["n_pick_and_place"] == r["n_expected"] and min(r["iou"]) >= 0.7


def sensitivity() -> None:
    """Files that still give the expected count with every grasp IoU >= 0.7."""
    for field, kind, values in SENSITIVITY:
        for v in values:
            gc = GraspConfig(**{field: v}) if kind is GraspConfig else None
            pc = PhaseConfig(**{field: v}) if kind is PhaseConfig else None
            res = [run(name, gc, pc) for name in ANNOTATION]
            worst = min(min(r["iou"]) for r in res)
            good = sum(_ok(r) for r in res)
            print(f"  {field} = {v:g}: {good}/{len(res)} files right, lowest grasp IoU {worst:.2f}")


def main() -> int:
    if not DATA.is_dir():
        print(f"no real landmark recordings at {DATA}: nothing to measure")
        return 0
    ok = True
    for name in ANNOTATION:
        r = run(name)
        good = _ok(r)
        ok &= good
        verdict = "OK" if good else "MISS"
        print(f"{name}: {r['n_pick_and_place']} pick-and-place(s) (expected {r['n_expected']}), "
              f"hand {r['hand']}, {1000 * r['elapsed_s']:.0f} ms {verdict}")  # fmt: skip
        print(f"  grasps {r['grasps']}  IoU " + ", ".join(f"{v:.2f}" for v in r["iou"]))
        print(f"  episodes {r['episodes']}")
        print(f"  tracks (id, label, seen, pick-and-places, carries) {r['tracks']}")
        if r["warning"]:
            print(f"  WARNING {r['warning']}")
    if "--sensitivity" in sys.argv:
        print("sensitivity (one setting changed at a time):")
        sensitivity()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
