"""Why a carried distance comes out short or long: the carry decomposed per recording.

For every pick-and-place of the real recordings (the landmark recordings and the videos'
cached tracker output of :mod:`bench_real_recordings`) ``record``'s own pipeline runs with
its defaults, and per carry (the grasp's first to last seen frame) this prints:

- the grasp frames found and their IoU with the annotated grasp;
- the wrist's image displacement [px], the hand's pixel length (wrist to middle MCP) at
  both ends and the focal length assumed [px];
- the palm template's length (wrist to middle MCP) and width (index to little MCP) [cm]
  and the depth each implies from its pixel length at the grasp (``f L / L_px``);
- the estimated depth at both ends [m], the carry's component along the line of sight
  and across it [m], the carry with its 1-sigma [m] (the typed ``carry_m`` /
  ``carry_std_m`` of the quality report) and its ratio to the annotated travel, and the
  depth's full-size factor with its relative 1-sigma (``Capture.depth_scale`` /
  ``depth_scale_sd``);
- the task frame's camera pitch from the pick-and-places, and the wrist's
  frame-to-frame step p99 / max [cm].

``--quantile Q`` (repeatable, default ``0`` and the configured default) runs each
recording with ``RecordingPoseConfig.depth_template_quantile = Q`` (0: the palm's
depth read against the clip's median palm; > 0: against the palm at its full size,
:func:`dexlfd.capture.palm_template.full_size_palm`), so the two can be set side by
side::

    PYTHONPATH=src python benchmarks/bench_carry_scale.py --quantile 0 --quantile 90
"""

from __future__ import annotations

import logging
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_real_recordings as brr  # noqa: E402
from dexlfd.apps.record import RecordConfig, record_demonstration  # noqa: E402
from dexlfd.capture.palm_template import PALM, full_size_palm, palm_template  # noqa: E402


def recordings() -> list[tuple[str, Path, dict]]:
    """(name, landmark file, annotation) of every real recording with a carry annotated."""
    out = [(n, brr.DATA / f"{n}.npz", a) for n, a in brr.ANNOTATION.items()]
    if brr.VIDEOS.is_dir():
        out += [(n, brr.video_landmarks(n), a) for n, a in brr.VIDEO_ANNOTATION.items()]
    # rearrange's camera is fixed (its background moves < 0.5 px): its carries are judged
    travel = {"rearrange": [0.35, 0.40]}
    return [(n, p, {**a, "travel": travel.get(n, a["travel"])}) for n, p, a in out if a["grasps"]]


def with_quantile(q: float) -> None:
    """Every pose estimate of this process with ``depth_template_quantile=q``."""
    import dexlfd.capture.recording_pose as rp

    base = rp.RecordingPoseConfig
    keep = getattr(rp, "_bench_base_config", base)
    rp._bench_base_config = keep  # type: ignore[attr-defined]
    rp.RecordingPoseConfig = lambda *a, **k: replace(keep(*a, **k), depth_template_quantile=q)  # type: ignore[misc,assignment]


def spy_pose() -> list:
    """The arguments of every :func:`estimate_recording_pose` call, collected."""
    import dexlfd.capture.recording_pose as rp

    seen: list = []
    real = getattr(rp, "_bench_real_estimate", rp.estimate_recording_pose)
    rp._bench_real_estimate = real  # type: ignore[attr-defined]

    def spy(*a, **k):  # type: ignore[no-untyped-def]
        seen.append(a)
        return real(*a, **k)

    rp.estimate_recording_pose = spy  # type: ignore[assignment]
    return seen


def one(name: str, path: Path, ann: dict, q: float) -> list[dict]:
    """The decomposition of each annotated carry of one recording at quantile ``q``."""
    from dexlfd.motion import estimate_task_frame

    with_quantile(q)
    seen = spy_pose()
    res = record_demonstration(str(path), RecordConfig())
    t, uv_all, W_all, valid_all, K = seen[0][:5]
    ok = valid_all & np.isfinite(W_all[:, PALM]).all(axis=(1, 2))
    T, _ = palm_template(W_all, ok)
    Qf = full_size_palm(W_all, ok)
    sizes = {
        "L_cm": 100 * float(np.linalg.norm(T[2] - T[0])),
        "W_cm": 100 * float(np.linalg.norm(T[1] - T[4])),
        "Wfull_cm": 100 * float(np.linalg.norm(Qf[1] - Qf[4])),
    }
    demos = [d for d in res.demos if d.quality.pick_and_place]
    pitch = float("nan")
    if demos:
        fr = estimate_task_frame(demos, names=[f"{name}-{k}" for k in range(len(demos))])
        pitch = float(fr.details["camera_pitch_deg"])
    dp, _ = brr.steps(list(res.demos))
    rows = []
    for k, g in enumerate(ann["grasps"]):
        found = [(brr.grasp_of(d), d) for d in demos]
        found = [(f, d) for f, d in found if f is not None]
        if not found:
            rows.append({"name": name, "k": k, "missing": True})
            continue
        (span, dist, _), d = max(found, key=lambda fd: brr.iou(g, fd[0][0]))
        first = int((d.source_frames or (0, 0))[0])
        seen_f = np.flatnonzero(d.valid)
        ia = seen_f[np.argmin(np.abs(seen_f - (span[0] - first)))]
        ib = seen_f[np.argmin(np.abs(seen_f - (span[1] - first)))]
        uv = d.extras["uv_px"]
        p = d.position
        hl = [float(np.linalg.norm(uv[i, 9] - uv[i, 0])) for i in (ia, ib)]
        wd = [float(np.linalg.norm(uv[i, 5] - uv[i, 17])) for i in (ia, ib)]
        move = p[ib] - p[ia]
        sight = (p[ia] + p[ib]) / np.linalg.norm(p[ia] + p[ib])
        along = float(np.dot(move, sight))
        rows.append(
            {
                "name": name,
                "k": k,
                "span": span,
                "iou": brr.iou(g, span),
                "px": float(np.linalg.norm(uv[ib, 0] - uv[ia, 0])),
                "hand_px": hl,
                "width_px": wd,
                "f": float(K.fx),
                "z": (float(p[ia, 2]), float(p[ib, 2])),
                "zL": K.fx * sizes["L_cm"] / 100 / hl[0],
                "zW": K.fx * sizes["Wfull_cm"] / 100 / wd[0],
                "along": along,
                "across": float(np.sqrt(max(dist**2 - along**2, 0.0))),
                "dist": dist,
                "carry": (d.quality.carry_m, d.quality.carry_std_m),
                "ratio": dist / ann["travel"][k],
                "pitch": pitch,
                "factor": (d.capture.depth_scale or 1.0, d.capture.depth_scale_sd or 0.0),
                "step": (100 * float(np.percentile(dp, 99)), 100 * float(dp.max())),
                **sizes,
            }
        )
    return rows


def show(r: dict, q: float) -> None:
    """One carry's line."""
    if r.get("missing"):
        print(f"{r['name']}#{r['k']} q={q:g}: no pick-and-place found")
        return
    c, s = r["carry"]
    carry = "-" if c is None else f"{100 * c:.0f}+-{100 * (s or 0):.0f}"
    print(
        f"{r['name']}#{r['k']} q={q:g} | {r['span'][0]}-{r['span'][1]} IoU {r['iou']:.2f} | "
        f"{r['px']:.0f} px, hand {r['hand_px'][0]:.0f}/{r['hand_px'][1]:.0f} px, "
        f"width {r['width_px'][0]:.0f}/{r['width_px'][1]:.0f} px, f {r['f']:.0f} px | "
        f"palm L {r['L_cm']:.1f} W {r['W_cm']:.1f} (full {r['Wfull_cm']:.1f}) cm, "
        f"z from L {r['zL']:.2f} from W {r['zW']:.2f} | z {r['z'][0]:.2f}->{r['z'][1]:.2f} m | "
        f"along/across {r['along']:+.2f}/{r['across']:.2f} m | carry {carry} cm, "
        f"ratio {r['ratio']:.2f} | factor {r['factor'][0]:.2f} +- {100 * r['factor'][1]:.0f} % | "
        f"pitch {r['pitch']:.0f} | step {r['step'][0]:.1f}/"
        f"{r['step'][1]:.1f} cm"
    )


def main() -> int:
    qs = [float(sys.argv[i + 1]) for i, a in enumerate(sys.argv) if a == "--quantile"]
    if not brr.DATA.is_dir():
        print(f"no real landmark recordings at {brr.DATA}: nothing to measure")
        return 0
    from dexlfd.capture.recording_pose_config import RecordingPoseConfig

    qs = qs or sorted({0.0, RecordingPoseConfig().depth_template_quantile})
    logging.disable(logging.WARNING)
    for name, path, ann in recordings():
        for q in qs:
            for r in one(name, path, ann, q):
                show(r, q)
    return 0


if __name__ == "__main__":
    sys.exit(main())
