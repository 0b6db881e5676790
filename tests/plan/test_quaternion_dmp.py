from __future__ import annotations

import numpy as np

from dexlfd.datasets import PickPlaceConfig, pick_place_reference
from dexlfd.plan import fit_quaternion_dmp, rollout_quaternion_dmp
from dexlfd.plan.quaternion_dmp import _rotvec_between
from dexlfd.rotations import quat_exp, quat_multiply

T = 8.0


def _demo(n: int = 1000) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, T, n)
    _p, q, _g = pick_place_reference(t / T, PickPlaceConfig())
    return t, q


def test_reproduces_demonstration() -> None:
    t, q = _demo()
    r = rollout_quaternion_dmp(fit_quaternion_dmp(t, q), n_steps=len(t))
    err = np.linalg.norm(_rotvec_between(r.q, q), axis=1)
    # semi-implicit Euler, 4 sub-steps of 2.5e-4: O(h) error on a 0.35 rad swing
    assert err.max() < 2e-3
    np.testing.assert_allclose(np.linalg.norm(r.q, axis=1), 1.0, atol=1e-12)


def test_new_goal_orientation_is_reached() -> None:
    t, q = _demo()
    dmp = fit_quaternion_dmp(t, q)
    rng = np.random.default_rng(42)
    for _ in range(3):
        r_vec = rng.normal(size=3)
        r_vec *= 0.4 / np.linalg.norm(r_vec)  # 0.8 rad away from the demonstrated goal
        g = quat_multiply(quat_exp(r_vec), q[-1])
        q0 = quat_multiply(quat_exp(-r_vec / 2), q[0])
        r = rollout_quaternion_dmp(dmp, q0=q0, g=g, n_steps=4001)
        assert np.linalg.norm(_rotvec_between(r.q[-1], g)) < 5e-3  # [rad], 0.3 deg
        np.testing.assert_allclose(r.q[0], q0, atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(r.q, axis=1), 1.0, atol=1e-12)


def test_angular_velocity_matches_quaternion_derivative() -> None:
    t, q = _demo(500)
    r = rollout_quaternion_dmp(fit_quaternion_dmp(t, q), n_steps=2001)
    dt = r.t[1] - r.t[0]
    w_fd = _rotvec_between(r.q[1:], r.q[:-1]) / dt
    w_mid = 0.5 * (r.omega[1:] + r.omega[:-1])
    np.testing.assert_allclose(w_fd, w_mid, atol=2e-3)  # sub-stepped Euler vs midpoint


def test_same_goal_sign_is_irrelevant() -> None:
    t, q = _demo(300)
    dmp = fit_quaternion_dmp(t, q)
    a = rollout_quaternion_dmp(dmp, g=q[-1], n_steps=501)
    b = rollout_quaternion_dmp(dmp, g=-q[-1], n_steps=501)
    np.testing.assert_allclose(a.q, b.q, atol=1e-12)
