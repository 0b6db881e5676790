"""The payload study's figure draws any rollout the study accepts."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dexlfd.experiments.payload import PayloadConfig, PayloadResult
from dexlfd.io import Rollout
from dexlfd.viz.control import plot_payload_lift


def _flat_rollout(n: int = 50) -> Rollout:
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    p = np.tile([0.5, 0.0, 0.2], (n, 1))  # never rises: no metrics window
    return Rollout(t=np.arange(n) * 1e-2, q=np.zeros((n, 7)), dq=np.zeros((n, 7)),
                   tau=np.zeros((n, 7)), ee_position=p, ee_quaternion=quat,
                   ref_position=p, ref_quaternion=quat, gripper=np.full(n, 0.04))  # fmt: skip


def test_a_plan_that_never_rises_by_the_clearance_still_plots(tmp_path: Path) -> None:
    cfg = PayloadConfig(controllers=("pd",), payloads=(0.0, 1.2))
    ro = _flat_rollout()
    result = PayloadResult(rows=[], rollouts={("pd", 0.0): ro, ("pd", 1.2): ro}, config=cfg)
    out = plot_payload_lift(result, tmp_path / "lift.png")
    assert out.is_file() and out.stat().st_size > 1000
