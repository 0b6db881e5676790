"""The parts both 1 kHz loops are built from: safety stop, rate limit, delay, recording."""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.control import LoopConfig, Reference, TrackingStopped, make_controller
from dexlfd.control.arm_loop import ArmLoop
from dexlfd.control.recording import Recording
from dexlfd.control.safety import SafetyStop
from dexlfd.errors import InvalidInput
from dexlfd.panda import DQ_MAX, Q_MAX, Q_READY, TAU_MAX
from dexlfd.robot import MujocoPandaModel
from dexlfd.robot.actuation import TorqueDelay, rate_limit
from dexlfd.robot.arm import Arm, ArmState, run_lockstep
from dexlfd.rotations import matrix_from_quat


def _ref(p: np.ndarray, R: np.ndarray) -> Reference:
    return Reference(p, np.zeros(3), np.zeros(3), R, np.zeros(3))


def test_safety_stop_reasons_in_order() -> None:
    loop = LoopConfig()
    stop = SafetyStop(loop)
    p, R = np.array([0.4, 0.0, 0.4]), np.eye(3)
    dq0 = np.zeros(7)
    assert stop.check(Q_READY, dq0, p, R, _ref(p, R)) == (None, 0.0)
    q_bad = Q_READY.copy()
    q_bad[3] = Q_MAX[3] + 2 * loop.joint_limit_margin
    reason, _ = stop.check(q_bad, dq0, p + 1.0, R, _ref(p, R))
    assert reason is not None and reason.startswith("joint 4 position")  # joints first
    q_in = Q_READY.copy()
    q_in[3] = Q_MAX[3] + 0.5 * loop.joint_limit_margin  # inside the margin
    assert stop.check(q_in, dq0, p, R, _ref(p, R))[0] is None
    dq = dq0.copy()
    dq[6] = -1.01 * DQ_MAX[6]
    assert "joint 7 velocity" in str(stop.check(Q_READY, dq, p, R, _ref(p, R))[0])
    assert "non-finite" in str(stop.check(Q_READY * np.nan, dq0, p, R, _ref(p, R))[0])
    off = p + np.array([0.0, 0.0, 1.5 * loop.max_position_error])
    assert "TCP position error" in str(stop.check(Q_READY, dq0, off, R, _ref(p, R))[0])
    # a rotation about z by a known angle: the recorded error is that angle
    a = 1.2 * loop.max_orientation_error
    Rz = matrix_from_quat(np.array([0.0, 0.0, np.sin(a / 2), np.cos(a / 2)]))
    reason, err = stop.check(Q_READY, dq0, p, Rz, _ref(p, R))
    assert "TCP orientation error" in str(reason) and err == pytest.approx(a, abs=1e-12)


class _PacedArm:
    """A robot-paced arm standing at the ready pose: it records what the loop acts."""

    period = 1e-3

    def __init__(self, p: np.ndarray, R: np.ndarray) -> None:
        self.p, self.R, self.acted, self.commanded = p, R, [], np.zeros(7)

    def sense(self) -> ArmState:
        t = len(self.acted) * self.period
        z = np.zeros(7)
        return ArmState(t, Q_READY, z, self.p, self.R, Q_READY, z, self.period)

    def act(self, tau, last=False):  # type: ignore[no-untyped-def]
        self.acted.append((None if tau is None else tau.copy(), last))
        self.commanded = np.zeros(7) if tau is None else tau
        return self.commanded

    def run(self, tick, n_ticks):  # type: ignore[no-untyped-def]
        run_lockstep(self, tick, n_ticks)

    def close(self) -> None:
        pass


def test_one_loop_stops_on_the_rule_and_keeps_the_stop_tick_the_arm_acted() -> None:
    """A TCP error past the bound at tick 5: no torque that tick, the run ends, it is kept."""
    loop = LoopConfig()
    model = MujocoPandaModel()
    terms = model.terms(Q_READY, np.zeros(7))
    arm = _PacedArm(terms.p, terms.R)
    follow = ArmLoop(arm, make_controller("pd"), model, loop, capacity=2)
    jump = np.array([0.0, 0.0, 2 * loop.max_position_error])

    def reference_at(k: int, t: float) -> Reference:
        return _ref(terms.p + (jump if k >= 5 else 0.0), terms.R)

    with pytest.raises(TrackingStopped, match="TCP position error") as info:
        follow.run(reference_at, 100)
    assert info.value.time == pytest.approx(5e-3)
    assert [tau is None for tau, _ in arm.acted] == [False] * 5 + [True]
    assert follow.k == 6 and follow.stopped is not None  # the robot got a command: kept
    a = follow.recorded()
    np.testing.assert_allclose(a["t"], np.arange(6) * 1e-3)
    np.testing.assert_allclose(a["ref_position"][5], terms.p + jump)
    # holding still at the reference, the law's torque is the gravity of its model
    np.testing.assert_allclose(a["tau"][:5], np.tile(terms.g, (5, 1)), atol=1e-9)
    with pytest.raises(InvalidInput, match="stopped"):
        follow.step(_ref(terms.p, terms.R), 0.08)


def test_rate_limit_steps_and_saturation() -> None:
    prev = np.array([0.0, 1.0, -1.0, 5.0, 0.0, 11.5, -11.5])
    want = np.array([3.0, 1.2, -4.0, 5.0, -0.5, 20.0, -20.0])
    out = rate_limit(want, prev, 1.0)
    np.testing.assert_array_equal(out, [1.0, 1.2, -2.0, 5.0, -0.5, TAU_MAX[5], -TAU_MAX[6]])
    # ramping to a far target takes ceil(distance / step) ticks, never overshooting
    tau, target, n = np.zeros(7), np.full(7, 3.3), 0
    while not np.array_equal(tau, target):
        tau = rate_limit(target, tau, 1.0)
        n += 1
    assert n == 4


def test_torque_delay_lags_by_whole_ticks() -> None:
    hold = np.full(7, -1.0)
    line = TorqueDelay(2, hold)
    out = [line.push(np.full(7, float(k)))[0] for k in range(5)]
    assert out == [-1.0, -1.0, 0.0, 1.0, 2.0]
    assert TorqueDelay(0, hold).push(np.ones(7))[0] == 1.0


def test_recording_grows_and_keeps_rows() -> None:
    rec = Recording({"t": ((), np.float64), "q": ((7,), np.float64)}, 2)
    for k in range(5):
        rec.ensure(k)
        rec.a["t"][k] = k
        rec.a["q"][k] = k
    first = rec.first(5, copy=True)
    np.testing.assert_array_equal(first["t"], np.arange(5.0))
    np.testing.assert_array_equal(first["q"][:, 3], np.arange(5.0))
    first["t"][0] = 99.0
    assert rec.a["t"][0] == 0.0  # a copy


def test_sim_arm_senses_noisy_acts_late_and_limited() -> None:
    """The simulated arm: noise only on what the law sees, rate limit, whole-tick delay."""
    from dexlfd.robot import PlantConfig
    from dexlfd.robot.sim_arm import SimSensing, plant_arm

    hold = MujocoPandaModel().terms(Q_READY, np.zeros(7)).g
    sensing = SimSensing(1e-3, q_noise=1e-4, dq_noise=0.0, torque_delay=2, torque_rate_limit=1e3)
    arm = plant_arm(PlantConfig(), sensing, Q_READY, hold, rng=np.random.default_rng(0))
    assert isinstance(arm, Arm)
    s0 = arm.sense()
    np.testing.assert_array_equal(s0.q, Q_READY)  # the true state is recorded
    assert 0 < np.abs(s0.q_sensed - Q_READY).max() < 1e-3 and s0.t == 0.0
    np.testing.assert_array_equal(arm.sense().q_sensed, s0.q_sensed)  # same tick, same noise
    applied = [arm.act(hold + 5.0) for _ in range(4)]
    for k in (0, 1):
        np.testing.assert_array_equal(applied[k], hold)  # two ticks late
    np.testing.assert_allclose(applied[2], hold + 1.0)  # 1 N·m per 1 ms tick
    np.testing.assert_allclose(applied[3], hold + 2.0)
    assert arm.sense().t == pytest.approx(4e-3) and arm.sim.t == pytest.approx(4e-3)
    assert arm.act(None) is None and arm.k == 4  # a stop applies nothing
    arm.close()
