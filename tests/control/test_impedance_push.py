"""Cartesian impedance with an external-force input (Eq. 5.15): the commanded stiffness.

A constant push on the simulated hand (MuJoCo ``xfrc_applied``) held still deflects
the TCP by ``F / K_d`` when F_ext is fed back (target impedance 5.11 exactly); with
F_ext = 0 the felt stiffness is ``Λ M_d⁻¹ K_d`` instead, so the same test fails.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dexlfd.control import Impedance, Reference, RobotState, make_controller
from dexlfd.errors import InvalidInput
from dexlfd.panda import Q_READY
from dexlfd.robot import MujocoPandaModel, PlantConfig
from dexlfd.robot.sim import PandaSim

K_D = 600.0  # [N/m], the default translational stiffness


def _push(controller, force: np.ndarray, measured: bool = False) -> np.ndarray:
    """TCP displacement [m] from 1 s at rest to 3 s under ``force`` [N] on the hand."""
    model = MujocoPandaModel()  # exact model, no friction: the closed form holds
    with PandaSim(PlantConfig(friction_scale=0.0, contacts=False), Q_READY) as sim:
        mj = sim._mj
        hand = mj.mj_name2id(sim.model, mj.mjtObj.mjOBJ_BODY, "panda_hand")
        p0, R0 = model.tcp_pose(Q_READY)
        z = np.zeros(3)
        ref = Reference(p=p0, v=z, a=z, R=R0, w=z)
        st = sim.state()
        cs = controller.init(RobotState(st.t, st.q, st.dq), model.terms(st.q, st.dq))
        wrench = np.zeros(6)
        p_rest = p0
        for k in range(4000):
            if k == 1000:
                p_rest = model.tcp_pose(sim.state().q)[0]
                sim.data.xfrc_applied[hand, :3] = force
            st = sim.state()
            if k >= 1000:  # the wrench at the TCP of a force at the hand's centre of mass
                p_tcp = model.tcp_pose(st.q)[0]
                wrench = np.concatenate([force, np.cross(sim.data.xipos[hand] - p_tcp, force)])
            robot_state = RobotState(st.t, st.q, st.dq, wrench if measured else None)
            tau, cs = controller.step(cs, robot_state, ref, model.terms(st.q, st.dq))
            sim.step(tau)
        return model.tcp_pose(sim.state().q)[0] - p_rest


@pytest.mark.parametrize("force", [(0.0, 0.0, -10.0), (8.0, -6.0, 0.0)])
def test_estimated_external_force_gives_the_commanded_stiffness(force) -> None:
    F = np.array(force)
    d = _push(make_controller("impedance-fext"), F)
    # 2 s after the step the observer (60 1/s) and the impedance (ζ = 1, 24 rad/s)
    # have settled to ~1e-6 of the deflection; 1e-3 leaves room for the hand's fingers
    np.testing.assert_allclose(d, F / K_D, rtol=1e-3, atol=1e-6)


def test_measured_external_force_gives_the_commanded_stiffness() -> None:
    F = np.array([0.0, 5.0, -5.0])
    d = _push(Impedance(external_force="measured"), F, measured=True)
    np.testing.assert_allclose(d, F / K_D, rtol=1e-3, atol=1e-6)


def test_without_external_force_the_felt_stiffness_is_not_the_commanded_one() -> None:
    F = np.array([0.0, 0.0, -10.0])
    d = _push(make_controller("impedance"), F)
    # felt stiffness Λ M_d⁻¹ K_d: Λ_zz of a few kg makes the arm several times stiffer
    assert abs(d[2]) < 0.5 * abs(F[2]) / K_D


def test_torque_is_eq_5_15_with_f_ext() -> None:
    rng = np.random.default_rng(42)
    model = MujocoPandaModel()
    q = Q_READY + rng.normal(size=7) * 0.05
    dq = rng.normal(size=7) * 0.05
    terms = model.terms(q, dq)
    w = rng.normal(size=6)
    z = np.zeros(3)
    ref = Reference(p=terms.p + 0.01, v=z, a=z, R=terms.R, w=z)
    c = Impedance(external_force="measured", k_null=0.0, d_null=0.0, M_d=2.0, M_dr=0.05)
    st = c.init(RobotState(0.0, q, dq), terms)
    tau, _ = c.step(st, RobotState(0.0, q, dq, w), ref, terms)
    tau0, _ = dataclasses.replace(c, external_force="none").step(
        st, RobotState(0.0, q, dq), ref, terms
    )
    J = terms.J
    Lam = np.linalg.inv(J @ np.linalg.solve(terms.M, J.T) + 1e-6 * np.eye(6))
    F_ext = -w  # Eq. (5.12)'s sign
    expected = tau0 + J.T @ F_ext - J.T @ Lam @ (np.repeat([1 / 2.0, 1 / 0.05], 3) * F_ext)
    np.testing.assert_allclose(tau, expected, rtol=1e-9, atol=1e-9)


def test_unknown_external_force_source_is_rejected() -> None:
    with pytest.raises(InvalidInput, match="external_force"):
        Impedance(external_force="sensor")
    assert make_controller("impedance-fext").name == "impedance-fext"


def test_measured_external_force_without_a_wrench_is_refused_not_ignored() -> None:
    """A state without a wrench would silently be F_ext = 0: refused in one line."""
    c = Impedance(external_force="measured")
    model = MujocoPandaModel()
    z7 = np.zeros(7)
    state = RobotState(0.0, Q_READY.copy(), z7)
    terms = model.terms(Q_READY, z7)
    p0, R0 = model.tcp_pose(Q_READY)
    z = np.zeros(3)
    cs = c.init(state, terms)
    with pytest.raises(InvalidInput, match="wrench"):
        c.step(cs, state, Reference(p=p0, v=z, a=z, R=R0, w=z), terms)
