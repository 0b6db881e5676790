"""The end-to-end demo on bundled data (``dexlfd demo``): video to torque in one run.

Stages (each writes files under the output folder and is resumable, see
:mod:`dexlfd.apps._stages`; ``capture``, ``learn_figures``, ``video`` and ``generalize`` run
in background processes beside the others, and so does ``kernels``, the planner's and the
control tick's numba kernels compiled into numba's cache for the plan and simulate stages):

1. ``demos`` - six SYNTHETIC pick-and-place demonstrations as hand keypoint
   sequences (our seeded generator, a sponge-like object carried over a cup),
   turned into end-effector motion by the motion stage (Eqs. 4.10-4.14).
2. ``capture`` - the REAL hand video shipped in :mod:`dexlfd.data`
   tracked with MediaPipe: overlay video, 3-D hand and motion figures.
3. ``learn`` - mean filter, DTW, GMM, GMR (Eqs. 4.15-4.19); its figures are drawn
   in the background (``learn_figures``) while the plan stage runs.
4. ``plan`` - modified DMP to the three new starts and goals of thesis
   §5.3.1, obstacles of 0.4 m and 0.5 m (variance-avoidance DMP, Eq. 5.7), and
   the plan that is executed: the learned task over a 0.4 m cup.
5. ``control`` - the simulated Panda tracks the plan, grasps the 1.2 kg object
   by contact, lifts it over the cup and places it; PD, SM-PD, NTSM-PD and our
   NTSM-PD-DOB with and without the object the controllers do not know
   (Table 5.1-style figures, Eq. 5.27-5.28).
6. ``video`` - an MP4 of the Panda doing the task with NTSM-PD, replayed from
   the study's run (``control_video``, simulated first so that rendering overlaps
   the other runs).
7. ``generalize`` - a small pick/place grid over the table with the video's
   controller and payload (``dexlfd experiment generalize`` at full size), in the
   background beside the control study.
8. ``export`` - the executed plan and rollout as ROS 2 bags and CSV.
9. ``report`` - one self-contained HTML page with every stage's figures,
   tables and settings.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd import __version__
from dexlfd.apps import demo_control, demo_plan
from dexlfd.apps._stages import Stage, StageRunner, settings_key
from dexlfd.apps.demo_report import build_demo_report
from dexlfd.learn import LearnConfig

__all__ = ["DemoConfig", "DemoResult", "run_demo", "write_demo_rerun"]

logger = logging.getLogger(__name__)


def _default_video() -> Path | None:
    """The sample video shipped in the package (``None`` if the install lacks it)."""
    from dexlfd.data import hand_video
    from dexlfd.errors import InvalidInput

    try:
        return hand_video()
    except InvalidInput as exc:
        logger.warning("%s", exc)
        return None


@dataclass(frozen=True, slots=True)
class DemoConfig:
    """Settings of the demo run.

    ``learn.n_components`` is chosen from the data ("auto"), not the thesis's
    K = 6: our task has five distinct segments (approach, grasp, carry over the
    cup, release, retreat) and with K = 6 the GMR mean leaves the
    demonstrations by up to 56 mm and its σ_z is 4x the demonstrations' spread
    (measured; K = 12: 16 mm, 1.2x).
    """

    seed: int = 0
    n_demos: int = 6
    learn: LearnConfig = field(default_factory=lambda: LearnConfig())
    cup_center_xy: tuple[float, float] = (0.45, 0.0)  # [m], between pick and place
    cup_width: float = 0.08  # [m]
    obstacle_heights: tuple[float, ...] = (0.4, 0.5)  # thesis Fig. 5.5 [m]
    executed_height: float = 0.4  # the cup the robot lifts the object over [m]
    plan_margin: float = 0.08  # TCP clearance: object (6 cm tall) + 2 cm [m]
    # the object is set down on a place table as high as the one it is picked from
    # (the demonstrations released it at the height they grasped it) [m]
    place_surface_z: float = 0.09
    # the executed task at the robot's pace, slower than the demonstrations' ~7.9 s: at
    # their pace passing the cup needs 1.5x their peak speed and NTSM-PD-DOB at 1.2 kg
    # touched joint 1's velocity limit (2.2 vs 2.175 rad/s) [s]
    task_duration_s: float = 10.0
    payload_kg: float = 1.2
    hand: str = "franka"  # or "softhand" (with SOFTHAND_PAYLOAD_KG)
    controllers: tuple[str, ...] = ("pd", "sm-pd", "ntsm-pd", "ntsm-pd-dob")
    video_controller: str = "ntsm-pd"
    # the report shows the video at most ~700 px wide; software rendering costs about
    # pixels x frames (640x480 at 15 fps took 2.2x the time of 480x360 at 12 fps)
    video_size_px: tuple[int, int] = (480, 360)
    video_fps: float = 12.0  # the slow pick-and-place still reads well
    workers: int = 2  # processes of the control study and of the generalize grid
    # the small pick/place grid of the generalize stage (``experiment generalize`` runs
    # the full grid): two pairs, two directions of carry; each pair is a ~17 s simulation
    generalize_pairs: int = 2
    real_video: Path | None = field(default_factory=_default_video)
    real_video_width_px: int = 640
    # the first 10 s (at 30 fps) of the real video: tracking costs ~30 ms a frame, and the
    # report's figures and overlay need no more than that of the gesture
    real_video_max_frames: int | None = 300
    # hands MediaPipe tracks per frame: the bundled video shows one right hand, and
    # `record`'s default of two (to choose among hands) costs 1.5x the CPU for the same
    # result (the same motion, to the bit, on the first 300 frames)
    real_video_max_hands: int = 1


@dataclass(frozen=True, slots=True)
class DemoResult:
    """Files the demo wrote and its key figures."""

    outputs: dict[str, Path] = field(default_factory=dict)
    summary: dict[str, Any] = field(default_factory=dict)


# --------------------------------------------------------------------------- stages


def _stage_demos(cfg: DemoConfig, out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    from dexlfd.datasets import demonstration_with_hand, pick_place_demonstrations
    from dexlfd.io import save_demonstration
    from dexlfd.viz.capture import plot_hand_3d
    from dexlfd.viz.demonstrations import plot_demonstrations

    rng = np.random.default_rng([cfg.seed, 0])
    poses = pick_place_demonstrations(cfg.n_demos, rng)
    demos = [demonstration_with_hand(d, rng) for d in poses]
    (out / "demos").mkdir(exist_ok=True)
    (out / "figures").mkdir(exist_ok=True)
    outputs = {}
    for i, demo in enumerate(demos):
        outputs[f"demo_{i}"] = save_demonstration(out / "demos" / f"demo_{i:02d}.npz", demo)
    outputs["fig_demos"] = plot_demonstrations(demos, out / "figures" / "demonstrations.png")
    outputs["fig_hand"] = plot_hand_3d(demos[0], out / "figures" / "synthetic_hand_3d.png")
    summary = {
        "n_demos": len(demos),
        "samples": [d.n_samples for d in demos],
        "durations_s": [round(float(d.t[-1]), 2) for d in demos],
    }
    return outputs, summary


def _stage_capture(cfg: DemoConfig, out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    from dexlfd.apps.record import RecordConfig, record_demonstration
    from dexlfd.capture import CaptureConfig, TrackerConfig
    from dexlfd.io import save_demonstration
    from dexlfd.viz.capture import save_capture_figures

    if cfg.real_video is None:
        logger.warning("no real hand video (dexlfd.data): capture stage skipped")
        return {}, {"skipped": "real hand video not found"}
    folder = out / "capture"
    folder.mkdir(exist_ok=True)
    tracker = TrackerConfig(max_num_hands=cfg.real_video_max_hands)
    rec = RecordConfig(
        capture=CaptureConfig(tracker=tracker),
        resize_width=cfg.real_video_width_px,
        max_frames=cfg.real_video_max_frames,
    )
    res = record_demonstration(str(cfg.real_video), rec, overlay=folder / "overlay.mp4")
    outputs = {
        "demo": save_demonstration(folder / "real_hand.npz", res.demo),
        "overlay": folder / "overlay.mp4",
    }
    for path in save_capture_figures(res.demo, folder):
        outputs[f"fig_{path.stem}"] = path
    opening = res.demo.gripper[res.demo.valid]
    summary = {
        "video": cfg.real_video.name,
        "frames": res.n_frames,
        "detection_rate": round(res.detection_rate, 4),
        "hand": res.hand,
        "fps": round(res.n_frames / res.elapsed_s, 1),
        "depth": None if res.demo.capture is None else res.demo.capture.depth,
        "thumb_index_m": [round(float(opening.min()), 3), round(float(opening.max()), 3)],
    }
    return outputs, summary


def _stage_kernels(cfg: DemoConfig, out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    """The planner's and the control tick's numba kernels compiled into numba's cache.

    Beside capture and learn: the plan and simulate stages then load them (about 5 s of
    CPU each off the critical path on a fresh install). A failure here costs nothing but
    that: those stages compile them themselves.
    """
    from dexlfd.control.tick_kernels import warm_kernels as warm_tick_kernels
    from dexlfd.plan.kernels import warm_kernels

    try:
        return {}, {"kernels": warm_kernels() + warm_tick_kernels()}
    except Exception as exc:  # noqa: BLE001 - any failure: the plan stage compiles them
        logger.warning("the planner's kernels were not compiled ahead (%s); the plan stage "
                       "compiles them", exc)  # fmt: skip
        return {}, {"kernels": 0}


def _learn(cfg: DemoConfig, out: Path) -> Any:
    """The learning result of the demonstrations in ``out`` (seeded: the same every time)."""
    from dexlfd.io import load_demonstration
    from dexlfd.learn import learn_from_demonstrations

    names = [f"demos/demo_{i:02d}.npz" for i in range(cfg.n_demos)]
    demos = [load_demonstration(out / n) for n in names]
    return learn_from_demonstrations(
        demos, cfg.learn, np.random.default_rng([cfg.seed, 1]), names=names
    )


def _stage_learn_figures(cfg: DemoConfig, out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    """The learning figures, in the background beside the plan stage.

    The seeded learning is done again here (about a second) rather than handed over:
    drawing the six figures takes several times that.
    """
    from dexlfd.viz.learning import plot_learning

    folder = out / "figures" / "learn"
    folder.mkdir(parents=True, exist_ok=True)
    quiet = logging.getLogger("dexlfd.learn")  # the learn stage logged it all already
    level = quiet.level
    quiet.setLevel(logging.WARNING)
    try:
        learned = _learn(cfg, out)
    finally:
        quiet.setLevel(level)
    return {f"fig_{p.stem}": p for p in plot_learning(learned, folder)}, {}


def _stage_learn(cfg: DemoConfig, out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    from dexlfd.io import save_model

    names = [f"demos/demo_{i:02d}.npz" for i in range(cfg.n_demos)]
    learned = _learn(cfg, out)
    outputs = {"model": save_model(out / "model.npz", learned.model)}
    traj = learned.trajectory
    summary = {
        "reference": names[traj.alignment.reference_index],
        "dtw_distances": [round(float(d), 4) for d in traj.quality.distances],
        "outliers": list(learned.model.outliers),
        "gmm_k": traj.gmm_result.gmm.n_components,
        "gmm_iterations": traj.gmm_result.n_iter,
        "gmm_converged": bool(traj.gmm_result.converged),
        "gmm_log_likelihood": round(traj.gmm_result.log_likelihood, 2),
    }
    return outputs, summary


def run_demo(cfg: DemoConfig, out: Path, *, fresh: bool = False) -> DemoResult:
    """Run the whole pipeline on bundled data; write all outputs under ``out``.

    A rerun reuses the stages that finished with the same settings (``fresh``
    starts clean), so an interrupted run resumes where it stopped.
    """
    base = settings_key(__version__, cfg.seed, cfg.n_demos)
    learn_key = settings_key(base, cfg.learn)
    plan_key = settings_key(
        learn_key, cfg.cup_center_xy, cfg.cup_width, cfg.obstacle_heights,
        cfg.executed_height, cfg.plan_margin, cfg.place_surface_z, cfg.task_duration_s,
    )  # fmt: skip
    control_key = settings_key(
        plan_key, cfg.controllers, cfg.payload_kg, cfg.video_controller, cfg.hand
    )
    video_path = cfg.real_video
    # capture (the real video) needs nothing else: it runs in the background from
    # the start, beside demos -> learn -> plan, and so does the compiling of the
    # planner's kernels that the plan stage waits for; the study's run that the video shows
    # is simulated first, and the video renders from it in the background while the
    # other runs, their figures and the exports go on (no run is simulated twice); the
    # generalize grid starts in the background after the plan stage, so its process
    # inherits the DMP kernels the plan stage compiled
    stages = [
        Stage("capture", "capture on the real hand video",
              settings_key(__version__, str(video_path), cfg.real_video_width_px,
                           cfg.real_video_max_frames, cfg.real_video_max_hands),
              lambda o: _stage_capture(cfg, o), after=(), background=True),
        Stage("kernels", "compile the planner's numba kernels", base,
              lambda o: _stage_kernels(cfg, o), after=(), background=True),
        Stage("demos", "demonstrations (synthetic hands -> motion)", base,
              lambda o: _stage_demos(cfg, o), after=()),
        Stage("learn", "learn: filter, DTW, GMM, GMR", learn_key,
              lambda o: _stage_learn(cfg, o), after=("demos",)),
        Stage("learn_figures", "learn: figures", learn_key,
              lambda o: _stage_learn_figures(cfg, o), after=("demos", "learn"), background=True),
        Stage("plan", "plan: modified / variance-avoidance DMP", plan_key,
              lambda o: demo_plan.stage_plan(cfg, o), after=("learn", "kernels")),
        Stage("control_video", "control: the run the video shows", control_key,
              lambda o: demo_control.stage_control_video(cfg, o), after=("plan",)),
        Stage("video", "render the robot video",
              settings_key(control_key, cfg.video_size_px, cfg.video_fps, "caption"),
              lambda o: demo_control.stage_video(cfg, o), after=("plan", "control_video"),
              background=True, renders=True),
        Stage("generalize", "pick and place over the table (small grid)",
              settings_key(learn_key, cfg.generalize_pairs, cfg.video_controller,
                           cfg.payload_kg, cfg.hand),
              lambda o: demo_control.stage_generalize(cfg, o), after=("learn",),
              background=True),
        Stage("control", "control: simulated Panda, unknown payload", control_key,
              lambda o: demo_control.stage_control(cfg, o), after=("plan", "control_video")),
        Stage("control_figures", "control: figures", control_key,
              lambda o: demo_control.stage_control_figures(cfg, o),
              after=("plan", "control_video", "control")),
        Stage("export", "export ROS 2 bags and CSV", control_key,
              lambda o: demo_control.stage_export(cfg, o), after=("plan", "control_video")),
    ]  # fmt: skip
    runner = StageRunner(out, fresh=fresh)
    results = runner.run(stages)
    if "learn" in results and "learn_figures" in results:  # the report's learn section
        learn = results["learn"]
        learn["outputs"] = {**learn["outputs"], **results["learn_figures"]["outputs"]}
    report_out = {"report": build_demo_report(cfg, out, results)}
    outputs = {
        f"{stage}.{k}": Path(v) for stage, r in results.items() for k, v in r["outputs"].items()
    }
    outputs.update(report_out)
    summary = {
        "report": str(report_out["report"]),
        "seconds": {k: round(v["seconds"], 1) for k, v in results.items()},
        "cpu_seconds": {k: round(v.get("cpu_seconds", 0.0), 1) for k, v in results.items()},
        "control": results["control"]["summary"].get("rows"),
    }
    return DemoResult(outputs=outputs, summary=summary)


def write_demo_rerun(cfg: DemoConfig, out: Path, path: str | os.PathLike[str]) -> Path:
    """One rerun ``.rrd`` of a finished demo in ``out`` (``dexlfd demo --rerun FILE.rrd``).

    The synthetic demonstrations, the real video (images re-read from
    ``cfg.real_video``, with the tracked 2-D landmarks and the 3-D hand), the
    executed plan with the model's ±2σ tube and the cup, and the rollout of
    ``cfg.video_controller`` carrying ``cfg.payload_kg``; each starts at time 0.
    """
    from dexlfd.capture import open_source
    from dexlfd.io import load_demonstration, load_model, load_plan, load_rollout
    from dexlfd.viz.rerun_log import RerunLog

    with RerunLog(path) as log:
        for i in range(cfg.n_demos):
            demo = load_demonstration(out / "demos" / f"demo_{i:02d}.npz")
            log.demonstration(demo, f"demo_{i:02d}")
        real = out / "capture" / "real_hand.npz"
        if cfg.real_video is not None and real.is_file():
            demo = load_demonstration(real)
            log.demonstration(demo, "real_hand")
            uv = demo.extras["uv_px"]  # the tracker's pixels and detections (capture stage)
            seen = demo.extras["detected"]
            with open_source(cfg.real_video, resize_width=cfg.real_video_width_px) as src:
                for frame in src:
                    if frame.index >= demo.n_samples:
                        break
                    hand = uv[frame.index] if seen[frame.index] else None
                    log.camera(float(demo.t[frame.index]), frame.rgb, hand)
        log.plan(load_plan(out / "plans" / "task.npz"), load_model(out / "model.npz"))
        ro = out / "control" / f"{cfg.video_controller}_{cfg.payload_kg:g}kg.npz"
        log.rollout(load_rollout(ro), "robot")
    return log.path
