from __future__ import annotations

import numpy as np

from dexlfd.control import nullspace_torque, orientation_error, saturate
from dexlfd.panda import Q_READY, TAU_MAX
from dexlfd.robot import MujocoPandaModel
from dexlfd.rotations import matrix_from_quat, quat_normalize


def _literal_e_H(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Eq. (5.9) as printed: quaternions scalar-last here, (eta, eps) in the thesis."""
    eps1, eta1 = q1[:3], q1[3]
    eps2, eta2 = q2[:3], q2[3]
    S = np.array([[0, -eps1[2], eps1[1]], [eps1[2], 0, -eps1[0]], [-eps1[1], eps1[0], 0]])
    return (eta1 * eta2 + eps1 @ eps2) * (-eta1 * eps2 + eta2 * eps1 - S @ eps2)


def test_orientation_error_equals_eq_5_9(rng: np.random.Generator) -> None:
    for _ in range(20):
        q1, q2 = quat_normalize(rng.normal(size=(2, 4)))
        expected = _literal_e_H(q1, q2)
        got = orientation_error(matrix_from_quat(q1), matrix_from_quat(q2))
        np.testing.assert_allclose(got, expected, atol=1e-12)
        # q and -q are the same rotation: the error does not change
        np.testing.assert_allclose(_literal_e_H(-q1, q2), expected, atol=1e-12)


def test_orientation_error_small_angle_is_half_rotation_vector() -> None:
    th = 1e-4
    R = matrix_from_quat(np.array([0.0, 0.0, np.sin(th / 2), np.cos(th / 2)]))
    np.testing.assert_allclose(orientation_error(R, np.eye(3)), [0, 0, th / 2], atol=1e-12)


def test_nullspace_torque_does_not_move_the_tcp(rng: np.random.Generator) -> None:
    model = MujocoPandaModel()
    q = Q_READY + rng.normal(0, 0.2, 7)
    dq = rng.normal(0, 0.3, 7)
    terms = model.terms(q, dq)
    tau = nullspace_torque(terms, q, dq, Q_READY, 10.0, 6.0)
    assert np.linalg.norm(tau) > 0.1
    # TCP acceleration caused by tau: J M^-1 tau = 0 (dynamically consistent projector)
    acc = terms.J @ np.linalg.solve(terms.M, tau)
    # Λ is regularised by 1e-6 I (singularity guard): residual ~1e-5 of ~1 rad/s² scale
    np.testing.assert_allclose(acc, 0.0, atol=5e-5)
    assert np.linalg.norm(np.linalg.solve(terms.M, tau)) > 1.0


def test_saturate_clips_to_panda_limits() -> None:
    tau = saturate(np.full(7, 1000.0))
    np.testing.assert_allclose(tau, TAU_MAX, atol=0)
    np.testing.assert_allclose(saturate(-tau), -TAU_MAX, atol=0)
