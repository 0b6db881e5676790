"""The arm's elbow chosen so its links keep clear of the plan's obstacles.

The planner shapes the hand's and the held object's path round the obstacles
(:mod:`dexlfd.plan.clearance`, :mod:`dexlfd.plan.envelope`); the Panda reaches a
TCP pose with a one-parameter family of joint configurations (its self-motion, the
elbow's swivel), and the inverse kinematics alone picks the one nearest the
previous sample (or, as the controllers did, the start posture), whatever the
forearm then sweeps through. :func:`clear_posture` uses that redundancy: at the
plan's first joint sample (:func:`dexlfd.plan.feasibility.joint_profile`) it walks
the self-motion (steps of :data:`STEP` rad along the null space of the TCP Jacobian,
each put back on the pose by the inverse kinematics, within the joint limits) and
carries each of those postures along the plan by the inverse kinematics from its
own previous sample (a column of one continuous arm motion), measures every link's
clearance from every obstacle (:func:`dexlfd.robot.arm_clearance.arm_clearance`,
MuJoCo's distance to the collision meshes), and picks by dynamic programming the
profile that keeps every link at least ``margin`` away with the least swivel and the
smoothest change (at most one column a sample, each move under :data:`PATH_SPEED`
of the joints' velocity limits, starting from the plan's own start posture), then
smooths it in time. Where the inverse kinematics' own posture keeps every link
``margin + BAND`` away, nothing moves. The result is the plan's planned posture: the
controllers take it as their null-space reference, so the arm that runs is the arm
that was checked. Where no continuous swivel keeps a link out of an obstacle
(:func:`plan_arm_posture`), the plan gets no posture and a warning names the link.

The thesis's 0.5 m pillar, 0.15 m beside the pick, is the case this is built for:
the hand comes down beside it, the wrist 0.2 m above the TCP, and with the inverse
kinematics' posture link 5 (the forearm, which hangs behind and above the wrist)
meets the pillar's top edge from the descent on and through the grasp. An elbow
swivelled 1-2 rad before the descent keeps it clear throughout; re-walking the
self-motion at every sample missed it, as the shoulder passes upright there (joint
2 through zero) and the walks either side set off along opposite swivels. Where no
swivel keeps a link out (the demo's 0.4 m cup, passed over), the planning pipeline
re-plans the hand's path round the obstacle widened (:mod:`dexlfd.plan.arm_room`).
"""

from __future__ import annotations

import dataclasses
import logging
from typing import NamedTuple

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.geometry import Obstacle
from dexlfd.io import Plan
from dexlfd.io.plan_facts import ArmPosture
from dexlfd.panda import DQ_MAX, Q_MAX, Q_MIN
from dexlfd.panda_ik import KinematicModel, solve_ik, solve_ik_batch
from dexlfd.robot.arm_clearance import arm_clearance
from dexlfd.robot.posture_hold import held_windows
from dexlfd.rotations import matrix_from_quat

__all__ = [
    "BUFFER",
    "STEP",
    "PostureChoice",
    "clear_posture",
    "plan_arm_posture",
]

logger = logging.getLogger(__name__)

STEP = 0.05  # [rad] one step of the self-motion (its joint-space length)
REACH = 40  # steps tried each way (2 rad of swivel)
BAND = 0.10  # [m] a plan whose links come within margin + BAND anywhere is re-posed
BUFFER = 0.01  # [m] aimed for beyond the margin (the controller tracks the posture loosely)
SMOOTH_S = 0.4  # [s] moving-average width applied (twice) to the chosen swivel
_LIMIT_GAP = 0.02  # [rad] the walk keeps this far inside the joint limits
_IK_TOL = 1e-3  # [m] a walk step whose IK misses by more ends the walk (rotation: 10x in rad)
_JUMP = 0.3  # [rad] a followed posture moving a joint more in one sample has left its branch
MIN_GAIN = 0.001  # [m] a swivel that raises the least clearance less is not worth it
SPEED_SHARE = 0.9  # a posture moving a joint faster than this share of its limit is not used
PATH_SPEED = 0.85  # share of the joint velocity limits the chosen swivel keeps under
TOUCH = 0.0  # [m] a link nearer than this with every posture: no planned posture
_BIG = 1e6  # cost per metre of a link inside an obstacle


class PostureChoice(NamedTuple):
    """The chosen posture along the joint samples and what it clears."""

    q: FloatArray  # (m, 7) [rad]
    swivel: FloatArray  # (m,) [rad] self-motion from the inverse kinematics' posture
    clearance: FloatArray  # (n_obstacles, m) [m] of the links, at ``q``
    default_clearance: FloatArray  # (n_obstacles, m) [m] at the inverse kinematics' posture
    worst: list[tuple[str, int]]  # per obstacle: nearest link, sample (at ``q``)


def _null(model: KinematicModel, q: FloatArray, prev: FloatArray | None) -> FloatArray:
    """Unit null-space direction of the TCP Jacobian at ``q``, signed along ``prev``."""
    n = np.linalg.svd(model.tcp_jacobian(q))[2][-1]
    if prev is not None and float(n @ prev) < 0.0:
        n = -n
    return np.asarray(n, dtype=np.float64)


def _walk(
    model: KinematicModel, q0: FloatArray, p: FloatArray, R: FloatArray, n0: FloatArray
) -> list[FloatArray]:
    """Up to :data:`REACH` postures along the self-motion from ``q0`` towards ``n0``."""
    out: list[FloatArray] = []
    q, n = q0, n0
    for _ in range(REACH):
        n = _null(model, q, n)
        q_try = q + STEP * n
        if (q_try < Q_MIN + _LIMIT_GAP).any() or (q_try > Q_MAX - _LIMIT_GAP).any():
            break
        ik = solve_ik(model, p, R, q_try, max_iter=30)
        if ik.position_error > _IK_TOL or ik.rotation_error > 10 * _IK_TOL:
            break
        q = ik.q
        out.append(q)
    return out


def _grid(
    model: KinematicModel, qs: FloatArray, poses: tuple[FloatArray, FloatArray],
    rows: BoolArray, obstacles: tuple[Obstacle, ...],
) -> tuple[FloatArray, FloatArray]:  # fmt: skip
    """Postures (m, 2 REACH + 1, 7) and their links' clearance (m, 2 REACH + 1) [m].

    Only the samples in ``rows`` (bool, m) are posed. At the first sample of each run
    of ``rows`` the self-motion is walked both ways from the inverse kinematics'
    posture (:func:`_walk`); every later sample of the run continues each of those
    postures in time (:func:`_follow`), so a column is one continuous arm motion
    whatever the null space does in between. Re-walking at every sample gave no such
    columns: where the shoulder passes upright (joint 2 through zero, joints 1 and 3
    in line) the null space is their counter-rotation, which moves no link, and the
    walks either side of it set off along opposite elbow swivels (the 0.5 m pillar:
    the swivel that clears the descent to the pick seemed to flip sign at the pick,
    so no continuous swivel was found, while one of 1-2 rad clears throughout). A
    posture past a joint limit, off the pose or lost by the continuation has
    clearance -inf.
    """
    m = qs.shape[0]
    grid = np.repeat(qs[:, None, :], 2 * REACH + 1, axis=1)
    clear = np.full((m, 2 * REACH + 1), -np.inf)
    alive = np.zeros(2 * REACH + 1, dtype=bool)
    for k in range(m):
        if not rows[k]:
            continue
        if k == 0 or not rows[k - 1]:  # a run starts: walk the self-motion
            n_k = _null(model, qs[k], None)
            alive[:] = False
            alive[REACH] = True
            for sign in (1, -1):
                for i, q in enumerate(_walk(model, qs[k], poses[0][k], poses[1][k], sign * n_k), 1):
                    grid[k, REACH + sign * i] = q
                    alive[REACH + sign * i] = True
        else:
            alive &= _follow(model, grid, k, poses, alive)
        walked = np.flatnonzero(alive)
        per, _ = arm_clearance(grid[k, walked], obstacles)
        clear[k, walked] = per.min(axis=0)
    return grid, clear


def _follow(
    model: KinematicModel, grid: FloatArray, k: int, poses: tuple[FloatArray, FloatArray],
    alive: BoolArray,
) -> BoolArray:  # fmt: skip
    """Each live column of ``grid`` at sample ``k - 1`` carried to sample ``k``'s pose.

    The inverse kinematics from the column's previous posture (its nearest solution);
    the middle column is the inverse kinematics' posture carried on. Returns which
    columns are still on the pose, inside the joint limits and moved less than
    :data:`_JUMP` rad in a joint (a column that jumped has left its branch).
    """
    ok = alive.copy()
    cols = np.flatnonzero(alive)
    if cols.size == 0:
        return ok
    prev = grid[k - 1, cols]
    ik = solve_ik_batch(model, poses[0][k], poses[1][k], prev, max_iter=30)
    q = ik.q
    bad = (
        (ik.position_error > _IK_TOL) | (ik.rotation_error > 10 * _IK_TOL)
        | (q < Q_MIN + _LIMIT_GAP).any(axis=1) | (q > Q_MAX - _LIMIT_GAP).any(axis=1)
        | (np.abs(q - prev).max(axis=1) > _JUMP)
    )  # fmt: skip
    ok[cols[bad]] = False
    grid[k, cols[~bad]] = q[~bad]
    return ok


def _within_speed(grid: FloatArray, dt: float) -> BoolArray:
    """Which column moves keep every joint under :data:`PATH_SPEED` of its limit.

    (m, 3, w): the move to column ``j`` at sample ``k`` from column ``j - d``
    (d = -1, 0, 1) at ``k - 1``.
    """
    m, w, _ = grid.shape
    ok = np.ones((m, 3, w), dtype=bool)
    lim = PATH_SPEED * DQ_MAX * dt
    for i, d in enumerate((-1, 0, 1)):
        prev = np.roll(grid[:-1], d, axis=1)  # column j - d at the previous sample
        ok[1:, i] = (np.abs(grid[1:] - prev) <= lim).all(axis=2)
    return ok


def _choose(clear: FloatArray, rows: BoolArray, margin: float, fast_ok: BoolArray) -> FloatArray:
    """Grid index (m,) per sample: least cost path, one step at most per sample.

    A step outside ``fast_ok`` (:func:`_within_speed`) is not taken unless no step
    into any column at that sample is (the inverse kinematics' own posture is as
    fast as it is).

    Cost: a link touching an obstacle (:data:`_BIG` per metre, so the least
    intrusion wins where nothing clears), inside ``margin`` (1e3 per metre), inside
    ``margin + BUFFER`` (softly), the swivel's size and its change. The first
    sample and every sample outside ``rows`` keep the inverse kinematics' posture.
    """
    m, w = clear.shape
    s = (np.arange(w) - REACH) * STEP
    touch = np.maximum(-clear, 0.0)
    short = np.maximum(margin - clear, 0.0)
    soft = np.maximum(margin + BUFFER - clear, 0.0)
    cost = _BIG * touch + 1e3 * short + 1e3 * soft**2 + 0.1 * s**2
    node = np.where(np.isfinite(clear), cost, np.inf)
    node[~rows] = np.inf
    node[~rows, REACH] = 0.0
    node[0] = np.inf
    node[0, REACH] = 0.0
    cost = node[0].copy()
    back = np.zeros((m, w), dtype=int)
    for k in range(1, m):
        cands = np.stack([np.roll(cost, d) + 0.05 * d * d for d in (-1, 0, 1)])
        cands[0, -1] = cands[2, 0] = np.inf  # no wrap-around
        slow = np.where(fast_ok[k], cands, np.inf)
        if np.isfinite(slow + node[k]).any():
            cands = slow
        pick = np.argmin(cands, axis=0)
        back[k] = np.arange(w) - (pick - 1)
        cost = cands[pick, np.arange(w)] + node[k]
    path = np.empty(m, dtype=int)
    path[-1] = int(np.argmin(cost))
    for k in range(m - 1, 0, -1):
        path[k - 1] = back[k, path[k]]
    return path


def _smooth(x: FloatArray, width: int) -> FloatArray:
    """Moving average of ``x`` over ``width`` samples, twice (ends held)."""
    if width < 2:
        return x
    kernel = np.ones(width) / width
    for _ in range(2):
        padded = np.concatenate([np.full(width, x[0]), x, np.full(width, x[-1])])
        x = np.convolve(padded, kernel, mode="same")[width:-width]
    return x


def clear_posture(
    t: FloatArray, qs: FloatArray, poses: tuple[FloatArray, FloatArray],
    obstacles: tuple[Obstacle, ...], margin: float, model: KinematicModel,
) -> PostureChoice:  # fmt: skip
    """The posture along the joint samples that keeps the arm's links clear.

    ``t`` (m,) [s] and ``qs`` (m, 7) [rad]: the plan's inverse kinematics; ``poses``:
    the TCP positions (m, 3) [m] and rotation matrices (m, 3, 3) there. The result
    is ``qs`` itself where its links keep ``margin + BAND`` [m] from every obstacle.
    """
    default, worst = arm_clearance(qs, obstacles)
    if not (default.min(axis=0) < margin + BAND).any():
        return PostureChoice(qs, np.zeros(len(t)), default, default, worst)
    # every sample: the swivel is carried to the plan's end, not brought back to the
    # inverse kinematics' posture (a column far from it would have to jump there)
    rows = np.ones(len(t), dtype=bool)
    grid, clear = _grid(model, qs, poses, rows, obstacles)
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    path = _choose(clear, rows, margin, _within_speed(grid, dt))
    j = _smooth(path.astype(np.float64), max(1, int(round(SMOOTH_S / dt))))
    j[0] = REACH
    lo = np.clip(np.floor(j).astype(int), 0, 2 * REACH)
    hi = np.clip(lo + 1, 0, 2 * REACH)
    f = (j - lo)[:, None]
    out = qs.copy()
    ks = np.flatnonzero(rows)
    seeds = (1 - f[ks]) * grid[ks, lo[ks]] + f[ks] * grid[ks, hi[ks]]
    ik = solve_ik_batch(model, poses[0][ks], poses[1][ks], seeds, max_iter=50)
    hit = ik.position_error < _IK_TOL
    out[ks[hit]] = ik.q[hit]
    per, worst = arm_clearance(out, obstacles)
    return PostureChoice(out, (j - REACH) * STEP, per, default, worst)


def _speed(q: FloatArray, t: FloatArray) -> float:
    """The largest joint speed between joint samples, as a share of its limit.

    ``joint_posture`` is linear between the samples, so its speed is these slopes
    (central differences average two of them and understated a peak by a third).
    """
    if len(t) < 2:
        return 0.0
    return float((np.abs(np.diff(q, axis=0)) / np.diff(t)[:, None] / DQ_MAX).max())


def _rest_at_start(
    model: KinematicModel, q_ik: FloatArray, plan: Plan, t: FloatArray
) -> FloatArray:
    """The plan's inverse kinematics with the start posture as the null-space rest.

    What the controllers did with the start posture as their fixed null-space
    reference: the posture the elbow is swivelled from.
    """
    idx = np.searchsorted(plan.t, t).clip(0, plan.n_samples - 1)
    R = matrix_from_quat(plan.quaternion[idx])
    out = np.empty_like(q_ik)
    q = q_ik[0]
    for k in range(t.shape[0]):
        ik = solve_ik(model, plan.position[idx[k]], R[k], q, max_iter=50, q_rest=q_ik[0])
        q = ik.q if ik.position_error < _IK_TOL else q_ik[k]
        out[k] = q
    return out


def _unplanned(
    plan: Plan, t: FloatArray, q_ik: FloatArray, obstacles: tuple[Obstacle, ...],
    default: FloatArray, margin: float,
) -> Plan:  # fmt: skip
    """``plan`` without a planned posture: the clearances of the IK's own posture."""
    per, worst = arm_clearance(q_ik, obstacles)
    i = int(np.argmin(per.min(axis=1)))
    link, k = worst[i]
    fact = ArmPosture(
        planned=False,
        margin=margin,
        min_clearance=float(per[i, k]),
        default_min_clearance=float(default.min()),
        link=link,
        obstacle=i,
        t_s=float(t[k]),
        joint_velocity_ratio=_speed(q_ik, t),
        rate_hz=float(1.0 / np.median(np.diff(t))) if len(t) > 1 else 0.0,
    )
    arm = np.interp(plan.t, t, per.min(axis=0))
    return dataclasses.replace(plan, arm_posture=fact, extras={**plan.extras, "arm_clearance": arm})


def plan_arm_posture(
    plan: Plan, obstacles: tuple[Obstacle, ...], margin: float,
    qs: tuple[FloatArray, FloatArray], model: KinematicModel,
) -> Plan:  # fmt: skip
    """``plan`` with its planned posture, the links kept ``margin`` [m] off ``obstacles``.

    ``qs``: the plan's inverse kinematics, times (m,) [s] and joints (m, 7) [rad]
    (:func:`dexlfd.plan.feasibility.joint_profile`). Sets ``joint_posture`` (the
    chosen joints at the plan's samples, linear between the joint samples),
    ``arm_posture`` (what was chosen and what it clears) and
    ``extras["arm_clearance"]`` (n,) [m]. A link still inside ``margin`` is warned
    about, naming it and the obstacle. Where no posture keeps a link out of an
    obstacle along the path (they would touch whatever the elbow does), the plan
    gets no ``joint_posture`` (the controllers keep their start posture, as the
    least-intrusion swivel is no better and may be fast), ``arm_posture.planned``
    is false and a warning names the link, the obstacle, the depth and when. The
    same holds, with a warning, where the posture would raise the links' least
    clearance by less than :data:`MIN_GAIN` while still inside ``margin`` (a swivel
    for nothing), or would move a joint faster than :data:`SPEED_SHARE` of its
    limit (the controllers' safety stop would end the run).
    """
    t, q_ik = qs
    q = _rest_at_start(model, q_ik, plan, t)
    idx = np.searchsorted(plan.t, t).clip(0, plan.n_samples - 1)
    poses = (plan.position[idx], matrix_from_quat(plan.quaternion[idx]))
    choice = clear_posture(t, q, poses, obstacles, margin, model)
    least_per = choice.clearance.min(axis=1)
    i = int(np.argmin(least_per))
    link, k = choice.worst[i]
    least = float(least_per[i])
    before = float(choice.default_clearance.min())
    planned = least >= TOUCH
    fast = _speed(choice.q, t)
    swivels = bool(np.abs(choice.swivel).max() > 0.0)
    if planned and swivels and least < min(before + MIN_GAIN, margin):
        logger.warning(
            "the arm's %s passes %.3f m from obstacle %d at t=%.2f s (inside the margin "
            "%.3f m) and no elbow posture keeps it further: the controllers keep their "
            "start posture", link, before, i, t[k], margin,
        )  # fmt: skip
        return _unplanned(plan, t, q_ik, obstacles, choice.default_clearance, margin)
    if planned and swivels and fast > SPEED_SHARE:
        logger.warning(
            "the elbow posture that keeps the links %.1f mm from the obstacles would move "
            "the joints at %.0f %% of their limits: the controllers keep their start "
            "posture (%.1f mm); slow the plan to use it", 1e3 * least, 100 * fast, 1e3 * before,
        )  # fmt: skip
        return _unplanned(plan, t, q_ik, obstacles, choice.default_clearance, margin)
    if not planned:  # no elbow keeps the links out: the start posture, said
        per, worst = arm_clearance(q_ik, obstacles)
        i = int(np.argmin(per.min(axis=1)))
        link, k = worst[i]
        logger.warning(
            "the arm's %s passes %.1f mm into obstacle %d at t=%.2f s and no elbow "
            "posture keeps it out along this path (the hand's path clears it): the "
            "controllers keep their start posture",
            link, -1e3 * float(per[i, k]), i, t[k],
        )  # fmt: skip
        return _unplanned(plan, t, q_ik, obstacles, choice.default_clearance, margin)
    if least < margin:
        logger.warning(
            "the arm's %s passes %.3f m from obstacle %d at t=%.2f s (inside the margin "
            "%.3f m; no elbow posture keeps it further)", link, least, i, t[k], margin,
        )  # fmt: skip
    if swivels:
        logger.info(
            "arm posture: the elbow swivels up to %.2f rad so the links keep %.1f mm from "
            "the obstacles (the inverse kinematics' posture: %.1f mm)",
            np.abs(choice.swivel).max(), 1e3 * least, 1e3 * before,
        )  # fmt: skip
    else:
        logger.info("clearance of the arm's links: %.1f mm (%s)", 1e3 * least, link)
    fact = ArmPosture(
        planned=True,
        margin=margin,
        min_clearance=least,
        default_min_clearance=before,
        link=link,
        obstacle=i,
        t_s=float(t[k]),
        max_swivel=float(np.abs(choice.swivel).max()),
        joint_velocity_ratio=fast,
        rate_hz=float(1.0 / np.median(np.diff(t))) if len(t) > 1 else 0.0,
    )
    arm = np.interp(plan.t, t, choice.clearance.min(axis=0))
    extras = {**plan.extras, "arm_clearance": arm}
    posture = np.stack([np.interp(plan.t, t, choice.q[:, j]) for j in range(7)], axis=1)
    hold = held_windows(plan, posture, obstacles, margin, model)  # the arm's own, at rest
    fact = dataclasses.replace(fact, hold_s=hold)
    return dataclasses.replace(plan, joint_posture=posture, arm_posture=fact, extras=extras)
