"""Pick it up where it is now, put it where it should go: plans cut at the grasp events."""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path

import numpy as np
import pytest

from dexlfd.cli import main
from dexlfd.errors import InvalidInput
from dexlfd.geometry import Box, signed_distance
from dexlfd.io import LearnedModel, load_plan, save_model
from dexlfd.plan import PlanConfig, plan_from_model
from dexlfd.plan.task_poses import heading
from dexlfd.plan.timing import moving_stretches, retime
from dexlfd.rotations import quat_angle

PICK = (0.52, -0.12, 0.12)
PLACE = (0.40, 0.30, 0.15)


@pytest.fixture(scope="module")
def task_plan(event_model: LearnedModel):
    cfg = PlanConfig(pick=PICK, place=PLACE, pick_yaw=np.radians(30.0), rate_hz=500.0)
    return plan_from_model(event_model, cfg)


def _switches(plan) -> tuple[int, int]:
    on = np.flatnonzero(plan.grasp)
    return int(on[0]), int(on[-1]) + 1


def test_closes_at_the_pick_and_opens_at_the_place(task_plan, event_model) -> None:
    plan = task_plan
    assert plan.task == "pick-and-place"
    k_close, k_open = _switches(plan)
    # one closed run, from the pick to the place
    assert np.count_nonzero(np.diff(plan.grasp.astype(int)) == 1) == 1
    assert np.linalg.norm(plan.position[k_close] - PICK) <= 0.005
    assert np.linalg.norm(plan.position[k_open] - PLACE) <= 0.005
    np.testing.assert_allclose(plan.pick_pose[:3], PICK)
    np.testing.assert_allclose(plan.place_pose[:3], PLACE)
    # the orientation at the pick is the demonstrated one turned to the asked heading
    assert float(quat_angle(plan.quaternion[k_close], plan.pick_pose[3:])) <= np.radians(3.0)
    assert np.degrees(heading(plan.quaternion[k_close])) == pytest.approx(30.0, abs=3.0)
    demo_tilt = quat_angle(plan.pick_pose[3:], event_model.event_quaternion[0])
    assert np.degrees(demo_tilt) == pytest.approx(
        abs(30.0 - np.degrees(heading(event_model.event_quaternion[0]))), abs=1.0
    )
    # the arm holds still while the gripper closes and while it opens
    for k in (k_close, k_open):
        assert np.abs(plan.velocity[k - 5 : k + 5]).max() < 1e-9
    # the gripper channel follows the schedule: closed level while held
    assert np.median(plan.gripper[plan.grasp]) < np.median(plan.gripper[~plan.grasp])


def test_approaches_from_above_and_joins_with_continuous_velocity(task_plan) -> None:
    plan = task_plan
    k_close, _ = _switches(plan)
    # the last 4 cm before the pick: straight down (the demonstrations came from above),
    # from the pre-grasp pose 4 cm above it
    pre = np.asarray(PICK) + [0.0, 0.0, 0.04]
    # (to 0.1 um: the retimed reach ends there up to the interpolation's rounding)
    at_pre = np.flatnonzero(np.linalg.norm(plan.position[:k_close] - pre, axis=1) < 1e-7)
    assert at_pre.size > 10  # it settles there first
    seg = plan.position[at_pre[-1] : k_close + 1]
    np.testing.assert_allclose(seg[:, :2], np.tile(PICK[:2], (seg.shape[0], 1)), atol=1e-7)
    assert np.all(np.diff(seg[:, 2]) <= 1e-12)
    assert plan.approach.demonstrated_from_vertical_deg < 45.0
    # no jumps: velocity continuous everywhere, and consistent with the position
    dt = float(plan.t[1] - plan.t[0])
    assert np.abs(np.diff(plan.velocity, axis=0)).max() < 0.05
    v_num = np.gradient(plan.position, plan.t, axis=0)
    assert np.abs(v_num - plan.velocity).max() < 0.02
    assert np.linalg.norm(np.diff(plan.position, axis=0), axis=1).max() < 1.7 * dt


def test_defaults_are_the_demonstrated_pick_and_place(event_model) -> None:
    plan = plan_from_model(event_model, PlanConfig(rate_hz=200.0))
    k_close, k_open = _switches(plan)
    np.testing.assert_allclose(plan.position[k_close], event_model.event_position[0], atol=1e-3)
    np.testing.assert_allclose(plan.position[k_open], event_model.event_position[1], atol=1e-3)
    assert plan.pick.given is False
    # the supports the simulator builds: under the pick and the place, up to the object
    assert plan.support_center.shape == (2, 3)
    tops = plan.support_center[:, 2] + plan.support_size[:, 2] / 2
    np.testing.assert_allclose(tops, event_model.event_position[:, 2] - 0.03, atol=1e-9)


def test_obstacles_and_the_variance_term_work_on_the_carry(event_model) -> None:
    free = plan_from_model(event_model, PlanConfig(pick=PICK, place=PLACE, rate_hz=200.0))
    k_close, k_open = _switches(free)
    c = free.position[(k_close + k_open) // 2]  # the middle of the carry
    top = float(c[2]) + 0.03  # 3 cm above the carried path
    box = Box((float(c[0]), float(c[1]), top / 2), (0.06, 0.03, top))
    cfg = PlanConfig(pick=PICK, place=PLACE, obstacles=(box,), rate_hz=200.0)
    plan = plan_from_model(event_model, cfg)
    d = signed_distance(box, plan.position)
    assert d.min() >= 0.02 - 2e-3  # the margin, on the part that passes the box
    np.testing.assert_allclose(plan.obstacle_center, [box.center])
    records = [r for r in plan.obstacle_passes if r.displacement]
    assert records and all(r.min_clearance >= 0.018 for r in records)
    k_close, k_open = _switches(plan)
    assert np.linalg.norm(plan.position[k_open] - PLACE) <= 0.005


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"pick": (1.2, 0.0, 0.12)}, "pick .* outside the Panda's workspace"),
        ({"pick": (0.5, -0.1, 0.01)}, "pick .* under the table: z must be >= 0.03"),
        ({"place": (0.5, 0.0, 0.12), "obstacles": (Box((0.5, 0.0, 0.1), (0.1, 0.1, 0.2)),)},
         "place .* inside obstacle 0"),
        ({"pick": PICK, "place": PICK}, "at least 0.05 m away"),
    ],
)  # fmt: skip
def test_bad_pick_and_place_are_refused(event_model, kwargs, match) -> None:
    with pytest.raises(InvalidInput, match=match):
        plan_from_model(event_model, PlanConfig(rate_hz=100.0, **kwargs))


def test_bad_flags_name_the_flag(event_model, tmp_path: Path, capsys) -> None:
    model = save_model(tmp_path / "m.npz", event_model)
    out = tmp_path / "p.npz"
    for flag, value, words in (
        ("--pick", "0.5,-0.2,0.12,nan", "--pick '0.5,-0.2,0.12,nan': yaw_deg must be a finite"),
        ("--place", "0.5,0.2", "--place '0.5,0.2': expected x,y,z"),
        ("--pick", "0.5,-0.2,-0.1", "--pick [0.5, -0.2, -0.1] m is outside"),
    ):
        assert main(["plan", str(model), flag, value, "-o", str(out)]) == 1
        err = capsys.readouterr().err
        assert words in err and "Traceback" not in err
        assert not out.exists()


def test_a_model_without_events_plans_as_one_motion(ref_model, caplog) -> None:
    with caplog.at_level(logging.WARNING):
        plan = plan_from_model(ref_model, PlanConfig(pick=PICK, rate_hz=100.0))
    assert "no grasp events" in caplog.text
    assert plan.task is None and plan.pick_pose is None
    assert plan.grasp is not None  # the schedule, read from the learned opening
    # and a model with events can still be planned as the thesis's one motion
    assert not ref_model.has_events


def test_retime_slows_a_stretch_and_keeps_the_path(task_plan) -> None:
    plan = task_plan
    stretches = moving_stretches(plan)
    assert len(stretches) >= 5  # reach, approach, lift, carry, lower, rise, retreat
    factors = [1.0] * len(stretches)
    factors[0] = 2.0
    slow = retime(plan, stretches, factors)
    a, b = stretches[0]
    assert slow.t[-1] == pytest.approx(plan.t[-1] + (plan.t[b] - plan.t[a]), abs=2e-3)
    assert (
        np.linalg.norm(slow.velocity, axis=1).max()
        <= np.linalg.norm(plan.velocity, axis=1).max() + 1e-9
    )
    # the same path: every retimed sample lies on the original path
    dist = np.min(
        np.linalg.norm(slow.position[::50, None, :] - plan.position[None, ::5, :], axis=2), axis=1
    )
    assert dist.max() < 0.01
    assert np.count_nonzero(np.diff(slow.grasp.astype(int)) == 1) == 1


def test_plan_command_writes_a_feasible_task(event_model, tmp_path: Path) -> None:
    model = save_model(tmp_path / "m.npz", event_model)
    out = tmp_path / "p.npz"
    rc = main(["plan", str(model), "--pick", "0.5,-0.15,0.12,20", "--place", "0.45,0.25,0.12",
               "--rate-hz", "200", "-o", str(out)])  # fmt: skip
    assert rc == 0
    plan = load_plan(out)
    feas = plan.feasibility
    assert feas.joint_velocity_ratio <= 0.8 + 1e-6
    assert feas.joint_acceleration_ratio <= 0.8 * 1.05
    assert plan.grasp is not None and plan.pick_pose is not None
    assert np.linalg.norm(plan.position[_switches(plan)[0]] - [0.5, -0.15, 0.12]) <= 0.005


def test_too_fast_a_plan_is_slowed_until_feasible(event_model) -> None:
    from dexlfd.panda import CARTESIAN_LIMITS
    from dexlfd.plan.feasibility import make_feasible
    from dexlfd.robot import MujocoPandaModel

    fast = plan_from_model(
        event_model,
        PlanConfig(duration=2.0, task="motion", rate_hz=200.0, on_limit="scale", feasible=False),
    )
    assert fast.limits.exceeded  # the Panda could not follow it
    slow, report = make_feasible(fast, MujocoPandaModel())
    assert report.needed and report.largest > 1.5
    assert slow.t[-1] > 2.0 * 1.5
    assert (
        np.linalg.norm(slow.velocity, axis=1).max() <= CARTESIAN_LIMITS["translational_velocity"][0]
    )
    assert (
        np.linalg.norm(slow.acceleration, axis=1).max()
        <= CARTESIAN_LIMITS["translational_acceleration"][0]
    )
    assert report.joint_velocity_ratio <= 0.8 + 1e-6
    # the path is the same one, only slower
    np.testing.assert_allclose(slow.position[-1], fast.position[-1], atol=1e-4)
    # a pose the arm cannot take is refused with the reason: no timing fixes that
    far = dataclasses.replace(fast, position=fast.position * [1.0, 1.0, 1.0] + [0.0, 0.0, 0.0])
    far_pos = np.array(far.position)
    far_pos[len(far_pos) // 2] = [0.05, 0.0, 0.05]  # inside the base
    with pytest.raises(InvalidInput, match="workspace"):
        make_feasible(dataclasses.replace(far, position=far_pos), MujocoPandaModel())


def test_a_model_whose_hand_closes_and_opens_in_place_is_planned_as_one_motion(
    event_model: LearnedModel, caplog
) -> None:
    """Demonstrated grasp and release 1 cm apart (a fist in place): nothing is carried, so
    the default plan is one motion with a warning, not an error about flags never given."""
    import dataclasses
    import logging

    assert event_model.event_position is not None
    pos = event_model.event_position.copy()
    pos[1] = pos[0] + [0.01, 0.0, 0.0]
    in_place = dataclasses.replace(event_model, event_position=pos)
    with caplog.at_level(logging.WARNING):
        plan = plan_from_model(in_place, PlanConfig(rate_hz=200.0))
    assert "nothing is carried" in caplog.text
    whole = plan_from_model(in_place, PlanConfig(rate_hz=200.0, task="motion"))
    np.testing.assert_allclose(plan.position, whole.position)
    with pytest.raises(InvalidInput, match="at least 0.05 m away"):  # the user's own place
        plan_from_model(in_place, PlanConfig(place=tuple(pos[0] + [0.01, 0, 0]), rate_hz=200.0))


def test_a_place_surface_sets_the_object_down_on_it(event_model, tmp_path: Path, capsys) -> None:
    # the object's bottom (0.03 m below the TCP) rests on a 0.05 m surface: the release is
    # at TCP z = 0.08 m, not at the demonstrated place's height
    plan = plan_from_model(event_model, PlanConfig(place_surface_z=0.05, rate_hz=200.0))
    assert plan.place_pose[2] == pytest.approx(0.08)
    assert plan.position[_switches(plan)[1], 2] == pytest.approx(0.08, abs=0.005)
    assert abs(event_model.event_position[1][2] - 0.08) > 0.02  # the flag changed it
    # a --place whose height disagrees with the surface is refused, naming both flags
    model = save_model(tmp_path / "m.npz", event_model)
    out = tmp_path / "p.npz"
    argv = ["plan", str(model), "--place", "0.45,0.25,0.12", "--place-surface-m", "0.05"]
    assert main([*argv, "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert "--place z 0.12 m and --place-surface-m 0.05 m disagree" in err
    assert "Traceback" not in err and not out.exists()
