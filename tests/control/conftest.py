from __future__ import annotations

import numpy as np
import pytest

from dexlfd.io import Plan


def hold_plan(duration: float = 1.0, p=(0.45, 0.0, 0.35), gripper: float = 0.08) -> Plan:
    n = int(round(duration / 0.01)) + 1
    return Plan(
        t=np.linspace(0, duration, n),
        position=np.tile(p, (n, 1)),
        velocity=np.zeros((n, 3)),
        acceleration=np.zeros((n, 3)),
        quaternion=np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)),
        angular_velocity=np.zeros((n, 3)),
        gripper=np.full(n, gripper),
    )


@pytest.fixture
def exact_model():
    from dexlfd.robot import MujocoPandaModel

    return MujocoPandaModel()
