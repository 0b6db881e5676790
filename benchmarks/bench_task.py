"""Pick-and-place planning: learn with events, plan with one obstacle, pose at the events.

Times (median of repeats after a warm-up, this machine, shared):

- ``learn`` on six synthetic demonstrations with automatic K (target <= 1 s), events
  included;
- ``plan_from_model`` of a pick-and-place task with one obstacle over the carry,
  without the joint-space feasibility (``feasible=False``, target <= 0.2 s) and as
  by default (feasible), and of the whole motion with the same obstacle;
- ``make_feasible`` on the task plan (the IK joint check the library adds).

Then the thesis's 0.5 m obstacle case (``--obstacle box:0.46,-0.05,0.25,0.10,0.10,0.50``
on the six-demo model's default plan): planned or not, its clearance from the
obstacle and from the placed object after the rise; and with ``--sim N`` (default 3)
the placement of N pick/place pairs simulated with NTSM-PD at 1.2 kg: the six-demo
model and a model learned from the same demonstrations tilted 30 deg (top-down
default, and ``grasp_orientation="demonstrated"``): error [mm] and tilt [deg].

Then the plan's pose error at the events (the reference at the grasp and release
switch against the asked pick and place) and, with ``--generalize JSON`` (written by
``bench_generalize.py``), the simulated TCP error at the grasp and how often time
scaling was needed over the grid, with the largest slow-down.

    python benchmarks/bench_task.py [--sim 3] [--generalize bench-generalize/generalize.json]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import timeit

import numpy as np

from dexlfd.datasets import pick_place_demonstrations
from dexlfd.learn import LearnConfig, learn_from_demonstrations
from dexlfd.plan import Box, PlanConfig, plan_from_model


def _median_s(fn, repeat: int = 5) -> float:  # type: ignore[no-untyped-def]
    fn()
    return float(np.median(timeit.repeat(fn, number=1, repeat=repeat)))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--generalize", default=None)
    ap.add_argument("--sim", type=int, default=3, help="pick/place pairs to simulate")
    args = ap.parse_args()
    demos = pick_place_demonstrations(6, np.random.default_rng(0))
    t_learn = _median_s(lambda: learn_from_demonstrations(demos, LearnConfig(),
                                                          np.random.default_rng(0)))  # fmt: skip
    model = learn_from_demonstrations(demos, LearnConfig(), np.random.default_rng(0)).model
    print(f"learn, 6 demos, automatic K (K={len(model.gmm_weights)}), with events: "
          f"{t_learn:.3f} s (target <= 1 s)")  # fmt: skip
    pick, place = (0.5, -0.15, 0.12), (0.42, 0.28, 0.14)
    free = plan_from_model(model, PlanConfig(pick=pick, place=place))
    on = np.flatnonzero(free.grasp)
    c = free.position[(on[0] + on[-1]) // 2]
    box = Box((float(c[0]), float(c[1]), (float(c[2]) + 0.03) / 2), (0.06, 0.03, c[2] + 0.03))
    cfg = PlanConfig(pick=pick, place=place, obstacles=(box,), feasible=False)
    t_task = _median_s(lambda: plan_from_model(model, cfg))
    feas_cfg = dataclasses.replace(cfg, feasible=None)
    t_feasible = _median_s(lambda: plan_from_model(model, feas_cfg), repeat=3)
    whole = PlanConfig(obstacles=(box,), task="motion")
    t_whole = _median_s(lambda: plan_from_model(model, whole))
    print(f"plan, pick-and-place, one obstacle, 1 kHz: {t_task:.3f} s (target <= 0.2 s)")
    print(f"plan, pick-and-place, one obstacle, 1 kHz, feasible (default): {t_feasible:.3f} s")
    print(f"plan, whole motion, one obstacle, 1 kHz:   {t_whole:.3f} s")
    plan = plan_from_model(model, cfg)
    from dexlfd.plan.feasibility import make_feasible
    from dexlfd.robot import MujocoPandaModel

    robot = MujocoPandaModel()
    t_feas = _median_s(lambda: make_feasible(plan, robot), repeat=3)
    _, report = make_feasible(plan, robot)
    print(f"make_feasible (IK at 50 Hz, {plan.t[-1]:.1f} s plan): {t_feas:.3f} s; slowed "
          f"{report.largest:.2f}x at most")  # fmt: skip
    e = plan.event_errors.to_json()
    print(f"plan pose error at the events: pick {1e3 * e['pick_position_error_m']:.3f} mm, "
          f"{e['pick_angle_error_deg']:.3f} deg; place {1e3 * e['place_position_error_m']:.3f} "
          "mm (targets 5 mm, 3 deg)")  # fmt: skip
    _thesis_obstacle(model)
    if args.sim > 0:
        _placements(model, args.sim)
    if args.generalize:
        from pathlib import Path

        data = json.loads(Path(args.generalize).read_text())
        plans = [p for p in data["plans"] if p["ok"]]
        scaled = [p["time_scaling_largest"] for p in plans if p["time_scaling_needed"]]
        share = 100 * len(scaled) / max(len(plans), 1)
        print(f"grid: {len(plans)} plans; time scaling needed in {len(scaled)} ({share:.0f} %), "
              f"largest {max(scaled, default=1):.2f}x, "
              f"median {np.median(scaled) if scaled else 1:.2f}x")  # fmt: skip
        for m in sorted({r["payload_kg"] for r in data["runs"]}):
            err = [r["tcp_error_at_grasp_m"] for r in data["runs"]
                   if r["payload_kg"] == m and "tcp_error_at_grasp_m" in r]  # fmt: skip
            if err:
                print(f"simulated TCP error at the grasp, {m:g} kg: median "
                      f"{1e3 * np.median(err):.1f} mm, worst {1e3 * max(err):.1f} mm")  # fmt: skip


def _thesis_obstacle(model) -> None:  # type: ignore[no-untyped-def]
    """The thesis's 0.5 m obstacle on the default plan: planned? clearance?"""
    from dexlfd.errors import InvalidInput
    from dexlfd.geometry import signed_distance

    ob = Box((0.46, -0.05, 0.25), (0.10, 0.10, 0.50))
    try:
        plan = plan_from_model(model, PlanConfig(obstacles=(ob,)))
    except InvalidInput as exc:
        print(f"thesis 0.5 m obstacle: NOT planned: {exc}")
        return
    obj = plan.meta["object"]["placed_box"]
    placed = Box(obj["center"], obj["size"])
    k = int(np.flatnonzero(plan.grasp)[-1]) + 1
    top = placed.center[2] + placed.size[2] / 2
    risen = k + int(np.argmax(plan.position[k:, 2] >= top + 0.03 - 1e-4))
    print(f"thesis 0.5 m obstacle: planned, {plan.t[-1]:.2f} s; clearance from it "
          f"{1e3 * signed_distance(ob, plan.position).min():.1f} mm, from the placed "
          f"object after the rise {1e3 * signed_distance(placed, plan.position[risen:]).min():.1f}"
          " mm (margin 20 mm)")  # fmt: skip


def _tilted(deg: float) -> list:  # type: ignore[type-arg]
    """The six synthetic demonstrations with the hand turned ``deg`` about its x axis."""
    from dexlfd.rotations import quat_multiply

    a = np.radians(deg) / 2
    r = np.array([np.sin(a), 0.0, 0.0, np.cos(a)])
    out = []
    for d in pick_place_demonstrations(6, np.random.default_rng(0)):
        q = quat_multiply(d.quaternion, np.broadcast_to(r, d.quaternion.shape))
        out.append(dataclasses.replace(d, quaternion=q))
    return out


def _placements(model, n: int) -> None:  # type: ignore[no-untyped-def]
    """Placement error and tilt over ``n`` pick/place pairs, NTSM-PD, 1.2 kg."""
    from dexlfd.control import LoopConfig, make_controller, track
    from dexlfd.robot import MujocoPandaModel, PlantConfig, plan_world

    tilted = learn_from_demonstrations(_tilted(30.0), LearnConfig(), np.random.default_rng(0)).model
    pairs = [
        (None, None),
        ((0.5, -0.15, 0.12), (0.42, 0.28, 0.14)),
        ((0.40, -0.30, 0.10), (0.55, 0.10, 0.12)),
        ((0.55, 0.20, 0.12), (0.40, -0.20, 0.12)),
    ]
    cases = [("six demos, top-down", model, "top-down"),
             ("tilted 30 deg, top-down", tilted, "top-down"),
             ("tilted 30 deg, demonstrated", tilted, "demonstrated")]  # fmt: skip
    for label, m, mode in cases:
        for pick, place in pairs[:n]:
            plan = plan_from_model(m, PlanConfig(pick=pick, place=place, grasp_orientation=mode))
            plant = PlantConfig(payload_kg=1.2, obstacles=plan_world(plan))
            ro = track(plan, make_controller("ntsm-pd"), MujocoPandaModel(), plant, LoopConfig(),
                       rng=np.random.default_rng(0))  # fmt: skip
            pl = ro.placement
            print(f"placement, {label}, pick {pick or 'demonstrated'} place "
                  f"{place or 'demonstrated'}: {'ok' if pl.ok else 'FAILED'}, "
                  f"{1e3 * _num(pl.error_m):.1f} mm, tilt {_num(pl.tilt_deg):.1f} deg, "
                  f"set down {_num(pl.set_down_speed_mps):.3f} m/s")  # fmt: skip


def _num(value: float | None) -> float:
    """``value``, NaN where the placement report has none (0.0 stays 0.0)."""
    return np.nan if value is None else float(value)


if __name__ == "__main__":
    main()
