from __future__ import annotations

import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.panda import Q_READY
from dexlfd.robot import MujocoPandaModel, PandaSim, PlantConfig


def test_plant_config_rejects_bad_payloads() -> None:
    with pytest.raises(InvalidInput, match="payload_kg.*3"):
        PlantConfig(payload_kg=3.5)
    with pytest.raises(InvalidInput, match="payload_kg"):
        PlantConfig(payload_kg=-1.0)
    with pytest.raises(InvalidInput, match="payload_com"):
        PlantConfig(payload_kg=1.0, payload_com=(0.0, 0.0, 0.5))


def test_gravity_compensation_holds_still_without_friction() -> None:
    model = MujocoPandaModel()
    with PandaSim(PlantConfig(friction_scale=0.0), Q_READY) as sim:
        for _ in range(300):
            st = sim.state()
            sim.step(model.terms(st.q, st.dq).h)
        # exact model: the arm stays where it is (only integration error)
        np.testing.assert_allclose(sim.state().q, Q_READY, atol=1e-5)


@pytest.mark.parametrize("grasp", ["contact", "weld"])
def test_grasped_object_moves_with_the_hand_and_falls_when_released(grasp: str) -> None:
    model = MujocoPandaModel()
    q0 = Q_READY
    with PandaSim(PlantConfig(payload_kg=1.0, friction_scale=0.0, grasp=grasp), q0) as sim:
        assert sim.grasp()
        for _ in range(300):  # let the grip force build up (fingers close at 0.1 m/s)
            st = sim.state()
            sim.step(model.terms(st.q, st.dq).h + 300 * (q0 - st.q) - 30 * st.dq)
        p_tcp0, _ = sim.tcp_pose()
        offset0 = sim.payload_position() - p_tcp0
        q_target = q0 + np.array([0.3, 0.1, 0.0, 0.1, 0.0, 0.0, 0.0])
        for _ in range(800):
            st = sim.state()
            sim.step(model.terms(st.q, st.dq).h + 300 * (q_target - st.q) - 30 * st.dq)
        p_tcp, _ = sim.tcp_pose()
        assert np.linalg.norm(p_tcp - p_tcp0) > 0.05  # the hand moved
        # ...and the object kept its place between the fingers (weld, < 2 mm compliance)
        np.testing.assert_allclose(sim.payload_position() - p_tcp, offset0, atol=2e-3)
        assert sim.release()
        z0 = sim.payload_position()[2]
        for _ in range(100):
            st = sim.state()
            sim.step(model.terms(st.q, st.dq).h + 300 * (q_target - st.q) - 30 * st.dq)
        # 0.1 s of free fall: z drops by g t^2 / 2 = 49 mm (less the fingers' opening time)
        assert z0 - sim.payload_position()[2] == pytest.approx(0.049, abs=0.012)


def test_friction_dissipates_energy() -> None:
    # unpowered except gravity compensation: a spinning joint 1 slows down with friction
    model = MujocoPandaModel()
    speeds = {}
    for scale in (0.0, 1.0):
        with PandaSim(PlantConfig(friction_scale=scale), Q_READY) as sim:
            sim.data.qvel[0] = 1.0
            for _ in range(200):
                st = sim.state()
                sim.step(model.terms(st.q, st.dq).h)
            speeds[scale] = sim.state().dq[0]
    assert speeds[0.0] == pytest.approx(1.0, abs=0.02)
    assert speeds[1.0] < speeds[0.0] - 0.05
