"""The model, plan and rollout facts: typed fields, written and read back, older files lifted."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dexlfd.errors import InvalidFile
from dexlfd.io import (
    Plan,
    Rollout,
    load_model,
    load_plan,
    load_rollout,
    save_plan,
    save_rollout,
)
from dexlfd.io._facts import unit_of
from dexlfd.io._npz import save_npz
from dexlfd.io.plan_facts import (
    GraspSchedule,
    Limits,
    ObstaclePass,
    PlaceCorrection,
    Slowdown,
    TaskPose,
    TimeScaling,
)
from dexlfd.io.rollout_facts import GraspEvent, ObjectReport, Placement, TaskPoses

N = 5


def _plan_arrays() -> dict[str, np.ndarray]:
    z = np.zeros((N, 3)) + [0.4, 0.0, 0.2]
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (N, 1))
    return dict(
        t=np.arange(N) * 0.1, position=z, velocity=0 * z, acceleration=0 * z,
        quaternion=quat, angular_velocity=0 * z, gripper=np.full(N, 0.04),
    )  # fmt: skip


def _rollout_arrays() -> dict[str, np.ndarray]:
    z7, z3 = np.zeros((N, 7)), np.zeros((N, 3)) + [0.4, 0.0, 0.2]
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (N, 1))
    return dict(
        t=np.arange(N) * 1e-3, q=z7, dq=z7, tau=z7, ee_position=z3, ee_quaternion=quat,
        ref_position=z3, ref_quaternion=quat, gripper=np.full(N, 0.04),
    )  # fmt: skip


BOX = {"type": "box", "center": [0.45, 0.0, 0.1], "size": [0.1, 0.1, 0.2], "direction": "+z"}
OLD_PLAN_META = {
    "frame": "panda_base",
    "source": "an older dexlfd",
    "settings": {"margin": 0.03, "obstacles": [BOX]},
    "goal_error": 0.001,
    "obstacles": [{**BOX, "direction_used": "+z", "max_intrusion": 0.05, "required_lift": 0.06,
                   "coupling": "shaped", "gain": 2.0, "band_met": True, "displacement": 0.07,
                   "min_clearance": 0.031}],
    "grasp": {"method": "plan levels", "closed_level": 0.02, "open_level": 0.08,
              "close_below": 0.04, "open_above": 0.05, "intervals_s": [[0.1, 0.3]]},
    "place": {"surface_z": 0.05, "object_bottom": 0.03, "release_t": 0.3,
              "place_point": [0.4, 0.0, 0.08], "height_change": -0.02,
              "support": {"type": "box", "center": [0.4, 0.0, 0.025], "size": [0.1, 0.1, 0.05]}},
    "limits": {"peaks": {"translational velocity": 0.4}, "exceeded": []},
    "time_scaling": {"slowdowns": [{"stage": "joint", "t_s": [0.0, 0.2], "factor": 1.2,
                                    "limit": "joint velocity", "added_s": 0.04}],
                     "added_s": 0.04, "needed": True, "largest": 1.2},
}  # fmt: skip


def test_an_older_plan_has_its_facts_lifted_out_of_meta(tmp_path: Path) -> None:
    path = save_npz(tmp_path / "old.npz", "plan", 2, _plan_arrays(), OLD_PLAN_META)
    plan = load_plan(path)
    assert plan.frame == "panda_base" and plan.goal_error == pytest.approx(0.001)
    (ob,) = plan.obstacle_passes
    assert isinstance(ob, ObstaclePass)
    assert ob.size == (0.1, 0.1, 0.2) and ob.min_clearance == pytest.approx(0.031)
    assert ob.margin == pytest.approx(0.03)  # from the settings it was planned with
    assert plan.grasp_schedule == GraspSchedule(
        closed_level=0.02, open_level=0.08, close_below=0.04, open_above=0.05,
        intervals_s=((0.1, 0.3),),
    )  # fmt: skip
    assert isinstance(plan.place_correction, PlaceCorrection) and plan.place is None
    assert plan.limits == Limits(peaks={"translational velocity": 0.4}, exceeded=())
    assert plan.time_scaling is not None and plan.time_scaling.slowdowns == (
        Slowdown(t_s=(0.0, 0.2), factor=1.2, added_s=0.04, limit="joint velocity", stage="joint"),
    )
    # meta keeps the provenance only; the obstacles and the support became arrays
    assert set(plan.meta) - {"kind", "software"} == {"source", "settings"}
    np.testing.assert_allclose(plan.obstacle_center, [BOX["center"]])
    np.testing.assert_allclose(plan.support_size, [[0.1, 0.1, 0.05]])


def test_an_older_task_plans_pick_and_place_are_poses(tmp_path: Path) -> None:
    pose = {"position": [0.5, -0.1, 0.1], "quaternion": [1.0, 0.0, 0.0, 0.0],
            "yaw_deg": 0.0, "tilt_deg": 180.0, "given": True, "t": 1.5}  # fmt: skip
    meta = {"task": "pick-and-place", "pick": pose, "place": {**pose, "t": 3.0}}
    plan = load_plan(save_npz(tmp_path / "old.npz", "plan", 2, _plan_arrays(), meta))
    assert plan.task == "pick-and-place" and plan.place_correction is None
    assert isinstance(plan.pick, TaskPose) and plan.pick.t == 1.5 and plan.place.t == 3.0


def test_a_plans_facts_survive_a_round_trip(tmp_path: Path) -> None:
    plan = Plan(
        **_plan_arrays(), task="pick-and-place", goal_error=0.002,
        obstacle_passes=(ObstaclePass(type="sphere", center=(0.4, 0.1, 0.2), radius=0.05),),
        time_scaling=TimeScaling(per_part={"reach": 1.0}, needed=False, largest=1.0),
    )  # fmt: skip
    back = load_plan(save_plan(tmp_path / "p.npz", plan))
    for name in Plan.FACTS:
        assert getattr(back, name) == getattr(plan, name), name
    assert "obstacles" not in back.meta and unit_of(ObstaclePass, "min_clearance") == "m"


def test_an_older_rollout_has_its_facts_lifted_out_of_meta(tmp_path: Path) -> None:
    meta = {
        "controller": {"name": "ntsm-pd", "kp": 1.0},
        "plant": {"payload_kg": 1.2},
        "rate_hz": 1000.0,
        "stopped": None,
        "grasp_schedule": {"intervals_s": [[0.001, 0.003]], "source": "plan",
                           "grasp_t": 0.001, "grasp_position": [0.4, 0.0, 0.2],
                           "release_t": 0.003, "release_position": [0.4, 0.0, 0.2]},
        "grasp_events": [{"event": "dropped", "t": 0.002, "distance_m": 0.2}],
        "object": {"final_position": [0.4, 0.0, 0.03], "final_quaternion": [0, 0, 0, 1],
                   "tilt_deg": 1.0, "released_t": 0.003, "release_speed": 0.0,
                   "impact_speed": 0.05, "touch_speed": 0.05},
        "task": {"pick_pose": [0.4, 0, 0.2, 1, 0, 0, 0], "place_pose": [0.4, 0, 0.2, 1, 0, 0, 0]},
        "placement": {"ok": False, "carried": False, "error_m": None,
                      "horizontal_error_m": None, "tilt_deg": 1.0,
                      "set_down_speed_mps": 0.05, "failure": "dropped", "success": False,
                      "place_error_m": None, "set_down_speed": 0.05},
    }  # fmt: skip
    ro = load_rollout(save_npz(tmp_path / "old.npz", "rollout", 2, _rollout_arrays(), meta))
    assert ro.controller == "ntsm-pd" and ro.payload_kg == 1.2 and ro.rate_hz == 1000.0
    assert ro.stopped is None
    assert ro.grasp_events == (GraspEvent(event="dropped", t=0.002, distance_m=0.2),)
    assert isinstance(ro.object_report, ObjectReport) and ro.object_report.tilt_deg == 1.0
    assert isinstance(ro.task, TaskPoses) and ro.task.place_pose[3] == 1.0
    assert isinstance(ro.placement, Placement) and ro.placement["success"] is False
    assert ro.grasp_schedule is not None and ro.grasp_schedule.release_t == 0.003
    assert set(ro.meta) - {"kind", "software"} == {"controller", "plant"}  # provenance


def test_a_rollouts_facts_survive_a_round_trip(tmp_path: Path) -> None:
    ro = Rollout(
        **_rollout_arrays(), stopped="safety stop at t=0.004 s", controller="pd",
        rate_hz=1000.0, payload_kg=0.0,
        grasp_events=(GraspEvent(event="missed", t=0.001, distance_m=None),),
    )  # fmt: skip
    back = load_rollout(save_rollout(tmp_path / "r.npz", ro))
    for name in Rollout.FACTS:
        assert getattr(back, name) == getattr(ro, name), name


def test_a_placement_without_an_object_has_no_tilt_not_a_nan(tmp_path: Path) -> None:
    """What the placement check says of a rollout with no object report: tilt unknown."""
    from dexlfd.control.grasp import placement_report

    task = TaskPoses((0.4, 0, 0.2, 1, 0, 0, 0), (0.5, 0, 0.2, 1, 0, 0, 0))
    ro = Rollout(**_rollout_arrays(), task=task)
    placement = placement_report(ro)
    assert placement.tilt_deg is None and placement.error_m is None and not placement.ok
    assert "nan" not in repr(placement).lower()
    back = load_rollout(
        save_rollout(tmp_path / "r.npz", Rollout(**_rollout_arrays(), placement=placement))
    )
    assert back.placement == placement and back.placement.tilt_deg is None
    assert Placement(True, True, 0.01, 0.01, 2.0, 0.05, None).tilt_deg == 2.0


def test_an_older_model_has_its_facts_lifted_out_of_meta(tmp_path: Path) -> None:
    mean = np.zeros((N, 8)) + [0.4, 0.0, 0.2, 0.0, 0.0, 0.0, 1.0, 0.04]
    arrays = dict(
        t=np.arange(N) * 0.1, mean=mean, cov=np.tile(1e-6 * np.eye(8), (N, 1, 1)),
        gmm_weights=np.ones(1), gmm_means=np.zeros((1, 9)), gmm_covs=np.eye(9)[None],
    )  # fmt: skip
    meta = {"source": "old", "frame": "camera (no extrinsics)", "outliers": ["demo 2"],
            "grasp_events": {"demonstrations": [{"name": "demo 1", "skipped": "never closes"}],
                             "n_with_events": 0, "note": "no events"}}  # fmt: skip
    back = load_model(save_npz(tmp_path / "old.npz", "model", 2, arrays, meta))
    assert back.frame == "camera (no extrinsics)" and back.outliers == ("demo 2",)
    assert back.grasp_events is not None and back.grasp_events.note == "no events"
    assert back.grasp_events.demonstrations[0].skipped == "never closes"
    assert set(back.meta) - {"kind", "software"} == {"source"}


@pytest.mark.parametrize(
    ("kind", "meta", "message"),
    [
        ("plan", {"obstacles": [{"type": "cone", "center": [0, 0, 0]}]},
         r"facts\.obstacle_passes\[0\]\.type must be one of 'box', 'sphere'"),
        ("plan", {"goal_error": "small"}, r"facts\.goal_error must be a finite number"),
        ("rollout", {"grasp_events": [{"event": "dropped", "t": "x"}]},
         r"facts\.grasp_events\[0\]\.t must be a finite number"),
        ("rollout", {"object": "x"}, r"facts\.object_report must be a JSON object"),
    ],
)  # fmt: skip
def test_a_damaged_older_fact_is_one_line_naming_the_file(
    tmp_path: Path, kind: str, meta: dict, message: str
) -> None:
    arrays = _plan_arrays() if kind == "plan" else _rollout_arrays()
    path = save_npz(tmp_path / "bad.npz", kind, 2, arrays, meta)
    with pytest.raises(InvalidFile, match=r"bad\.npz: " + message):
        (load_plan if kind == "plan" else load_rollout)(path)
