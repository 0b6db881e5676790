"""The arm keeps its own posture while the hand grasps and sets down: :class:`PostureHold`.

With an obstacle the plan carries a joint posture (its ``joint_posture``: the inverse
kinematics' elbow carried along the plan, or a swivel that keeps the links clear) and
the task-space laws follow it in their null space. Near the pick and the place that
posture can swing fast while the hand barely moves: the inverse kinematics' own elbow
near a joint limit (bagging's pick, 0.29 m from the base: joint 4 at -3.04 rad, within
0.03 rad of its limit) turns joints 1, 3, 5 and 7 by 0.5-0.7 rad in half a second during
a 5 cm descent. The null-space spring lags it by up to 0.8 rad and drags the arm through
its self-motion during the grasp. The projection is dynamically consistent
(:func:`~dexlfd.control.base.nullspace_torque`), but the joints' friction is in no
model: moving the wrist joints against it turned the hand 8.8 deg off its reference at
the grasp (the TCP 3.3 mm off), the object was gripped askew and set down on an edge
(0.086 m/s; held: 3.1 deg, 0.2 mm, 0.065 m/s; without friction the planned posture
costs nothing, 0.5 mm).

So within :data:`HOLD_RADIUS` of where the gripper closes or opens, the null-space
reference is the arm's own posture when the hand came that near (measured, held still
with no rate): no self-motion is commanded while the hand is slow and precise, and the
spring still keeps the arm from drifting along its self-motion (no null-space torque at
all let the model's gravity error drift it: 2.2 mm). After the window the reference
returns to the plan's posture over :data:`BLEND_S` (a smoothstep), while the hand
carries or retreats. A posture chosen for clearance near the pick (a swivel for a
pillar beside it) may still be turning within the radius, or the blend back may take a
link near the obstacle (the 0.5 m pillar: link 5 to 8 mm of it): a window is held only
where the posture the plan has on entering it, carried along the window by the inverse
kinematics and through the blend (every :data:`CHECK_S`), keeps every link the plan's
margin from its obstacles (:func:`held_windows`); elsewhere the plan's posture is
followed, as before.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.control.base import Controller, Reference, RobotState
from dexlfd.geometry import Obstacle
from dexlfd.panda_ik import solve_ik
from dexlfd.robot.robot_model import ModelTerms, RobotModel

if TYPE_CHECKING:
    from dexlfd.control.reference import ReferenceTrajectory

__all__ = [
    "BLEND_S",
    "CHECK_S",
    "HOLD_RADIUS",
    "HoldState",
    "PostureHold",
    "held_windows",
    "hold_windows",
]

HOLD_RADIUS = 0.06  # [m] the hand within this of where the gripper closes or opens
BLEND_S = 1.0  # [s] back from the held posture to the plan's after a window
CHECK_S = 0.05  # [s] the held posture's links are checked this often along a window
DEFAULT_MARGIN = 0.02  # [m] the links' margin when the plan does not say its own


def hold_windows(
    t: FloatArray, p: FloatArray, closed: BoolArray, radius: float = HOLD_RADIUS
) -> tuple[tuple[float, float], ...]:
    """The spans [s] round each change of ``closed`` where the reference stays near it.

    ``t`` (n,) [s], ``p`` (n, 3) the reference TCP [m], ``closed`` (n,) the gripper's
    schedule. Each span is the contiguous run of samples, round the sample where the
    gripper closes or opens, whose TCP is within ``radius`` [m] of the TCP there.
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
    ref: ReferenceTrajectory, closed: BoolArray, model: RobotModel,
    obstacles: tuple[Obstacle, ...], margin: float | None = None,
) -> tuple[tuple[float, float], ...]:  # fmt: skip
    """The :func:`hold_windows` of ``ref`` where holding the posture keeps the links clear.

    In each window the posture the plan has at its start (``ref.q_null``) is carried
    along the window's TCP poses by the inverse kinematics (each sample from the last:
    the self-motion held) every :data:`CHECK_S`, and through the :data:`BLEND_S` after
    it the arm is taken where the inverse kinematics puts the blended posture; the
    window is kept when every link stays ``margin`` [m] (the plan's, default
    :data:`DEFAULT_MARGIN`) from every obstacle throughout.
    """
    from dexlfd.robot.arm_clearance import arm_clearance

    wins = hold_windows(ref.t, ref.p, closed)
    if ref.q_null is None or not obstacles:
        return wins
    margin = DEFAULT_MARGIN if margin is None else margin
    dt = float(ref.t[1] - ref.t[0]) if ref.n > 1 else CHECK_S
    step = max(1, round(CHECK_S / dt))
    kept = []
    for t0, t1 in wins:
        a, b, c = np.searchsorted(ref.t, [t0, t1, t1 + BLEND_S])
        held, qs = ref.q_null[a], []
        for k in range(int(a), min(int(c), ref.n - 1) + 1, step):
            held = solve_ik(model, ref.p[k], ref.R[k], held, max_iter=50).q
            w = min(max((ref.t[k] - t1) / BLEND_S, 0.0), 1.0)
            seed = held + w * w * (3.0 - 2.0 * w) * (ref.q_null[k] - held)
            qs.append(held if k <= b else solve_ik(model, ref.p[k], ref.R[k], seed, max_iter=50).q)
        per, _ = arm_clearance(np.array(qs), obstacles)
        if float(per.min()) >= margin:
            kept.append((t0, t1))
    return tuple(kept)


@dataclass(frozen=True, slots=True)
class HoldState:
    """The wrapped law's state, the held posture [rad] and when its window ended [s]."""

    inner: Any
    hold: FloatArray | None = None
    left_t: float | None = None


@dataclass(frozen=True, slots=True)
class PostureHold:
    """Wrap ``inner``: within ``windows`` [s] its null-space reference is the held posture.

    Only a reference with a planned posture (``q_null``) is changed; the name, the
    joint reference and the gains are ``inner``'s.
    """

    inner: Controller
    windows: tuple[tuple[float, float], ...]
    blend_s: float = BLEND_S
    name: str = field(default="", init=False)
    needs_joint_reference: bool = field(default=False, init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "name", self.inner.name)
        object.__setattr__(self, "needs_joint_reference", self.inner.needs_joint_reference)

    def init(self, robot_state: RobotState, terms: ModelTerms) -> HoldState:
        """The wrapped law's state; nothing held yet."""
        return HoldState(self.inner.init(robot_state, terms))

    def step(
        self, ctrl_state: HoldState, robot_state: RobotState, reference: Reference,
        terms: ModelTerms,
    ) -> tuple[FloatArray, HoldState]:  # fmt: skip
        """The wrapped law's torque, its null-space reference held within a window."""
        st = ctrl_state
        hold, left_t = st.hold, st.left_t
        q_plan = reference.q_null
        if q_plan is not None:
            t = robot_state.t
            if any(a <= t <= b for a, b in self.windows):
                hold = robot_state.q.copy() if hold is None else hold
                left_t = None
                reference = dataclasses.replace(reference, q_null=hold, dq_null=None)
            elif hold is not None:
                left_t = t if left_t is None else left_t
                w = (t - left_t) / self.blend_s if self.blend_s > 0 else 1.0
                if w >= 1.0:
                    hold = left_t = None
                else:
                    s = w * w * (3.0 - 2.0 * w)  # smoothstep: no step in the torque
                    q_null = hold + s * (q_plan - hold)
                    reference = dataclasses.replace(reference, q_null=q_null, dq_null=None)
        tau, inner = self.inner.step(st.inner, robot_state, reference, terms)
        return tau, HoldState(inner, hold, left_t)

    def describe(self) -> dict[str, Any]:
        """The wrapped law's name and gains, and the windows [s] of the held posture."""
        out = dict(self.inner.describe())
        out["posture_hold_s"] = [list(w) for w in self.windows]
        return out
