"""Real-arm path over the Franka protocol (pylibfranka ↔ franky-sim on loopback).

Figures:
1. loop: achieved command rate, missed cycles, controller + model compute time
   per cycle (state in to command out; the 1 ms budget must stay ≥ 50 % free);
2. offline compute: median of repeats of one cycle's work (model terms + law);
3. tracking: the payload experiment's lift plan on both backends — over the
   protocol (franky-sim's MuJoCo FR3 with joint friction, unmodelled fingers,
   gravity compensated by the simulator's Pinocchio model) and on our direct
   MuJoCo Panda backend (``control.track``, its realistic default plant) —
   PD vs NTSM-PD with no object and 1 kg that no model knows (Table 5.1 style,
   z RMSE while carried, Eq. 5.27).

    python benchmarks/bench_franka.py            # 6 s lift (as the experiment)
    python benchmarks/bench_franka.py --duration-s 3 --payload 1.0
"""

from __future__ import annotations

import argparse
import json
import sys
import timeit
from pathlib import Path

import numpy as np

from dexlfd.control import LoopConfig, RobotState, make_controller, track
from dexlfd.control.franka import track_franka
from dexlfd.experiments.payload import lift_metrics
from dexlfd.experiments.payload_franka import on_grid, start_joints
from dexlfd.plan.moves import lift_plan
from dexlfd.robot import MujocoPandaModel, PlantConfig
from dexlfd.robot.franka import FrankaArm
from dexlfd.robot.franka_sim import FrankaSimServer, SimulatorUnavailable, ensure_simulator_venv
from dexlfd.robot.libfranka import RobotStopped

ROOT = Path(__file__).resolve().parents[1]


def run_protocol(python: Path, plan, q0, name: str, payload: float):  # type: ignore[no-untyped-def]
    with (
        FrankaSimServer(python, payload_kg=payload, q0=q0.tolist()) as sim,
        FrankaArm(sim.host) as arm,
    ):
        try:
            ro, stats = track_franka(arm, plan, make_controller(name))
        except RobotStopped as exc:
            print(f"  {name} {payload} kg STOPPED: {exc}")
            return exc.rollout, None, None
        # offline compute time of one cycle at the final state (model terms + law)
        ctrl = make_controller(name)
        st = arm.read_state()
        rs = RobotState(0.0, st.q, st.dq)
        terms = arm.model.terms_at(st)
        from dexlfd.control import Reference

        ref = Reference(terms.p, np.zeros(3), np.zeros(3), terms.R, np.zeros(3))
        cs = ctrl.init(rs, terms)

        def one_cycle() -> None:
            t = arm.model.terms_at(st)
            ctrl.step(cs, rs, ref, t)

        reps = np.array(timeit.repeat(one_cycle, number=200, repeat=7)) / 200
    return ro, stats, reps


def run_mujoco(plan, q0, name: str, payload: float):  # type: ignore[no-untyped-def]
    return track(
        plan,
        make_controller(name),
        MujocoPandaModel(),
        PlantConfig(payload_kg=payload),
        LoopConfig(),
        rng=np.random.default_rng([0, 2]),
        q0=q0,
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration-s", type=float, default=6.0)
    parser.add_argument("--payload", type=float, default=1.0)
    parser.add_argument("--controllers", default="pd,ntsm-pd")
    parser.add_argument("--json", help="write all figures to this JSON file")
    parser.add_argument("--plot", help="write the z-error figure (PNG) here")
    args = parser.parse_args()
    try:
        python = ensure_simulator_venv(ROOT / ".venv-franka-sim")
    except SimulatorUnavailable as exc:
        print(f"skipped: {exc}")
        return 0
    plan = lift_plan(args.duration_s)
    q0 = start_joints(plan)
    names = [c.strip() for c in args.controllers.split(",")]
    out: dict[str, dict[str, object]] = {}
    results = {}
    for name in names:
        for payload in (0.0, args.payload):
            ro_p, stats, reps = run_protocol(python, plan, q0, name, payload)
            ro_m = run_mujoco(plan, q0, name, payload)
            results[(name, payload)] = (ro_p, ro_m)
            row: dict[str, object] = {}
            if stats is not None:
                s = stats.summary()
                row.update(
                    rate_hz=s["rate_hz"],
                    missed_cycles=s["missed_cycles"],
                    n_cycles=s["n_cycles"],
                    loop_compute_us_median=s["compute_us_median"],
                    loop_compute_us_p99=s["compute_us_p99"],
                    loop_budget_free_pct=100.0 * (1.0 - s["compute_us_median"] / 1000.0),
                    offline_cycle_us=1e6 * float(np.median(reps)),
                    offline_cycle_us_std=1e6 * float(np.std(reps)),
                )
                ro_p = on_grid(ro_p, ro_m.t)
                results[(name, payload)] = (ro_p, ro_m)
                e_p = ro_p.ee_position - ro_p.ref_position
                e_m = ro_m.ee_position - ro_m.ref_position
                gap = ro_p.ee_position - ro_m.ee_position
                row.update(
                    rmse_protocol_mm=1e3 * float(np.sqrt(np.mean(np.sum(e_p**2, 1)))),
                    rmse_mujoco_mm=1e3 * float(np.sqrt(np.mean(np.sum(e_m**2, 1)))),
                    rms_gap_protocol_vs_mujoco_mm=1e3 * float(np.sqrt(np.mean(np.sum(gap**2, 1)))),
                )
            out[f"{name}@{payload:g}kg"] = row
            print(
                f"{name:8s} {payload:4.2f} kg: "
                + ", ".join(
                    f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()
                )
            )
    print("\nUnknown payload, z RMSE while carried (Eq. 5.27) [mm]:")
    print(f"{'controller':10s} {'backend':9s} {'E_NOB':>7s} {'E_OB':>7s} {'dE':>7s} {'sag':>7s}")
    for name in names:
        for k, backend in enumerate(("protocol", "mujoco")):
            r0, r1 = results[(name, 0.0)][k], results[(name, args.payload)][k]
            if r0 is None or r1 is None or r0.t.size != r1.t.size or r1.stopped:
                print(f"{name:10s} {backend:9s} (a run stopped early)")
                continue
            m0, m1 = lift_metrics(r0, 0.05), lift_metrics(r1, 0.05)
            sag = float(np.mean((m1["z_err"] - m0["z_err"])[m0["mask"]]))
            e0, e1 = 1e3 * m0["e_z"], 1e3 * m1["e_z"]
            print(f"{name:10s} {backend:9s} {e0:7.2f} {e1:7.2f} {e1 - e0:+7.2f} {1e3 * sag:+7.2f}")
            out[f"{name}@{backend}"] = {"e_nob_mm": e0, "e_ob_mm": e1, "sag_mm": 1e3 * sag}
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))
    if args.plot:
        from dexlfd.viz.franka import plot_protocol_vs_mujoco

        runs = {
            (c, m, b): results[(c, m)][k]
            for (c, m) in results
            for k, b in enumerate(("protocol", "mujoco"))
            if results[(c, m)][k] is not None
        }
        title = (
            f"Lift of plan.moves.lift_plan ({args.duration_s:g} s) — solid: pylibfranka ↔ "
            "franky-sim (MuJoCo FR3, joint friction, libfranka model); dashed: our MuJoCo "
            "Panda (Gaz friction, noise, 1-tick delay, exact model)"
        )
        print("wrote", plot_protocol_vs_mujoco(runs, args.plot, title=title))
    return 0


if __name__ == "__main__":
    sys.exit(main())
