"""A plan resampled at the control rate: the references a controller tracks."""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.control.base import Reference
from dexlfd.errors import InvalidInput
from dexlfd.io import Plan
from dexlfd.panda import N_JOINTS, check_workspace
from dexlfd.panda_ik import solve_ik
from dexlfd.robot.robot_model import RobotModel
from dexlfd.rotations import matrix_from_quat, quat_sign_continuous
from dexlfd.trajectory import resample

__all__ = ["ReferenceTrajectory", "check_plan_workspace", "joint_reference", "resample_plan"]


@dataclass(frozen=True, slots=True)
class ReferenceTrajectory:
    """References on a uniform grid (n samples at ``dt``)."""

    t: FloatArray  # (n,) [s], starts at 0
    p: FloatArray  # (n, 3) [m]
    v: FloatArray  # (n, 3) [m/s]
    a: FloatArray  # (n, 3) [m/s²]
    quat: FloatArray  # (n, 4) x, y, z, w
    R: FloatArray  # (n, 3, 3)
    w: FloatArray  # (n, 3) [rad/s]
    gripper: FloatArray  # (n,) [m]
    # the plan's posture (n, 7) [rad] and its rate [rad/s]; None: the plan has none
    q_null: FloatArray | None = None
    dq_null: FloatArray | None = None

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.t.shape[0])

    def reference(
        self, k: int, q: FloatArray | None = None, dq: FloatArray | None = None
    ) -> Reference:
        """Sample ``k`` as a controller's :class:`~dexlfd.control.base.Reference`.

        ``q``, ``dq`` (n, 7) are the joint reference of :func:`joint_reference`
        (for joint-space laws), or None.
        """
        return Reference(
            self.p[k], self.v[k], self.a[k], self.R[k], self.w[k],
            None if q is None else q[k],
            None if dq is None else dq[k],
            None if self.q_null is None else self.q_null[k],
            None if self.dq_null is None else self.dq_null[k],
        )  # fmt: skip


def check_plan_workspace(plan: Plan) -> None:
    """Reject a plan with a TCP position the Panda cannot take.

    The rule is :func:`dexlfd.panda.check_workspace`'s.

    Raises
    ------
    InvalidInput
        Naming the first offending sample, its time and the rule it breaks.
    """
    check_workspace(plan.position, "plan position", plan.t)


def resample_plan(plan: Plan, dt: float) -> ReferenceTrajectory:
    """Interpolate a plan to a uniform grid of step ``dt`` [s] starting at 0.

    Positions, velocities, accelerations, angular velocity and gripper are
    interpolated linearly; orientations by spherical linear interpolation
    (sign-continuous first); the planned posture (``joint_posture``, if any) linearly,
    with its rate.
    """
    from scipy.spatial.transform import Rotation, Slerp

    if not (np.isfinite(dt) and dt > 0):
        raise InvalidInput(f"dt must be > 0, got {dt!r}")
    t0 = plan.t - plan.t[0]
    n = int(np.floor(t0[-1] / dt + 1e-9)) + 1
    if n < 2:
        raise InvalidInput(f"plan lasts {t0[-1]:.4f} s: shorter than one control step {dt} s")
    # k * dt rounds one step past the plan's end for many durations (5.1 s: 5100 *
    # 0.001 = 5.1000000000000005 > 5.1); the last sample is the plan's end
    t = cast(FloatArray, np.minimum(np.arange(n) * dt, t0[-1]))

    def lin(x: FloatArray) -> FloatArray:
        return resample(t, t0, x)

    q = quat_sign_continuous(plan.quaternion)
    quat = Slerp(t0, Rotation.from_quat(q))(t).as_quat()
    quat = quat_sign_continuous(quat)
    q_null = dq_null = None
    if plan.joint_posture is not None:
        q_null = lin(plan.joint_posture)
        dq_null = resample(t, t0, np.gradient(plan.joint_posture, t0, axis=0))
    return ReferenceTrajectory(
        t=t,
        p=lin(plan.position),
        v=lin(plan.velocity),
        a=lin(plan.acceleration),
        quat=quat,
        R=matrix_from_quat(quat),
        w=lin(plan.angular_velocity),
        gripper=lin(plan.gripper),
        q_null=q_null,
        dq_null=dq_null,
    )


def joint_reference(
    model: RobotModel, ref: ReferenceTrajectory, q0: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Joint positions (n, 7) [rad] and velocities (n, 7) [rad/s] along ``ref`` by IK.

    Each sample is solved from the previous one (warm start), so the branch
    stays continuous; with a planned posture (``ref.q_null``) from that posture, so
    the joints follow the elbow the plan chose.
    """
    qs = np.empty((ref.n, N_JOINTS))
    q = q0
    for k in range(ref.n):
        seed = q if ref.q_null is None else ref.q_null[k]
        q = solve_ik(model, ref.p[k], ref.R[k], seed, max_iter=50).q
        qs[k] = q
    dqs = cast(FloatArray, np.gradient(qs, ref.t, axis=0))
    return qs, dqs
