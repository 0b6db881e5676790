"""The thesis's 0.5 m pillar between pick and place: clearance of the hand and object, tracking.

Six synthetic demonstrations (``dexlfd synth -n 6``, seed 0), learned, planned round the
pillar ``box:0.46,-0.05,0.25,0.10,0.10,0.50`` from the ready pose, simulated with the
default controller (ntsm-pd, 10 % model error) carrying 1.2 kg. Printed: the plan's
duration, the clearance of the hand and held object and the TCP's [mm], the TCP
tracking error at 0.5 s, at the grasp and its largest before the grasp [mm], where the
largest came from, and the placement.

Measured (planfix branch, Dec 2026): plan 24.8 s; hand/object clearance 25.4 mm (TCP
63.1 mm); tracking 2.7 mm at 0.5 s, 8.7 mm at the grasp, at most 26.5 mm before it
(at 4.5 s the forearm, link 5, rubs the pillar's top edge while the hand comes down
beside it: the planner's envelope holds the hand, not the forearm); placed 5.1 mm from
the place, upright. Before (TCP-only clearance, reach as fast as its distance asked):
22.5 mm reported (the TCP's), 29.5 mm off at 0.5 s, 29.6 mm at the grasp, safety stop
at 7.87 s (the object's bottom on the pillar's top), exit 1.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from dexlfd.cli import main
from dexlfd.io import load_plan, load_rollout


def _arm(qs: np.ndarray, obstacles: tuple) -> str:
    """The arm links' least clearance [mm] from the obstacles, and which link, when."""
    from dexlfd.robot.arm_clearance import arm_clearance

    per, worst = arm_clearance(qs, obstacles)
    i = int(np.argmin(per.min(axis=1)))
    return f"{1e3 * per[i].min():.1f} mm ({worst[i][0]}, obstacle {i})", worst[i][1]


def run(folder: Path) -> None:
    assert main(["synth", "-n", "6", "-o", str(folder / "demos"), "-q"]) == 0
    demos = sorted(str(p) for p in (folder / "demos").glob("*.npz"))
    assert main(["learn", *demos, "-o", str(folder / "model.npz"), "-q"]) == 0
    pillar = "box:0.46,-0.05,0.25,0.10,0.10,0.50"
    plan_path, out = folder / "plan.npz", folder / "r.npz"
    rc = main(["plan", str(folder / "model.npz"), "--obstacle", pillar, "-o", str(plan_path),
               "-q"])  # fmt: skip
    if rc != 0:
        print(f"plan exit {rc} (refused)")
        return
    plan = load_plan(plan_path)
    c = plan.meta["clearance"]
    print(f"plan {plan.t[-1]:.1f} s; clearance hand/object {1e3 * c['min_m']:.1f} mm, "
          f"TCP {1e3 * min(c['tcp_per_obstacle_min_m']):.1f} mm")  # fmt: skip
    a = getattr(plan, "arm_posture", None)  # absent before the planned posture
    if a is not None:
        print(f"arm links along the plan: {1e3 * a.min_clearance:.1f} mm ({a.link}, t={a.t_s:.2f}"
              f" s), IK posture {1e3 * a.default_min_clearance:.1f} mm, swivel <= "
              f"{a.max_swivel:.2f} rad")  # fmt: skip
    rc = main(["simulate", str(plan_path), "--payload-kg", "1.2", "-q", "-o", str(out)])
    ro = load_rollout(out)
    err = np.linalg.norm(ro.ee_position - ro.ref_position, axis=1)
    t_g = ro.grasp_schedule.grasp_t if ro.grasp_schedule else None
    t_g = float(ro.t[-1]) if t_g is None else t_g
    before = ro.t < t_g
    k_max = int(np.argmax(np.where(before, err, 0.0)))
    print(f"simulate exit {rc}; tracking {1e3 * err[np.searchsorted(ro.t, 0.5)]:.1f} mm at "
          f"0.5 s, {1e3 * err[np.searchsorted(ro.t, t_g)]:.1f} mm at the grasp ({t_g:.2f} s), "
          f"max {1e3 * err[k_max]:.1f} mm before it (t={ro.t[k_max]:.2f} s)")  # fmt: skip
    text, k = _arm(ro.q[::10], plan.obstacles)
    print(f"arm links in simulation: {text} at t={ro.t[::10][k]:.2f} s")
    print("placement", ro.placement)


if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as tmp:
        run(Path(tmp))
