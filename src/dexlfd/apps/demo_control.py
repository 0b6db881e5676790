"""The demo's robot stages: the controller study, its figures, the robot video, the exports.

The control study tracks the executed plan with every controller, with and
without the object they do not know (Table 5.1 style, on
:func:`~dexlfd.experiments.payload.run_payload_experiment`); the video replays
one of its rollouts (nothing is simulated twice); the exports write the plan and
that rollout as ROS 2 bags and CSV.
"""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from dexlfd.errors import DependencyNotInstalled

if TYPE_CHECKING:
    from dexlfd.apps.demo import DemoConfig
    from dexlfd.experiments.payload import PayloadConfig
    from dexlfd.io import Plan

__all__ = [
    "stage_control",
    "stage_control_figures",
    "stage_control_video",
    "stage_export",
    "stage_video",
]

logger = logging.getLogger(__name__)


def _control_study(cfg: DemoConfig, plan: Plan) -> PayloadConfig:
    from dexlfd.experiments.payload import PayloadConfig
    from dexlfd.robot import plan_world

    return PayloadConfig(
        controllers=cfg.controllers,
        payloads=(0.0, cfg.payload_kg),
        plan=plan,
        obstacles=plan_world(plan),
        workers=cfg.workers,
        seed=cfg.seed,
        hand=cfg.hand,
    )


def _rollout_path(out: Path, name: str, kg: float) -> Path:
    return out / "control" / f"{name}_{kg:g}kg.npz"


def stage_control_video(cfg: DemoConfig, out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    """The study's run that the video shows, first, so the video renders beside the others."""
    from dexlfd.experiments.payload import run_payload_rollout
    from dexlfd.io import load_plan, save_rollout

    study = _control_study(cfg, load_plan(out / "plans" / "task.npz"))
    ro = run_payload_rollout(study, cfg.video_controller, cfg.payload_kg)
    (out / "control").mkdir(exist_ok=True)
    path = _rollout_path(out, cfg.video_controller, cfg.payload_kg)
    return {"rollout": save_rollout(path, ro)}, {}


def stage_control(cfg: DemoConfig, out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    """Track the executed plan with every controller, with and without the object.

    The video's run comes from :func:`stage_control_video` (not simulated twice).
    """
    from dexlfd.experiments.payload import format_table, run_payload_experiment
    from dexlfd.io import atomic_write, load_plan, load_rollout, save_rollout

    plan = load_plan(out / "plans" / "task.npz")
    video_run = (cfg.video_controller, cfg.payload_kg)
    known = {video_run: load_rollout(_rollout_path(out, *video_run))}
    result = run_payload_experiment(_control_study(cfg, plan), known=known)
    folder = out / "control"
    folder.mkdir(exist_ok=True)
    outputs: dict[str, Path] = {}
    for (name, kg), ro in result.rollouts.items():
        if (name, kg) != video_run:  # that file belongs to stage_control_video
            outputs[f"rollout_{name}_{kg:g}"] = save_rollout(_rollout_path(out, name, kg), ro)
    video_ro = result.rollouts[(cfg.video_controller, cfg.payload_kg)]
    table = format_table(result)
    data = table.encode()
    atomic_write(folder / "table.txt", lambda fh: fh.write(data))
    outputs["table"] = folder / "table.txt"
    rows = [
        {
            "controller": r.controller,
            "payload_kg": r.payload_kg,
            "e_nob_mm": round(1e3 * r.e_nob_m, 3),
            "e_ob_mm": round(1e3 * r.e_ob_m, 3),
            "delta_e_mm": round(1e3 * r.delta_e_m, 3),
            "delta_ob_pct": round(r.delta_ob_pct, 1),
            "max_orientation_error_deg": round(float(np.degrees(r.max_orientation_error_rad)), 2),
            "stopped": r.stopped,
        }
        for r in result.rows
    ]
    attached = video_ro.extras.get("attached")
    place = plan.place_correction
    placed = []
    for (name, kg), ro in result.rollouts.items():
        obj = ro.object_report
        if kg <= 0 or obj is None:
            continue
        err = None
        if place is not None:
            # resting: centre one TCP-to-bottom distance above the surface, at the place
            target = place.place_point
            rest = [target[0], target[1], place.surface_z + place.object_bottom]
            err = round(1e3 * float(np.linalg.norm(np.asarray(obj.final_position) - rest)), 1)
        placed.append({
            "controller": name,
            "payload_kg": kg,
            "final_position_m": [round(v, 4) for v in obj.final_position],
            "position_error_mm": err,
            "tilt_deg": round(obj.tilt_deg, 2),
            "impact_speed_m_s": None if obj.impact_speed is None
            else round(obj.impact_speed, 3),
            "release_speed_m_s": None if obj.release_speed is None
            else round(obj.release_speed, 4),
        })  # fmt: skip
    summary = {
        "placed": placed,
        "rows": rows,
        "best": result.best,
        "object_carried": bool(attached is not None and attached.any()),
        "video_rollout": f"control/{cfg.video_controller}_{cfg.payload_kg:g}kg.npz",
    }
    return outputs, summary


def stage_control_figures(cfg: DemoConfig, out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    """The control study's figures, from its saved rollouts (while the video renders)."""
    from dexlfd.experiments.payload import PayloadResult
    from dexlfd.io import load_plan, load_rollout
    from dexlfd.viz.control import plot_payload_lift, plot_rollout

    study = _control_study(cfg, load_plan(out / "plans" / "task.npz"))
    rollouts = {
        (c, kg): load_rollout(_rollout_path(out, c, kg))
        for c in study.controllers
        for kg in study.payloads
    }
    folder = out / "control"
    result = PayloadResult(rows=[], rollouts=rollouts, config=study)
    outputs = {"fig_lift": plot_payload_lift(result, folder / "payload_lift_z.png")}
    video_ro = rollouts[(cfg.video_controller, cfg.payload_kg)]
    outputs["fig_rollout"] = plot_rollout(video_ro, folder / f"{cfg.video_controller}_rollout.png")
    return outputs, {}


def stage_generalize(cfg: DemoConfig, out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    """A small pick/place grid on the learned model (``experiment generalize``'s study).

    ``cfg.generalize_pairs`` pairs over the two 30 x 40 cm table areas, the video's
    controller at the study's payload, on ``cfg.workers`` processes (beside the other
    stages: listed after the plan stage, it inherits the DMP kernels that compiled).
    """
    import json

    from dexlfd.experiments.generalize import (
        GeneralizeConfig,
        format_generalize,
        generalize_json,
        run_generalize,
    )
    from dexlfd.io import atomic_write, load_model
    from dexlfd.viz.control import plot_generalize

    folder = out / "generalize"
    folder.mkdir(parents=True, exist_ok=True)
    study = GeneralizeConfig(
        n_pairs=cfg.generalize_pairs, controllers=(cfg.video_controller,),
        payloads=(cfg.payload_kg,), seed=cfg.seed, workers=cfg.workers,
        hand=cfg.hand,
    )  # fmt: skip
    result = run_generalize(load_model(out / "model.npz"), study)
    text = format_generalize(result)
    data = json.dumps(generalize_json(result), default=str).encode()
    outputs = {"table": folder / "generalize.txt", "json": folder / "generalize.json"}
    atomic_write(outputs["table"], lambda fh: fh.write(text.encode() + b"\n"))
    atomic_write(outputs["json"], lambda fh: fh.write(data))
    outputs["figure"] = plot_generalize(result, folder / "generalize.png")
    return outputs, {"rows": result.summary()}


def stage_video(cfg: DemoConfig, out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    """Replay the video controller's rollout with the object as an MP4 (no new simulation)."""
    from dexlfd.io import load_plan, load_rollout
    from dexlfd.robot import PlantConfig, plan_world
    from dexlfd.viz.robot_video import render_rollout_video

    plan = load_plan(out / "plans" / "task.npz")
    ro = load_rollout(out / "control" / f"{cfg.video_controller}_{cfg.payload_kg:g}kg.npz")
    plant = PlantConfig(payload_kg=cfg.payload_kg, obstacles=plan_world(plan), hand=cfg.hand)
    w, h = cfg.video_size_px
    caption = f"{cfg.video_controller.upper()}, unknown {cfg.payload_kg:g} kg object" + (
        ", qb SoftHand" if cfg.hand == "softhand" else ""
    )
    path = render_rollout_video(
        ro, plant, out / "robot.mp4", fps=cfg.video_fps, width=w, height=h, caption=caption
    )
    return {"video": path}, {"seconds": round(float(ro.t[-1] - ro.t[0]), 2)}


def stage_export(cfg: DemoConfig, out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    """The executed plan and the video rollout as ROS 2 bags and CSV (100 Hz)."""
    import shutil

    from dexlfd.io import load_plan, load_rollout
    from dexlfd.io.csv import export_csv
    from dexlfd.io.rosbag import export_plan_rosbag, export_rollout_rosbag

    folder = out / "export"
    folder.mkdir(exist_ok=True)
    plan = load_plan(out / "plans" / "task.npz")
    ro = load_rollout(out / "control" / f"{cfg.video_controller}_{cfg.payload_kg:g}kg.npz")
    for bag in ("plan_bag", "rollout_bag"):  # a rerun replaces the bags
        shutil.rmtree(folder / bag, ignore_errors=True)
    # 100 Hz is plenty for replay/inspection in ROS tools; the .npz keeps 1 kHz
    step = max(1, int(round(0.01 / float(np.median(np.diff(ro.t))))))
    sub = dataclasses.replace(
        ro,
        **{
            n: getattr(ro, n)[::step]
            for n, spec in ro.SPECS.items()
            if spec.shape[0] == "n" and getattr(ro, n) is not None
        },  # fmt: skip
        extras={},
    )
    outputs: dict[str, Path] = {}
    try:
        outputs["plan_bag"] = export_plan_rosbag(plan, folder / "plan_bag")
        # one time base (the default origin): the rollout starts with the plan
        outputs["rollout_bag"] = export_rollout_rosbag(sub, folder / "rollout_bag")
    except DependencyNotInstalled as exc:  # a core install: the CSV files only
        logger.warning("%s; the ROS 2 bags are skipped", exc)
    outputs["plan_csv"] = export_csv(plan, folder / "plan.csv")
    outputs["rollout_csv"] = export_csv(sub, folder / "rollout_100hz.csv")
    return outputs, {"rollout_rate_hz": round(1.0 / (step * float(np.median(np.diff(ro.t)))))}
