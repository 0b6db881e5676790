"""A pick-and-place the robot runs from its own pose: start, grasp orientation, end, obstacles."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from dexlfd.cli import main
from dexlfd.datasets import pick_place_demonstrations
from dexlfd.errors import InvalidInput
from dexlfd.geometry import Box, signed_distance
from dexlfd.io import LearnedModel, save_model
from dexlfd.learn import LearnConfig, learn_from_demonstrations
from dexlfd.panda import Q_READY
from dexlfd.panda_kinematics import dh_tcp
from dexlfd.plan import PlanConfig, plan_from_model
from dexlfd.plan.part_timing import ROBOT_SPEED
from dexlfd.plan.task_poses import heading, top_down
from dexlfd.rotations import matrix_from_quat, quat_multiply

RATE = 200.0
THESIS_OBSTACLE = Box((0.46, -0.05, 0.25), (0.10, 0.10, 0.50))  # the thesis's 0.5 m box


def tilted_demos(deg: float, seed: int = 0) -> list:
    """The synthetic demonstrations with the hand turned ``deg`` about its own x axis."""
    a = np.radians(deg) / 2
    r = np.array([np.sin(a), 0.0, 0.0, np.cos(a)])
    out = []
    for d in pick_place_demonstrations(6, np.random.default_rng(seed)):
        q = quat_multiply(d.quaternion, np.broadcast_to(r, d.quaternion.shape))
        out.append(dataclasses.replace(d, quaternion=q))
    return out


def _learn(demos: list) -> LearnedModel:
    return learn_from_demonstrations(demos, LearnConfig(), np.random.default_rng(0)).model


@pytest.fixture(scope="module")
def six_demo_model() -> LearnedModel:
    return _learn(pick_place_demonstrations(6, np.random.default_rng(0)))


@pytest.fixture(scope="module")
def tilted_model() -> LearnedModel:
    return _learn(tilted_demos(30.0))


def _tcp_down_deg(q: np.ndarray) -> float:
    """Angle of the TCP's z axis from straight down [deg]."""
    return float(np.degrees(np.arccos(np.clip(-matrix_from_quat(q)[2, 2], -1, 1))))


def _ready():
    T = dh_tcp(Q_READY)
    return T[:3, 3], T[:3, :3]


def test_the_plan_starts_at_the_robots_ready_pose(six_demo_model) -> None:
    plan = plan_from_model(six_demo_model, PlanConfig(rate_hz=RATE))
    p_ready, R_ready = _ready()
    np.testing.assert_allclose(plan.position[0], p_ready, atol=1e-6)
    np.testing.assert_allclose(matrix_from_quat(plan.quaternion[0]), R_ready, atol=1e-6)
    assert np.linalg.norm(plan.velocity[0]) < 1e-6  # it starts at rest
    assert plan.meta["start_pose"]["source"] == "ready pose"
    # the old behaviour on request: the person's start
    old = plan_from_model(six_demo_model, PlanConfig(rate_hz=RATE, start="demonstrated"))
    np.testing.assert_allclose(old.position[0], six_demo_model.mean[0, :3], atol=1e-6)


def test_where_the_person_started_and_ended_never_fails_the_plan(six_demo_model) -> None:
    """The person's hand started and ended out of the arm's reach (beside the base):
    the plan still starts at the ready pose and ends at the ready pose, saying why."""
    mean = six_demo_model.mean.copy()
    n = mean.shape[0]
    far = np.array([0.05, 0.0, 0.05])  # inside the base: no arm pose reaches it
    w = np.clip(np.linspace(1.0, -4.0, n), 0, 1)[:, None]  # blend over the first fifth
    mean[:, :3] = w * far + (1 - w) * mean[:, :3]
    w_end = np.clip(np.linspace(-4.0, 1.0, n), 0, 1)[:, None]
    mean[:, :3] = w_end * far + (1 - w_end) * mean[:, :3]
    odd = dataclasses.replace(six_demo_model, mean=mean)
    with pytest.raises(InvalidInput):  # planned the old way, the person's start fails
        plan_from_model(odd, PlanConfig(rate_hz=RATE, start="demonstrated"))
    plan = plan_from_model(odd, PlanConfig(rate_hz=RATE))
    p_ready, _ = _ready()
    np.testing.assert_allclose(plan.position[0], p_ready, atol=1e-6)
    np.testing.assert_allclose(plan.position[-1], p_ready, atol=2e-3)
    end = plan.meta["retreat_end"]
    assert end["source"] == "ready pose" and "demonstrated end" in end["why_not_demonstrated"]


def test_the_retreat_ends_where_the_person_ended_relative_to_the_place(six_demo_model) -> None:
    m = six_demo_model
    assert m.event_position is not None
    offset = m.mean[-1, :3] - m.event_position[1]
    moved = m.event_position[1] + [-0.05, 0.03, 0.0]
    plan = plan_from_model(m, PlanConfig(rate_hz=RATE, place=tuple(moved)))
    assert plan.meta["retreat_end"]["source"] == "demonstrated end"
    np.testing.assert_allclose(plan.position[-1], moved + offset, atol=2e-3)


@pytest.mark.parametrize("which", ["six", "tilted"])
def test_the_default_grasp_is_top_down_with_the_demonstrated_heading(
    which: str, six_demo_model, tilted_model
) -> None:
    m = six_demo_model if which == "six" else tilted_model
    assert m.event_quaternion is not None
    plan = plan_from_model(m, PlanConfig(rate_hz=RATE))
    for k, pose in enumerate((plan.pick_pose, plan.place_pose)):
        assert pose is not None
        assert _tcp_down_deg(pose[3:]) < 1e-6
        yaw_err = np.angle(np.exp(1j * (heading(pose[3:]) - heading(m.event_quaternion[k]))))
        assert abs(yaw_err) < 1e-6
    # the planned TCP is top-down at the switches too (the arm holds the grasp pose)
    on = np.flatnonzero(plan.grasp)
    for k in (on[0], on[-1]):
        assert _tcp_down_deg(plan.quaternion[k]) < 0.5
    demo = plan_from_model(m, PlanConfig(rate_hz=RATE, grasp_orientation="demonstrated"))
    assert demo.pick_pose is not None
    expected = 30.0 if which == "tilted" else 0.0
    assert _tcp_down_deg(demo.pick_pose[3:]) == pytest.approx(expected, abs=2.0)


def test_the_thesis_obstacle_case_plans_and_clears(six_demo_model) -> None:
    cfg = PlanConfig(rate_hz=RATE, obstacles=(THESIS_OBSTACLE,))
    plan = plan_from_model(six_demo_model, cfg)
    clearance = signed_distance(THESIS_OBSTACLE, plan.position)
    assert clearance.min() >= cfg.margin - 1e-3
    # the placed object: its own size, below the hand at the release, and the retreat
    # rises above it before it moves sideways
    obj = plan.meta["object"]
    size = np.asarray(obj["size_m"])
    closed = plan.grasp_schedule.closed_level
    np.testing.assert_allclose(size, [closed, closed, 2 * cfg.object_bottom])
    placed = Box(**{k: obj["placed_box"][k] for k in ("center", "size")})
    k_release = np.flatnonzero(plan.grasp)[-1] + 1
    z_top = placed.center[2] + placed.size[2] / 2
    assert plan.meta["vertical"]["rise_m"] + plan.place_pose[2] >= z_top + 0.03 - 1e-9
    risen = k_release + int(np.argmax(plan.position[k_release:, 2] >= z_top + 0.03 - 1e-4))
    # straight up until then, clear of it by the margin after
    assert np.abs(plan.position[k_release:risen, :2] - plan.place_pose[:2]).max() < 1e-6
    assert signed_distance(placed, plan.position[risen:]).min() >= cfg.margin - 1e-3


def test_a_hand_leaving_the_place_sideways_plans_without_flags_never_given(
    six_demo_model, tmp_path: Path, capsys
) -> None:
    """The learned retreat leaves the place sideways at its height: not refused (the
    placed object is its own size), and no error names --goal."""
    m = six_demo_model
    assert m.event_t is not None and m.event_position is not None
    mean = m.mean.copy()
    after = m.t >= m.event_t[1]
    s = (m.t[after] - m.t[after][0]) / (m.t[-1] - m.t[after][0])
    mean[after, :3] = m.event_position[1] + np.outer(s, [0.0, 0.12, 0.0])
    sideways = dataclasses.replace(m, mean=mean)
    plan = plan_from_model(sideways, PlanConfig(rate_hz=RATE))
    assert plan.meta["retreat_end"]["source"] in ("demonstrated end", "ready pose")
    path = save_model(tmp_path / "m.npz", sideways)
    inside = "box:0.31,0.0,0.49,0.1,0.1,0.1"  # the ready pose inside an obstacle
    rc = main(["plan", str(path), "--obstacle", inside, "-o", str(tmp_path / "p.npz")])
    err = capsys.readouterr().err
    assert rc != 0 and "ready pose" in err
    assert "--goal" not in err and "--start" not in err


def test_object_size_is_checked_and_recorded(six_demo_model) -> None:
    plan = plan_from_model(six_demo_model, PlanConfig(rate_hz=RATE, object_size=(0.05, 0.04, 0.1)))
    assert plan.meta["object"]["size_m"] == [0.05, 0.04, 0.1]
    assert plan.meta["object"]["placed_box"]["size"][2] == pytest.approx(0.1)
    with pytest.raises(InvalidInput, match="object_size"):
        PlanConfig(object_size=(0.05, 0.0, 0.1))
    with pytest.raises(InvalidInput, match="grasp_orientation"):
        PlanConfig(grasp_orientation="sideways")
    with pytest.raises(InvalidInput, match="start"):
        PlanConfig(start="home")


def test_the_plan_command_takes_the_new_flags(six_demo_model, tmp_path: Path, capsys) -> None:
    from dexlfd.io import load_plan

    path = save_model(tmp_path / "m.npz", six_demo_model)
    out = tmp_path / "p.npz"
    rc = main(["plan", str(path), "--start", "demonstrated", "--grasp-orientation",
               "demonstrated", "--object-size", "0.05,0.04,0.08", "--rate-hz", "200",
               "-o", str(out)])  # fmt: skip
    assert rc == 0
    plan = load_plan(out)
    np.testing.assert_allclose(plan.position[0], six_demo_model.mean[0, :3], atol=1e-6)
    assert plan.meta["grasp_orientation"] == "demonstrated"
    assert plan.meta["object"]["size_m"] == [0.05, 0.04, 0.08]
    assert plan.time_scaling is not None and plan.feasibility is not None
    capsys.readouterr()
    rc = main(["plan", str(path), "--object-size", "0.05,0.04", "-o", str(tmp_path / "q.npz")])
    assert rc != 0 and "--object-size" in capsys.readouterr().err
    rc = main(["plan", str(path), "--start", "home", "-o", str(tmp_path / "q.npz")])
    assert rc != 0 and "--start" in capsys.readouterr().err
    assert not (tmp_path / "q.npz").exists()


def test_the_reach_from_the_ready_pose_is_timed_by_the_robot(six_demo_model) -> None:
    """The reach from the ready pose covers a distance the person never moved: it peaks
    at the robot's speed (not the person's stretch slowed to a speed cap), is no
    slow-down in the time-scaling log, and the log still adds up. The carry keeps the
    person's timing; from the person's own start the reach does too."""
    m = six_demo_model
    assert m.event_t is not None
    plan = plan_from_model(m, PlanConfig(rate_hz=RATE, feasible=False))
    t0, t1 = plan.meta["parts"][0]["t_s"]
    reach = (plan.t >= t0) & (plan.t <= t1)
    speed = np.linalg.norm(plan.velocity[reach], axis=1).max()
    assert speed == pytest.approx(ROBOT_SPEED, rel=0.03)
    assert plan.meta["part_timing"]["timed_by"]["reach"] == "robot"
    assert plan.meta["part_timing"]["timed_by"]["carry"] == "person"
    ts = plan.time_scaling
    assert not [s for s in ts.slowdowns if s.part == "reach"]
    assert ts.duration_unscaled_s + ts.added_s == pytest.approx(ts.duration_s, abs=1e-9)
    # the carry lasts the person's stretch (unless slowed, and then it says so)
    carry = plan.meta["parts"][1]
    person = float(m.event_t[1] - m.event_t[0])
    assert carry["duration"] == pytest.approx(person * carry["time_scale"], rel=0.02)
    # from the person's start, the reach is the person's (slowed to a cap, and said)
    own = plan_from_model(m, PlanConfig(rate_hz=RATE, feasible=False, start="demonstrated"))
    assert own.meta["part_timing"]["timed_by"]["reach"] == "person"


def test_a_robot_timed_reach_is_as_long_as_its_path_needs(six_demo_model) -> None:
    """A farther start gives a longer reach, a nearer one a shorter reach, both at the
    robot's speed: its duration follows the distance, not the person's reach time."""
    durations = []
    for start in ((0.35, 0.0, 0.45), (0.30, 0.30, 0.55)):
        plan = plan_from_model(
            six_demo_model, PlanConfig(rate_hz=RATE, feasible=False, start=start)
        )
        t0, t1 = plan.meta["parts"][0]["t_s"]
        reach = (plan.t >= t0) & (plan.t <= t1)
        assert np.linalg.norm(plan.velocity[reach], axis=1).max() == pytest.approx(
            ROBOT_SPEED, rel=0.03
        )
        durations.append(t1 - t0)
    assert durations[1] > durations[0] * 1.2


def _swinging_demos() -> list:
    """The synthetic demonstrations with the palm swinging 0 -> 35 -> 0 deg about its x axis."""
    out = []
    for d in pick_place_demonstrations(6, np.random.default_rng(0)):
        u = (d.t - d.t[0]) / (d.t[-1] - d.t[0])
        a = np.radians(35.0) * np.sin(np.pi * u) / 2
        r = np.column_stack([np.sin(a), np.zeros_like(a), np.zeros_like(a), np.cos(a)])
        out.append(dataclasses.replace(d, quaternion=quat_multiply(d.quaternion, r)))
    return out


def test_a_top_down_plan_stays_top_down_between_the_pick_and_the_place() -> None:
    """The person's palm swings (35 deg here); the gripper and the held object do not.

    (Learned as demonstrated, the carry tilts the TCP by tens of degrees between the
    top-down pick and place: see ``grasp_orientation="demonstrated"`` below.)
    """
    m = _learn(_swinging_demos())
    plan = plan_from_model(m, PlanConfig(rate_hz=RATE))
    tilts = [_tcp_down_deg(q) for q in plan.quaternion[:: max(1, plan.n_samples // 400)]]
    assert max(tilts) < 0.5
    # the angular velocity is the heading's turn about the base z axis only
    assert np.abs(plan.angular_velocity[:, :2]).max() < 1e-9
    demo = plan_from_model(m, PlanConfig(rate_hz=RATE, grasp_orientation="demonstrated"))
    assert max(_tcp_down_deg(q) for q in demo.quaternion[::50]) > 10.0


def test_a_heading_beyond_a_quarter_turn_is_grasped_the_other_way_round() -> None:
    """A parallel gripper grasps at psi and psi + 180 deg; the arm takes the one it reaches.

    Demonstrations turned 170 deg about the base z axis (a person's palm facing back)
    ask for a top-down heading near 170 deg, beyond the last joint's reach from the
    ready pose: the pick is grasped at -10 deg, and the place keeps the person's turn
    from pick to place.
    """
    a = np.radians(170.0) / 2
    rz = np.array([0.0, 0.0, np.sin(a), np.cos(a)])
    demos = [
        dataclasses.replace(d, quaternion=quat_multiply(np.broadcast_to(rz, d.quaternion.shape),
                                                        d.quaternion))
        for d in pick_place_demonstrations(6, np.random.default_rng(0))
    ]  # fmt: skip
    m = _learn(demos)
    assert m.event_quaternion is not None
    plan = plan_from_model(m, PlanConfig(rate_hz=RATE))
    assert plan.pick_pose is not None and plan.place_pose is not None
    pick, place = heading(plan.pick_pose[3:]), heading(plan.place_pose[3:])
    assert abs(pick) <= np.pi / 2 + 1e-9
    turn_plan = np.angle(np.exp(1j * (place - pick)))
    demo_turn = heading(m.event_quaternion[1]) - heading(m.event_quaternion[0])
    assert turn_plan == pytest.approx(np.angle(np.exp(1j * demo_turn)), abs=1e-6)
    assert np.angle(np.exp(1j * (pick - heading(m.event_quaternion[0]) - np.pi))) == (
        pytest.approx(0.0, abs=1e-6)
    )


def test_a_retreat_the_person_made_standing_still_is_not_stretched() -> None:
    """The hand rests after the release (as in real videos that run on): the retreat to
    the ready pose still moves at a trackable pace, not at the person's near-zero speed."""
    out = []
    for d in pick_place_demonstrations(6, np.random.default_rng(0)):
        k = int(np.flatnonzero(d.grasp)[-1]) + 8  # a few samples after the release
        pos = d.position.copy()
        pos[k:] = pos[k]
        out.append(dataclasses.replace(d, position=pos, keypoints=d.keypoints.copy()))
    m = _learn(out)
    plan = plan_from_model(m, PlanConfig(rate_hz=RATE))
    retreat = [s.to_json() for s in plan.time_scaling.slowdowns if s.part == "retreat"]
    assert all(s["factor"] < 10.0 for s in retreat), retreat
    after = plan.t > plan.place.t + 1.0
    speed = np.linalg.norm(plan.velocity[after], axis=1).max()
    assert 0.05 < speed <= 0.25 * 1.02


def test_top_down_over_many_headings_is_the_one_at_a_time_orientation() -> None:
    """An array of headings gives, row by row, what one heading at a time gives (the
    turn of a top-down part is built in one go), each pointing straight down."""
    yaws = np.concatenate([np.linspace(-7.0, 7.0, 401), [0.0, np.pi, -np.pi, np.pi / 2]])
    many = top_down(yaws)
    assert many.shape == (yaws.shape[0], 4)
    one = np.stack([top_down(float(y)) for y in yaws])
    np.testing.assert_array_equal(many, one)
    assert max(_tcp_down_deg(q) for q in many) < 1e-6
    assert np.allclose([heading(q) for q in many], np.angle(np.exp(1j * yaws)), atol=1e-9)


def test_a_top_down_part_turns_its_heading_without_a_sign_jump(six_demo_model) -> None:
    """The reach turns from the ready heading to the pick's: every neighbouring pair of
    quaternions on the same hemisphere, the heading monotone between its ends."""
    plan = plan_from_model(
        six_demo_model, PlanConfig(rate_hz=RATE, feasible=False, pick_yaw=np.radians(-170.0))
    )
    t0, t1 = plan.meta["parts"][0]["t_s"]
    q = plan.quaternion[(plan.t >= t0) & (plan.t <= t1)]
    assert (np.einsum("ij,ij->i", q[1:], q[:-1]) > 0).all()
    yaw = np.unwrap([heading(v) for v in q])
    assert abs(yaw[-1] - yaw[0]) > np.radians(150)
    step = np.diff(yaw)
    assert (step >= -1e-9).all() or (step <= 1e-9).all()
