"""The band warning states the measured clearance and is true either way (review item 10)."""

from __future__ import annotations

import logging
import re

import numpy as np
import pytest

from dexlfd.geometry import Box
from dexlfd.plan import PlanConfig, plan_from_model
from dexlfd.plan.clearance import _report_band

from .conftest import reference_model


def test_unmet_band_reports_the_clearance_it_measured(caplog) -> None:
    box = Box((0.45, 0.0, 0.2), (0.08, 0.08, 0.4))
    cfg = PlanConfig(obstacles=(box,), rate_hz=200, margin=0.05, band=0.002, variance_clearance=0,
                     variance_measure="relative")  # fmt: skip
    with caplog.at_level(logging.INFO, logger="dexlfd.plan"):
        plan = plan_from_model(reference_model(), cfg)
    info = plan.obstacle_passes[0].to_json()
    assert info["band_met"] is False
    (msg,) = [r.getMessage() for r in caplog.records if "margin + band" in r.getMessage()]
    lo, hi, excess, limit = (float(v) for v in re.findall(r"\d+\.\d+", msg)[:4])
    assert limit == pytest.approx(0.052)
    assert lo == pytest.approx(info["min_clearance"], abs=5e-4)  # the meta's own number
    assert hi > limit and excess == pytest.approx(hi - limit, abs=1e-3)
    assert "more than margin + band" in msg


def test_relaxed_band_within_the_limit_is_not_called_more(caplog) -> None:
    with caplog.at_level(logging.INFO, logger="dexlfd.plan"):
        _report_band(0, np.array([0.053, 0.06, 0.069]), 0.07)
        _report_band(1, np.array([0.053, 0.06, 0.09]), 0.07)
    within, more = (r for r in caplog.records)
    assert within.levelno == logging.INFO and "0.053..0.069 m, within" in within.getMessage()
    assert more.levelno == logging.WARNING
    assert "0.053..0.090 m, up to 0.020 m more than margin + band (0.070 m)" in more.getMessage()
