from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from dexlfd.rotations import (
    matrix_from_quat,
    quat_angle,
    quat_conjugate,
    quat_exp,
    quat_from_matrix,
    quat_log,
    quat_multiply,
    quat_sign_continuous,
    rotation_angle,
)


def test_against_scipy(rng: np.random.Generator) -> None:
    a = Rotation.random(50, random_state=1)
    b = Rotation.random(50, random_state=2)
    qa, qb = a.as_quat(), b.as_quat()
    prod = quat_multiply(qa, qb)
    expected = (a * b).as_quat()
    np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", prod, expected)), 1.0, atol=1e-12)
    np.testing.assert_allclose(matrix_from_quat(qa), a.as_matrix(), atol=1e-12)
    back = quat_from_matrix(a.as_matrix())
    np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", back, qa)), 1.0, atol=1e-12)
    # log is half the rotation vector
    r = quat_log(np.where(qa[:, 3:] < 0, -qa, qa))
    np.testing.assert_allclose(2 * r, a.as_rotvec(), atol=1e-10)
    np.testing.assert_allclose(quat_exp(quat_log(qa)), qa, atol=1e-12)
    ident = quat_multiply(qa, quat_conjugate(qa))
    np.testing.assert_allclose(ident, np.tile([0, 0, 0, 1.0], (50, 1)), atol=1e-12)


def test_sign_continuity_with_gaps(rng: np.random.Generator) -> None:
    t = np.linspace(0, 3, 60)
    q = Rotation.from_rotvec(np.outer(t, [0.3, 0.5, 2.0])).as_quat()
    flipped = q * rng.choice([-1.0, 1.0], size=(60, 1))
    flipped[10:13] = np.nan
    out = quat_sign_continuous(flipped)
    ok = np.isfinite(out).all(axis=1)
    dots = np.einsum("ij,ij->i", out[ok][1:], out[ok][:-1])
    assert (dots > 0).all()
    assert np.isnan(out[10:13]).all()
    assert np.isnan(flipped[10:13]).all()  # input untouched


def test_rotation_angles_against_scipy(rng: np.random.Generator) -> None:
    a = Rotation.random(50, random_state=3)
    b = Rotation.random(50, random_state=4)
    expected = (a * b.inv()).magnitude()
    np.testing.assert_allclose(rotation_angle(a.as_matrix(), b.as_matrix()), expected, atol=1e-6)
    np.testing.assert_allclose(quat_angle(a.as_quat(), b.as_quat()), expected, atol=1e-6)
    # q and -q are one rotation; a rotation has no angle to itself (no NaN from round-off)
    np.testing.assert_allclose(quat_angle(a.as_quat(), -a.as_quat()), 0.0, atol=1e-6)
    assert np.isfinite(rotation_angle(a.as_matrix(), a.as_matrix())).all()
