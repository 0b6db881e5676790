"""robot.plant: the scene obstacles are geometry shapes, read from plan meta."""

from __future__ import annotations

import logging

import pytest

from dexlfd.errors import InvalidInput
from dexlfd.geometry import Box, Sphere
from dexlfd.robot import PlantConfig, obstacles_from_plan_meta


def test_plan_meta_obstacles_are_geometry_shapes(caplog: pytest.LogCaptureFixture) -> None:
    box, ball = Box((0.5, 0.0, 0.1), (0.1, 0.2, 0.2)), Sphere((0.4, 0.2, 0.3), 0.05)
    meta = {
        "settings": {"obstacles": [box.to_dict(), ball.to_dict()]},
        "place": {"support": {"type": "box", "center": [0.3, 0.3, 0.05], "size": [0.1, 0.1, 0.1]}},
    }
    obs = obstacles_from_plan_meta(meta)
    assert obs == (box, ball, Box((0.3, 0.3, 0.05), (0.1, 0.1, 0.1)))
    with caplog.at_level(logging.WARNING):
        plant = PlantConfig(obstacles=obs)
    assert "bounding cube" in caplog.text
    # the description keeps the half sizes of the simulated boxes (a sphere's cube)
    assert plant.describe()["obstacles"][0][1] == [0.05, 0.1, 0.1]
    assert plant.describe()["obstacles"][1][1] == [0.05, 0.05, 0.05]
    assert obstacles_from_plan_meta({}) == ()
    with pytest.raises(InvalidInput, match="plan meta: unknown obstacle type 'cone'"):
        obstacles_from_plan_meta({"settings": {"obstacles": [{"type": "cone"}]}})
    with pytest.raises(InvalidInput, match="Box or Sphere"):
        PlantConfig(obstacles=((0.1, 0.2),))  # type: ignore[arg-type]
