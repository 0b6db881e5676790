"""The arm keeps its own posture where the plan says: a planned posture that swings
through the self-motion as the gripper closes must not tilt or shift the hand (the
joints' friction is in no controller's model)."""

from __future__ import annotations

import dataclasses

import numpy as np

from dexlfd.control import LoopConfig, make_controller, track
from dexlfd.control.base import Reference, RobotState
from dexlfd.control.posture_hold import PostureHold, hold_where_planned
from dexlfd.io import Plan
from dexlfd.io.plan_facts import ArmPosture
from dexlfd.panda_ik import solve_ik
from dexlfd.robot import PlantConfig, perturbed_model
from dexlfd.robot.posture_hold import hold_windows
from dexlfd.rotations import matrix_from_quat

QUIET = LoopConfig(q_noise=0.0, dq_noise=0.0)
GRASP_T = 2.0  # [s] the gripper closes


def swinging_posture_plan(exact_model) -> tuple[Plan, np.ndarray]:  # noqa: ANN001
    """The hand still over the pick; the planned posture swings 1 rad along the arm's
    self-motion in the second before the gripper closes (as the inverse kinematics'
    own elbow does near a joint limit). Its grasp schedule, no ``hold_s`` yet."""
    t = np.arange(0.0, 3.0 + 1e-9, 0.01)
    n = t.size
    p, quat = np.array([0.45, -0.1, 0.2]), np.array([1.0, 0.0, 0.0, 0.0])
    q0 = solve_ik(exact_model, p, matrix_from_quat(quat), None).q
    null = np.linalg.svd(exact_model.terms(q0, np.zeros(7)).J)[2][-1]
    u = np.clip(t - 1.0, 0.0, 1.0)
    swing = u * u * (3.0 - 2.0 * u)
    plan = Plan(
        t=t, position=np.tile(p, (n, 1)), velocity=np.zeros((n, 3)),
        acceleration=np.zeros((n, 3)), quaternion=np.tile(quat, (n, 1)),
        angular_velocity=np.zeros((n, 3)), gripper=np.where(t < GRASP_T, 0.08, 0.0),
        joint_posture=q0 + np.outer(swing, null / np.abs(null).max()),
        grasp=t >= GRASP_T,
        arm_posture=ArmPosture(planned=True, margin=0.02, min_clearance=1.0,
                               default_min_clearance=1.0),
    )  # fmt: skip
    return plan, q0


def test_a_swinging_planned_posture_neither_tilts_nor_moves_the_hand_at_the_grasp(
    exact_model,  # noqa: ANN001
) -> None:
    plan, q0 = swinging_posture_plan(exact_model)
    # what the arm posture step says for it: hold within 6 cm of the grasp, i.e. all along
    hold = hold_windows(plan.t, plan.position, plan.grasp)
    assert hold == ((0.0, 3.0),)
    plan = dataclasses.replace(plan, arm_posture=dataclasses.replace(plan.arm_posture, hold_s=hold))
    model = perturbed_model(0.1, np.random.default_rng([0, 1]))  # 10 % mass error
    ro = track(plan, make_controller("ntsm-pd"), model, PlantConfig(), QUIET,
               rng=np.random.default_rng(0))  # fmt: skip
    k = int(np.searchsorted(ro.t, GRASP_T))
    E = matrix_from_quat(ro.ref_quaternion[k]).T @ matrix_from_quat(ro.ee_quaternion[k])
    tilt_deg = np.degrees(np.arccos(np.clip((np.trace(E) - 1.0) / 2.0, -1.0, 1.0)))
    # following the swing dragged joints 1 and 3 by 1 rad against their friction and
    # turned the hand 1.75 deg off its reference (1.3 mm); held: 0.4 deg, 0.8 mm
    assert tilt_deg < 0.75
    assert np.linalg.norm(ro.ee_position[k] - ro.ref_position[k]) < 1.2e-3
    assert np.abs(ro.q[k, :7] - q0).max() < 0.05  # no self-motion was commanded


class _Spy:
    """A law that records the null-space reference it is handed."""

    name = "spy"
    needs_joint_reference = False

    def __init__(self) -> None:
        self.seen: list[np.ndarray | None] = []

    def init(self, robot_state, terms):  # noqa: ANN001, ANN201
        return None

    def step(self, ctrl_state, robot_state, reference, terms):  # noqa: ANN001, ANN201
        self.seen.append(None if reference.q_null is None else reference.q_null.copy())
        return np.zeros(7), ctrl_state

    def describe(self) -> dict:
        return {"name": self.name}


def test_the_held_posture_is_the_arms_own_and_blends_back_to_the_plans() -> None:
    spy = _Spy()
    hold = PostureHold(spy, ((1.0, 2.0),), blend_s=1.0)
    assert hold.name == "spy" and hold.describe()["posture_hold_s"] == [[1.0, 2.0]]
    q_arm, q_plan = np.full(7, 0.3), np.zeros(7)
    st = hold.init(RobotState(0.0, q_arm, np.zeros(7)), None)
    for t in (0.5, 1.0, 1.5, 2.1, 2.6, 3.5):
        ref = Reference(np.zeros(3), np.zeros(3), np.zeros(3), np.eye(3), np.zeros(3),
                        q_null=q_plan, dq_null=np.ones(7))  # fmt: skip
        q = q_arm + 0.1 * (t - 1.0)  # the arm moves on; the held posture does not
        _, st = hold.step(st, RobotState(t, q, np.zeros(7)), ref, None)
    before, at1, at15, left, blend, after = spy.seen
    np.testing.assert_array_equal(before, q_plan)  # outside a window: the plan's
    np.testing.assert_array_equal(at1, q_arm)  # entering: the arm's own, held
    np.testing.assert_array_equal(at15, q_arm)
    np.testing.assert_array_equal(left, q_arm)  # leaving: no step in the torque
    np.testing.assert_allclose(blend, 0.15)  # half-way back (a smoothstep), 0.5 s on
    np.testing.assert_array_equal(after, q_plan)


def test_a_piece_of_the_plan_gets_the_spans_shifted_by_its_start(exact_model) -> None:  # noqa: ANN001
    """A piece run on its own clock from 0 (the real arm's, between the gripper's events)."""
    plan, _ = swinging_posture_plan(exact_model)
    posture = dataclasses.replace(plan.arm_posture, hold_s=((0.5, 1.0), (1.8, 2.4)))
    plan = dataclasses.replace(plan, arm_posture=posture)
    spy = _Spy()
    whole = hold_where_planned(spy, plan)
    assert isinstance(whole, PostureHold) and whole.windows == ((0.5, 1.0), (1.8, 2.4))
    k = int(np.searchsorted(plan.t, 2.0))
    piece = hold_where_planned(spy, plan.part(k, plan.t.size - 1))  # the span before: gone
    assert isinstance(piece, PostureHold) and piece.inner is spy
    shift = float(plan.t[k])
    np.testing.assert_allclose(piece.windows, [(0.0, 2.4 - shift)], atol=1e-12)
    k = int(np.searchsorted(plan.t, 2.5))
    assert hold_where_planned(spy, plan.part(k, plan.t.size - 1)) is spy  # no span left
    assert hold_where_planned(spy, dataclasses.replace(plan, joint_posture=None)) is spy
