"""A grasp is reported as carried only when the object is really in the hand."""

from __future__ import annotations

import numpy as np

from dexlfd.control import LoopConfig, Reference, TrackingSession, make_controller, resample_plan
from dexlfd.plan.moves import lift_plan
from dexlfd.robot import PlantConfig, solve_ik

QUIET = LoopConfig(q_noise=0.0, dq_noise=0.0)


def _run(exact_model, offset: np.ndarray) -> tuple[np.ndarray, list]:
    """Close the gripper (the stream's grasp flag, held from t = 0) with the object at
    TCP + offset."""
    plan = lift_plan(0.8, z_high=0.3, y_start=-0.02, y_end=0.02)
    ref = resample_plan(plan, 1e-3)
    q0 = solve_ik(exact_model, ref.p[0], ref.R[0]).q

    def at(t: float):
        k = min(int(round(t * 1e3)), ref.n - 1)
        return (
            Reference(ref.p[k], ref.v[k], ref.a[k], ref.R[k], ref.w[k]),
            ref.gripper[k],
            ref.quat[k],
        )

    with TrackingSession(
        make_controller("ntsm-pd"), exact_model, PlantConfig(payload_kg=0.45), QUIET,
        rng=np.random.default_rng(0), q0=q0, gripper0=0.08,
        payload_at=(ref.p[0] + offset, ref.R[0]),
    ) as s:  # fmt: skip
        s.run_until(ref.t[-1], at, grasp=True)
        ro = s.rollout()
    return ro.extras["attached"], [e.to_json() for e in ro.grasp_events]


def test_object_between_the_fingers_is_carried(exact_model) -> None:
    attached, events = _run(exact_model, np.zeros(3))
    assert events == []
    assert attached[100:].all()


def test_grasp_that_misses_is_reported_not_carried(exact_model) -> None:
    # the object stands 15 cm beside the hand: the fingers close on nothing
    attached, events = _run(exact_model, np.array([0.0, 0.15, 0.0]))
    assert not attached.any()
    assert [e["event"] for e in events] == ["missed"]
    assert events[0]["distance_m"] > 0.1
