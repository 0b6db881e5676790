from __future__ import annotations

import numpy as np
import pytest

from dexlfd.control import (
    CONTROLLERS,
    CartesianPd,
    DisturbanceObserver,
    NtsmPd,
    NtsmPdI,
    Reference,
    RobotState,
    SmPd,
    make_controller,
    sig,
)
from dexlfd.errors import InvalidInput
from dexlfd.robot.model import ModelTerms


def _terms(p: np.ndarray, M_diag: float = 2.0) -> ModelTerms:
    """A toy 7-joint model: joints 1-3 translate the TCP, 4-6 rotate it, 7 is redundant."""
    J = np.zeros((6, 7))
    J[:, :6] = np.eye(6)
    return ModelTerms(
        M=M_diag * np.eye(7), h=np.zeros(7), g=np.zeros(7), J=J, Jdq=np.zeros(6), p=p,
        R=np.eye(3),
    )  # fmt: skip


def _ref(p: np.ndarray) -> Reference:
    z = np.zeros(3)
    return Reference(p=p, v=z, a=z, R=np.eye(3), w=z)


def test_sig_is_signed_power() -> None:
    np.testing.assert_allclose(sig(np.array([-8.0, 0.0, 8.0]), 1 / 3), [-2.0, 0.0, 2.0])


def test_ntsm_force_matches_eq_5_25_by_hand() -> None:
    c = NtsmPd(k_null=0.0, d_null=0.0)
    e = np.array([0.01, -0.002, 0.0])
    de = np.array([0.05, 0.0, -0.02])
    terms = _terms(p=e)
    state = RobotState(0.0, np.zeros(7), np.concatenate([de, np.zeros(4)]))
    tau, _ = c.step(c.init(state, terms), state, _ref(np.zeros(3)), terms)
    s = e + 0.2 * np.sign(de) * np.abs(de) ** 1.66
    a = -np.sign(de) * np.abs(de) ** (2 - 1.66) / (1.66 * 0.2) - 48 * np.tanh(10 * s)
    F = 2.0 * a - 6.0 * np.tanh(10 * s)  # M̄_p = 2 kg for this toy model
    np.testing.assert_allclose(tau[:3], F, rtol=1e-5)  # 1e-6 regularisation of M̄_p
    np.testing.assert_allclose(tau[6], 0.0, atol=1e-12)


def test_sm_and_ntsm_have_the_same_static_stiffness() -> None:
    e = np.array([0.0, 0.0, -0.005])
    terms = _terms(p=e)
    state = RobotState(0.0, np.zeros(7), np.zeros(7))
    out = []
    for c in (SmPd(k_null=0.0, d_null=0.0), NtsmPd(k_null=0.0, d_null=0.0)):
        out.append(c.step(c.init(state, terms), state, _ref(np.zeros(3)), terms)[0])
    np.testing.assert_allclose(out[0], out[1], atol=1e-12)
    # at rest s = e: F = -(M̄κ + λ) tanh(k_s e)
    np.testing.assert_allclose(out[0][2], (2.0 * 48 + 6) * np.tanh(10 * 0.005), rtol=1e-5)


def test_pd_force_and_moment() -> None:
    c = CartesianPd(k_null=0.0, d_null=0.0)
    terms = _terms(p=np.array([0.0, 0.0, -0.01]))
    state = RobotState(0.0, np.zeros(7), np.zeros(7))
    tau, _ = c.step(c.init(state, terms), state, _ref(np.zeros(3)), terms)
    np.testing.assert_allclose(tau[:3], [0.0, 0.0, 6.0], atol=1e-12)  # K_p e = 600 * 0.01


def test_integral_accumulates_and_is_bounded() -> None:
    c = NtsmPdI(k_null=0.0, d_null=0.0, k_I=1000.0, F_I_max=5.0)
    terms = _terms(p=np.array([0.0, 0.0, -0.01]))
    st = c.init(RobotState(0.0, np.zeros(7), np.zeros(7)), terms)
    taus = []
    for k in range(1, 2000):
        tau, st = c.step(
            st, RobotState(k * 1e-3, np.zeros(7), np.zeros(7)), _ref(np.zeros(3)), terms
        )
        taus.append(tau[2])
    assert taus[1] > taus[0]  # integral pushes up against the sag
    np.testing.assert_allclose(st.z[2] * 1000.0, -5.0, atol=1e-9)  # anti-windup bound


def test_observer_estimates_a_constant_disturbance() -> None:
    """Momentum observer on a simulated double integrator M q̈ = τ + τ_d."""

    class Zero:
        name = "zero"
        needs_joint_reference = False

        def init(self, s, t):
            return None

        def step(self, cs, s, r, t):
            return np.zeros(7), cs

        def describe(self):
            return {"name": "zero"}

    M = np.diag([2.0, 1.5, 1.0, 1.0, 0.5, 0.3, 0.2])
    tau_d = np.array([3.0, -2.0, 1.0, 0.5, -0.5, 0.2, 0.1])
    terms = ModelTerms(M=M, h=np.zeros(7), g=np.zeros(7), J=np.zeros((6, 7)),
                       Jdq=np.zeros(6), p=np.zeros(3), R=np.eye(3))  # fmt: skip
    dob = DisturbanceObserver(Zero(), K_O=50.0)  # type: ignore[arg-type]
    dt, dq = 1e-3, np.zeros(7)
    st = dob.init(RobotState(0.0, np.zeros(7), dq), terms)
    for k in range(1, 400):
        tau, st = dob.step(st, RobotState(k * dt, np.zeros(7), dq), _ref(np.zeros(3)), terms)
        dq = dq + dt * np.linalg.solve(M, tau + tau_d)
    # after 20 time constants the compensation cancels the disturbance
    np.testing.assert_allclose(st.r, tau_d, rtol=1e-3)


@pytest.mark.parametrize("name", sorted(CONTROLLERS))
def test_registry_builds_every_controller(name: str) -> None:
    c = make_controller(name)
    assert c.name == name
    assert c.describe()["name"] == name


def test_bad_gains_and_names_are_rejected() -> None:
    with pytest.raises(InvalidInput, match="choose one of"):
        make_controller("mpc")
    with pytest.raises(InvalidInput, match="K_p"):
        make_controller("pd", K_p=-600.0)
    with pytest.raises(InvalidInput, match="kappa"):
        NtsmPd(kappa=float("nan"))
    with pytest.raises(InvalidInput, match="alpha"):
        NtsmPd(alpha=2.5)
    with pytest.raises(InvalidInput, match="unexpected keyword"):
        make_controller("ntsm-pd", gain=1.0)
