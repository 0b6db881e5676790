from __future__ import annotations

import numpy as np
import pytest

from dexlfd.panda import FLANGE_D, Q_MAX, Q_MIN
from dexlfd.robot import MujocoPandaModel, dh_flange, dh_tcp


@pytest.fixture(scope="module")
def model() -> MujocoPandaModel:
    return MujocoPandaModel()


def test_dh_closed_form_at_zero() -> None:
    # q = 0: the arm stands straight up, offsets a4 - a5 + a7 along x
    T = dh_flange(np.zeros(7))
    np.testing.assert_allclose(T[:3, 3], [0.088, 0.0, 0.333 + 0.316 + 0.384 - FLANGE_D], atol=1e-12)
    np.testing.assert_allclose(T[:3, :3], np.diag([1.0, -1.0, -1.0]), atol=1e-12)


def test_mujoco_model_matches_dh_table(model: MujocoPandaModel, rng: np.random.Generator) -> None:
    for q in rng.uniform(Q_MIN, Q_MAX, (20, 7)):
        p, R = model.flange_pose(q)
        T = dh_flange(q)
        np.testing.assert_allclose(p, T[:3, 3], atol=1e-6)  # Table 3.1 to < 1e-6 m
        np.testing.assert_allclose(R, T[:3, :3], atol=1e-9)
        p, R = model.tcp_pose(q)
        T = dh_tcp(q)
        np.testing.assert_allclose(p, T[:3, 3], atol=1e-6)
        np.testing.assert_allclose(R, T[:3, :3], atol=1e-9)


def test_dh_batch_equals_loop(rng: np.random.Generator) -> None:
    qs = rng.uniform(Q_MIN, Q_MAX, (5, 7))
    batch = dh_tcp(qs)
    for i, q in enumerate(qs):
        np.testing.assert_allclose(batch[i], dh_tcp(q), atol=1e-15)
