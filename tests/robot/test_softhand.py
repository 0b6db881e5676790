"""The simulated qb SoftHand: build, synergy sequence, 3 N stop, grasp-and-lift, refusal."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.panda import Q_READY
from dexlfd.robot import MujocoPandaModel, PandaSim, PlantConfig
from dexlfd.robot.plant import HALF_SIZES
from dexlfd.robot.robot_model import import_mujoco
from dexlfd.robot.softhand import FINGERS, MASS, PHALANGES, SPAN, STOP_FORCE

mujoco = import_mujoco()  # after choosing the offscreen GL backend (MuJoCo reads it once)


def _sim(**plant: object) -> PandaSim:
    return PandaSim(PlantConfig(hand="softhand", friction_scale=0.0, **plant), Q_READY)  # type: ignore[arg-type]


def _hold(sim: PandaSim, model: MujocoPandaModel, n: int) -> None:
    """Hold the arm at Q_READY (gravity from the nominal model, soft wrist gains)."""
    kp = np.array([600.0] * 4 + [60.0] * 3)
    kd = np.array([30.0] * 4 + [1.5] * 3)
    for _ in range(n):
        st = sim.state()
        sim.step(model.terms(st.q, st.dq).g + kp * (Q_READY - st.q) - kd * st.dq)


def _contact_force(sim: PandaSim, other: str) -> float:
    """Total contact normal force [N] between the hand's pads and body ``other``.

    Read from MuJoCo's contacts directly, not from the hand's own touch sensors.
    """
    m, d = sim.model, sim.data
    oid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, other)
    f6, total = np.zeros(6), 0.0
    for i in range(d.ncon):
        c = d.contact[i]
        names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or "" for g in c.geom]
        bodies = (m.geom_bodyid[c.geom1], m.geom_bodyid[c.geom2])
        if oid in bodies and any(n.endswith("_pad") for n in names):
            mujoco.mj_contactForce(m, d, i, f6)
            total += f6[0]
    return total


def test_model_compiles_with_the_hands_mass_size_and_one_actuator() -> None:
    with _sim() as sim:
        m = sim.model
        hand = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "panda_hand")
        assert m.body_subtreemass[hand] == pytest.approx(MASS, abs=1e-9)  # 480 g
        assert m.nu == 1 and m.actuator_trntype[0] == mujoco.mjtTrn.mjTRN_TENDON
        assert m.ntendon == 1 and m.tendon_num[0] == 15  # one tendon over 15 joints
        assert m.nv == 7 + 15  # the arm and the hand's 15 hinges
        names = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m.njnt)}
        assert not any(n and "finger_joint" in n for n in names)  # no Franka fingers
        # hand-sized: palm + middle finger ~0.2 m long, palm 85 mm wide
        palm = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "softhand_palm")
        middle = next(f for f in FINGERS if f.name == "middle")
        length = 2 * m.geom_size[palm][1] + sum(middle.lengths)
        assert 0.17 < length < 0.22
        assert 2 * m.geom_size[palm][0] == pytest.approx(0.085)


def test_free_hand_curls_then_swings_each_digit_distal_first() -> None:
    model = MujocoPandaModel()
    with _sim() as sim:
        m, d = sim.model, sim.data
        adr = [
            [m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, f"{f.name}_{p}")]
             for p in PHALANGES]
            for f in FINGERS
        ]  # fmt: skip
        first_move = np.full((len(FINGERS), 3), np.inf)
        assert sim.synergy is not None
        sim.synergy.set_pose(d, 0.0)  # flat (the relaxed hand starts curled)
        sim.synergy.close()
        for k in range(1600):
            _hold(sim, model, 1)
            moved = (d.qpos[np.array(adr)] > 0.05) & np.isinf(first_move)
            first_move[moved] = k
        assert np.isfinite(first_move).all()  # every joint flexed
        # the tendon's design: distal joint first, then middle, then the knuckle
        assert (first_move[:, 2] < first_move[:, 1]).all()
        assert (first_move[:, 1] < first_move[:, 0]).all()
        assert sim.synergy.closure(d) > 0.85  # a free hand closes (nothing to stop it)
        assert not sim.synergy.stopped


def test_closure_stops_at_3_newtons_on_a_fixed_object_and_holds() -> None:
    model = MujocoPandaModel()
    # a 1 kg box on its pedestal under the held hand: the fingers squeeze a still object
    with _sim(payload_kg=1.0) as sim:
        syn = sim.synergy
        assert syn is not None and sim.grasp()
        _hold(sim, model, 1500)
        assert syn.stopped and syn.stop_t is not None
        held = syn.setpoint
        forces = []
        for _ in range(5):
            _hold(sim, model, 100)
            forces.append(_contact_force(sim, "payload"))
        assert syn.setpoint == held  # it holds: the motor no longer closes
        # thumb against the four fingers: each side presses ~3 N (total ~2 x squeeze)
        squeeze = 0.5 * np.mean(forces)
        assert squeeze == pytest.approx(STOP_FORCE, rel=0.35)
        assert np.ptp(forces) < 0.2 * np.mean(forces)  # steady, not chattering


@pytest.mark.parametrize("shape", ["box", "cylinder", "sphere"])
def test_grasps_and_lifts_a_300_g_object_without_slip(shape: str) -> None:
    from dexlfd.control import make_controller, track
    from dexlfd.control.slip import carry_slip
    from dexlfd.plan.moves import lift_plan

    plant = PlantConfig(
        payload_kg=0.3, hand="softhand", payload_shape=shape, payload_half_size=HALF_SIZES[shape]
    )
    ro = track(lift_plan(4.0), make_controller("ntsm-pd"), MujocoPandaModel(), plant,
               rng=np.random.default_rng(0))  # fmt: skip
    assert not ro.grasp_events  # never missed or dropped
    z = ro.extras["payload_position"][:, 2]
    assert z.max() - z[0] > 0.1  # it went up with the hand
    slip = carry_slip(ro)
    assert slip is not None and slip < 0.005  # [m] it stayed where the hand closed on it


def test_an_object_wider_than_the_span_is_refused_in_one_line() -> None:
    with pytest.raises(InvalidInput, match="softhand cannot hold a box 0.100 m wide.*span"):
        PlantConfig(hand="softhand", payload_kg=0.3, payload_half_size=(0.05, 0.05, 0.03))
    with pytest.raises(InvalidInput, match="tall under its palm"):
        PlantConfig(hand="softhand", payload_kg=0.3, payload_half_size=(0.02, 0.02, 0.05))
    PlantConfig(hand="softhand", payload_half_size=(0.05, 0.05, 0.03))  # no object: fine
    assert SPAN < 0.08  # the Franka Hand opens 8 cm; the softhand's span is less


def test_cli_refuses_an_oversized_object_before_simulating(tmp_path: Path, capsys) -> None:
    from dexlfd.cli import main
    from dexlfd.io import save_plan
    from dexlfd.plan.moves import lift_plan

    plan = save_plan(tmp_path / "lift.npz", lift_plan(2.0))
    out = tmp_path / "r.npz"
    argv = ["simulate", str(plan), "-o", str(out), "--hand", "softhand", "--payload", "0.3",
            "--object-size", "0.1,0.1,0.06"]  # fmt: skip
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    assert "softhand" in err and "span" in err
    assert not out.exists()
