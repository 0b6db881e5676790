"""Pillars between pick and place: clearance of the hand, object and arm links; tracking.

Six synthetic demonstrations (``dexlfd synth -n 6``, seed 0), learned, planned round a
pillar from the ready pose (the thesis's 0.5 m ``box:0.46,-0.05,0.25,0.10,0.10,0.50``,
then a 0.3 m one at the same place), simulated with the default controller (ntsm-pd,
10 % model error) carrying 1.2 kg. Printed per pillar: the plan's duration, the
clearance of the hand and held object and the TCP's [mm], the arm links' least
clearance along the plan (the planned posture's and the inverse kinematics' own) with
the largest elbow swivel, the TCP tracking error at 0.5 s, at the grasp and its largest
before the grasp [mm], the arm links' least clearance in the simulation (MuJoCo's
distance from the links' collision meshes to the obstacle geom along the rollout's
joints, every 10 ms; negative: in contact) and the placement.

Also printed: whether the arm posture was planned, the wall time of ``dexlfd plan``
(with the load average: the machine is shared) and the links' clearance on the
planned posture every 10 ms; then the demo's executed plan over the 0.4 m cup (its
hand's path widened where no elbow keeps link 5 out). Results:
``benchmarks/pillar_results.md``.

Measured 2026-12-03 (armpillar branch; the posture search follows each elbow swivel
in time, see :mod:`dexlfd.robot.arm_posture`; before: armclear branch, its figures):

=================================  ===================  ===================
                                   0.5 m before/after   0.3 m before/after
=================================  ===================  ===================
arm posture planned                no / yes             yes / yes
plan [s]                           25.3 / 25.2          19.3 / 18.6
hand/object clearance [mm]         25.5 / 25.5          25.8 / 25.9
links along the plan [mm]          -22.9 / 18.2         19.2 / 20.9
elbow swivel [rad]                 0 / 1.04             1.70 / 1.55
links in simulation [mm]           -1.2 / 13.6          10.9 / 8.2
tracking at the grasp [mm]         8.6 / 2.6            3.4 / 3.4
max before the grasp [mm]          26.5 / 6.5           4.6 / 4.8
placed [mm from the place]         5.0 / 2.5, upright   4.9 / 4.6, upright
=================================  ===================  ===================

The 0.5 m pillar: with the inverse kinematics' posture link 5 meets the pillar's top
edge from the descent to the pick on (0.15 m beside it) through the grasp. The
search used to re-walk the self-motion at every sample; the shoulder passes upright
during the descent (joint 2 through zero, where the null space is joints 1 and 3
counter-rotating and moves no link) and the walks either side set off along opposite
swivels, so the swivel that clears seemed to flip sign at the pick and none was
found. Followed in time, an elbow swivelled about 1 rad during the reach keeps link
5 18 mm off the pillar (2 mm inside the 20 mm margin, said) and the controllers
following it keep 13.6 mm in simulation. Planning takes about 10-15 s longer with an
obstacle near the arm (the self-motion followed at 20 Hz over the whole plan).
Without obstacles a plan has no posture and is the same, array for array.
"""

from __future__ import annotations

import os
import tempfile
import time
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


PILLARS = ("box:0.46,-0.05,0.25,0.10,0.10,0.50", "box:0.46,-0.05,0.15,0.10,0.10,0.30")


def run(folder: Path, pillar: str = PILLARS[0]) -> None:
    """Synthesize, learn, plan round ``pillar``, simulate; print the figures."""
    if not (folder / "model.npz").exists():
        assert main(["synth", "-n", "6", "-o", str(folder / "demos"), "-q"]) == 0
        demos = sorted(str(p) for p in (folder / "demos").glob("*.npz"))
        assert main(["learn", *demos, "-o", str(folder / "model.npz"), "-q"]) == 0
    print(pillar)
    plan_path, out = folder / "plan.npz", folder / "r.npz"
    t0 = time.perf_counter()
    rc = main(["plan", str(folder / "model.npz"), "--obstacle", pillar, "-o", str(plan_path),
               "-q"])  # fmt: skip
    wall = time.perf_counter() - t0
    if rc != 0:
        print(f"plan exit {rc} (refused)")
        return
    plan = load_plan(plan_path)
    print(f"dexlfd plan took {wall:.1f} s (wall; load average {os.getloadavg()[0]:.1f})")
    c = plan.meta["clearance"]
    print(f"plan {plan.t[-1]:.1f} s; clearance hand/object {1e3 * c['min_m']:.1f} mm, "
          f"TCP {1e3 * min(c['tcp_per_obstacle_min_m']):.1f} mm")  # fmt: skip
    a = getattr(plan, "arm_posture", None)  # absent before the planned posture
    if a is not None:
        print(f"arm posture planned: {a.planned}; arm links along the plan: "
              f"{1e3 * a.min_clearance:.1f} mm ({a.link}, t={a.t_s:.2f} s), IK posture "
              f"{1e3 * a.default_min_clearance:.1f} mm, swivel <= {a.max_swivel:.2f} rad, "
              f"joints at {100 * a.joint_velocity_ratio:.0f} % of their limits")  # fmt: skip
    if plan.joint_posture is not None:
        text, _ = _arm(plan.joint_posture[::10], plan.obstacles)
        print(f"arm links on the planned posture, every 10 ms: {text}")
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
    from dexlfd.robot.arm_clearance import HAND_BODIES, arm_clearance

    hand, _ = arm_clearance(ro.q[::10], plan.obstacles, HAND_BODIES)
    print(f"hand and fingers in simulation: {1e3 * hand.min():.1f} mm")
    print("placement", ro.placement)


def demo_cup() -> None:
    """The demo's executed plan over the 0.4 m cup: the links, the widened hand's path."""
    from dexlfd.apps.demo import DemoConfig
    from dexlfd.apps.demo_plan import cup, task_plan
    from dexlfd.datasets import pick_place_demonstrations
    from dexlfd.learn import LearnConfig, learn_from_demonstrations

    demos = pick_place_demonstrations(6, np.random.default_rng(0))
    model = learn_from_demonstrations(
        demos, LearnConfig(n_components=8), np.random.default_rng(0)
    ).model
    cfg = DemoConfig()
    t0 = time.perf_counter()
    plan = task_plan(model, cfg)  # its warnings say what was widened
    a = plan.arm_posture
    assert a is not None
    print(f"demo cup: planned in {time.perf_counter() - t0:.1f} s (load "
          f"{os.getloadavg()[0]:.1f}); plan {plan.t[-1]:.1f} s, links {1e3 * a.min_clearance:.1f}"
          f" mm ({a.link}), posture planned {a.planned}; TCP max z "
          f"{plan.position[:, 2].max():.3f} m over the {cfg.executed_height} m cup "
          f"{cup(cfg, cfg.executed_height).to_dict()}")  # fmt: skip


if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as tmp:
        for box in PILLARS:
            run(Path(tmp), box)
    demo_cup()
