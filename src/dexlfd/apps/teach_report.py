"""``teach``'s outputs for people and programs: ``report.html`` and ``teach.json``.

The report is built like the demo's (:mod:`dexlfd.apps.demo_report`: the prose from a
packaged template, ``templates/teach_report.ini``, one section per stage, written by
:mod:`dexlfd.viz.report`); this module picks the figures, tables and values.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING, Any

from dexlfd import __version__
from dexlfd.apps.demo_report import jsonable, prose, section

if TYPE_CHECKING:
    from dexlfd.apps.teach import TeachConfig
    from dexlfd.viz.report import Section

__all__ = ["build_teach_report", "teach_json"]

Results = dict[str, dict[str, Any]]
T = "teach_report"  # the template


def _summary(results: Results, stage: str) -> dict[str, Any]:
    return dict(results.get(stage, {}).get("summary", {}))


def _output(results: Results, stage: str, key: str) -> Path | None:
    path = results.get(stage, {}).get("outputs", {}).get(key)
    return None if path is None else Path(path)


def _round(v: Any, nd: int = 4) -> Any:
    if isinstance(v, float):
        return round(v, nd)
    if isinstance(v, list | tuple):
        return [_round(x, nd) for x in v]
    if isinstance(v, dict):
        return {k: _round(x, nd) for k, x in v.items()}
    return v


def teach_json(cfg: TeachConfig, out: Path, results: Results) -> dict[str, Any]:
    """The run's record: sources, demonstrations, task frame, pick, place, placement, lift.

    Positions in metres in the robot's base frame. ``task_frame`` holds the first
    camera's frame and, under ``"cameras"``, every camera's.
    """
    frame = _summary(results, "frame")
    placement = frame["placement"]
    frames = frame["frames"]
    first = frames[0]
    task_frame = {k: first[k] for k in ("method", "up_camera", "scale", "uncertainty")}
    task_frame["cameras"] = [
        {k: f[k] for k in ("group", "method", "up_camera", "scale", "uncertainty", "n_events")}
        for f in frames
    ]
    verdict = dict(_summary(results, "simulate")["placement"])
    plan = _summary(results, "plan")
    return _round({
        "sources": _summary(results, "record")["sources"],
        "demonstrations": frame["demonstrations"],
        "task_frame": task_frame,
        "pick": {"position_m": placement["pick"], "yaw_deg": placement["pick_yaw_deg"],
                 "default": "pick" in placement["defaults"]},
        "place": {"position_m": placement["place"], "yaw_deg": placement["place_yaw_deg"],
                  "default": "place" in placement["defaults"]},
        "object_size_m": placement["object_size"],
        "placement": verdict,
        "lift_m": {"plan": plan.get("lift_m"),
                   "demonstrated": placement["demonstrated_lift_m"]},
        "pick_to_place_m": plan.get("pick_to_place_m"),
        "obstacles": plan.get("obstacles", []),
        "clearance_m": {"plan": plan.get("clearance_m"),
                        "simulated": _summary(results, "simulate").get("obstacle_clearance")},
        "controller": cfg.controller,
        "payload_kg": cfg.payload_kg,
        "files": {k: str(Path(v).relative_to(out)) for k, v in
                  (("model", out / "model.npz"), ("plan", out / "plan.npz"),
                   ("rollout", out / "rollout.npz"), ("video", out / "robot.mp4"),
                   ("report", out / "report.html"))},
    })  # fmt: skip


def _sources_section(results: Results) -> Section:
    sources = _summary(results, "record")["sources"]
    rows, figures = [], []
    for s in sources:
        found = [f for f in s["pick_and_places"] if f is not None]
        rows.append([s["name"], s["kind"], s["n_frames"],
                     ", ".join(f"{a}-{b}" for a, b in found) or "none",
                     "; ".join(s["warnings"]) or ""])  # fmt: skip
    for path in sorted(results.get("record", {}).get("outputs", {}).values()):
        if Path(path).suffix == ".png":
            name, k, what = Path(path).stem.rsplit("_", 2)
            figures.append(
                (
                    Path(path),
                    prose("sources", "snapshot", {"name": name, "what": what, "k": k}, template=T),
                )
            )
    values = {
        "n_sources": len(sources),
        "n_demos": sum(sum(f is not None for f in s["pick_and_places"]) for s in sources),
    }
    header = ["source", "kind", "frames", "pick-and-places (grasp-release frames)", "warnings"]
    return section("sources", values, T, tables=[(header, rows, prose("sources", "table_caption",
                   template=T))], figures=figures)  # fmt: skip


def _frame_section(results: Results) -> Section:
    s = _summary(results, "frame")
    p = s["placement"]
    values = {
        "methods": ", ".join(sorted({f["method"] for f in s["frames"]})),
        "pick": _round(p["pick"], 3), "place": _round(p["place"], 3),
        "object_size": _round(p["object_size"], 3),
        "displacement": _round(p["displacement_task"], 3),
        "demonstrated_lift_m": _round(p["demonstrated_lift_m"], 3),
        "place_how": prose("frame", "place_default" if "place" in p["defaults"]
                           else "place_given", template=T),
    }  # fmt: skip
    rows = []
    for f in s["frames"]:
        u = f["uncertainty"]
        rows.append([f["group"], f["method"], _round(f["up_camera"], 3), _round(f["scale"], 3),
                     _round(u.get("up_deg"), 2), _round(u.get("scale_rel"), 3),
                     _round(u.get("table_m"), 3), f["n_events"]])  # fmt: skip
    header = ["camera", "method", "up (camera frame)", "scale", "up std [deg]",
              "scale std [rel]", "table std [m]", "events"]  # fmt: skip
    fig = _output(results, "figures", "fig_demos")
    figures = [(fig, "the demonstrations in the task frame")] if fig else []
    table = (header, rows, prose("frame", "table_caption", template=T))
    return section("frame", values, T, tables=[table], figures=figures)


def _simulate_section(cfg: TeachConfig, results: Results) -> Section:
    s = _summary(results, "simulate")
    v = s["placement"]
    values = {
        **s, "controller": cfg.controller, "payload_kg": cfg.payload_kg,
        "verdict": "placed." if v["ok"] else f"FAILED: {v['failure']}.",
        "error_mm": None if v["error_m"] is None else round(1e3 * v["error_m"], 1),
        "tilt_deg": None if v["tilt_deg"] is None else round(v["tilt_deg"], 1),
        "set_down_speed_mps": v["set_down_speed_mps"],
    }  # fmt: skip
    fig = _output(results, "tracking_figure", "fig_rollout")
    video = _output(results, "video", "video")
    caption = prose("simulate", "video", values, template=T)
    return section("simulate", values, T, figures=[(fig, "tracking")] if fig else [],
                   videos=[(video, caption)] if video else [])  # fmt: skip


def _obstacles_text(plan: dict[str, Any], sim: dict[str, Any]) -> str:
    """The obstacles and how far the plan and the simulated arm kept from them, in words."""
    given = plan.get("obstacles") or []
    if not given:
        return "none given."
    clear = plan.get("clearance_m") or {}
    parts = [f"{len(given)} obstacle(s); the hand and the held object pass "
             f"{1e3 * clear.get('hand_and_object', float('nan')):.0f} mm from them"]  # fmt: skip
    if clear.get("arm_links") is not None:
        parts.append(f"the arm's links {1e3 * clear['arm_links']:.0f} mm as planned")
    simulated = sim.get("obstacle_clearance")
    if simulated is not None:
        parts.append(f"in the simulation the arm came {1e3 * simulated['min_m']:.0f} mm near "
                     f"({simulated['body']}, obstacle {simulated['obstacle']}, "
                     f"t = {simulated['t_s']:.2f} s)")  # fmt: skip
    return ", ".join(parts) + "."


def build_teach_report(cfg: TeachConfig, out: Path, results: Results) -> Path:
    """Write ``out/report.html`` from the stages' ``results``; returns its path."""
    from dexlfd.viz.report import Report, write_report

    learn = _summary(results, "learn")
    learn.update(spread_median=learn.get("spread_mm", {}).get("median"),
                 spread_max=learn.get("spread_mm", {}).get("max"),
                 outliers=learn.get("outliers") or "none")  # fmt: skip
    plan = _summary(results, "plan")
    plan["demonstrated_lift_m"] = round(_summary(results, "frame")["placement"]
                                        ["demonstrated_lift_m"], 3)  # fmt: skip
    scaling = plan.get("time_scaling") or {}
    plan["time_scaling"] = (
        f"slowed at most {scaling.get('largest', 1.0):.2f}x, "
        f"{scaling.get('duration_before_s', 0):.2f} s -> {scaling.get('duration_s', 0):.2f} s"
        if scaling.get("needed") else "none needed"
    )  # fmt: skip
    plan["obstacles"] = _obstacles_text(plan, _summary(results, "simulate"))
    verdict = _summary(results, "simulate")["placement"]
    times = [[k, round(v.get("seconds", 0.0), 2), v.get("reused", False)]
             for k, v in results.items()]  # fmt: skip
    sections = [
        _sources_section(results),
        _frame_section(results),
        section("learn", learn, T, figures=[(p, "the model: GMR mean ± 2σ per channel")
                for p in [_output(results, "figures", "fig_model")] if p]),
        section("plan", plan, T, figures=[(p, "the plan with the object and its supports")
                for p in [_output(results, "plan_figure", "fig_plan")] if p]),
        _simulate_section(cfg, results),
        section("files", {}, T, tables=[(["stage", "seconds", "reused"], times,
                prose("files", "times_caption", template=T))],
                settings=jsonable(dataclasses.asdict(cfg))),
    ]  # fmt: skip
    intro = {
        "version": __version__, "sources": ", ".join(cfg.sources),
        "verdict": "the object was placed." if verdict["ok"] else
        f"the placement FAILED: {verdict['failure']}.",
    }  # fmt: skip
    report = Report(
        title=prose("report", "title", template=T),
        intro=prose("report", "intro", intro, template=T),
        sections=sections,
    )
    return write_report(report, out / "report.html")
