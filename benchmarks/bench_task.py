"""Pick-and-place planning: learn with events, plan with one obstacle, pose at the events.

Times (median of repeats after a warm-up, this machine, shared):

- ``learn`` on six synthetic demonstrations with automatic K (target <= 1 s), events
  included;
- ``plan_from_model`` of a pick-and-place task with one obstacle over the carry
  (target <= 0.2 s), and of the whole motion with the same obstacle;
- ``make_feasible`` on the task plan (the IK joint check ``dexlfd plan`` adds).

Then the plan's pose error at the events (the reference at the grasp and release
switch against the asked pick and place) and, with ``--generalize JSON`` (written by
``bench_generalize.py``), the simulated TCP error at the grasp and how often time
scaling was needed over the grid, with the largest slow-down.

    python benchmarks/bench_task.py [--generalize bench-generalize/generalize.json]
"""

from __future__ import annotations

import argparse
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
    cfg = PlanConfig(pick=pick, place=place, obstacles=(box,))
    t_task = _median_s(lambda: plan_from_model(model, cfg))
    whole = PlanConfig(obstacles=(box,), task="motion")
    t_whole = _median_s(lambda: plan_from_model(model, whole))
    print(f"plan, pick-and-place, one obstacle, 1 kHz: {t_task:.3f} s (target <= 0.2 s)")
    print(f"plan, whole motion, one obstacle, 1 kHz:   {t_whole:.3f} s")
    plan = plan_from_model(model, cfg)
    from dexlfd.control.feasibility import make_feasible
    from dexlfd.robot import MujocoPandaModel

    robot = MujocoPandaModel()
    t_feas = _median_s(lambda: make_feasible(plan, robot), repeat=3)
    _, report = make_feasible(plan, robot)
    print(f"make_feasible (IK at 50 Hz, {plan.t[-1]:.1f} s plan): {t_feas:.3f} s; slowed "
          f"{report['largest']:.2f}x at most")  # fmt: skip
    e = plan.meta["event_errors"]
    print(f"plan pose error at the events: pick {1e3 * e['pick_position_error_m']:.3f} mm, "
          f"{e['pick_angle_error_deg']:.3f} deg; place {1e3 * e['place_position_error_m']:.3f} "
          "mm (targets 5 mm, 3 deg)")  # fmt: skip
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


if __name__ == "__main__":
    main()
