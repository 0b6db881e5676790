from __future__ import annotations

import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.panda import Q_MAX, Q_MIN, Q_READY
from dexlfd.panda_ik import rotation_error, solve_ik_batch
from dexlfd.panda_kinematics import DhPanda, dh_tcp
from dexlfd.robot import MujocoPandaModel, solve_ik


@pytest.fixture(scope="module")
def model() -> MujocoPandaModel:
    return MujocoPandaModel()


def test_fk_then_ik_round_trip(model: MujocoPandaModel, rng: np.random.Generator) -> None:
    for _ in range(5):
        q = np.clip(Q_READY + rng.normal(0, 0.3, 7), Q_MIN + 0.05, Q_MAX - 0.05)
        p, R = model.tcp_pose(q)
        res = solve_ik(model, p, R)
        assert res.converged
        p2, R2 = model.tcp_pose(res.q)
        np.testing.assert_allclose(p2, p, atol=1e-6)
        np.testing.assert_allclose(R2, R, atol=1e-5)
        assert np.all(res.q >= Q_MIN) and np.all(res.q <= Q_MAX)


def test_unreachable_target_does_not_converge(model: MujocoPandaModel) -> None:
    res = solve_ik(model, np.array([1.5, 0.0, 0.5]), np.diag([1.0, -1.0, -1.0]), max_iter=50)
    assert not res.converged
    assert res.position_error > 0.3


def test_nan_target_is_rejected(model: MujocoPandaModel) -> None:
    with pytest.raises(InvalidInput, match="p_d"):
        solve_ik(model, np.array([np.nan, 0.0, 0.5]), np.eye(3))


def test_a_batch_of_starts_solves_as_each_start_alone(
    model: MujocoPandaModel, rng: np.random.Generator
) -> None:
    """solve_ik_batch: row i is solve_ik from start i (its own rest), to the same pose, to
    the last bit (one implementation); a start that cannot reach within the iterations
    is not converged in both."""
    p, R = model.tcp_pose(np.clip(Q_READY + 0.1, Q_MIN, Q_MAX))
    starts = np.clip(Q_READY + rng.normal(0.0, 0.05, (12, 7)), Q_MIN, Q_MAX)
    starts[0] = Q_MIN  # far: not converged in 8 iterations
    batch = solve_ik_batch(model, p, R, starts, max_iter=8)
    for i, start in enumerate(starts):
        one = solve_ik(model, p, R, start, max_iter=8)
        np.testing.assert_array_equal(batch.q[i], one.q)
        assert batch.converged[i] == one.converged
        assert batch.position_error[i] == one.position_error
        assert batch.rotation_error[i] == one.rotation_error
    assert batch.converged.any() and not batch.converged[0]
    # one target a row: row i is solve_ik to target i
    targets = [model.tcp_pose(q) for q in np.clip(starts + 0.05, Q_MIN, Q_MAX)]
    P, Rs = np.array([x[0] for x in targets]), np.array([x[1] for x in targets])
    rows = solve_ik_batch(model, P, Rs, starts, max_iter=8)
    for i, start in enumerate(starts):
        one = solve_ik(model, P[i], Rs[i], start, max_iter=8)
        np.testing.assert_array_equal(rows.q[i], one.q)
        assert rows.converged[i] == one.converged
    with pytest.raises(InvalidInput, match="q_init"):
        solve_ik_batch(model, p, R, starts[0])
    with pytest.raises(InvalidInput, match="p_d and R_d"):
        solve_ik_batch(model, P[:3], Rs[:3], starts)


def test_a_lone_start_solves_as_a_row_of_a_batch_with_either_kinematics(
    model: MujocoPandaModel, rng: np.random.Generator
) -> None:
    """solve_ik (a lone row, its own loop) gives a batch row's joints to the last bit,
    also with Table 3.1's kinematics, whose Jacobian comes in Fortran order (taken as
    it is, it went other BLAS paths: other last bits), and when out of iterations."""
    for kin in (model, DhPanda()):
        starts = np.clip(Q_READY + rng.normal(0.0, 0.3, (6, 7)), Q_MIN, Q_MAX)
        p, R = kin.tcp_pose(np.clip(Q_READY + 0.2, Q_MIN, Q_MAX))
        for max_iter in (3, 50):
            batch = solve_ik_batch(kin, p, R, starts, max_iter=max_iter)
            for i, start in enumerate(starts):
                one = solve_ik(kin, p, R, start, max_iter=max_iter)
                np.testing.assert_array_equal(one.q, batch.q[i])
                assert one.converged == batch.converged[i]
                assert one.position_error == batch.position_error[i]
            assert batch.converged.all() == (max_iter == 50)


def test_table_3_1_round_trip_meets_the_tolerances(rng: np.random.Generator) -> None:
    """IK on Table 3.1's chain (DhPanda) reaches poses of the broadcast chain (dh_tcp)
    within its tolerances; a start already on the pose is kept, after one iteration."""
    dh = DhPanda()
    for _ in range(5):
        q = np.clip(Q_READY + rng.normal(0, 0.3, 7), Q_MIN + 0.05, Q_MAX - 0.05)
        T = dh_tcp(q)
        res = solve_ik(dh, T[:3, 3], T[:3, :3], max_iter=300)
        assert res.converged and res.position_error < 1e-7 and res.rotation_error < 1e-6
        T2 = dh_tcp(res.q)
        assert np.linalg.norm(T2[:3, 3] - T[:3, 3]) < 1e-7
        assert np.linalg.norm(rotation_error(T[:3, :3], T2[:3, :3])) < 1e-6
        again = solve_ik(dh, T[:3, 3], T[:3, :3], res.q)
        assert again.converged and again.n_iter == 1
        np.testing.assert_array_equal(again.q, res.q)


def test_rotation_error_closed_forms() -> None:
    """The rotation vector of turns about known axes: none, 0.3 rad, half a turn."""

    def rz(a: float) -> np.ndarray:
        c, s = np.cos(a), np.sin(a)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    R = np.diag([1.0, -1.0, -1.0])  # the TCP pointing down
    np.testing.assert_array_equal(rotation_error(R, R), np.zeros(3))
    np.testing.assert_allclose(rotation_error(rz(0.3) @ R, R), [0.0, 0.0, 0.3], atol=1e-15)
    np.testing.assert_allclose(rotation_error(R, rz(0.3) @ R), [0.0, 0.0, -0.3], atol=1e-15)
    half = rotation_error(np.eye(3), R)  # R is half a turn about x
    np.testing.assert_allclose(np.abs(half), [np.pi, 0.0, 0.0], atol=1e-12)
