"""The tick kernels compiled ahead (``warm_kernels``) are the ones a simulation calls."""

from __future__ import annotations

import numpy as np

from dexlfd.control import LoopConfig, make_controller, track
from dexlfd.control.tick_kernels import kernel_signatures, warm_kernels
from dexlfd.plan.moves import lift_plan
from dexlfd.robot import PlantConfig


def _compiled() -> dict[str, int]:
    return {k.__name__: len(k.signatures) for k, _ in kernel_signatures()}  # type: ignore[attr-defined]


def test_a_simulation_after_the_warm_up_compiles_no_new_kernel(exact_model) -> None:
    assert warm_kernels() == len(kernel_signatures())
    warmed = _compiled()
    assert all(n >= 1 for n in warmed.values()), warmed
    plan = lift_plan(1.0, z_high=0.3, y_start=-0.05, y_end=0.05)
    for name in ("ntsm-pd", "ntsm-pd-i", "sm-pd-matrix"):
        rollout = track(plan, make_controller(name), exact_model, PlantConfig(payload_kg=0.5),
                        LoopConfig(), rng=np.random.default_rng(0))  # fmt: skip
        assert rollout.stopped is None
    assert _compiled() == warmed  # every call matched a signature compiled ahead
