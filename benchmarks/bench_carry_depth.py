"""What the pixels say about the depth's motion over each carry: the whole hand's bones.

The depth ``record`` writes is read from the palm (its template's affine fit), smoothed
with a motion prior. A carry that reads long could be the depth moving along the line
of sight where the hand does not: this measures, per carry of the real recordings (the
landmark recordings and the videos' cached tracker output of
:mod:`bench_real_recordings`), what the hand's apparent size in the image says.

The whole hand's reading (``landmark_files.bone_depth``): every bone (the palm's ten
distances, the fingers' phalanges, the thumb) bounds the depth from above
(``z <= f L / l``: a bone spans its full ``f L / z`` pixels only when square to the
line of sight), so each frame's bones that read the nearest depth are its least
foreshortened; each bone's length is its apparent size at the 90th percentile over the
clip at the written depth's level. The reading has the written depth's scale and the
pixels' own change.

Per carry (``record``'s grasp found, its first to last seen frame) this prints the
written depth at both ends and the bones' (7-frame medians), the agreement of their
changes in sigmas (the bones' frame-to-frame noise and the written depth's std), the
wrist-to-middle-MCP length and the palm's width in pixels at both ends, the carry's
component along the line of sight, the carry's ratio to the annotated travel, and both
changes again over the demonstration's frames alone (the wrist's distance from the camera,
the bones' lengths set on those frames: how much the reading depends on its frames).

``--variants`` then runs ``record`` with the bones' reading put into the depth, each
way leave-one-recording-out against the palm's alone (``palm``):

- ``fused-K``: the bones' reading (the mean of the ``K`` least foreshortened) a second
  measurement of each frame in the same robust smoother (its std its robust spread
  about the palm's smoothed depth);
- ``edge-K``: the same, only in frames whose palm is seen edge-on (``edge_on_deg``);
- ``slow-A``: the palm's depth times the slowly varying part of the bones' disagreement
  with it (a second smoother of ``log(bones / palm)`` with acceleration density ``A``
  [1/s^1.5]): the bones hold the long-run depth, the palm the short-run.

Per recording and variant: each carry's travel ratio and IoU, the carry with its
1-sigma, the wrist's step p99/max, the task frame's camera pitch and the deepest dip of
the wrist under its grasp height over the carry (and how long it stays 2 cm under)::

    PYTHONPATH=src python benchmarks/bench_carry_depth.py [--variants]
"""

from __future__ import annotations

import logging
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(ROOT / "tests" / "capture"))

from landmark_files import bone_depth  # noqa: E402

import bench_carry_scale as bcs  # noqa: E402
import bench_real_recordings as brr  # noqa: E402
from dexlfd.apps.record import RecordConfig, record_demonstration  # noqa: E402

# the camera's pitch a person read off the frames (the README: breakfast's camera looks
# down ~40 deg); each lift run's angle to that up is printed
ANNOTATED_PITCH_DEG = {"breakfast": 40.0}
VARIANTS = ("palm", "fused-1", "fused-2", "fused-3", "edge-2", "slow-0.02", "slow-0.1", "slow-0.5")
_SEEN: dict = {}


def use_variant(name: str) -> None:
    """Every pose estimate of this process with the depth made the ``name`` way."""
    import dexlfd.capture.recording_pose as rp

    real_fit = getattr(rp, "_bench_fit_palm", rp.fit_palm)
    real_depth = getattr(rp, "_bench_palm_depth", rp.palm_depth)
    rp._bench_fit_palm, rp._bench_palm_depth = real_fit, real_depth  # type: ignore[attr-defined]
    rp.fit_palm, rp.palm_depth = real_fit, real_depth  # type: ignore[misc]
    if name == "palm":
        return
    kind, arg = name.split("-", 1)

    def fit(uv, W, ok, K, cfg):  # type: ignore[no-untyped-def]
        out = real_fit(uv, W, ok, K, cfg)
        edge = np.zeros(ok.size, bool)
        edge[out.idx] = out.cos_world < math.cos(math.radians(cfg.edge_on_deg))
        _SEEN.update(uv=np.where(ok[:, None, None], uv, np.nan), f=float(K.fx), edge=edge)
        return out

    def depth(t, idx, z, sigma_l, curl, measured, cfg):  # type: ignore[no-untyped-def]
        dep = real_depth(t, idx, z, sigma_l, curl, measured, cfg)
        if dep.depth_measured:
            return dep
        curl_n = np.full(t.size, np.nan)
        curl_n[idx] = curl
        meas_l = dep.measured_m * np.exp(-dep.curl_beta * (curl_n - np.nanmedian(curl_n)))
        uv = (
            _SEEN["uv"]
            if kind != "edge"
            else np.where(_SEEN["edge"][:, None, None], _SEEN["uv"], np.nan)
        )
        least = int(arg) if kind != "slow" else 2
        zb = bone_depth(uv, dep.depth_m, _SEEN["f"], least=least)
        made = (
            fused(t, meas_l, dep, zb, cfg) if kind != "slow" else slow(t, dep, zb, float(arg), cfg)
        )
        return made if made is not None else dep

    rp.fit_palm, rp.palm_depth = fit, depth  # type: ignore[assignment]


def fused(t, meas_l, dep, zb, cfg):  # type: ignore[no-untyped-def]
    """The depth smoothed with the bones' reading as a second measurement."""
    from dexlfd.capture.palm_depth import running_median
    from dexlfd.capture.robust_smoother import robust_smooth

    good = np.isfinite(zb) & np.isfinite(dep.depth_m)
    if good.sum() < 10:
        return None
    r = np.log(zb[good] / dep.depth_m[good])
    rel = max(1.4826 * float(np.median(np.abs(r - np.median(r)))), 1e-3)
    level = np.full(t.size, np.nan)
    level[good] = running_median(zb[good], cfg.level_window)
    z, sd, w = robust_smooth(
        t, meas_l, dep.measured_std, cfg.depth_accel, cauchy_c=cfg.cauchy_c,
        iterations=cfg.iterations, extra=(np.where(good, zb, np.nan), rel * level),
    )  # fmt: skip
    return replace(dep, depth_m=z, depth_std=sd, weight=w)


def slow(t, dep, zb, accel, cfg):  # type: ignore[no-untyped-def]
    """The palm's depth times the slowly varying part of the bones' disagreement."""
    from dexlfd.capture.robust_smoother import robust_smooth

    good = np.isfinite(zb) & np.isfinite(dep.depth_m)
    if good.sum() < 10:
        return None
    d = np.where(good, np.log(zb / dep.depth_m), np.nan)
    rel = max(1.4826 * float(np.nanmedian(np.abs(d - np.nanmedian(d)))), 1e-3)
    ds, _, _ = robust_smooth(t, d, np.where(good, rel, np.nan), accel, cauchy_c=cfg.cauchy_c)
    k = np.exp(np.where(np.isfinite(ds), ds, 0.0))
    return replace(dep, depth_m=dep.depth_m * k, depth_std=dep.depth_std * k)


def one(name: str, path: Path, ann: dict) -> dict:
    """``record`` on one recording: per carry the written and the bones' depths, figures."""
    import dexlfd.capture.recording_pose as rp
    from dexlfd.motion import estimate_task_frame

    seen: list = []
    real = getattr(rp, "_bench_real_estimate", rp.estimate_recording_pose)
    rp._bench_real_estimate = real  # type: ignore[attr-defined]

    def spy(*a, **k):  # type: ignore[no-untyped-def]
        seen.append((a, real(*a, **k)))
        return seen[-1][1]

    rp.estimate_recording_pose = spy  # type: ignore[assignment]
    res = record_demonstration(str(path), RecordConfig())
    (t, uv_all, _, valid_all, K, *_), est = seen[0]
    z = est.depth_m
    zb = bone_depth(np.where(valid_all[:, None, None], uv_all, np.nan), z, float(K.fx))
    lz = np.diff(np.log(zb))
    lz = lz[np.isfinite(lz)]
    noise = 1.4826 * float(np.median(np.abs(lz - np.median(lz)))) / math.sqrt(2.0)
    demos = [d for d in res.demos if d.quality.pick_and_place]
    fr = estimate_task_frame(demos, names=[f"{name}-{k}" for k in range(len(demos))])
    up = np.asarray(fr.up_camera)
    dp, _ = brr.steps(list(res.demos))
    rows = []
    for k, g in enumerate(ann["grasps"]):
        found = [(f, d) for f, d in ((brr.grasp_of(d), d) for d in demos) if f is not None]
        (span, dist, _), d = max(found, key=lambda fd: brr.iou(g, fd[0][0]))
        first = int((d.source_frames or (0, 0))[0])
        sf = np.flatnonzero(d.valid)
        ia, ib = (int(sf[np.argmin(np.abs(sf - (s - first)))]) for s in span)
        ends = []
        for i in (ia + first, ib + first):
            w = slice(max(i - 3, 0), i + 4)
            nb = max(int(np.isfinite(zb[w]).sum()), 1)
            zw = float(np.nanmedian(z[w]))
            var = (1.25 * noise) ** 2 / nb + (float(np.nanmedian(est.depth_std[w])) / zw) ** 2
            ends.append((zw, float(np.nanmedian(zb[w])), var))
        (wa, ba, va), (wb, bb, vb) = ends
        p, uv = d.position, d.extras["uv_px"]
        # the same reading made over the demonstration's frames alone, at the wrist's
        # distance from the camera: how much it depends on the frames it is set on
        dist_d = np.where(d.valid, np.linalg.norm(p, axis=1), np.nan)
        zb_d = bone_depth(np.where(d.valid[:, None, None], uv, np.nan), dist_d, 1.0)
        demo_ends = [
            tuple(float(np.nanmedian(x[max(i - 3, 0) : i + 4])) for x in (dist_d, zb_d))
            for i in (ia, ib)
        ]
        sight = (p[ia] + p[ib]) / np.linalg.norm(p[ia] + p[ib])
        h = p @ up
        h0 = float(np.nanmedian(h[max(ia - 2, 0) : ia + 3][d.valid[max(ia - 2, 0) : ia + 3]]))
        under = np.where(d.valid[ia : ib + 1], h0 - h[ia : ib + 1], np.nan)
        rows.append({
            "k": k, "span": span, "iou": brr.iou(g, span), "ratio": dist / ann["travel"][k],
            "carry": (d.quality.carry_m, d.quality.carry_std_m), "written": (wa, wb),
            "bones": (ba, bb),
            "demo": demo_ends,
            "sigmas": abs(math.log(wb / wa) - math.log(bb / ba)) / math.sqrt(va + vb),
            "hand_px": [float(np.linalg.norm(uv[i, 9] - uv[i, 0])) for i in (ia, ib)],
            "width_px": [float(np.linalg.norm(uv[i, 5] - uv[i, 17])) for i in (ia, ib)],
            "along": float(np.dot(p[ib] - p[ia], sight)),
            "dip_cm": 100 * float(np.nanmax(under)),
            "under_s": float(np.sum(under > 0.02) * np.median(np.diff(d.t))),
        })  # fmt: skip
    return {
        "name": name, "rows": rows, "pitch": float(fr.details["camera_pitch_deg"]),
        "step": (100 * float(np.percentile(dp, 99)), 100 * float(dp.max())), "noise": noise,
        "runs": [(np.asarray(u["up_camera"]), bool(u["kept"])) for u in fr.details["runs"]],
    }  # fmt: skip


def show_evidence(r: dict) -> None:
    """One line per carry: the written depth's change against the bones'."""
    for c in r["rows"]:
        (wa, wb), (ba, bb) = c["written"], c["bones"]
        print(
            f"{r['name']}#{c['k']} {c['span'][0]}-{c['span'][1]} | written {wa:.2f}->{wb:.2f} "
            f"({wb / wa:.2f}x) | bones {ba:.2f}->{bb:.2f} ({bb / ba:.2f}x) | "
            f"{c['sigmas']:.1f} sigma (bones' noise {100 * r['noise']:.1f} %/frame) | "
            f"hand {c['hand_px'][0]:.0f}/{c['hand_px'][1]:.0f} px, "
            f"width {c['width_px'][0]:.0f}/{c['width_px'][1]:.0f} px | "
            f"along sight {c['along']:+.2f} m | ratio {c['ratio']:.2f} | over the "
            f"demonstration alone: written {c['demo'][1][0] / c['demo'][0][0]:.2f}x, bones "
            f"{c['demo'][1][1] / c['demo'][0][1]:.2f}x"
        )


def show_variant(v: str, r: dict) -> None:
    """One recording's figures under variant ``v``."""
    carries = "; ".join(
        f"{c['ratio']:.2f} (IoU {c['iou']:.2f}, {100 * c['carry'][0]:.0f}+-"
        f"{100 * (c['carry'][1] or 0):.0f} cm, dip {c['dip_cm']:.1f} cm/{c['under_s']:.1f} s)"
        for c in r["rows"]
    )
    runs = ""
    if r["name"] in ANNOTATED_PITCH_DEG:  # each run's angle to the annotated up
        p = math.radians(ANNOTATED_PITCH_DEG[r["name"]])
        true_up = np.array([0.0, -math.cos(p), -math.sin(p)])
        angles = [
            f"{math.degrees(math.acos(float(np.clip(u @ true_up, -1, 1)))):.0f}"
            + ("" if k else " (not used)")
            for u, k in r["runs"]
        ]
        runs = f" | runs' angle to the annotated up [deg]: {', '.join(angles)}"
    print(
        f"{v:9s} {r['name']:14s} pitch {r['pitch']:5.1f} | step {r['step'][0]:.1f}/"
        f"{r['step'][1]:.1f} cm | {carries}{runs}"
    )


def loro(results: dict[str, list[dict]]) -> None:
    """Leave one recording out: the variant of least mean |log ratio| on the others."""
    names = [r["name"] for r in results["palm"]]

    def err(v: str, keep: set[str]) -> float:
        lr = [abs(math.log(c["ratio"])) for r in results[v] if r["name"] in keep for c in r["rows"]]
        return float(np.mean(lr))

    held = []
    for n in names:
        best = min(results, key=lambda v: err(v, set(names) - {n}))
        rows = next(r for r in results[best] if r["name"] == n)["rows"]
        held += [(n, c["ratio"]) for c in rows]
        print(
            f"held out {n}: chosen {best}, ratios " + ", ".join(f"{c['ratio']:.2f}" for c in rows)
        )
    for v in results:
        own = [(r["name"], c["ratio"]) for r in results[v] for c in r["rows"]]
        _count(f"{v} (all folds)", own)
    _count("held out", held)


def _count(label: str, pairs: list[tuple[str, float]]) -> None:
    """Carries within 0.7-1.4 (of all, and without rearrange) and mean |log ratio|."""
    inr = [0.7 <= r <= 1.4 for _, r in pairs]
    judged = [ok for (n, _), ok in zip(pairs, inr, strict=True) if n != "rearrange"]
    mean = np.mean([abs(math.log(r)) for _, r in pairs])
    print(
        f"{label}: within 0.7-1.4 {sum(inr)} of {len(inr)} "
        f"({sum(judged)} of {len(judged)} without rearrange); mean |log ratio| {mean:.2f}"
    )


def main() -> int:
    if not brr.DATA.is_dir():
        print(f"no real landmark recordings at {brr.DATA}: nothing to measure")
        return 0
    logging.disable(logging.WARNING)
    recs = bcs.recordings()
    use_variant("palm")
    for name, path, ann in recs:
        show_evidence(one(name, path, ann))
    if "--variants" not in sys.argv:
        return 0
    results: dict[str, list[dict]] = {}
    for v in VARIANTS:
        use_variant(v)
        results[v] = [one(name, path, ann) for name, path, ann in recs]
        for r in results[v]:
            show_variant(v, r)
    use_variant("palm")
    loro(results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
