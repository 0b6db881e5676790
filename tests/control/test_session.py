"""The steppable loop (TrackingSession) behind track()."""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.control import (
    CartesianPd,
    LoopConfig,
    Reference,
    TrackingSession,
    TrackingStopped,
    make_controller,
    resample_plan,
    track,
)
from dexlfd.errors import InvalidInput
from dexlfd.plan.moves import lift_plan
from dexlfd.robot import PlantConfig, solve_ik

from .conftest import hold_plan

QUIET = LoopConfig(q_noise=0.0, dq_noise=0.0)


def test_run_until_with_a_growing_recording_equals_track(exact_model) -> None:
    """Same references tick by tick (tiny capacity: the recording grows) = track()."""
    plan = lift_plan(0.6, z_high=0.3, y_start=-0.05, y_end=0.05)
    ctrl = make_controller("ntsm-pd")
    expected = track(plan, ctrl, exact_model, PlantConfig(), QUIET, rng=np.random.default_rng(0))
    ref = resample_plan(plan, 1e-3)
    q0 = solve_ik(exact_model, ref.p[0], ref.R[0]).q

    def at(t: float):
        k = int(round(t * 1e3))
        return (
            Reference(ref.p[k], ref.v[k], ref.a[k], ref.R[k], ref.w[k]),
            ref.gripper[k],
            ref.quat[k],
        )

    with TrackingSession(ctrl, exact_model, PlantConfig(), QUIET, rng=np.random.default_rng(0),
                         q0=q0, gripper0=float(ref.gripper[0]), payload_at=(ref.p[0], ref.R[0]),
                         capacity=7) as s:  # fmt: skip
        n1 = s.run_until(0.25, at)
        n2 = s.run_until(ref.t[-1] + 0.5e-3, at)
        got = s.rollout()
    assert n1 == 250 and n1 + n2 == ref.n
    for name in ("t", "q", "dq", "tau", "ee_position", "ee_quaternion", "ref_position",
                 "ref_quaternion", "gripper"):  # fmt: skip
        np.testing.assert_array_equal(getattr(got, name), getattr(expected, name), err_msg=name)
    np.testing.assert_array_equal(got.extras["tau_applied"], expected.extras["tau_applied"])


def test_noise_blocks_are_deterministic_and_the_session_finishes_on_a_stop(exact_model) -> None:
    ref = resample_plan(hold_plan(0.3), 1e-3)
    q0 = solve_ik(exact_model, ref.p[0], ref.R[0]).q
    r = Reference(ref.p[0], ref.v[0], ref.a[0], ref.R[0], ref.w[0])
    runs = []
    for _ in range(2):
        with TrackingSession(make_controller("ntsm-pd"), exact_model, rng=np.random.default_rng(1),
                             q0=q0, noise_block=64) as s:  # fmt: skip
            s.run_until(0.2, lambda t: (r, 0.08, None))
            runs.append(s.rollout())
    np.testing.assert_array_equal(runs[0].tau, runs[1].tau)
    assert runs[0].n_samples == 200 and runs[0].stopped is None
    # unstable gains: the stop carries the rollout so far, and the session refuses to go on
    bad = CartesianPd(K_p=2e6, D_p=0.0, K_H=3e4, D_H=0.0)
    with TrackingSession(bad, exact_model, rng=np.random.default_rng(0), q0=q0) as s:
        with pytest.raises(TrackingStopped) as exc:
            s.run_until(1.0, lambda t: (r, 0.08, None))
        assert exc.value.rollout.n_samples == s.k >= 1
        assert "t=" in exc.value.rollout.stopped
        with pytest.raises(InvalidInput, match="stopped"):
            s.step(r, 0.08)
    with pytest.raises(InvalidInput, match="with TrackingSession"):
        TrackingSession(bad, exact_model, rng=np.random.default_rng(0), q0=q0).step(r, 0.08)


def test_regrasp_closes_on_the_object_again_after_a_release(exact_model) -> None:
    ref = resample_plan(hold_plan(0.1), 1e-3)
    q0 = solve_ik(exact_model, ref.p[0], ref.R[0]).q
    r = Reference(ref.p[0], ref.v[0], ref.a[0], ref.R[0], ref.w[0])
    schedule = [0.08] * 20 + [0.0] * 20 + [0.08] * 20 + [0.0] * 20
    attached = {}
    for regrasp in (False, True):
        with TrackingSession(make_controller("ntsm-pd"), exact_model, PlantConfig(payload_kg=0.3),
                             QUIET, rng=np.random.default_rng(0), q0=q0, gripper0=0.08,
                             regrasp=regrasp) as s:  # fmt: skip
            for g in schedule:
                s.step(r, g, None, g < 0.04)  # the stream's grasp flag
            attached[regrasp] = s.rollout().extras["attached"]
    for regrasp, a in attached.items():
        assert not a[:20].any() and a[20:40].all() and not a[40:60].any()
        assert a[60:].all() == regrasp and a[60:].any() == regrasp
