"""The variance term in metres: demonstrations that agree get no extra bend."""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.plan import Box, PlanConfig, plan_from_model

from .conftest import reference_model


def _pair(measure: str) -> dict[float, dict]:
    out = {}
    for sigma in (0.001, 0.03):  # demonstrations agreeing to 1 mm / disagreeing by 3 cm
        model = reference_model(sigma_low=sigma, sigma_high=sigma)
        nominal = plan_from_model(model, PlanConfig(rate_hz=100.0))
        c = nominal.position[int(0.55 * (nominal.n_samples - 1))]
        top = float(c[2]) + 0.03
        box = Box((float(c[0]), float(c[1]), top / 2), (0.06, 0.03, top))
        plan = plan_from_model(
            model, PlanConfig(obstacles=(box,), rate_hz=100.0, variance_measure=measure)
        )
        out[sigma] = plan.obstacle_passes[0].to_json()
    return out


def test_extra_bend_follows_the_spread_in_metres() -> None:
    metres = _pair("metres")
    beyond = {s: r["displacement"] - r["required_lift"] for s, r in metres.items()}
    assert metres[0.001]["variance_level"] == pytest.approx(0.001 / 0.015, rel=0.05)
    assert metres[0.03]["variance_level"] == pytest.approx(1.0)
    # agreeing demonstrations: no extra bend beyond the coupling's own few mm (3.5 mm
    # measured); 3 cm of disagreement: a centimetre more (13.5 mm, cap 1.5 cm)
    assert beyond[0.001] < 0.005
    assert beyond[0.03] > beyond[0.001] + 0.0075
    for r in metres.values():
        assert 0.02 - 2e-3 <= r["min_clearance"] <= 0.02 + 0.02 + 2e-3
    # the relative measure bends both alike: each model is measured against itself
    relative = _pair("relative")
    rb = [r["displacement"] - r["required_lift"] for r in relative.values()]
    assert abs(rb[0] - rb[1]) < 0.003
    assert np.isclose(relative[0.001]["variance_level"], relative[0.03]["variance_level"])
