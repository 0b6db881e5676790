from __future__ import annotations

import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.panda import Q_MAX, Q_MIN, Q_READY
from dexlfd.panda_ik import rotation_error
from dexlfd.robot import MujocoPandaModel, perturbed_model


@pytest.fixture(scope="module")
def model() -> MujocoPandaModel:
    return MujocoPandaModel()


def _random_q(rng: np.random.Generator, n: int) -> np.ndarray:
    return rng.uniform(Q_MIN + 0.1, Q_MAX - 0.1, (n, 7))


def test_identified_inertials_are_loaded(model: MujocoPandaModel) -> None:
    m = model.model
    total = float(m.body_mass.sum())
    # franka_ros: links 0..7 + hand 0.73 kg + two fingers 0.015 kg
    assert total == pytest.approx(
        0.629769
        + 4.970684
        + 0.646926
        + 3.228604
        + 3.587895
        + 1.225946
        + 1.666555
        + 0.735522
        + 0.73
        + 0.03,
        abs=1e-6,
    )


def test_mass_matrix_symmetric_positive_definite(
    model: MujocoPandaModel, rng: np.random.Generator
) -> None:
    for q in _random_q(rng, 10):
        M = model.terms(q, np.zeros(7)).M
        np.testing.assert_allclose(M, M.T, atol=1e-12)
        assert np.linalg.eigvalsh(M).min() > 0


def test_jacobian_matches_finite_differences(
    model: MujocoPandaModel, rng: np.random.Generator
) -> None:
    eps = 1e-6
    for q in _random_q(rng, 5):
        J = model.terms(q, np.zeros(7)).J
        p0, R0 = model.tcp_pose(q)
        Jfd = np.zeros((6, 7))
        for i in range(7):
            dq = np.zeros(7)
            dq[i] = eps
            pp, Rp = model.tcp_pose(q + dq)
            pm, Rm = model.tcp_pose(q - dq)
            Jfd[:3, i] = (pp - pm) / (2 * eps)
            Jfd[3:, i] = rotation_error(Rp, Rm) / (2 * eps)
        np.testing.assert_allclose(J, Jfd, atol=1e-7)  # central differences: O(eps^2)


def test_jdot_qdot_matches_finite_differences(
    model: MujocoPandaModel, rng: np.random.Generator
) -> None:
    h = 1e-6
    for q in _random_q(rng, 3):
        dq = rng.normal(0, 0.5, 7)
        Jdq = model.terms(q, dq).Jdq
        Jp = model.terms(q + h * dq, dq).J
        Jm = model.terms(q - h * dq, dq).J
        np.testing.assert_allclose(Jdq, (Jp - Jm) @ dq / (2 * h), atol=1e-6)


def test_gravity_is_bias_at_rest_and_bias_is_quadratic(
    model: MujocoPandaModel, rng: np.random.Generator
) -> None:
    q = _random_q(rng, 1)[0]
    dq = rng.normal(0, 0.5, 7)
    t0 = model.terms(q, np.zeros(7))
    np.testing.assert_allclose(t0.h, t0.g, atol=1e-12)
    # C(q, dq) dq is quadratic in dq: h(2dq) - g = 4 (h(dq) - g)
    c1 = model.terms(q, dq).h - t0.g
    c2 = model.terms(q, 2 * dq).h - t0.g
    np.testing.assert_allclose(c2, 4 * c1, atol=1e-10)


def test_gravity_torque_equals_potential_gradient(model: MujocoPandaModel) -> None:
    # G(q) = dV/dq with V = sum m_i g z_i
    m, d = model.model, model.data
    import mujoco

    def potential(q: np.ndarray) -> float:
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        return float(9.81 * np.sum(m.body_mass * d.xipos[:, 2]))

    q = Q_READY + 0.2
    g = model.terms(q, np.zeros(7)).g
    eps = 1e-6
    grad = [
        (potential(q + eps * np.eye(7)[i]) - potential(q - eps * np.eye(7)[i])) / (2 * eps)
        for i in range(7)
    ]
    np.testing.assert_allclose(g, grad, atol=1e-6)


def test_perturbed_model_scales_masses(rng: np.random.Generator) -> None:
    nominal = MujocoPandaModel()
    pert = perturbed_model(0.1, rng)
    ratio = (
        pert.model.body_mass[nominal.moving_bodies] / nominal.model.body_mass[nominal.moving_bodies]
    )
    assert np.all(np.abs(ratio - 1) <= 0.1 + 1e-12)
    assert np.any(np.abs(ratio - 1) > 1e-3)
    with pytest.raises(InvalidInput, match="model error"):
        perturbed_model(-0.1, rng)
    with pytest.raises(InvalidInput, match="mass_scale"):
        MujocoPandaModel(np.ones(3))


def test_pinocchio_cross_check() -> None:
    """M, C·q̇+G, G, TCP pose, J and J̇q̇ against Pinocchio on the same URDF."""
    pin = pytest.importorskip(
        "pinocchio",
        reason="pin (Pinocchio) is not installed; with it M, bias, J, J̇q̇ agree to ~1e-5 "
        "(the oracle of this test)",
    )
    from dexlfd.panda import Q_MAX, Q_MIN, TCP_OFFSET
    from dexlfd.robot.description import panda_urdf_text

    pm = pin.buildModelFromXML(panda_urdf_text(fixed_fingers=True))
    assert pm.nq == 7
    hand = pm.frames[pm.getFrameId("panda_hand")]
    tcp = pm.addFrame(
        pin.Frame("tcp", hand.parentJoint, pm.getFrameId("panda_hand"),
                  hand.placement * pin.SE3(np.eye(3), np.array([0.0, 0.0, TCP_OFFSET])),
                  pin.FrameType.OP_FRAME)
    )  # fmt: skip
    pd = pm.createData()
    ours = MujocoPandaModel()
    rng = np.random.default_rng(42)
    world = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    for _ in range(5):
        q = rng.uniform(np.asarray(Q_MIN) + 0.1, np.asarray(Q_MAX) - 0.1)
        dq = rng.normal(0.0, 1.0, 7)
        terms = ours.terms(q, dq)
        M = pin.crba(pm, pd, q)
        M = np.triu(M) + np.triu(M, 1).T
        np.testing.assert_allclose(terms.M, M, atol=1e-9)
        np.testing.assert_allclose(terms.h, pin.nonLinearEffects(pm, pd, q, dq), atol=1e-9)
        np.testing.assert_allclose(terms.g, pin.computeGeneralizedGravity(pm, pd, q), atol=1e-9)
        pin.forwardKinematics(pm, pd, q, dq, np.zeros(7))
        pin.updateFramePlacements(pm, pd)
        np.testing.assert_allclose(terms.p, pd.oMf[tcp].translation, atol=1e-9)
        np.testing.assert_allclose(terms.R, pd.oMf[tcp].rotation, atol=1e-9)
        J = pin.computeFrameJacobian(pm, pd, q, tcp, world)
        np.testing.assert_allclose(terms.J, J, atol=1e-9)
        pin.forwardKinematics(pm, pd, q, dq, np.zeros(7))
        acc = pin.getFrameClassicalAcceleration(pm, pd, tcp, world)
        np.testing.assert_allclose(terms.Jdq, np.concatenate([acc.linear, acc.angular]), atol=1e-9)
