"""From a person's videos to the robot doing the task (``dexlfd teach``).

Stages (each writes files under the output folder and is resumable, see
:mod:`dexlfd.apps._stages`; the figures and the video are drawn in background processes):

1. ``record`` - every source to demonstrations, one per pick-and-place, in a folder per
   source (:mod:`dexlfd.apps.teach_sources`), with snapshots of the grasp and release.
2. ``frame`` - each source's task frame (from its own demonstrations, or the base frame
   of calibrated ones), all demonstrations moved through it into the robot's base frame,
   the robot's pick and place (:mod:`dexlfd.apps.teach_frame`).
3. ``learn`` - DTW, GMM, GMR over every demonstration together (thesis §4.3).
4. ``figures`` - the demonstrations and the model drawn in a background process
   while the plan is made (:mod:`dexlfd.apps.teach_figures`).
5. ``plan`` - the pick-and-place from the ready pose to the new pick and place.
6. ``plan_figure`` - the plan drawn in a background process while the simulation runs.
7. ``simulate`` - the simulated Panda carries the object; the placement is judged.
8. ``tracking_figure`` - the rollout's tracking figure, beside the video.
9. ``video`` - the rollout as an MP4: drawn by a render process while the simulation
   runs (:mod:`dexlfd.viz.robot_video_stream`), else (this process has an OpenGL
   context, or only the video is missing on a rerun) replayed from ``rollout.npz``.

Then ``teach.json`` (the run's figures) and ``report.html``. The run succeeds when
the object was placed: :attr:`TeachResult.ok`.
"""

from __future__ import annotations

import json
import logging
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd.apps._stages import MANIFEST, Stage, StageRunner, settings_key
from dexlfd.apps.record import RecordConfig
from dexlfd.errors import InvalidInput
from dexlfd.geometry import Obstacle
from dexlfd.io import atomic_write
from dexlfd.learn import LearnConfig

__all__ = ["OUTPUT_NAMES", "TeachConfig", "TeachResult", "foreign_outputs", "run_teach"]

logger = logging.getLogger(__name__)

# what a run writes at the top of its folder (anything else there is left alone)
OUTPUT_NAMES = ("demos", "demos_base", "figures", "task_frame.json", "model.npz", "plan.npz",
                "rollout.npz", "robot.mp4", "teach.json", "report.html")  # fmt: skip
_OWNER = "teach"  # the manifest's key naming the files a teach run owns
# [s] the longest tracking gap learning fills: in real takes the object hides the hand
# for a second or more while it is carried (bagging: 1.5 s); the placement check judges
LEARN_MAX_GAP_S = 2.0
# the figures of the demonstrations, the model and the plan are drawn beside the plan and
# the simulation at this lower CPU priority (``Stage.nice``): with the simulation and the
# robot video's render process they are three on two cores, and what they have not drawn
# when the simulation ends they draw beside the tracking figure, which leaves a core idle
FIGURES_NICE = 10


@dataclass(frozen=True, slots=True)
class TeachConfig:
    """Settings of one ``teach`` run.

    ``pick``/``place`` are ``(x, y, z[, yaw_deg])`` in the base frame [m] or None (the
    defaults of :func:`~dexlfd.apps.teach_frame.placement_targets`); ``object_size``
    (x, y, z) [m] or None (from the grasp aperture); ``payload_kg`` the object's mass,
    unknown to ``controller``; ``obstacles`` what is in the way (base frame): the plan
    keeps the hand, the held object and the arm's links clear of them, and the
    simulated arm touching one fails the run.
    """

    sources: tuple[str, ...]
    record: RecordConfig = field(default_factory=RecordConfig)
    pick: tuple[float, ...] | None = None
    place: tuple[float, ...] | None = None
    object_size: tuple[float, float, float] | None = None
    controller: str = "ntsm-pd"
    payload_kg: float = 0.3
    model_error: float = 0.1  # the controller model's relative mass/inertia error
    friction: bool = True
    noise: bool = True
    learn: LearnConfig = field(default_factory=lambda: LearnConfig(max_gap_s=LEARN_MAX_GAP_S))
    seed: int = 0
    video_size_px: tuple[int, int] = (480, 360)
    video_fps: float = 12.0
    obstacles: tuple[Obstacle, ...] = ()


@dataclass(frozen=True, slots=True)
class TeachResult:
    """How the run ended: ``ok`` when the object was placed, else ``reason``."""

    ok: bool
    reason: str | None
    teach_json: Path
    report: Path
    summary: dict[str, Any] = field(default_factory=dict)


def _source_key(source: str) -> Any:
    """A source's identity for resuming: its path with size and time of change."""
    try:
        st = os.stat(source)
    except OSError:
        return source
    return [source, st.st_size, st.st_mtime_ns]


# --------------------------------------------------------------------------- stages


def _stage_record(cfg: TeachConfig, out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    """Every source recorded; the later stages made ready beside the tracking (``WarmUp``)."""
    from dexlfd.apps.teach_sources import record_source, source_name, write_snapshots
    from dexlfd.apps.teach_warm import WarmUp

    names = _unique_names([source_name(s) for s in cfg.sources])
    outputs: dict[str, Path] = {}
    summaries = []
    with WarmUp() as warm:
        for i, (source, name) in enumerate(zip(cfg.sources, names, strict=True), start=1):
            logger.info("record %d/%d: %s", i, len(cfg.sources), source)
            rec = record_source(source, cfg.record, out, name=name, on_frame=warm.start)
            warm.wait()  # the summary imports learning modules the warm-up may be importing
            for path in rec.files + write_snapshots(rec, out / "figures" / "sources"):
                outputs[str(path.relative_to(out))] = path
            summaries.append(rec.summary(out))
    return outputs, {"sources": summaries}


def _unique_names(names: list[str]) -> list[str]:
    """Names made unique by a numeric suffix (two ``hand.mp4`` in different folders)."""
    seen: dict[str, int] = {}
    out = []
    for n in names:
        seen[n] = seen.get(n, 0) + 1
        out.append(n if seen[n] == 1 else f"{n}_{seen[n]}")
    return out


def _stage_frame(
    cfg: TeachConfig, out: Path, record: dict[str, Any]
) -> tuple[dict[str, Path], dict[str, Any]]:
    from dexlfd.apps.teach_align import align_sources

    return align_sources(cfg, out, record["summary"]["sources"])


def _stage_learn(cfg: TeachConfig, out: Path, frame: dict[str, Any]) -> tuple[
    dict[str, Path], dict[str, Any]
]:  # fmt: skip
    from dexlfd.apps.teach_figures import learn_demonstrations
    from dexlfd.io import save_model

    names = list(frame["summary"]["demonstrations"])
    learned, demos = learn_demonstrations(cfg, out, names)
    outputs = {"model": save_model(out / "model.npz", learned.model)}
    traj = learned.trajectory
    summary = {
        "n_demos": len(demos),
        "reference": names[traj.alignment.reference_index],
        "dtw_distances": [round(float(d), 4) for d in traj.quality.distances],
        "outliers": list(learned.model.outliers),
        "gmm_k": traj.gmm_result.gmm.n_components,
        "spread_mm": _spread_mm(learned.model),
    }
    return outputs, summary


def _spread_mm(model: Any) -> dict[str, float]:
    """The model's positional spread: median and largest 1-sigma [mm] over time."""
    sigma = np.sqrt(np.clip(np.trace(model.cov[:, :3, :3], axis1=1, axis2=2), 0, None) / 3)
    return {"median": round(1e3 * float(np.median(sigma)), 1),
            "max": round(1e3 * float(sigma.max()), 1)}  # fmt: skip


def _stage_plan(cfg: TeachConfig, out: Path, frame: dict[str, Any]) -> tuple[
    dict[str, Path], dict[str, Any]
]:  # fmt: skip
    from dexlfd.apps.teach_robot import plan_lift, teach_plan
    from dexlfd.io import load_model, save_plan

    placement = _placement(frame["summary"]["placement"])
    model = load_model(out / "model.npz")
    plan, scaling = teach_plan(model, placement, cfg.obstacles)
    outputs = {"plan": save_plan(out / "plan.npz", plan)}
    lift = plan_lift(plan)
    summary = {
        "duration_s": round(float(plan.t[-1] - plan.t[0]), 2),
        "start": [round(float(v), 4) for v in plan.position[0]],
        "lift_m": None if lift is None else round(lift, 4),
        "pick_to_place_m": round(float(np.linalg.norm(
            np.subtract(placement.place, placement.pick))), 4),
        "time_scaling": {k: scaling[k] for k in ("needed", "largest", "duration_before_s",
                                                 "duration_s", "slowdowns") if k in scaling},
        "obstacles": [ob.to_dict() for ob in cfg.obstacles],
        "clearance_m": _plan_clearance(plan),
    }  # fmt: skip
    return outputs, summary


def _plan_clearance(plan: Any) -> dict[str, float | None] | None:
    """The plan's least clearance [m] from the obstacles; None without obstacles.

    The hand's and the held object's, and the arm's links' (their planned posture).
    """
    hand = plan.extras.get("clearance")
    if hand is None or not plan.obstacles:
        return None
    arm = plan.arm_posture
    return {"hand_and_object": round(float(np.min(hand)), 4),
            "arm_links": None if arm is None else round(float(arm.min_clearance), 4)}  # fmt: skip


def _placement(d: dict[str, Any]) -> Any:
    from dexlfd.apps.teach_frame import Placement

    def yaw(key: str) -> float | None:
        return None if d.get(key) is None else float(np.radians(d[key]))

    return Placement(
        pick=tuple(d["pick"]), pick_yaw=yaw("pick_yaw_deg"), place=tuple(d["place"]),
        place_yaw=yaw("place_yaw_deg"), displacement_task=tuple(d["displacement_task"]),
        demonstrated_lift_m=d["demonstrated_lift_m"], object_size=tuple(d["object_size"]),
        defaults=tuple(d["defaults"]),
    )  # fmt: skip


def _stage_simulate(
    cfg: TeachConfig, out: Path, frame: dict[str, Any], streams: dict[str, Any]
) -> tuple[dict[str, Path], dict[str, Any]]:
    """Simulate the plan; a safety stop is a failed placement (its rollout kept), not a crash.

    The robot video is drawn meanwhile (in ``streams["video"]`` for the video stage),
    when this process can fork its renderer.
    """
    from dexlfd.apps.teach_robot import (
        obstacle_clearance,
        placement_verdict,
        simulate_plan,
        stream_video,
    )
    from dexlfd.control import TrackingStopped, tracking_summary
    from dexlfd.io import load_plan, save_rollout

    plan = load_plan(out / "plan.npz")
    stopped = None
    stream = stream_video(plan, out / "robot.mp4", **_video_settings(cfg, frame))
    try:
        rollout = simulate_plan(plan, cfg, _object_size(frame),
                                samples=None if stream is None else stream.rows)  # fmt: skip
    except TrackingStopped as exc:
        logger.error("%s: the rollout up to the stop is kept", exc)
        rollout, stopped = exc.rollout, str(exc)
    except BaseException:
        if stream is not None:
            stream.stop()
        raise
    if stream is not None and stream.finish(rollout):  # the video of what was simulated
        streams["video"] = stream
    outputs = {"rollout": save_rollout(out / "rollout.npz", rollout)}
    verdict = placement_verdict(rollout)
    if stopped is not None:
        verdict.update(ok=False, failure=f"{stopped}; {verdict['failure'] or 'not placed'}")
    clear = obstacle_clearance(rollout, cfg.obstacles)
    if clear is not None and clear["min_m"] < 0.0:
        touched = (f"the arm's {clear['body']} touched obstacle {clear['obstacle']} at "
                   f"t={clear['t_s']:.2f} s ({-1e3 * clear['min_m']:.0f} mm deep)")  # fmt: skip
        verdict.update(ok=False, failure="; ".join(s for s in (verdict["failure"], touched) if s))
    track = tracking_summary(rollout)
    obj = rollout.object_report
    summary = {
        "placement": verdict,
        "stopped": stopped,
        "object_final_m": None if obj is None else list(obj.final_position),
        "tracking_rms_mm": round(1e3 * float(track["position_rms_m"]), 2),
        "tracking_max_mm": round(1e3 * float(track["position_max_m"]), 2),
        "obstacle_clearance": clear,
    }
    return outputs, summary


def _object_size(frame: dict[str, Any]) -> tuple[float, ...]:
    """The object's size [m] the plan was made for (the frame stage's placement)."""
    return tuple(float(v) for v in frame["summary"]["placement"]["object_size"])


def _stage_figures(
    cfg: TeachConfig, out: Path, frame: dict[str, Any]
) -> tuple[dict[str, Path], dict[str, Any]]:
    from dexlfd.apps.teach_figures import draw_figures

    return draw_figures(cfg, out, frame)


def _stage_plan_figure(out: Path, frame: dict[str, Any]) -> tuple[dict[str, Path], dict[str, Any]]:
    from dexlfd.apps.teach_figures import draw_plan_figure

    return draw_plan_figure(out, frame)


def _stage_tracking_figure(out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    from dexlfd.io import load_rollout
    from dexlfd.viz.control import plot_rollout

    (out / "figures").mkdir(exist_ok=True)
    rollout = load_rollout(out / "rollout.npz")
    return {"fig_rollout": plot_rollout(rollout, out / "figures" / "rollout.png")}, {}


def _video_settings(cfg: TeachConfig, frame: dict[str, Any]) -> dict[str, Any]:
    """The robot video's settings (:func:`~dexlfd.apps.teach_robot.render_video`'s)."""
    return {"payload_kg": cfg.payload_kg, "size_px": cfg.video_size_px, "fps": cfg.video_fps,
            "caption": f"{cfg.controller.upper()}, unknown {cfg.payload_kg:g} kg object",
            "object_size": _object_size(frame)}  # fmt: skip


def _stage_video(
    cfg: TeachConfig, out: Path, frame: dict[str, Any], streams: dict[str, Any]
) -> tuple[dict[str, Path], dict[str, Any]]:
    """The video drawn during the simulation (``streams["video"]``), else the rollout replayed.

    A render process that hung is killed (said) and the rollout replayed.
    """
    from dexlfd.apps.teach_robot import render_video
    from dexlfd.io import load_plan, load_rollout

    stream = streams.pop("video", None)
    if stream is not None and (streamed := stream.result()) is not None:
        return {"video": streamed}, {"rendered": "during the simulation"}
    path = render_video(
        load_rollout(out / "rollout.npz"), load_plan(out / "plan.npz"), out / "robot.mp4",
        **_video_settings(cfg, frame),
    )  # fmt: skip
    return {"video": path}, {"rendered": "after the simulation"}


# --------------------------------------------------------------------------- the run


def foreign_outputs(out: Path) -> list[Path]:
    """Files in ``out`` a run would write that an earlier ``teach`` run did not write."""
    owned = set(_read_manifest(out).get(_OWNER, {}).get("files", []))
    return [out / n for n in OUTPUT_NAMES if (out / n).exists() and n not in owned]


def _read_manifest(out: Path) -> dict[str, Any]:
    try:
        data = json.loads((out / MANIFEST).read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _claim(out: Path, fresh: bool) -> None:
    """Record in the manifest that this folder's outputs are teach's (``fresh``: no stage)."""
    manifest = _read_manifest(out)
    if fresh:
        manifest = {}
    manifest[_OWNER] = {"files": list(OUTPUT_NAMES)}
    data = json.dumps(manifest, indent=2, sort_keys=True, default=str).encode()
    atomic_write(out / MANIFEST, lambda fh: fh.write(data))


def _stages(cfg: TeachConfig, runner: StageRunner, streams: dict[str, Any]) -> list[Stage]:
    """The stages; ``streams``: what the simulation hands to the video stage."""
    res = runner.results
    rec_key = settings_key([_source_key(s) for s in cfg.sources], cfg.record)
    frame_key = settings_key(rec_key, cfg.pick, cfg.place, cfg.object_size)
    learn_key = settings_key(frame_key, cfg.learn, cfg.seed)
    plan_key = settings_key(learn_key, cfg.obstacles)
    sim_key = settings_key(
        plan_key, cfg.controller, cfg.payload_kg, cfg.seed, cfg.model_error, cfg.friction, cfg.noise
    )
    return [
        Stage("record", "record every source", rec_key, lambda o: _stage_record(cfg, o)),
        Stage("frame", "task frame: every demonstration in the base frame", frame_key,
              lambda o: _stage_frame(cfg, o, res["record"]), after=("record",)),
        Stage("learn", "learn: DTW, GMM, GMR", learn_key,
              lambda o: _stage_learn(cfg, o, res["frame"]), after=("frame",)),
        Stage("figures", "draw the demonstrations and the model", learn_key,
              lambda o: _stage_figures(cfg, o, res["frame"]), after=("frame", "learn"),
              background=True, nice=FIGURES_NICE),
        Stage("plan", "plan the pick-and-place from the ready pose", plan_key,
              lambda o: _stage_plan(cfg, o, res["frame"]), after=("frame", "learn")),
        Stage("plan_figure", "draw the plan", plan_key,
              lambda o: _stage_plan_figure(o, res["frame"]), after=("frame", "learn", "plan"),
              background=True, nice=FIGURES_NICE),
        Stage("simulate", f"simulate: {cfg.controller}, {cfg.payload_kg:g} kg object", sim_key,
              lambda o: _stage_simulate(cfg, o, res["frame"], streams), after=("frame", "plan")),
        Stage("tracking_figure", "draw the tracking figure", sim_key,
              lambda o: _stage_tracking_figure(o), after=("simulate",), background=True),
        Stage("video", "render the robot video",
              settings_key(sim_key, cfg.video_size_px, cfg.video_fps),
              lambda o: _stage_video(cfg, o, res["frame"], streams),
              after=("frame", "plan", "simulate"), background=True, renders=True,
              here=lambda: "drawn during the simulation" if "video" in streams else None),
    ]  # fmt: skip


def run_teach(cfg: TeachConfig, out: Path, *, fresh: bool = False) -> TeachResult:
    """Run every stage under ``out``; write ``teach.json`` and ``report.html``.

    A rerun reuses the stages that finished with the same settings (``fresh`` starts
    clean). Raises :class:`~dexlfd.errors.InvalidInput` for bad input (a source
    without a pick-and-place, a pick out of reach); a failed placement is a result
    (``ok`` False, with the reason), its files written.
    """
    from dexlfd.apps.teach_report import build_teach_report, teach_json

    if not cfg.sources:
        raise InvalidInput("SOURCE: give at least one video, landmark recording or demonstration")
    out.mkdir(parents=True, exist_ok=True)
    _claim(out, fresh)
    runner = StageRunner(out)
    streams: dict[str, Any] = {}  # the video drawn during the simulation, until collected
    try:
        results = runner.run(_stages(cfg, runner, streams))
    finally:
        for stream in streams.values():  # an error after the simulation: end its renderer
            stream.stop()
    record = json.dumps(teach_json(cfg, out, results), indent=2).encode()
    atomic_write(out / "teach.json", lambda fh: fh.write(record))
    report = build_teach_report(cfg, out, results)
    placement = results["simulate"]["summary"]["placement"]
    return TeachResult(
        ok=bool(placement["ok"]), reason=placement.get("failure"),
        teach_json=out / "teach.json", report=report,
        summary={k: round(v["seconds"], 1) for k, v in results.items()},
    )  # fmt: skip
