"""robot.plant: the scene obstacles are geometry shapes, from the plan's arrays."""

from __future__ import annotations

import dataclasses
import json
import logging

import numpy as np
import pytest

from dexlfd.errors import InvalidFile, InvalidInput
from dexlfd.geometry import Box, Sphere
from dexlfd.io import load_plan, save_plan
from dexlfd.io._world import obstacle_arrays, support_arrays
from dexlfd.plan.moves import lift_plan
from dexlfd.robot import PlantConfig, plan_world


def test_plan_obstacles_are_typed_arrays_and_v1_meta_is_read_once(
    tmp_path, caplog: pytest.LogCaptureFixture
) -> None:
    box, ball = Box((0.5, 0.0, 0.1), (0.1, 0.2, 0.2)), Sphere((0.4, 0.2, 0.3), 0.05)
    support = Box((0.3, 0.3, 0.05), (0.1, 0.1, 0.1))
    base = lift_plan(1.0)
    plan = dataclasses.replace(base, **obstacle_arrays([box, ball]), **support_arrays([support]))
    assert plan_world(plan) == (box, ball, support)
    back = load_plan(save_plan(tmp_path / "p.npz", plan))
    assert plan_world(back) == (box, ball, support)
    # a version-1 file kept its obstacles in meta: read into the arrays on load
    names = ("t", "position", "velocity", "acceleration", "quaternion", "angular_velocity")
    arrays = {n: getattr(base, n) for n in (*names, "gripper")}
    meta = {
        "kind": "plan",
        "settings": {"obstacles": [box.to_dict(), ball.to_dict()]},
        "place": {"support": {"type": "box", "center": [0.3, 0.3, 0.05], "size": [0.1, 0.1, 0.1]}},
    }
    np.savez(tmp_path / "v1.npz", format_version=1, meta=json.dumps(meta), **arrays)
    old = load_plan(tmp_path / "v1.npz")
    assert plan_world(old) == (box, ball, support) and old.grasp is None
    with caplog.at_level(logging.WARNING):
        plant = PlantConfig(obstacles=plan_world(plan))
    assert "bounding cube" in caplog.text
    # the description keeps the half sizes of the simulated boxes (a sphere's cube)
    assert plant.describe()["obstacles"][0][1] == [0.05, 0.1, 0.1]
    assert plant.describe()["obstacles"][1][1] == [0.05, 0.05, 0.05]
    assert plan_world(base) == ()
    meta["settings"] = {"obstacles": [{"type": "cone"}]}
    np.savez(tmp_path / "bad.npz", format_version=1, meta=json.dumps(meta), **arrays)
    with pytest.raises(InvalidFile, match="unknown obstacle type 'cone'"):
        load_plan(tmp_path / "bad.npz")
    with pytest.raises(InvalidInput, match="Box or Sphere"):
        PlantConfig(obstacles=((0.1, 0.2),))  # type: ignore[arg-type]
