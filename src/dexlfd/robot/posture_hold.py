"""Where the controllers may hold the arm's own posture instead of the planned one.

With an obstacle the plan carries a joint posture that the task-space controllers
follow in their null space. Near the pick and the place it can swing fast while the
hand barely moves: the inverse kinematics' own elbow near a joint limit (bagging's pick,
0.29 m from the base: joint 4 at -3.04 rad, 0.03 rad from its limit) turns joints 1, 3,
5 and 7 by 0.5-0.7 rad in half a second during a 5 cm descent. Following it drags the
arm through its self-motion against the joints' friction, which is in no controller's
model: the hand stood 8.8 deg off its reference at the grasp (the TCP 3.3 mm), the
object was gripped askew and set down on an edge (0.086 m/s). Holding the arm's own
posture there (:class:`dexlfd.control.posture_hold.PostureHold`): 3.1 deg, 0.2 mm,
0.065 m/s. The arm's posture is only known as it runs, so the plan cannot hold it
itself: a planned posture held at its value on entering (not the arm's) set the
object down at 0.129 m/s, and one carried by the inverse kinematics from there moved
at 3.6 rad/s (the safety stop).

:func:`held_windows` gives the plan's ``arm_posture.hold_s``: the spans within
:data:`HOLD_RADIUS` of where the gripper closes or opens (:func:`hold_windows`), each
kept only where the posture the plan has on entering it, carried along the span by the
inverse kinematics and through the controllers' :data:`BLEND_S` back to the planned
posture after it, keeps every link ``margin`` from the obstacles (checked every
:data:`CHECK_S`). A swivel chosen for a pillar beside the pick may still be turning
within the radius (the 0.3 m pillar), or the blend back may take a link near it (the
0.5 m pillar: link 5 to 8 mm): that span is not held, the planned posture is followed.
"""

from __future__ import annotations

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.geometry import Obstacle
from dexlfd.io import Plan
from dexlfd.panda_ik import KinematicModel, solve_ik
from dexlfd.robot.arm_clearance import arm_clearance
from dexlfd.rotations import matrix_from_quat

__all__ = ["BLEND_S", "CHECK_S", "HOLD_RADIUS", "held_windows", "hold_windows"]

HOLD_RADIUS = 0.06  # [m] the hand within this of where the gripper closes or opens
BLEND_S = 1.0  # [s] the controllers' blend back from the held posture to the plan's
CHECK_S = 0.05  # [s] the held posture's links are checked this often


def hold_windows(
    t: FloatArray, p: FloatArray, closed: BoolArray, radius: float = HOLD_RADIUS
) -> tuple[tuple[float, float], ...]:
    """The spans [s] round each change of ``closed`` where the TCP stays near it.

    ``t`` (n,) [s], ``p`` (n, 3) the TCP [m], ``closed`` (n,) the gripper's schedule.
    Each span is the contiguous run of samples, round the sample where the gripper
    closes or opens, whose TCP is within ``radius`` [m] of the TCP there.
    """
    closed = np.asarray(closed, dtype=bool)
    changes = np.flatnonzero(closed[1:] != closed[:-1]) + 1
    out: list[tuple[float, float]] = []
    for k in changes:
        far = np.linalg.norm(p - p[k], axis=1) >= radius
        before = np.flatnonzero(far[:k])
        after = np.flatnonzero(far[k:])
        a = int(before[-1]) + 1 if before.size else 0
        b = k + int(after[0]) - 1 if after.size else t.shape[0] - 1
        out.append((float(t[a]), float(t[b])))
    return tuple(out)


def held_windows(
    plan: Plan, posture: FloatArray, obstacles: tuple[Obstacle, ...], margin: float,
    model: KinematicModel,
) -> tuple[tuple[float, float], ...]:  # fmt: skip
    """The :func:`hold_windows` of ``plan`` [s from its start] where holding is clear.

    ``posture`` (n, 7) [rad] is the planned posture at the plan's samples; the plan's
    ``grasp`` its schedule (no schedule: no span). In each span the posture on entering
    is carried along the TCP poses by the inverse kinematics (each sample from the
    last) and, through the :data:`BLEND_S` after it, taken where the inverse kinematics
    puts the blended posture; the span is kept when every link stays ``margin`` [m]
    from every obstacle throughout.
    """
    if plan.grasp is None:
        return ()
    t = plan.t - plan.t[0]
    wins = hold_windows(t, plan.position, plan.grasp)
    if not obstacles:
        return wins
    R = matrix_from_quat(plan.quaternion)
    step = max(1, round(CHECK_S / float(np.median(np.diff(t))))) if t.shape[0] > 1 else 1
    kept = []
    for t0, t1 in wins:
        a, b, c = (int(k) for k in np.searchsorted(t, [t0, t1, t1 + BLEND_S]))
        held, qs = posture[a], []
        for k in range(a, min(c, t.shape[0] - 1) + 1, step):
            held = solve_ik(model, plan.position[k], R[k], held, max_iter=50).q
            w = min(max((t[k] - t1) / BLEND_S, 0.0), 1.0)
            seed = held + w * w * (3.0 - 2.0 * w) * (posture[k] - held)
            qs.append(held if k <= b else solve_ik(model, plan.position[k], R[k], seed).q)
        per, _ = arm_clearance(np.array(qs), obstacles)
        if float(per.min()) >= margin:
            kept.append((t0, t1))
    return tuple(kept)
