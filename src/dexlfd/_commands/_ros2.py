"""``--ros2-publish`` of ``plan`` and ``simulate``: the plan and the robot state on ROS 2 topics.

Examples
--------
    dexlfd plan model.npz -o plan.npz --ros2-publish
    ROS_DOMAIN_ID=7 dexlfd simulate plan.npz -o rollout.npz --ros2-publish --ros2-rate-hz 50
"""

from __future__ import annotations

import argparse
import logging
import time
from typing import Any

import numpy as np

from dexlfd._commands._common import bounded_float

logger = logging.getLogger(__name__)

MAX_ROS2_RATE_HZ = 1000.0  # [Hz] the control loop's rate


def add_ros2_arguments(p: argparse.ArgumentParser, *, states: bool) -> None:
    """``--ros2-publish`` and ``--ros2-rate-hz``."""
    what = "the plan" + (
        " and, while simulating, the robot state (/joint_states)" if states else ""
    )
    p.add_argument(
        "--ros2-publish", action="store_true",
        help=f"publish {what} as ROS 2 messages over DDS (trajectory_msgs/JointTrajectory, "
        "geometry_msgs/PoseStamped, sensor_msgs/JointState; domain ROS_DOMAIN_ID, default "
        "0; no ROS installation needed: pip install 'dexlfd[ros2]')",
    )  # fmt: skip
    p.add_argument(
        "--ros2-rate-hz", type=bounded_float(0.0, MAX_ROS2_RATE_HZ, lo_open=True), default=100.0,
        help=f"messages per second of plan/robot time on the pose and joint-state topics, "
        f"(0, {MAX_ROS2_RATE_HZ:g}] (default: %(default)s)",
    )  # fmt: skip


def plan_joint_path(plan: Any, rate_hz: float, model: Any = None) -> tuple[Any, Any]:
    """The plan's inverse kinematics at ``rate_hz``: times (m,) [s], joints (m, 7) [rad]."""
    from dexlfd.control.reference import joint_reference, resample_plan
    from dexlfd.panda import Q_READY
    from dexlfd.robot import MujocoPandaModel, solve_ik

    model = model or MujocoPandaModel()
    ref = resample_plan(plan, 1.0 / rate_hz)
    q0 = solve_ik(model, ref.p[0], ref.R[0], Q_READY).q
    q, _ = joint_reference(model, ref, q0)
    return plan.t[0] + ref.t, q


def publish_plan(plan: Any, rate_hz: float, publisher: Any = None) -> None:
    """Publish ``plan`` (its JointTrajectory by IK and its poses) once."""
    from dexlfd.io.ros2 import Ros2Publisher

    path = plan_joint_path(plan, rate_hz)
    own = publisher is None
    pub = Ros2Publisher() if own else publisher
    try:
        n = pub.publish_plan(plan, joint_path=path, t0=time.time(), rate_hz=rate_hz)
        logger.info(
            "ROS 2 (domain %d): published the plan, %d messages (%d joint points)",
            pub.domain_id, n, len(path[1]),
        )  # fmt: skip
    finally:
        if own:
            pub.close()


class StateTap:
    """The controller's model, passed through; publishes the state it is asked about.

    The tracking loop asks the model for its terms at the measured state once per
    tick (after two calls at start); every ``every``-th tick that state goes to
    ``/joint_states``, stamped with the simulated time, while the simulation runs.
    """

    def __init__(self, model: Any, publisher: Any, rate_hz: float, loop_rate_hz: float) -> None:
        self._model, self._pub = model, publisher
        self._every = max(1, int(round(loop_rate_hz / rate_hz)))
        self._dt = 1.0 / loop_rate_hz
        self._calls = 0
        self.published = 0

    def __getattr__(self, name: str) -> Any:
        return getattr(self._model, name)

    def terms(self, q: Any, dq: Any) -> Any:
        """The wrapped model's terms; every ``every``-th tick also publishes (q, dq)."""
        terms = self._model.terms(q, dq)
        tick = self._calls - 2  # the session asks twice before its first tick
        self._calls += 1
        if tick >= 0 and tick % self._every == 0:
            self._pub.publish_state(tick * self._dt, np.asarray(q), np.asarray(dq))
            self.published += 1
        return terms


def arm_state_listener(publisher: Any, rate_hz: float) -> Any:
    """``FrankaArm.state_listener``: the arm's state on ``/joint_states`` at ``rate_hz``."""
    period = 1.0 / rate_hz
    due = [0.0]

    def listener(t: float, state: Any) -> None:
        if t + 1e-9 >= due[0]:
            publisher.publish_state(t, state.q, state.dq, state.tau_J)
            due[0] = t + period

    return listener
