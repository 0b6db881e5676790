"""The planner's kernels compiled ahead (``warm_kernels``) are the ones a plan calls."""

from __future__ import annotations

import logging
from pathlib import Path

from dexlfd.plan import Box, PlanConfig, plan_from_model
from dexlfd.plan.kernels import kernel_signatures, warm_kernels


def _compiled() -> dict[str, int]:
    return {k.__name__: len(k.signatures) for k, _ in kernel_signatures()}  # type: ignore[attr-defined]


def test_a_plan_after_the_warm_up_compiles_no_new_kernel(ref_model, demo_model) -> None:
    assert warm_kernels() == len(kernel_signatures())
    warmed = _compiled()
    assert all(n >= 1 for n in warmed.values()), warmed
    box = Box((0.45, 0.0, 0.2), (0.1, 0.1, 0.4))
    plan_from_model(ref_model, PlanConfig(obstacles=(box,), rate_hz=100))  # one motion
    plan_from_model(demo_model, PlanConfig(rate_hz=100))  # a pick-and-place, if it has events
    assert _compiled() == warmed  # every call matched a signature compiled ahead


def test_the_warm_up_makes_the_reach_band_the_first_plan_would_make() -> None:
    from dexlfd.plan import reach

    reach._band.cache_clear()
    warm_kernels()
    assert reach._band.cache_info().currsize == 1
    before = reach._band.cache_info().hits
    reach.top_down_radius(0.3)  # a plan's check: the band made ahead
    assert reach._band.cache_info().hits == before + 1


def test_the_demo_goes_on_when_the_warm_up_fails(monkeypatch, caplog, tmp_path: Path) -> None:
    import dexlfd.plan.kernels as kernels
    from dexlfd.apps import demo
    from dexlfd.apps.demo import DemoConfig

    def broken() -> int:
        raise OSError("read-only cache folder")

    monkeypatch.setattr(kernels, "warm_kernels", broken)
    with caplog.at_level(logging.WARNING, logger="dexlfd"):
        assert demo._stage_kernels(DemoConfig(real_video=None), tmp_path) == ({}, {"kernels": 0})
    assert "read-only cache folder" in caplog.text and "plan stage compiles" in caplog.text
