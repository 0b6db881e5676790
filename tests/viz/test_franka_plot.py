from __future__ import annotations

from pathlib import Path

import numpy as np

from dexlfd.io import Rollout


def _rollout(sag: float) -> Rollout:
    n = 300
    t = np.arange(n) * 1e-3
    ref = np.zeros((n, 3))
    ref[:, 2] = 0.3 + 0.1 * t
    ee = ref.copy()
    ee[:, 2] -= sag
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    z7 = np.zeros((n, 7))
    return Rollout(t=t, q=z7, dq=z7, tau=z7, ee_position=ee, ee_quaternion=quat,
                   ref_position=ref, ref_quaternion=quat, gripper=np.zeros(n))  # fmt: skip


def test_plot_protocol_vs_mujoco_writes_png(tmp_path: Path) -> None:
    from dexlfd.viz.franka import plot_protocol_vs_mujoco

    runs = {
        (c, m, b): _rollout(0.001 * (1 + m) * (2 if c == "pd" else 1))
        for c in ("pd", "ntsm-pd") for m in (0.0, 1.0) for b in ("protocol", "mujoco")
    }  # fmt: skip
    out = plot_protocol_vs_mujoco(runs, tmp_path / "f.png", title="t")
    assert out.stat().st_size > 1000
