from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dexlfd.control import (
    CartesianPd,
    LoopConfig,
    TrackingStopped,
    make_controller,
    resample_plan,
    track,
)
from dexlfd.errors import InvalidInput, SimulationDiverged
from dexlfd.io import Plan
from dexlfd.plan.moves import lift_plan
from dexlfd.robot import PlantConfig

from .conftest import hold_plan

QUIET = LoopConfig(q_noise=0.0, dq_noise=0.0)


def test_resample_is_exact_for_linear_motion() -> None:
    plan = lift_plan(2.0)
    plan = dataclasses.replace(
        plan, position=np.outer(plan.t, [0.1, 0.2, 0.3]) + [0.4, 0.0, 0.3], meta={}
    )
    ref = resample_plan(plan, 1e-3)
    assert ref.n == 2001
    np.testing.assert_allclose(
        ref.p, np.outer(ref.t, [0.1, 0.2, 0.3]) + [0.4, 0.0, 0.3], atol=1e-12
    )
    np.testing.assert_allclose(np.linalg.norm(ref.quat, axis=1), 1.0, atol=1e-12)


def test_short_lift_is_tracked_and_recorded(exact_model) -> None:
    plan = lift_plan(3.0, z_high=0.35, y_start=-0.1, y_end=0.1)
    ro = track(plan, make_controller("ntsm-pd"), exact_model, PlantConfig(), QUIET,
               rng=np.random.default_rng(0))  # fmt: skip
    assert ro.n_samples == 3001 and ro.stopped is None
    assert ro.controller == "ntsm-pd" == ro.meta["controller"]["name"]
    err = np.linalg.norm(ro.ee_position - ro.ref_position, axis=1)
    assert err.max() < 5e-3
    np.testing.assert_allclose(np.abs(ro.tau) <= [87] * 4 + [12] * 3, True)
    # the rollout's TCP pose is the true one: FK of the recorded joints
    p, _ = exact_model.tcp_pose(ro.q[-1])
    np.testing.assert_allclose(ro.ee_position[-1], p, atol=1e-9)


def test_same_seed_is_bit_identical(exact_model) -> None:
    plan = hold_plan(0.3)
    runs = [
        track(plan, make_controller("ntsm-pd-dob"), exact_model, PlantConfig(payload_kg=0.45),
              LoopConfig(), rng=np.random.default_rng(7))
        for _ in range(2)
    ]  # fmt: skip
    np.testing.assert_array_equal(runs[0].q, runs[1].q)
    np.testing.assert_array_equal(runs[0].tau, runs[1].tau)


def _rise_and_hold(rise: float = 0.1, t_rise: float = 1.0, t_total: float = 2.5) -> Plan:
    t = np.linspace(0.0, t_total, int(t_total / 0.01) + 1)
    u = np.clip(t / t_rise, 0.0, 1.0)
    s = 10 * u**3 - 15 * u**4 + 6 * u**5
    n = t.size
    pos = np.tile([0.45, 0.0, 0.3], (n, 1))
    pos[:, 2] += rise * s
    return Plan(t=t, position=pos, velocity=np.gradient(pos, t, axis=0),
                acceleration=np.zeros((n, 3)), quaternion=np.tile([1.0, 0, 0, 0], (n, 1)),
                angular_velocity=np.zeros((n, 3)), gripper=np.full(n, 0.05),
                grasp=np.ones(n, bool))  # fmt: skip


def test_pd_sag_under_a_lifted_payload_is_weight_over_kp(exact_model) -> None:
    """Closed form: a Cartesian spring K_p holding m kg sags by m g / K_p."""
    plan = _rise_and_hold()
    ro = track(plan, CartesianPd(), exact_model, PlantConfig(payload_kg=1.2, friction_scale=0.0),
               QUIET, rng=np.random.default_rng(0))  # fmt: skip
    assert ro.extras["attached"].all()
    sag = ro.ref_position[-1, 2] - ro.ee_position[-1, 2]
    # settled 1.5 s after the rise (damping ratio ~0.3): within 3 %
    assert sag == pytest.approx(1.2 * 9.81 / 600, rel=0.03)
    # the object left its pedestal with the hand
    assert ro.extras["payload_position"][-1, 2] > ro.extras["payload_position"][0, 2] + 0.07


def test_joint_pd_tracks_with_ik_reference(exact_model) -> None:
    plan = lift_plan(1.0, z_high=0.3, y_start=-0.05, y_end=0.05)
    ro = track(plan, make_controller("joint-pd"), exact_model, PlantConfig(), QUIET,
               rng=np.random.default_rng(0))  # fmt: skip
    assert np.linalg.norm(ro.ee_position - ro.ref_position, axis=1).max() < 0.01


def test_unstable_gains_trigger_the_safety_stop(exact_model) -> None:
    c = CartesianPd(K_p=2e6, D_p=0.0, K_H=3e4, D_H=0.0)
    with pytest.raises(TrackingStopped) as exc:
        track(hold_plan(1.0), c, exact_model, PlantConfig(), LoopConfig(),
              rng=np.random.default_rng(0))  # fmt: skip
    err = exc.value
    assert isinstance(err, SimulationDiverged)
    assert "t=" in str(err) and err.reason
    ro = err.rollout
    assert 1 <= ro.n_samples < 1001
    assert "t=" in ro.stopped
    assert np.isfinite(ro.q).all()


def test_tracking_error_bound_stops(exact_model) -> None:
    loop = LoopConfig(max_position_error=1e-4)
    # an unknown 1.2 kg object under a soft PD sags more than 0.1 mm
    with pytest.raises(TrackingStopped, match="TCP position error"):
        track(lift_plan(2.0), CartesianPd(), exact_model, PlantConfig(payload_kg=1.2), loop,
              rng=np.random.default_rng(0))  # fmt: skip


def test_reference_outside_workspace_is_rejected(exact_model) -> None:
    plan = hold_plan(0.5, p=(1.2, 0.0, 0.4))
    with pytest.raises(InvalidInput, match=r"workspace.*") as exc:
        track(plan, CartesianPd(), exact_model, rng=np.random.default_rng(0))
    assert "t=0.000 s" in str(exc.value)
    with pytest.raises(InvalidInput, match="z must be"):
        track(hold_plan(0.5, p=(0.4, 0.0, -0.1)), CartesianPd(), exact_model,
              rng=np.random.default_rng(0))  # fmt: skip


def test_nan_reference_and_wrong_types_are_rejected(exact_model) -> None:
    plan = hold_plan(0.5)
    pos = plan.position.copy()
    pos[10, 2] = np.nan
    with pytest.raises(InvalidInput, match="position.*NaN"):
        dataclasses.replace(plan, position=pos)
    with pytest.raises(InvalidInput, match="dexlfd.io.Plan"):
        track(object(), CartesianPd(), exact_model, rng=np.random.default_rng(0))  # type: ignore[arg-type]


def test_control_period_must_be_a_multiple_of_the_physics_step(exact_model) -> None:
    with pytest.raises(InvalidInput, match="whole multiple"):
        track(hold_plan(0.2), CartesianPd(), exact_model, PlantConfig(timestep=0.0003),
              rng=np.random.default_rng(0))  # fmt: skip
    with pytest.raises(InvalidInput, match="torque_delay"):
        LoopConfig(torque_delay=-1)


def test_payload_beyond_rated_is_rejected() -> None:
    with pytest.raises(InvalidInput, match="rated payload"):
        PlantConfig(payload_kg=3.2)


def test_plan_shorter_than_a_tick_is_rejected(exact_model) -> None:
    plan = Plan(
        t=np.array([0.0, 0.0005]), position=np.tile([0.45, 0.0, 0.35], (2, 1)),
        velocity=np.zeros((2, 3)), acceleration=np.zeros((2, 3)),
        quaternion=np.tile([1.0, 0, 0, 0], (2, 1)), angular_velocity=np.zeros((2, 3)),
        gripper=np.zeros(2),
    )  # fmt: skip
    with pytest.raises(InvalidInput, match="shorter than one control step"):
        track(plan, CartesianPd(), exact_model, rng=np.random.default_rng(0))


@pytest.mark.parametrize("name", ["joint-pd", "pd", "impedance", "sm-pd", "ntsm-pd", "ntsm-pd-i",
                                  "ntsm-pd-dob", "pd-dob"])  # fmt: skip
def test_every_controller_tracks_a_short_lift(name: str, exact_model) -> None:
    plan = lift_plan(2.0, z_high=0.32, y_start=-0.08, y_end=0.08)
    ro = track(plan, make_controller(name), exact_model, PlantConfig(), LoopConfig(),
               rng=np.random.default_rng(0))  # fmt: skip
    err = np.linalg.norm(ro.ee_position - ro.ref_position, axis=1)
    # PD (5.8) has no acceleration feedforward: it lags by ~Λ a / K_p (~2 cm here)
    bound = 0.025 if name in ("pd", "pd-dob") else 0.005
    assert err.max() < bound, f"{name}: max error {err.max():.4f} m"
    assert np.degrees(ro.extras["orientation_error"].max()) < 3.0


def test_plan_gripper_channel_picks_up_the_object(exact_model) -> None:
    """Approach with open fingers, close at t = 1.2 s (opening < 6 cm), lift 10 cm."""
    t = np.linspace(0.0, 2.6, 261)
    u1 = np.clip(t / 1.0, 0, 1)
    u2 = np.clip((t - 1.4) / 1.0, 0, 1)
    z = (
        0.35
        - 0.1 * (10 * u1**3 - 15 * u1**4 + 6 * u1**5)
        + 0.1 * (10 * u2**3 - 15 * u2**4 + 6 * u2**5)
    )
    n = t.size
    pos = np.stack([np.full(n, 0.45), np.zeros(n), z], 1)
    plan = Plan(t=t, position=pos, velocity=np.gradient(pos, t, axis=0),
                acceleration=np.zeros((n, 3)), quaternion=np.tile([1.0, 0, 0, 0], (n, 1)),
                angular_velocity=np.zeros((n, 3)),
                gripper=np.where(t < 1.2, 0.08, 0.0))  # fmt: skip
    ro = track(plan, make_controller("ntsm-pd"), exact_model, PlantConfig(payload_kg=0.45),
               LoopConfig(), rng=np.random.default_rng(0))  # fmt: skip
    attached = ro.extras["attached"]
    assert not attached[ro.t < 1.19].any() and attached[ro.t > 1.21].all()
    box = ro.extras["payload_position"]
    assert box[-1, 2] - box[0, 2] == pytest.approx(0.1, abs=0.005)  # carried up by friction
    assert ro.gripper[0] == pytest.approx(0.08, abs=1e-3)
    assert ro.gripper[-1] == pytest.approx(0.05, abs=3e-3)  # squeezing the 5 cm box


def test_commanded_torque_rate_is_limited_like_libfranka(exact_model) -> None:
    plan = lift_plan(1.0, z_high=0.3, y_start=-0.05, y_end=0.05)
    ro = track(plan, make_controller("ntsm-pd"), exact_model, PlantConfig(), LoopConfig(),
               rng=np.random.default_rng(0))  # fmt: skip
    assert np.abs(np.diff(ro.tau, axis=0)).max() <= 1.0 + 1e-9  # 1000 N·m/s at 1 kHz
    free = track(plan, make_controller("ntsm-pd"), exact_model, PlantConfig(),
                 LoopConfig(torque_rate_limit=None), rng=np.random.default_rng(0))  # fmt: skip
    assert np.abs(np.diff(free.tau, axis=0)).max() > 1.0  # NTSM's |ė|^(2-α) chatters
    with pytest.raises(InvalidInput, match="torque_rate_limit"):
        LoopConfig(torque_rate_limit=-5.0)


@pytest.mark.parametrize("rate_hz", [1000.0, 100.0])
@pytest.mark.parametrize("plan_hz", [1000, 200, 100])
def test_resample_ends_within_the_plan_for_every_duration(rate_hz, plan_hz) -> None:
    # k * dt rounds one step past the plan's end for most durations (5.1 s at 1 ms:
    # 5.1000000000000005 > 5.1); SciPy's Slerp then refused the last sample
    dt = 1.0 / rate_hz
    durations = np.round(np.arange(0.1, 12.01, 0.1), 10)  # every 0.1 s class up to 12 s
    for T in (*durations, 5.1, 6.1, 7.1, 7.3333, 19.99):
        n = int(round(T * plan_hz)) + 1
        t = np.linspace(0.0, 1.0, n) * T
        z = np.zeros((n, 3))
        plan = Plan(
            t=t, position=z + [0.45, 0.0, 0.35], velocity=z, acceleration=z,
            quaternion=np.tile([1.0, 0, 0, 0], (n, 1)), angular_velocity=z,
            gripper=np.full(n, 0.08),
        )  # fmt: skip
        ref = resample_plan(plan, dt)
        assert ref.t[-1] <= t[-1] and t[-1] - ref.t[-1] < dt
        assert ref.n == int(np.floor(T / dt + 1e-9)) + 1
        assert np.all(np.diff(ref.t) > 0)
