"""End shaping: the plan ends exactly at the goal pose, at rest.

The modified DMP reaches its goal only as ``t -> inf``: at ``t = T`` the fading phase
terms and the fit leave a residual (0.26 % of the goal change, more for a noisy
mean), and a learned mean cut off mid-motion hands its last velocity on. Everything
here acts over the last ``END_WINDOW`` of normalised time through one window
``W(tb)`` that falls 1 -> 0 with the minimum-jerk profile
(:func:`dexlfd.trajectory.minimum_jerk`):

* :func:`end_window` -- ``W`` and its derivatives; the obstacle displacement is
  faded out with it so the goal is still reached;
* :func:`blend_out_residual` -- the position residual is blended in by ``1 - W``;
* :func:`rest_correction` -- quintics that zero the end velocity and acceleration;
* :func:`settle_at_goal` -- both, in order, on a position path;
* :func:`blend_orientation_goal` -- the quaternion's residual rotation, the same way.

Derivatives are per normalised time ``tb = t / T`` unless a docstring says otherwise.
"""

from __future__ import annotations

import logging

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.plan.quaternion_dmp import _rotvec_between
from dexlfd.rotations import matrix_from_quat, quat_exp, quat_multiply, quat_sign_continuous
from dexlfd.trajectory import minimum_jerk

__all__ = [
    "END_WINDOW",
    "blend_orientation_goal",
    "blend_out_residual",
    "end_window",
    "rest_correction",
    "settle_at_goal",
]

logger = logging.getLogger(__name__)

END_WINDOW = 0.1  # the end shaping acts over the last 10 % of normalised time
_GOAL_WARN = 5e-3  # [m] a larger DMP end residual is blended out with a warning

Window = tuple[FloatArray, FloatArray, FloatArray]
Path = tuple[FloatArray, FloatArray, FloatArray]  # x, x', x'' (n, 3) per normalised time


def end_window(tb: FloatArray) -> Window:
    """Window ``W`` 1 -> 0 (minimum jerk) over the last ``END_WINDOW`` of ``tb``.

    Returns ``W`` and its first two derivatives per normalised time.
    """
    S, dS, ddS = minimum_jerk((tb - (1.0 - END_WINDOW)) / END_WINDOW)
    return 1.0 - S, -dS / END_WINDOW, -ddS / END_WINDOW**2


def blend_out_residual(
    x: FloatArray, xd: FloatArray, xdd: FloatArray, goal: FloatArray, window: Window
) -> tuple[FloatArray, FloatArray, FloatArray, float]:
    """Subtract ``(1 - W) (x[-1] - goal)`` so the path ends exactly at ``goal``.

    Returns the corrected ``x, xd, xdd`` (n, 3) and the residual's norm [m]
    (warned about above 5 mm: a noisy or coarse model).
    """
    win, dwin, ddwin = window
    residual = x[-1] - goal
    end_err = float(np.linalg.norm(residual))
    if end_err > _GOAL_WARN:
        logger.warning(
            "the DMP ends %.2f mm from the goal (noisy or coarse model?); blended out over "
            "the last %d %% of the motion",
            1e3 * end_err,
            int(100 * END_WINDOW),
        )
    x = x - residual[None, :] * (1.0 - win)[:, None]
    xd = xd + residual[None, :] * dwin[:, None]
    xdd = xdd + residual[None, :] * ddwin[:, None]
    return x, xd, xdd, end_err


def rest_correction(
    tb: FloatArray, v_end: FloatArray, a_end: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Correction over the last ``END_WINDOW`` that zeroes the final velocity/acceleration.

    Quintics in ``u`` with value, slope and curvature 0 at the window's start and
    value 0 at its end: ``p_v = -4u³ + 7u⁴ - 3u⁵`` (slope 1 at u = 1) and
    ``p_a = (u³ - 2u⁴ + u⁵)/2`` (curvature 1 at u = 1). Adding
    ``-L v_end p_v - L² a_end p_a`` (L = window length in normalised time) keeps
    the end position and makes the end velocity and acceleration 0; the
    derivatives are per normalised time, like ``v_end`` and ``a_end``.
    """
    L = END_WINDOW
    u = np.clip((tb - (1.0 - L)) / L, 0.0, 1.0)[:, None]
    p_v = -4 * u**3 + 7 * u**4 - 3 * u**5
    dp_v = -12 * u**2 + 28 * u**3 - 15 * u**4
    ddp_v = -24 * u + 84 * u**2 - 60 * u**3
    p_a = 0.5 * u**3 - u**4 + 0.5 * u**5
    dp_a = 1.5 * u**2 - 4 * u**3 + 2.5 * u**4
    ddp_a = 3 * u - 12 * u**2 + 10 * u**3
    v, a = v_end[None, :], a_end[None, :]
    dx = -L * v * p_v - L**2 * a * p_a
    dxd = -v * dp_v - L * a * dp_a
    dxdd = -v * ddp_v / L - a * ddp_a
    return dx, dxd, dxdd


def blend_orientation_goal(
    q: FloatArray,
    omega: FloatArray,
    omegad: FloatArray,
    goal: FloatArray,
    S: FloatArray,
    Sd: FloatArray,
    Sdd: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Rotate the tail by ``exp(S(t) r / 2)`` so the last sample equals ``goal``.

    ``r`` [rad] is the small residual rotation from the DMP's end to the goal (base
    frame); ``S`` goes 0 -> 1 over the end of the motion with derivatives ``Sd``
    [1/s], ``Sdd`` [1/s²]. Angular velocity: ``omega' = Sd r + R_c omega``.
    """
    r = _rotvec_between(np.asarray(goal), q[-1])
    if not np.any(r):
        return q, omega, omegad
    qc = quat_exp(0.5 * S[:, None] * r[None, :])
    q_new = quat_sign_continuous(quat_multiply(qc, q))
    Rc = matrix_from_quat(qc)
    omega_new = Sd[:, None] * r[None, :] + np.einsum("nij,nj->ni", Rc, omega)
    omegad_new = (
        Sdd[:, None] * r[None, :]
        + np.einsum("nij,nj->ni", Rc, omegad)
        + np.cross(Sd[:, None] * r[None, :], np.einsum("nij,nj->ni", Rc, omega))
    )
    return q_new, omega_new, omegad_new


def settle_at_goal(
    tb: FloatArray, T: float, path: Path, goal: FloatArray, window: Window
) -> tuple[Path, float, float]:
    """End a position path ``(x, x', x'')`` (per normalised time) at ``goal``, at rest.

    Returns the path, the DMP's goal residual [m] and its end speed [m/s] (``T`` the
    duration [s]) before the rest correction.
    """
    x, xd, xdd, end_err = blend_out_residual(*path, goal, window)
    # The learned mean may still move at its last sample (a demonstration cut off
    # mid-motion), and the DMP passes that velocity on: bring the plan to rest at
    # the goal over the same window, so the robot is not stopped dead.
    end_speed = float(np.linalg.norm(xd[-1])) / T
    dx, dxd, dxdd = rest_correction(tb, xd[-1], xdd[-1])
    return (x + dx, xd + dxd, xdd + dxdd), end_err, end_speed
