"""The arm keeps its own posture while the hand grasps and sets down: :class:`PostureHold`.

A plan with a planned posture (``joint_posture``) names, in ``arm_posture.hold_s``, the
spans round its grasps and releases where the controllers hold the arm's own posture
instead (why, and how those spans are chosen with the links kept clear:
:mod:`dexlfd.robot.posture_hold`). Within a span the null-space reference is the arm's
measured posture on entering it, held still with no rate: no self-motion is commanded
while the hand is slow and precise, and the spring still keeps the arm from drifting
along its self-motion (no null-space torque at all let the model's gravity error drift
it: 2.2 mm). After the span the reference returns to the plan's posture over
:data:`~dexlfd.robot.posture_hold.BLEND_S` (a smoothstep), while the hand carries or
retreats. The controller decides nothing: it holds where the plan says.
:func:`hold_where_planned` wraps a controller for a plan, or for a piece of it (the real
arm runs a plan piece by piece between the gripper's events, each a plan on its own
clock: :meth:`Plan.part <dexlfd.io.Plan.part>`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from dexlfd._types import FloatArray
from dexlfd.control.base import Controller, Reference, RobotState
from dexlfd.io import Plan
from dexlfd.robot.posture_hold import BLEND_S
from dexlfd.robot.robot_model import ModelTerms

__all__ = ["HoldState", "PostureHold", "hold_where_planned"]


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


def hold_where_planned(controller: Controller, plan: Plan) -> Controller:
    """``controller`` holding the arm's own posture where ``plan`` says (``hold_s``).

    The spans are on the plan's clock, from its start; a piece of a plan run on its
    own clock is a plan of its own with them shifted (:meth:`Plan.part
    <dexlfd.io.Plan.part>`). ``controller`` itself where the plan has no planned
    posture (``joint_posture``) or no span.
    """
    windows = () if plan.arm_posture is None else plan.arm_posture.hold_s
    if plan.joint_posture is None or not windows:
        return controller
    return PostureHold(controller, tuple(windows))
