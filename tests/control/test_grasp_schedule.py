"""The loop grasps on the plan's own schedule, not on an absolute width (review item 3).

The plan's gripper never opens beyond 0.058 m (below the stream rule's 0.06 m) but
clearly closes (0.03 m) at A, carries to B and opens there before retreating.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dexlfd.control import LoopConfig, TrackingSession, make_controller, resample_plan, track
from dexlfd.control.grasp import carry_failure, plan_grasp_schedule
from dexlfd.control.loop import _grasp_schedule
from dexlfd.io import Plan, Rollout
from dexlfd.io.plan_facts import GraspSchedule
from dexlfd.plan.moves import GRIPPER_DOWN_XYZW
from dexlfd.robot import PlantConfig, solve_ik
from dexlfd.trajectory import minimum_jerk

QUIET = LoopConfig(q_noise=0.0, dq_noise=0.0)
A, B = np.array([0.45, -0.12, 0.2]), np.array([0.45, 0.12, 0.2])
RETREAT = B + np.array([-0.1, 0.0, 0.1])
DT = 0.01


def _segment(p0: np.ndarray, p1: np.ndarray, T: float) -> tuple[np.ndarray, ...]:
    t = np.arange(0.0, T, DT)
    s, ds, dds = minimum_jerk(t / T)
    d = p1 - p0
    return p0 + s[:, None] * d, (ds / T)[:, None] * d, (dds / T**2)[:, None] * d


def carry_plan(open_w: float = 0.058, closed_w: float = 0.03) -> Plan:
    """Hold at A (close), move to B, hold (open), retreat back and up."""
    segs = [_segment(A, A, 1.0), _segment(A, B, 3.0), _segment(B, B, 1.0)]
    segs.append(_segment(B, RETREAT, 1.5))
    p, v, a = (np.concatenate([s[i] for s in segs]) for i in range(3))
    n = p.shape[0]
    t = np.arange(n) * DT
    g = np.interp(t, [0.0, 0.4, 0.8, 4.2, 4.6, t[-1]], [open_w, open_w, closed_w, closed_w,
                                                          open_w, open_w])  # fmt: skip
    return Plan(
        t=t, position=p, velocity=v, acceleration=a,
        quaternion=np.tile(GRIPPER_DOWN_XYZW, (n, 1)), angular_velocity=np.zeros((n, 3)),
        gripper=g,
    )  # fmt: skip


def test_schedule_is_read_from_the_plans_own_levels() -> None:
    plan = carry_plan()
    assert plan.gripper.max() < 0.06  # an absolute width would call it closed throughout
    closed, info = plan_grasp_schedule(plan)
    ((t0, t1),) = info.intervals_s
    # closes 1/3 of the way down (0.0393 m at t = 0.67 s), opens at half way (0.044 m, 4.4 s)
    assert t0 == pytest.approx(0.4 + 0.4 * (2 / 3), abs=0.02)
    assert t1 == pytest.approx(4.4, abs=0.02)
    assert info.source == "gripper levels"
    # a plan that carries its schedule is taken at its word
    given = np.zeros(plan.t.shape, bool)
    given[100:200] = True
    plan2 = dataclasses.replace(plan, grasp=given)
    closed2, info2 = plan_grasp_schedule(plan2)
    assert info2.source == "plan" and (closed2 == given).all()


def test_object_is_carried_to_where_the_plan_releases_it(exact_model) -> None:
    plan = carry_plan()
    ro = track(plan, make_controller("ntsm-pd"), exact_model, PlantConfig(payload_kg=0.45),
               QUIET, rng=np.random.default_rng(0))  # fmt: skip
    sched = ro.grasp_schedule
    assert sched.release_position == pytest.approx(B.tolist(), abs=1e-6)
    held = ro.t[ro.extras["attached"]]
    assert held[0] == pytest.approx(sched.grasp_t, abs=0.05)  # not from t = 0
    assert held[-1] == pytest.approx(sched.release_t, abs=0.05)
    final = np.asarray(ro.object_report.final_position)
    assert np.hypot(*(final - B)[:2]) < 0.02  # under the release point, not in the hand
    assert final[2] < 0.05  # on the floor (half height 0.03), not carried up on the retreat
    assert ro.grasp_events == ()
    assert carry_failure(ro) is None


def test_absolute_width_rule_carries_it_away_and_is_reported(exact_model) -> None:
    # the old rule (opening below 0.06 m: held from t = 0, never released) on this plan
    plan = carry_plan()
    ref = resample_plan(plan, 1e-3)
    old_rule = ref.gripper < 0.06
    schedule = GraspSchedule(intervals_s=((0.0, float(ref.t[-1])),), release_t=4.4,
                             release_position=tuple(B.tolist()))  # fmt: skip
    q0 = solve_ik(exact_model, ref.p[0], ref.R[0]).q
    with TrackingSession(
        make_controller("ntsm-pd"), exact_model, PlantConfig(payload_kg=0.45), QUIET,
        rng=np.random.default_rng(0), q0=q0, gripper0=float(ref.gripper[0]),
        payload_at=(ref.p[0], ref.R[0]), facts={"grasp_schedule": schedule},
    ) as s:  # fmt: skip
        for k in range(ref.n):
            s.step(ref.reference(k), float(ref.gripper[k]), ref.quat[k], bool(old_rule[k]))
        ro = s.rollout()
    assert ro.extras["attached"][:10].all()  # "held" from t = 0
    final = np.asarray(ro.object_report.final_position)
    assert np.linalg.norm(final - RETREAT) < 0.03  # still in the hand at the end
    msg = carry_failure(ro)
    assert msg is not None and "from where the plan releases it at t=4.40 s" in msg


def test_a_plan_that_never_closes_is_reported(exact_model) -> None:
    plan = carry_plan(open_w=0.08, closed_w=0.08)
    ro = track(plan, make_controller("ntsm-pd"), exact_model, PlantConfig(payload_kg=0.45),
               QUIET, rng=np.random.default_rng(0))  # fmt: skip
    assert not ro.extras["attached"].any()
    assert carry_failure(ro) == "the plan never closes the gripper"


def _with_gripper(plan: Plan, g: np.ndarray) -> Plan:
    return Plan(**{**{k: getattr(plan, k) for k in Plan.SPECS}, "gripper": g.copy()})


def test_short_end_grasps_are_dropped_and_the_longest_run_is_carried() -> None:
    # review 2: a relaxed hand closed at the plan's start is not the grasp
    plan = carry_plan()
    g = plan.gripper.copy()
    g[plan.t < 0.1] = 0.03  # 0.1 s closed at the start (< min_duration_s 0.15 s)
    g[plan.t > plan.t[-1] - 0.1] = 0.03  # and at the end
    _, info = plan_grasp_schedule(_with_gripper(plan, g))
    ((t0, t1),) = info.intervals_s
    assert t0 == pytest.approx(0.67, abs=0.02) and t1 == pytest.approx(4.4, abs=0.02)
    # a longer closed run at the start is kept, but the main (longest) run is carried
    g[plan.t < 0.1] = 0.058
    g[plan.t < 0.3] = 0.03
    g[plan.t > plan.t[-1] - 0.1] = 0.058
    plan2 = _with_gripper(plan, g)
    ref = resample_plan(plan2, 1e-3)
    closed, carried, sched = _grasp_schedule(plan2, ref, QUIET)
    assert len(sched.intervals_s) == 2 and closed[0] and not carried[0]
    assert sched.grasp_t == pytest.approx(0.67, abs=0.02)
    assert sched.release_t == pytest.approx(4.4, abs=0.02)
    assert sched.grasp_position == pytest.approx(A.tolist(), abs=1e-6)
    assert sched.release_position == pytest.approx(B.tolist(), abs=1e-6)
    assert (ref.t[carried] >= sched.grasp_t).all()


def test_an_object_grabbed_at_the_start_and_dropped_at_once_was_not_carried(
    exact_model,
) -> None:
    _, _, schedule = _grasp_schedule(carry_plan(), resample_plan(carry_plan(), 1e-3), QUIET)
    # the plan carries it A -> B; the arm lifts off A, so the open fingers leave it there
    up = np.array([0.0, 0.0, 0.12])
    segs = [_segment(A, A, 0.5), _segment(A, A + up, 1.0), _segment(A + up, B + up, 2.0)]
    p, v, a = (np.concatenate([s[i] for s in segs]) for i in range(3))
    n = p.shape[0]
    plan = Plan(
        t=np.arange(n) * DT, position=p, velocity=v, acceleration=a,
        quaternion=np.tile(GRIPPER_DOWN_XYZW, (n, 1)), angular_velocity=np.zeros((n, 3)),
        gripper=np.full(n, 0.08),
    )  # fmt: skip
    ref = resample_plan(plan, 1e-3)
    q0 = solve_ik(exact_model, ref.p[0], ref.R[0]).q
    with TrackingSession(
        make_controller("ntsm-pd"), exact_model, PlantConfig(payload_kg=0.45), QUIET,
        rng=np.random.default_rng(0), q0=q0, gripper0=0.03,
        payload_at=(ref.p[0], ref.R[0]), facts={"grasp_schedule": schedule},
    ) as s:  # fmt: skip
        for k in range(ref.n):
            held = ref.t[k] < 0.2  # grabbed at t = 0, let go at once
            s.step(ref.reference(k), 0.03 if held else 0.08, ref.quat[k], bool(held))
        ro = s.rollout()
    assert ro.extras["attached"][:10].all() and not ro.extras["attached"][-1]
    final = np.asarray(ro.object_report.final_position)
    assert np.hypot(*(final - A)[:2]) < 0.05  # it stayed where it was picked
    msg = carry_failure(ro)
    assert msg is not None and msg.startswith("it was not carried"), msg

    # with the release point where it lies, only the carried-distance rule catches it
    def released_at(where: tuple[float, float, float] | None) -> Rollout:
        return dataclasses.replace(
            ro, grasp_schedule=dataclasses.replace(schedule, release_position=where)
        )

    msg = carry_failure(released_at((A[0] + 0.09, A[1], A[2])), tolerance=0.2)
    assert msg is None  # 0.09 m is within the tolerance: no carry is asked for
    # 0.24 m travel > 0.2: must have moved >= 0.12
    msg = carry_failure(released_at(tuple(B.tolist())), tolerance=0.2)
    assert msg is not None and msg.startswith("it was not carried"), msg
    # a rollout that does not say where the object ended, or where it was to be let go,
    # is no success: the reason says what is missing
    assert carry_failure(released_at(None)) == (
        "object position not recorded (the rollout's schedule has no release position)"
    )
    msg = carry_failure(dataclasses.replace(released_at(tuple(B.tolist())), object_report=None))
    assert msg is not None and msg.startswith("object position not recorded"), msg
