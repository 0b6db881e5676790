"""Quality report of one recorded demonstration: is it usable, and if not, why.

:func:`quality_report` measures what a user needs before teaching a robot with a
recording: how often the hand was seen (over all the frames recorded, not only the
ones kept by the trim) and the longest gap, which hand was followed and why, the
grasp intervals, how far the wrist travelled, how much the tracking jitters, the
largest orientation step. It is **usable** only as one pick-and-place: one grasp
and one release (with ``phases``, :mod:`dexlfd.motion.phases`: one
``pick_and_place`` episode), the hand seen, real motion, plausible depth (where a
per-frame ``extras["depth_std"]`` [m] is recorded) and the hand that does the task.
Every warning names its reason and the frames (of the recording) it concerns; two
hands acting is a note, not a warning. :func:`format_quality` prints it in a few lines.
"""

from __future__ import annotations

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.intervals import true_runs
from dexlfd.io import Demonstration
from dexlfd.io.demonstration_facts import (
    GraspSpan,
    HandChoice,
    Quality,
    TaskEpisode,
    Trim,
    Trimmed,
)
from dexlfd.motion.gaps import find_gaps
from dexlfd.rotations import quat_angle

__all__ = [
    "format_quality",
    "jitter_dominated",
    "jitter_mm",
    "quality_report",
]

MIN_DETECTION = 0.8  # a recording seen in fewer frames has lost the hand
MAX_GAP_S = 0.5  # an interior gap longer than this loses the hand
MIN_TRAVEL_M = 0.02  # a wrist moving less than this did not move
# Jitter-dominated motion (see jitter_dominated): a real pick-and-place wrist path is
# 2.5-3.6 times its 5-95 % extent (MimicPlay's real play demo 3.6, the synthetic
# pick-and-place demos 2.5-2.9); the still hand of the shared video (frames of fists
# and pinches, no transport) gives 14.8 with the shape-gated pnp lift (15.8 before).
MAX_PATH_RATIO = 8.0  # wrist path / extent above which the motion is mostly jitter [-]
MAX_P99_SPEED = 2.0  # 99th-percentile wrist speed above which steps are jumps [m/s]
MAX_ORIENTATION_STEP_DEG = 90.0  # a larger step between seen frames is a tracking flip
# depth uncertainty (extras["depth_std"]): above this the depth of a frame is a guess; a
# hand 0.5-1 m from the camera carrying things 20-40 cm cannot be told apart beyond it
MAX_DEPTH_STD_M = 0.1
MAX_UNCERTAIN_FRACTION = 0.25  # more uncertain frames than this: implausible depth


def jitter_mm(t: FloatArray, position: FloatArray, valid: BoolArray, window: int = 5) -> float:
    """RMS distance [mm] of the wrist from its centred ``window``-frame mean, over seen runs.

    The hand's own motion over 5 frames (1/6 s) is nearly linear, which a centred
    mean leaves almost unchanged; what remains is tracking noise. NaN when no run is
    at least ``window`` frames long.
    """
    p = np.asarray(position, dtype=np.float64)
    v = np.asarray(valid, dtype=bool) & np.isfinite(p).all(axis=1)
    res = []
    kernel = np.ones(window) / window
    for a, b in true_runs(v):
        if b - a < window:
            continue
        seg = p[a:b]
        mean = np.stack([np.convolve(seg[:, k], kernel, mode="valid") for k in range(3)], 1)
        h = window // 2
        res.append(seg[h : h + mean.shape[0]] - mean)
    if not res:
        return float("nan")
    r = np.concatenate(res)
    return float(1000 * np.sqrt(np.mean(np.sum(r**2, axis=1))))


def jitter_dominated(path_m: float, extent_m: float, p99_speed: float) -> str | None:
    """Why the wrist's motion is mostly tracking noise, or None when it is not.

    A hand carrying something travels a path a few times its extent (there and
    back, approach and retreat: 2.5-3.6 on the demos measured, see
    ``MAX_PATH_RATIO``); noise on a still or barely moving hand adds path without
    extent (14.8-15.8 on the shared video's still hand). A path over 8 times the
    extent (about twice the largest real ratio, half the still hand's) is called
    jitter. Independently, a 99th-percentile wrist speed above 2 m/s (faster than
    a hand moves objects; the still hand gave 1.04 m/s before the shape gate,
    0.23 after, MimicPlay's 8 fps play demo 1.57) means the steps are jumps.
    """
    if extent_m > 0 and path_m > MAX_PATH_RATIO * extent_m:
        return (
            f"jitter-dominated motion: the wrist's path ({100 * path_m:.1f} cm) is "
            f"{path_m / extent_m:.0f} times its extent ({100 * extent_m:.1f} cm)"
        )
    if p99_speed > MAX_P99_SPEED:
        return (
            f"jumpy motion: the wrist moves faster than {p99_speed:.2f} m/s in 1 % of the "
            f"frames (a hand carrying things stays below {MAX_P99_SPEED:g} m/s)"
        )
    return None


def _finite_or_none(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def _frames(first: int, a: int, b: int) -> str:
    """``frames A-B`` of the recording for local frames ``a..b`` (inclusive)."""
    return f"frame {first + a}" if a == b else f"frames {first + a}-{first + b}"


def _structure(
    demo: Demonstration, first: int, intervals: list[tuple[int, int]]
) -> tuple[list[str], TaskEpisode | GraspSpan | None]:
    """Warnings on the task's structure and the pick-and-place episode (None without one).

    With ``phases``: the episodes whose grasp starts in this demonstration's
    frames; without: the grasp flags (a grasp ending before the last frame is released).
    """
    n = demo.n_samples
    last = first + n - 1
    everything = _frames(first, 0, n - 1)
    phases = demo.phases
    if phases is None:
        released = [iv for iv in intervals if iv[1] < n - 1]
        if not intervals:
            return [f"no grasp event: the aperture never closed and reopened ({everything})"], None
        if len(intervals) > 1:
            where = ", ".join(_frames(first, a, b) for a, b in intervals)
            return [f"{len(intervals)} grasps ({where}): one pick-and-place each"], None
        if not released:
            a, b = intervals[0]
            return [f"grasp without a release ({_frames(first, a, b)})"], None
        a, b = intervals[0]
        return [], GraspSpan(grasp_start=first + a, release=first + b + 1)
    mine = [e for e in phases.episodes if first <= e.grasp_start <= last]
    pp = [e for e in mine if e.kind == "pick_and_place"]
    warnings = []
    for e in mine:
        end = e.release - 1 if e.release is not None else last
        where = f"frames {e.grasp_start}-{min(end, last)}"
        if e.kind == "no_release":
            warnings.append(f"no pick-and-place: a grasp never released ({where}; a pour, or "
                            "an object still held?)")  # fmt: skip
        elif e.kind == "push":
            warnings.append(f"no pick-and-place: a push ({where}; contact, no grasp)")
        elif e.kind == "drag":
            warnings.append(f"no pick-and-place: a drag ({where}; never lifted)")
    if not mine:
        warnings.append(f"no pick-and-place: no grasp ({everything}: the hand never closed "
                        "at a stop, carried and opened)")  # fmt: skip
    if len(pp) > 1:
        where = ", ".join(f"frames {e.grasp_start}-{(e.release or 0) - 1}" for e in pp)
        warnings.append(f"{len(pp)} pick-and-places ({where}): one demonstration each "
                        "(episode_demonstrations)")  # fmt: skip
    return warnings, (pp[0] if len(pp) == 1 else None)


_KIND_WORDS = {
    "pick_and_place": "another pick-and-place",
    "no_release": "a grasp never released",
    "push": "a push",
    "drag": "a drag",
}


def _episode_notes(demo: Demonstration) -> list[str]:
    """What a demonstration cut from a recording leaves out: reported, never a veto."""
    ep = demo.episode
    notes = []
    others = ep.others if ep is not None else ()
    if others:
        where = ", ".join(
            f"{_KIND_WORDS.get(o.kind, o.kind)} (frame {o.grasp_start}"
            + ("" if o.release is None else f"-{o.release - 1}")
            + ")"
            for o in others
        )
        notes.append(f"the recording's other episodes, not part of this one: {where}")
    out = ep.outside if ep is not None else None
    unseen = 0 if out is None else out.unseen_before + out.unseen_after
    if unseen:
        a, b = demo.source_frames or (0, demo.n_samples)
        notes.append(
            f"hand unseen in {unseen} of the recording's frames outside this demonstration "
            f"(which is frames {a}-{b - 1}): not judged"
        )
    return notes


def _judged_rate(
    demo: Demonstration,
    detected: BoolArray,
    first: int,
    rate_all: float,
    trim: Trim | None,
) -> tuple[float, int, str]:
    """(detection rate, frames, what they are) the hand-lost verdict reads.

    A demonstration cut from a recording for one pick-and-place (its ``episode``)
    is judged on its carry: the frames from the grasp to the release (the reach and
    retreat are judged by the longest gap only); otherwise every frame recorded.
    """
    ep = demo.episode
    n = detected.size
    if ep is not None and ep.release is not None and n:
        a = max(int(ep.grasp_start) - first, 0)
        b = min(int(ep.release) - first, n - 1)
        if b >= a:
            seen = detected[a : b + 1]
            return (
                float(seen.mean()),
                int(seen.size),
                f"frames from the grasp to the release ({_frames(first, a, b)})",
            )
    return rate_all, n if trim is None else trim.n_original, "frames"


def _depth_warning(demo: Demonstration, first: int) -> str | None:
    """Implausible depth: too many seen frames with ``extras["depth_std"]`` above the limit."""
    std = demo.extras.get("depth_std")
    if std is None or np.shape(std) != (demo.n_samples,):
        return None
    std = np.asarray(std, dtype=np.float64)
    seen = demo.valid & np.isfinite(std)
    bad = np.flatnonzero(seen & (std > MAX_DEPTH_STD_M))
    if not seen.any() or bad.size <= MAX_UNCERTAIN_FRACTION * seen.sum():
        return None
    return (
        f"implausible depth: uncertain by more than {100 * MAX_DEPTH_STD_M:.0f} cm in "
        f"{_pct(bad.size / seen.sum())} of the seen frames ({_frames(first, bad[0], bad[-1])}, "
        f"median {100 * float(np.median(std[bad])):.0f} cm)"
    )


def _hand_warning(choice: HandChoice | None) -> tuple[str | None, str | None]:
    """(warning, note): not the hand doing the task; two hands acting."""
    if choice is None:
        return None, None
    mine = [a for a in choice.tracks if a.track == choice.track]
    others = [a for a in choice.tracks if a.track != choice.track]
    warning = None
    # a pick-and-place the skeleton alone reads does not outdo a grasp the pixels show
    shown = bool(mine and mine[0].shown_carries)
    doers = [a for a in others if a.pick_and_places and (a.shown_carries or not shown)]
    if mine and not mine[0].pick_and_places and doers:
        doer = doers[0]
        warning = (f"not the acting hand: the {mine[0].label} hand recorded does no "
                   f"pick-and-place; the {doer.label} hand does")  # fmt: skip
    return warning, choice.warning


def quality_report(demo: Demonstration) -> Quality:
    """Figures and warnings of one demonstration (its typed ``quality``).

    Frame numbers in the warnings are the recording's (``source_frames``).
    """
    t, v = demo.t, demo.valid
    n = t.size
    first = int((demo.source_frames or (0, n))[0])
    detected = np.asarray(demo.extras.get("detected", v), dtype=bool)
    gaps = [g for g in find_gaps(t, v) if g.interior] if n else []
    longest_gap = max(gaps, key=lambda g: g.duration_s, default=None)
    longest = float(longest_gap.duration_s) if longest_gap is not None else 0.0
    p = demo.position[v]
    if p.shape[0]:
        lo, hi = np.percentile(p, [5, 95], axis=0)
        extent = float(np.linalg.norm(hi - lo))
        steps = np.linalg.norm(np.diff(p, axis=0), axis=1)
        path = float(np.sum(steps))
        dt = np.diff(t[v])
        speed = steps[dt > 0] / dt[dt > 0]
        p99_speed = float(np.percentile(speed, 99)) if speed.size else 0.0
    else:
        extent = path = p99_speed = 0.0
    q = demo.quaternion[v]
    step, step_at = 0.0, 0
    if q.shape[0] > 1:
        steps_deg = np.degrees(quat_angle(q[1:], q[:-1]))
        step, step_at = float(steps_deg.max()), int(np.flatnonzero(v)[int(steps_deg.argmax()) + 1])
    intervals_idx = _grasp_runs(demo.grasp)
    intervals = [(float(t[a]), float(t[b])) for a, b in intervals_idx]
    choice = None if demo.capture is None else demo.capture.hand_choice
    hand = (choice.hand if choice else None) or (demo.motion.hand if demo.motion else None)
    rate = float(detected.mean()) if detected.size else 0.0
    trim = demo.trim
    rate_all = rate if trim is None else trim.detection_rate_original  # before the idle trim
    everything = _frames(first, 0, max(n - 1, 0))
    warnings = []
    judged, judged_n, of = _judged_rate(demo, detected, first, rate_all, trim)
    if judged < MIN_DETECTION or longest > MAX_GAP_S:
        where = ""
        if longest_gap is not None:
            span = _frames(first, longest_gap.start, longest_gap.stop - 1)
            where = f", longest gap {longest:.2f} s ({span})"
        warnings.append(f"hand lost: seen in {_pct(judged)} of the {judged_n} {of}{where}")
    structure, episode = _structure(demo, first, intervals_idx)
    warnings += structure
    if extent < MIN_TRAVEL_M:
        warnings.append(f"no motion: the wrist moved {100 * extent:.1f} cm ({everything})")
    elif (jitter := jitter_dominated(path, extent, p99_speed)) is not None:
        warnings.append(f"{jitter} ({everything})")
    if (depth := _depth_warning(demo, first)) is not None:
        warnings.append(depth)
    if step > MAX_ORIENTATION_STEP_DEG:
        warnings.append(
            f"orientation flips: a step of {step:.0f} deg between seen frames "
            f"(above {MAX_ORIENTATION_STEP_DEG:.0f} deg, at {_frames(first, step_at, step_at)})"
        )
    not_acting, two_hands = _hand_warning(choice)
    if not_acting:
        warnings.append(not_acting)
    recording = demo.recording
    notes = ([two_hands] if two_hands else []) + _episode_notes(demo)
    carry_m, carry_std_m = _carry(demo)
    return Quality(
        usable=not warnings,
        warnings=tuple(warnings),
        notes=tuple(notes),
        n_frames=int(n),
        n_frames_recorded=int(n if trim is None else trim.n_original),
        detection_rate_recorded=rate_all,
        source_frames=(first, first + int(n)),
        recording_frames=None if recording is None else recording.n_frames,
        recording_detection_rate=None if recording is None else recording.detection_rate,
        episode=demo.episode,
        pick_and_place=episode,
        duration_s=float(t[-1] - t[0]) if n else 0.0,
        detection_rate=rate,
        n_gaps=len(gaps),  # interior gaps left unfilled
        n_interpolated=int(np.sum(demo.extras.get("interpolated", np.zeros(0, bool)))),
        longest_gap_s=longest,
        hand=hand,
        hand_reason=choice.reason if choice else "the configured hand",
        grasp_intervals_s=tuple(intervals),
        grasp_method=None if demo.motion is None else demo.motion.grasp_method,
        # the object's carry (the longest grasp's ends) with its 1-sigma uncertainty [m]
        carry_m=carry_m,
        carry_std_m=carry_std_m,
        travel_extent_m=extent,
        travel_path_m=path,
        p99_speed_m_s=p99_speed,
        jitter_mm=_finite_or_none(jitter_mm(t, demo.position, v)),
        max_orientation_step_deg=step,
        trimmed=(
            Trimmed(start_s=trim.cut_start_s, end_s=trim.cut_end_s)
            if trim is not None and trim.moved
            else None
        ),
    )


def _carry(demo: Demonstration) -> tuple[float | None, float | None]:
    """The carry and its std [m] (:func:`~dexlfd.motion.carry_travel.carry_travel`)."""
    from dexlfd.motion.carry_travel import carry_travel

    cap = demo.capture
    scale_sd = 0.0 if cap is None or cap.depth_scale_sd is None else float(cap.depth_scale_sd)
    dist, std = carry_travel(
        demo.position, demo.grasp, demo.valid, demo.extras.get("depth_std"), scale_sd=scale_sd
    )
    return _finite_or_none(dist), _finite_or_none(std)


def _grasp_runs(grasp: BoolArray) -> list[tuple[int, int]]:
    """``(first, last)`` frame of every grasp run (inclusive)."""
    return [(a, b - 1) for a, b in true_runs(grasp)]


def _carry_text(q: Quality) -> str:
    """The carry and its std as printed, or nothing when the report has none."""
    if q.carry_m is None or q.carry_std_m is None:
        return ""
    return f", object carried {100 * q.carry_m:.0f} +- {100 * q.carry_std_m:.0f} cm"


def _pct(x: float) -> str:
    """A detection rate as every line prints it (one decimal)."""
    return f"{100 * x:.1f} %"


def _mm(x: float | None) -> str:
    return "n/a" if x is None else f"{x:.1f} mm"


def format_quality(name: str, q: Quality) -> str:
    """A few short lines summarising :func:`quality_report`'s result for ``name``."""
    iv = ", ".join(f"{a:.1f}-{b:.1f} s" for a, b in q.grasp_intervals_s) or "none"
    ep = q.episode
    part = f" [pick-and-place {ep.index} of {ep.of}]" if ep and ep.of > 1 else ""
    first, stop = q.source_frames
    rec = q.recording_frames
    rec_rate = q.recording_detection_rate
    seen_all = (
        f"; recording: {rec} frames, hand seen in {_pct(rec_rate)}"
        if rec is not None and rec_rate is not None
        else ""
    )
    reason = str(q.hand_reason).split(":")[0]  # the rule; the figures are in the file
    lines = [
        f"{name}{part}: {q.n_frames} frames ({first}-{stop - 1}, {q.duration_s:.1f} s), "
        "hand seen in "
        f"{_pct(q.detection_rate)} of them{seen_all}",
        f"  hand: {q.hand} ({reason})",
        f"  grasp ({q.grasp_method}): {iv}; {q.n_gaps} gap(s) left (longest "
        f"{q.longest_gap_s:.2f} s), {q.n_interpolated} frame(s) interpolated",
        f"  wrist travel {100 * q.travel_extent_m:.1f} cm{_carry_text(q)} (path "
        f"{100 * q.travel_path_m:.1f} cm), jitter {_mm(q.jitter_mm)}, largest "
        f"orientation step {q.max_orientation_step_deg:.0f} deg",
    ]
    cut = q.trimmed
    if cut is not None and (cut.start_s or cut.end_s):
        lines.append(
            f"  trimmed {cut.start_s or 0.0:.2f} s at the start, "
            f"{cut.end_s or 0.0:.2f} s at the end (hand still, or not in view; "
            f"of all {q.n_frames_recorded} frames recorded the hand was seen in "
            f"{_pct(q.detection_rate_recorded)})"
        )
    lines += [f"  note: {w}" for w in q.notes]
    lines += [f"  WARNING: {w}" for w in q.warnings]
    if q.usable:
        lines.append("  usable")
    else:
        why = "; ".join(w.split(":")[0] for w in q.warnings)
        lines.append(f"  NOT USABLE as a pick-and-place demonstration ({why})")
    return "\n".join(lines)
