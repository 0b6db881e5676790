"""The joint-space sliding-mode law of Eqs. (5.21)-(5.22), as printed."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dexlfd.control import (
    JointPd,
    JointSlidingMode,
    LoopConfig,
    Reference,
    RobotState,
    make_controller,
    track,
)
from dexlfd.control.sliding_mode_joint import joint_sm_acceleration
from dexlfd.errors import InvalidInput
from dexlfd.panda import TAU_MAX
from dexlfd.plan.moves import lift_plan
from dexlfd.robot import PlantConfig
from dexlfd.robot.robot_model import ModelTerms


def _terms(rng: np.random.Generator) -> ModelTerms:
    A = rng.normal(size=(7, 7))
    return ModelTerms(
        M=A @ A.T + 7 * np.eye(7), h=rng.normal(size=7), g=rng.normal(size=7),
        J=rng.normal(size=(6, 7)), Jdq=np.zeros(6), p=np.zeros(3), R=np.eye(3),
    )  # fmt: skip


def _ref(q: np.ndarray, dq: np.ndarray) -> Reference:
    z = np.zeros(3)
    return Reference(p=z, v=z, a=z, R=np.eye(3), w=z, q=q, dq=dq)


def test_torque_is_eq_5_22_by_hand() -> None:
    rng = np.random.default_rng(42)
    terms = _terms(rng)
    c = JointSlidingMode(c=20.0, p=5.0, epsilon=0.7)
    q, dq = rng.normal(size=7) * 0.1, rng.normal(size=7) * 0.1
    q_d0, q_d = q + 0.01, q + rng.normal(size=7) * 0.01
    dq_d0, dq_d = rng.normal(size=7) * 0.1, rng.normal(size=7) * 0.1
    st = c.init(RobotState(0.0, q, dq), terms)
    _, st = c.step(st, RobotState(0.0, q, dq), _ref(q_d0, dq_d0), terms)
    tau, _ = c.step(st, RobotState(0.002, q, dq), _ref(q_d, dq_d), terms)
    e, de = q_d - q, dq_d - dq
    s = 20.0 * e + de  # Eq. (5.17)
    ddq_d = (dq_d - dq_d0) / 0.002
    ddq = 20.0 * de + ddq_d + 0.7 * np.sign(s) + 5.0 * s  # Eq. (5.21)
    expected = np.clip(terms.M @ ddq + terms.h, -TAU_MAX, TAU_MAX)
    np.testing.assert_allclose(tau, expected, rtol=1e-12, atol=1e-12)


def test_reaching_law_holds_on_a_double_integrator() -> None:
    """With the exact model, ṡ = −ε sgn(s) − p s (the reaching law below Eq. 5.18)."""
    e, de, ddq_d = np.array([0.02, -0.01]), np.array([0.1, 0.3]), np.array([1.0, -2.0])
    s, ddq = joint_sm_acceleration(e, de, ddq_d, c=10.0, p=4.0, epsilon=0.5)
    s_dot = 10.0 * de + (ddq_d - ddq)  # d/dt (c e + ė) with ë = q̈_d − q̈
    np.testing.assert_allclose(s_dot, -0.5 * np.sign(s) - 4.0 * s, rtol=1e-12, atol=1e-12)


def test_without_switching_it_is_the_critically_damped_joint_pd() -> None:
    rng = np.random.default_rng(7)
    terms = dataclasses.replace(_terms(rng), h=np.zeros(7), g=np.zeros(7))
    q, dq = rng.normal(size=7) * 0.1, rng.normal(size=7) * 1e-3
    ref = _ref(q + rng.normal(size=7) * 1e-3, np.zeros(7))  # small: no torque saturates
    sm = JointSlidingMode(c=30.0, p=30.0, epsilon=0.0)
    pd = JointPd(omega=30.0, zeta=1.0)
    state = RobotState(0.0, q, dq)
    tau_sm, _ = sm.step(sm.init(state, terms), state, ref, terms)
    tau_pd, _ = pd.step(pd.init(state, terms), state, ref, terms)
    np.testing.assert_allclose(tau_sm, tau_pd, rtol=1e-12, atol=1e-9)


def test_boundary_layer_and_gain_checks() -> None:
    s, ddq = joint_sm_acceleration(np.array([1e-4]), np.zeros(1), np.zeros(1), 1.0, 0.0, 2.0, 0.1)
    np.testing.assert_allclose(ddq, 2.0 * np.tanh(1e-4 / 0.1), rtol=1e-12)
    with pytest.raises(InvalidInput, match="JointSlidingMode.c"):
        JointSlidingMode(c=0.0)
    with pytest.raises(InvalidInput, match="epsilon"):
        make_controller("sm-joint", epsilon=-1.0)
    assert make_controller("sm-joint").needs_joint_reference


def test_tracks_a_lift_in_simulation(exact_model) -> None:
    plan = lift_plan(2.0, z_high=0.32, y_start=-0.08, y_end=0.08)
    ro = track(plan, make_controller("sm-joint"), exact_model, PlantConfig(), LoopConfig(),
               rng=np.random.default_rng(0))  # fmt: skip
    err = np.linalg.norm(ro.ee_position - ro.ref_position, axis=1)
    assert err.max() < 0.005, f"max error {err.max():.4f} m"
    assert not ro.stopped
