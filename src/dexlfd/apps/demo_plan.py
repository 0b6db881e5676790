"""The demo's planning stage: thesis §5.3.1 starts and goals, obstacles, and the executed task.

Named steps, each one kind of plan: the modified DMP to three new starts and
goals, the variance-avoidance DMP over cups of two heights (and without the
variance term, for comparison), thesis Figs. 5.6-5.7 on the demo's own model
(these are the thesis's whole-motion DMPs: ``task="motion"``), and the plan the
robot executes (the pick-and-place task through the learned grasp events).
:func:`stage_plan` writes the plans and figures.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from dexlfd.apps.demo import DemoConfig
    from dexlfd.io import LearnedModel, Plan
    from dexlfd.io._facts import Fact
    from dexlfd.plan import Box

__all__ = ["PAIR_PHASES", "THESIS_GOALS", "THESIS_STARTS", "cup", "stage_plan", "task_plan"]

# thesis §5.3.1: three new start points and three new end points [m], base frame
THESIS_STARTS = ((0.37, -0.34, 0.22), (0.50, -0.25, 0.21), (0.55, -0.34, 0.28))
THESIS_GOALS = ((0.51, 0.11, 0.31), (0.50, 0.19, 0.30), (0.50, 0.28, 0.32))

# where the pair of thesis Figs. 5.6-5.7 is placed on the demo's learned path:
# the carry over the cup (demonstrations disagree) and the lift-off after the pick
# (they agree); phase t/T of the obstacle's centre
PAIR_PHASES = ((0.55, "high-variance part (carry)"), (0.41, "low-variance part (lift-off)"))


logger = logging.getLogger(__name__)


def cup(cfg: DemoConfig, height: float) -> Box:
    """The cup of ``height`` [m] between the pick and the place."""
    from dexlfd.plan import Box

    cx, cy = cfg.cup_center_xy
    return Box(center=(cx, cy, height / 2), size=(cfg.cup_width, cfg.cup_width, height))


def adapted_plans(model: LearnedModel) -> list[Plan]:
    """The modified DMP to the three new starts and goals of thesis §5.3.1."""
    from dexlfd.plan import PlanConfig, plan_from_model

    return [plan_from_model(model, PlanConfig(start=s, goal=g, task="motion"))
            for s, g in zip(THESIS_STARTS, THESIS_GOALS, strict=True)]  # fmt: skip


def cup_plans(model: LearnedModel, cfg: DemoConfig, *, variance_aware: bool) -> list[Plan]:
    """The learned task over each cup of ``cfg.obstacle_heights`` (thesis Fig. 5.5)."""
    from dexlfd.plan import PlanConfig, plan_from_model

    return [
        plan_from_model(model, PlanConfig(obstacles=(cup(cfg, h),), margin=cfg.plan_margin,
                                          variance_aware=variance_aware, task="motion"))
        for h in cfg.obstacle_heights
    ]  # fmt: skip


def pair_boxes(model: LearnedModel) -> list[tuple[Box, str]]:
    """The obstacle of Figs. 5.6-5.7 at each phase of :data:`PAIR_PHASES`, with its label.

    A 6 x 3 cm box whose top is 3 cm above the learned path at that phase.
    """
    from dexlfd.plan import Box, PlanConfig, plan_from_model

    nominal = plan_from_model(model, PlanConfig(rate_hz=100.0, task="motion"))
    tb = nominal.t / nominal.t[-1]
    out = []
    for phase, label in PAIR_PHASES:
        c = nominal.position[int(np.searchsorted(tb, phase))]
        top = float(c[2]) + 0.03  # 3 cm above the learned path
        out.append((Box(center=(float(c[0]), float(c[1]), top / 2), size=(0.06, 0.03, top)), label))
    return out


def variance_pair(
    model: LearnedModel,
    variance_aware: bool = True,
    boxes: list[tuple[Box, str]] | None = None,
) -> tuple[list[Plan], list[str]]:
    """Thesis Figs. 5.6-5.7 on the demo's own model.

    The same obstacle, relative to the learned path, at a high- and a low-variance
    phase (``variance_aware=False``: the same plans without the variance term).
    ``boxes``: :func:`pair_boxes` of ``model``, when the caller already has them.
    """
    from dexlfd.plan import PlanConfig, plan_from_model

    plans, labels = [], []
    for box, label in boxes if boxes is not None else pair_boxes(model):
        cfg = PlanConfig(
            obstacles=(box,), rate_hz=100.0, variance_aware=variance_aware, task="motion"
        )
        plans.append(plan_from_model(model, cfg))
        labels.append(label)
    return plans, labels


def task_plan(model: LearnedModel, cfg: DemoConfig) -> Plan:
    """The plan the robot executes: the learned task over the executed cup, placed.

    The whole learned motion (``task="motion"``, the thesis's Table 5.1 setting): a
    pick-and-place plan's carry (pick to place, 5 s) is too short for the shaped
    coupling to lift the path over the 0.4 m cup by the 8 cm margin (the linear
    programme is infeasible); the pick-and-place task itself is the demo's
    ``generalize`` stage.

    It is slowed where the Panda's joint or Cartesian limits need it, as ``dexlfd plan``
    slows every plan it writes (:func:`~dexlfd.plan.feasibility.make_feasible`), and
    its elbow is planned to keep the arm's links off the cup, as ``dexlfd plan`` plans
    it (:func:`~dexlfd.robot.arm_posture.plan_arm_posture`; the figures' plans are
    not executed and keep the hand's path only).
    """
    from dexlfd.plan import PlanConfig, plan_from_model
    from dexlfd.robot import MujocoPandaModel
    from dexlfd.robot.arm_posture import plan_arm_posture

    plan = plan_from_model(
        model,
        PlanConfig(
            obstacles=(cup(cfg, cfg.executed_height),),
            margin=cfg.plan_margin,
            place_surface_z=cfg.place_surface_z,
            duration=cfg.task_duration_s,
            task="motion",
            # the variance term as Table 5.1's run was tuned with (the spread over its
            # 90th percentile): with it in metres the 0.4 m cup is passed faster, and the
            # controllers then drive joints 2 and 6 past their velocity limits
            variance_measure="relative",
            feasible=True,
        ),
        # the simulated robot's own kinematics, as dexlfd plan: the elbow posture search
        # runs thousands of inverse kinematics, batched over its swivel columns (measured:
        # ~1 s of CPU, 6 s one solve at a time, 11.8 s with the NumPy Table 3.1 chain)
        MujocoPandaModel(),
        arm=plan_arm_posture,
    )
    report = plan.feasibility  # plan_from_model made it feasible
    if report is not None and report.needed:
        logger.info(
            "executed plan: slowed at most %.2fx to meet the Panda's limits (%.2f s -> %.2f s)",
            report.largest, report.duration_before_s, report.duration_s,
        )  # fmt: skip
    return plan


def _lift(p: Plan) -> float:
    """The coupling's own displacement over the first obstacle [m].

    (position - nominal_position also holds the end shaping over the last 10 %: 5 cm
    on this model.)
    """
    return round(float(p.obstacle_passes[0].displacement), 4)


def _obstacle(p: Plan, key: str, default: float = 0.0) -> float:
    value = getattr(p.obstacle_passes[0], key)
    return float(default if value is None else value)


def _json(fact: Fact | None) -> dict[str, Any] | None:
    return None if fact is None else fact.to_json()


def _pair_summary(pair: list[Plan], labels: list[str]) -> list[dict[str, Any]]:
    return [
        {
            "label": lab,
            "displacement_m": _lift(p),
            "beyond_needed_lift_m": round(_lift(p) - _obstacle(p, "required_lift"), 4),
            "variance_level": round(_obstacle(p, "variance_level"), 3),
            "min_clearance_m": round(_obstacle(p, "min_clearance", float("nan")), 4),
            "gain": round(_obstacle(p, "gain"), 3),
        }
        for p, lab in zip(pair, labels, strict=True)
    ]


def plan_summary(
    cfg: DemoConfig,
    adapted: list[Plan],
    heights: list[Plan],
    plain: list[Plan],
    pair: tuple[list[Plan], list[str]],
    pair_plain: list[Plan],
    task: Plan,
) -> dict[str, Any]:
    """The figures of the planning stage the report quotes (SI units, rounded)."""
    return {
        "goal_errors_mm": [round(1e3 * float(p.goal_error or 0.0), 3) for p in adapted],
        "obstacle_heights_m": list(cfg.obstacle_heights),
        "min_clearance_m": [
            round(float("nan" if ob.min_clearance is None else ob.min_clearance), 3)
            for p in heights
            for ob in p.obstacle_passes
        ],  # fmt: skip
        "margin_m": cfg.plan_margin,
        "displacement_m": [_lift(p) for p in heights],
        "displacement_no_variance_m": [_lift(p) for p in plain],
        "peak_z_m": [round(float(p.position[:, 2].max()), 4) for p in heights],
        "peak_z_no_variance_m": [round(float(p.position[:, 2].max()), 4) for p in plain],
        "coupling_gain": [round(_obstacle(p, "gain"), 3) for p in heights],
        "thesis_weight": [round(_obstacle(p, "thesis_weight"), 3) for p in heights],
        "variance_pair": _pair_summary(*pair),
        "variance_pair_no_variance_m": [_lift(p) for p in pair_plain],
        "place": _json(task.place_correction or task.place),
        "task_duration_s": round(float(task.t[-1]), 2),
        "task_peak_z_m": round(float(task.position[:, 2].max()), 3),
        "limits_exceeded": [] if task.limits is None else list(task.limits.exceeded),
    }


def stage_plan(cfg: DemoConfig, out: Path) -> tuple[dict[str, Path], dict[str, Any]]:
    """Plan every variant from ``out/model.npz``; write plans and figures under ``out``."""
    from dexlfd.io import load_model, save_plan
    from dexlfd.viz.planning import plot_obstacle_comparison, plot_obstacle_profile, plot_paths

    model = load_model(out / "model.npz")
    folder, figs = out / "plans", out / "figures" / "plan"
    folder.mkdir(exist_ok=True)
    figs.mkdir(parents=True, exist_ok=True)
    outputs: dict[str, Path] = {}
    adapted = adapted_plans(model)
    for i, p in enumerate(adapted):
        outputs[f"plan_new_{i}"] = save_plan(folder / f"new_start_goal_{i + 1}.npz", p)
    outputs["fig_new"] = plot_paths(
        model, adapted, figs / "new_starts_goals.png",
        labels=[f"start {s} -> goal {g}" for s, g in zip(THESIS_STARTS, THESIS_GOALS, strict=True)],
        title="Modified DMP: three new starts and goals of thesis §5.3.1",
    )  # fmt: skip
    heights = cup_plans(model, cfg, variance_aware=True)
    plain = cup_plans(model, cfg, variance_aware=False)
    outputs["fig_heights"] = plot_obstacle_comparison(
        model, heights, [f"cup {h:.2f} m" for h in cfg.obstacle_heights],
        figs / "obstacle_heights.png",
        title="Variance-avoidance DMP: a higher obstacle bends the path more (thesis Fig. 5.5)",
    )  # fmt: skip
    boxes = pair_boxes(model)
    pair = variance_pair(model, boxes=boxes)
    outputs["fig_variance_pair"] = plot_obstacle_comparison(
        model, *pair, figs / "variance_high_low.png",
        title="Same obstacle (3 cm above the learned path, 6 x 3 cm) where the "
        "demonstrations disagreed / agreed (thesis Figs. 5.6-5.7)",
    )  # fmt: skip
    task = task_plan(model, cfg)
    outputs["task_plan"] = save_plan(folder / "task.npz", task)
    outputs["fig_task"] = plot_obstacle_profile(model, task, figs / "task_obstacle.png")
    pair_plain = variance_pair(model, variance_aware=False, boxes=boxes)[0]
    return outputs, plan_summary(cfg, adapted, heights, plain, pair, pair_plain, task)
