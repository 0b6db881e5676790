"""The simulated qb SoftHand against the Franka Hand: grasp force, lift, pick and place.

Three parts, NTSM-PD on the realistic plant (friction, 10 % model error, noise, delay):

1. **The 3 N stop**: the softhand closes on each object standing on its pedestal
   under the held arm; the squeeze (thumb against fingers, from MuJoCo's contacts)
   at the stop and 1 s later, and when the stop fired.
2. **Lift** (the payload study's 6 s lift over the box): per hand, object (box,
   cylinder, sphere) and mass: carried or not, the object's largest slide in the hand
   during the carry (:func:`dexlfd.control.slip.carry_slip`), the z RMSE while carried
   and the wall time.
3. **Pick/place grid** (``experiment generalize`` on the demo's learned model,
   ``--pairs`` pairs): success rate, placement error and slip per hand.

    python benchmarks/bench_softhand.py [--pairs 6] [--masses 0.3,0.45,1.2] [--parts 1,2,3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

SHAPES = ("box", "cylinder", "sphere")


def _squeeze(mujoco, sim) -> float:  # type: ignore[no-untyped-def]
    """Half the pads' total contact normal force on the object [N], from MuJoCo's contacts."""
    m, d = sim.model, sim.data
    pid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "payload")
    f6, total = np.zeros(6), 0.0
    for i in range(d.ncon):
        c = d.contact[i]
        pads = any(
            (mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or "").endswith("_pad")
            for g in c.geom
        )
        if pads and pid in (m.geom_bodyid[c.geom1], m.geom_bodyid[c.geom2]):
            mujoco.mj_contactForce(m, d, i, f6)
            total += f6[0]
    return 0.5 * total


def stop_force() -> None:
    """Part 1: the squeeze at the stop and after holding 1 s, per object."""
    from dexlfd.panda import Q_READY
    from dexlfd.robot import MujocoPandaModel, PandaSim, PlantConfig
    from dexlfd.robot.plant import HALF_SIZES
    from dexlfd.robot.robot_model import import_mujoco

    mujoco = import_mujoco()

    model = MujocoPandaModel()
    kp, kd = np.array([600.0] * 4 + [60.0] * 3), np.array([30.0] * 4 + [1.5] * 3)
    print("1. the 3 N stop (object on its pedestal, arm held): squeeze [N] = mean of both sides")
    for shape in SHAPES:
        plant = PlantConfig(payload_kg=1.0, hand="softhand", friction_scale=0.0,
                            payload_shape=shape, payload_half_size=HALF_SIZES[shape])  # fmt: skip
        with PandaSim(plant, Q_READY) as sim:
            sim.grasp()
            at_stop = None
            for k in range(1500):
                st = sim.state()
                sim.step(model.terms(st.q, st.dq).g + kp * (Q_READY - st.q) - kd * st.dq)
                if at_stop is None and sim.synergy is not None and sim.synergy.stopped:
                    at_stop = (k, _squeeze(mujoco, sim))
            assert sim.synergy is not None
            print(f"   {shape:<9} stop at t = {at_stop[0] if at_stop else -1} ms, squeeze "
                  f"{at_stop[1] if at_stop else float('nan'):.2f} N at the stop, "
                  f"{_squeeze(mujoco, sim):.2f} N 1 s later")  # fmt: skip


def lift(masses: tuple[float, ...]) -> None:
    """Part 2: the payload study's lift with each hand, object and mass."""
    from dexlfd.control import LoopConfig, make_controller, track
    from dexlfd.control.slip import carry_slip
    from dexlfd.experiments.payload import LIFT_OBSTACLE, lift_metrics
    from dexlfd.plan.moves import lift_plan
    from dexlfd.robot import PlantConfig, perturbed_model
    from dexlfd.robot.plant import HALF_SIZES

    plan = lift_plan(6.0)
    model = perturbed_model(0.1, np.random.default_rng([0, 1]))
    print("\n2. lift (6 s, NTSM-PD): carried | slip in the hand | z RMSE carried | wall")
    for hand in ("franka", "softhand"):
        for shape in SHAPES:
            for kg in masses:
                plant = PlantConfig(payload_kg=kg, hand=hand, payload_shape=shape,
                                    payload_half_size=HALF_SIZES[shape],
                                    obstacles=(LIFT_OBSTACLE,))  # fmt: skip
                t0 = time.perf_counter()
                ro = track(plan, make_controller("ntsm-pd"), model, plant, LoopConfig(),
                           rng=np.random.default_rng([0, 2]))  # fmt: skip
                wall = time.perf_counter() - t0
                events = [e.to_json() for e in ro.grasp_events]
                slip = carry_slip(ro)
                ez = lift_metrics(ro, 0.05)["e_z"] if not events else float("nan")
                print(f"   {hand:<9} {shape:<9} {kg:4.2f} kg  "
                      f"{'carried' if not events else events[0]['event']:<8} "
                      f"slip {'-' if slip is None else f'{1e3 * slip:6.2f} mm'}  "
                      f"E_z {1e3 * ez:6.3f} mm  {wall:5.1f} s")  # fmt: skip


def grid(pairs: int, kg: float) -> None:
    """Part 3: the pick/place grid with each hand."""
    import importlib.util
    from pathlib import Path

    from dexlfd.experiments.generalize import GeneralizeConfig, run_generalize

    spec = importlib.util.spec_from_file_location(
        "bench_generalize", Path(__file__).with_name("bench_generalize.py")
    )
    assert spec is not None and spec.loader is not None
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    model = bench.demo_model()
    print(f"\n3. pick/place grid ({pairs} pairs, {kg:g} kg box, NTSM-PD)")
    for hand in ("franka", "softhand"):
        t0 = time.perf_counter()
        cfg = GeneralizeConfig(n_pairs=pairs, payloads=(kg,), hand=hand, workers=1)
        result = run_generalize(model, cfg, quiet=True)
        (row,) = result.summary()

        def mm(v: float | None) -> str:
            return "-" if v is None else f"{1e3 * v:.1f} mm"

        print(f"   {hand:<9} placed {100 * row['success_rate']:3.0f} %  carried "
              f"{100 * row['carried_rate']:3.0f} %  place error median "
              f"{mm(row['place_error_median_m'])}, worst {mm(row['place_error_worst_m'])}  "
              f"slip median {mm(row['slip_median_m'])}, worst {mm(row['slip_worst_m'])}  "
              f"({time.perf_counter() - t0:.0f} s)")  # fmt: skip
        for r in result.runs:
            if not r["placement"].get("success"):
                print(f"      pair {r['pair']}: {r['placement'].get('failure')}")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--pairs", type=int, default=6)
    ap.add_argument("--masses", default="0.3,0.45,1.2")
    ap.add_argument("--grid-kg", type=float, default=0.3)
    ap.add_argument("--parts", default="1,2,3", help="which parts to run (default: all)")
    args = ap.parse_args()
    parts = set(args.parts.split(","))
    if "1" in parts:
        stop_force()
    if "2" in parts:
        lift(tuple(float(v) for v in args.masses.split(",")))
    if "3" in parts:
        grid(args.pairs, args.grid_kg)


if __name__ == "__main__":
    main()
