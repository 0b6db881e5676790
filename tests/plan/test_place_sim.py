"""Place, don't drop, in the MuJoCo simulation (control loop + plant)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco")

from dexlfd.control import LoopConfig, make_controller, track  # noqa: E402
from dexlfd.plan import PlanConfig, plan_from_model  # noqa: E402
from dexlfd.robot import MujocoPandaModel, PlantConfig, plan_world  # noqa: E402

from .conftest import reference_model  # noqa: E402

SURFACE = 0.09  # [m] the place table, as high as the pick pedestal
HALF = 0.03  # [m] the simulated box's half height (PlantConfig.payload_half_size)


@pytest.mark.integration
def test_box_is_placed_upright_on_the_table_not_dropped() -> None:
    plan = plan_from_model(
        reference_model(), PlanConfig(rate_hz=1000, place_surface_z=SURFACE, object_bottom=HALF)
    )
    place = plan.place_correction.to_json()
    plant = PlantConfig(payload_kg=0.45, obstacles=plan_world(plan))
    ro = track(
        plan, make_controller("ntsm-pd"), MujocoPandaModel(), plant, LoopConfig(),
        rng=np.random.default_rng(0),
    )  # fmt: skip
    assert ro.stopped is None and not ro.grasp_events
    obj = ro.object_report.to_json()
    final = np.asarray(obj["final_position"])
    # on the table (its centre one half height above the surface), at the place point
    # (within the TCP's tracking error), upright, and it met the table gently
    assert final[2] == pytest.approx(SURFACE + HALF, abs=2e-3)
    assert np.linalg.norm(final[:2] - np.asarray(place["place_point"][:2])) < 0.015
    assert obj["tilt_deg"] < 2.0
    assert obj["released_t"] == pytest.approx(place["release_t"], abs=0.05)
    assert obj["impact_speed"] < 0.1
    # it stays where it was put while the hand retreats
    p = ro.extras["payload_position"]
    after = ro.t > obj["released_t"]
    assert np.abs(p[after] - final).max() < 3e-3
