from __future__ import annotations

import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.panda import Q_MAX, Q_MIN, Q_READY
from dexlfd.panda_ik import solve_ik_batch
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
    """solve_ik_batch: row i is solve_ik from start i (its own rest), to the same pose;
    a start that cannot reach within the iterations is not converged in both."""
    p, R = model.tcp_pose(np.clip(Q_READY + 0.1, Q_MIN, Q_MAX))
    starts = np.clip(Q_READY + rng.normal(0.0, 0.05, (12, 7)), Q_MIN, Q_MAX)
    starts[0] = Q_MIN  # far: not converged in 8 iterations
    batch = solve_ik_batch(model, p, R, starts, max_iter=8)
    for i, start in enumerate(starts):
        one = solve_ik(model, p, R, start, max_iter=8)
        np.testing.assert_allclose(batch.q[i], one.q, rtol=0.0, atol=1e-12)
        assert batch.converged[i] == one.converged
        assert batch.position_error[i] == pytest.approx(one.position_error, rel=1e-9, abs=1e-15)
        assert batch.rotation_error[i] == pytest.approx(one.rotation_error, rel=1e-9, abs=1e-15)
    assert batch.converged.any() and not batch.converged[0]
    # one target a row: row i is solve_ik to target i
    targets = [model.tcp_pose(q) for q in np.clip(starts + 0.05, Q_MIN, Q_MAX)]
    P, Rs = np.array([x[0] for x in targets]), np.array([x[1] for x in targets])
    rows = solve_ik_batch(model, P, Rs, starts, max_iter=8)
    for i, start in enumerate(starts):
        one = solve_ik(model, P[i], Rs[i], start, max_iter=8)
        np.testing.assert_allclose(rows.q[i], one.q, rtol=0.0, atol=1e-12)
        assert rows.converged[i] == one.converged
    with pytest.raises(InvalidInput, match="q_init"):
        solve_ik_batch(model, p, R, starts[0])
    with pytest.raises(InvalidInput, match="p_d and R_d"):
        solve_ik_batch(model, P[:3], Rs[:3], starts)
