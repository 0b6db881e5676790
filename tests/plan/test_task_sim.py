"""Planned from the robot's pose with a top-down grasp, the object is set down upright (MuJoCo)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")

from dexlfd.cli import main  # noqa: E402
from dexlfd.control import LoopConfig, make_controller, track  # noqa: E402
from dexlfd.datasets import pick_place_demonstrations  # noqa: E402
from dexlfd.io import load_plan, load_rollout, save_plan  # noqa: E402
from dexlfd.learn import LearnConfig, learn_from_demonstrations  # noqa: E402
from dexlfd.plan import PlanConfig, plan_from_model  # noqa: E402
from dexlfd.robot import MujocoPandaModel, PlantConfig, plan_world  # noqa: E402

from .test_task_poses import tilted_demos  # noqa: E402

RATE = 200.0


@pytest.mark.integration
def test_a_tilted_demonstration_is_placed_upright() -> None:
    """Demonstrations whose hand is tilted 30 deg: the top-down plan sets the 1.2 kg box
    down upright, where the plan puts it, gently."""
    model = learn_from_demonstrations(
        tilted_demos(30.0), LearnConfig(), np.random.default_rng(0)
    ).model
    plan = plan_from_model(model, PlanConfig(rate_hz=RATE))
    plant = PlantConfig(payload_kg=1.2, obstacles=plan_world(plan))
    ro = track(
        plan, make_controller("ntsm-pd"), MujocoPandaModel(), plant, LoopConfig(),
        rng=np.random.default_rng(0),
    )  # fmt: skip
    pl = ro.placement
    assert pl["carried"], pl["failure"]
    assert pl["tilt_deg"] <= 10.0
    assert pl["error_m"] <= 0.02
    assert pl["set_down_speed_mps"] < 0.1
    assert pl["ok"]


@pytest.mark.integration
def test_simulate_exits_1_when_the_placement_fails(tmp_path: Path, capsys) -> None:
    """The six-demo model's default plan is placed (exit 0, upright); the same plan whose
    place pose says 5 cm further (the object is set down where the arm goes, not there)
    exits 1 naming the distance, and still writes the rollout."""
    model = learn_from_demonstrations(
        pick_place_demonstrations(6, np.random.default_rng(0)), LearnConfig(),
        np.random.default_rng(0),
    ).model  # fmt: skip
    plan = plan_from_model(model, PlanConfig(rate_hz=RATE))
    good = save_plan(tmp_path / "good.npz", plan)
    assert plan.place_pose is not None
    moved = plan.place_pose.copy()
    moved[1] += 0.05
    bad = save_plan(tmp_path / "bad.npz", dataclasses.replace(plan, place_pose=moved))
    args = ["--controller", "ntsm-pd", "--payload", "1.2", "--quiet"]
    assert main(["simulate", str(good), *args, "-o", str(tmp_path / "g.npz")]) == 0
    ro = load_rollout(tmp_path / "g.npz")
    placed = ro.placement
    assert placed["ok"] and placed["tilt_deg"] <= 10.0
    # from the ready pose to the grasp the arm follows its reference to millimetres (a
    # reach as fast as the ready pose's distance asked ran 30 mm behind)
    before = ro.t < ro.grasp_schedule.grasp_t
    err = np.linalg.norm(ro.ee_position - ro.ref_position, axis=1)[before]
    assert err.max() < 0.01, err.max()
    capsys.readouterr()
    assert main(["simulate", str(bad), *args, "-o", str(tmp_path / "b.npz")]) == 1
    err = capsys.readouterr().err
    assert "placement failed" in err and "mm from the place position" in err
    assert (tmp_path / "b.npz").exists()


@pytest.mark.integration
def test_the_thesis_pillar_is_planned_round_with_the_hand_and_object_and_placed(
    tmp_path: Path,
) -> None:
    """The 0.5 m pillar between pick and place (the thesis's obstacle case), from the CLI:
    the plan keeps the hand and the 1.2 kg object, not only the TCP, clear of it, and
    the simulation carries the object over it and places it (exit 0)."""
    d = tmp_path
    assert main(["synth", "-n", "6", "-o", str(d / "demos"), "-q"]) == 0
    demos = sorted(str(p) for p in (d / "demos").glob("*.npz"))
    assert main(["learn", *demos, "-o", str(d / "model.npz"), "-q"]) == 0
    pillar = "box:0.46,-0.05,0.25,0.10,0.10,0.50"
    assert main(["plan", str(d / "model.npz"), "--obstacle", pillar,
                 "-o", str(d / "plan.npz"), "-q"]) == 0  # fmt: skip
    plan = load_plan(d / "plan.npz")
    clear = plan.meta["clearance"]
    assert clear["min_m"] >= 0.015  # the margin (0.02 m) within the box's 5 mm pad
    assert clear["tcp_per_obstacle_min_m"][0] > clear["min_m"] + 0.03  # hand and object
    args = ["--payload", "1.2", "-q", "-o", str(d / "r.npz")]
    assert main(["simulate", str(d / "plan.npz"), *args]) == 0
    ro = load_rollout(d / "r.npz")
    assert ro.placement.ok
    assert ro.stopped is None
