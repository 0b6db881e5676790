from __future__ import annotations

import numpy as np

from dexlfd.panda import FRICTION_PHI1
from dexlfd.robot import friction_torque


def test_zero_at_rest_and_opposes_motion() -> None:
    np.testing.assert_allclose(friction_torque(np.zeros(7)), 0.0, atol=1e-15)
    v = np.linspace(-2, 2, 401)[:, None] * np.ones(7)
    tf = friction_torque(v)
    assert np.all(np.diff(tf, axis=0) >= 0)  # monotone in velocity
    # the sigmoid spans phi1 between large negative and positive velocities
    np.testing.assert_allclose(tf[-1] - tf[0], FRICTION_PHI1, rtol=1e-3)


def test_scale_and_viscous() -> None:
    dq = np.full(7, 0.7)
    np.testing.assert_allclose(friction_torque(dq, 0.0, 2.0), 1.4, atol=1e-15)
    np.testing.assert_allclose(friction_torque(dq, 2.0), 2.0 * friction_torque(dq), atol=1e-15)
