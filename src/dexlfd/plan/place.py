"""Place, don't drop: lower the held object onto the surface before the gripper opens.

A learned place point inherits the height at which the demonstrator let go, which
need not be where the robot's object touches the robot's table: released 10 cm
above it, the object falls. Given the surface height under the place point and the
distance from the TCP down to the held object's bottom (both known from the scene),
:func:`place_correction` moves the path vertically so the object rests on the surface
*before* the gripper opens (``press`` > 0 would push it that far into the surface; the
default 0 does not: a controller with integral or disturbance-observer action winds up
against the contact and lurches when the fingers let go, measured with NTSM-PD-DOB at
1.2 kg: a joint-velocity stop at the release with 3 mm, a 0.02 m/s touchdown with 0),
holds it there while the fingers open, and hands the path back to the
learned retreat afterwards: the height is blended towards the resting height,

    z'(t) = (1 - S(t)) z(t) + S(t) z_rest,   z_rest = surface + bottom - press

``S`` rises from 0 to 1 with a quintic smoothstep over ``ramp`` seconds ending
``settle`` seconds before the release instant ``t_r`` (zero velocity and
acceleration at both ends, so the object arrives at rest, and the TCP stands still
at ``z_rest`` while ``S = 1`` even if the learned path still moves), stays 1 until ``hold``
seconds after ``t_r`` (shortened to a quarter of the time left) and falls back to 0
over the rest of the plan. The release instant
is where the plan's grasp schedule (:mod:`dexlfd.plan.grasp_schedule`) opens again
after its main closed (carrying) run.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.intervals import longest_run
from dexlfd.io.plan_facts import PlaceCorrection as PlaceFact
from dexlfd.panda import TABLE_Z
from dexlfd.plan.grasp_schedule import grasp_schedule
from dexlfd.trajectory import minimum_jerk

__all__ = ["PlaceCorrection", "PlaceTiming", "place_correction", "release_index", "set_down"]

logger = logging.getLogger(__name__)

Path3 = tuple[FloatArray, FloatArray, FloatArray]

_MIN_RAMP = 0.3  # [s] shortest return to the learned path after the release
_SOFT = 3e-3  # [m] softness of the approach floor (softplus scale)
_FLOOR_ON = 0.3  # [s] the floor is switched on over this time before the lowering
_SUPPORT_WIDTH = 0.1  # [m] footprint of the place support recorded for the simulator


@dataclass(frozen=True, slots=True)
class PlaceTiming:
    """How the object is set down (see the module docstring).

    ``ramp`` lowering duration, ``settle`` time at rest before and ``hold`` time
    after the release [s]; ``approach`` [m]: the learned path may bring the object no
    nearer to the surface than this (a smooth floor), the rest of the way is the
    lowering's alone.
    """

    ramp: float = 1.0
    settle: float = 0.3
    hold: float = 0.25
    approach: float = 0.02


@dataclass(frozen=True, slots=True)
class PlaceCorrection:
    """Position correction (n, 3) and its time derivatives [m, m/s, m/s²], plus facts.

    ``release_t`` [s] the release instant, ``shift`` [m] the height change at the
    place point (negative: lowered), ``rest_z`` [m] the TCP height while placing.
    """

    dz: FloatArray
    dzd: FloatArray
    dzdd: FloatArray
    release_t: float
    shift: float
    rest_z: float


def release_index(t: FloatArray, gripper: FloatArray) -> int:
    """First sample where the schedule opens after its main closed (carrying) run, or -1.

    The plan's grasp schedule (:func:`~dexlfd.plan.grasp_schedule.grasp_schedule`:
    its levels, hysteresis and minimum duration; ``t`` [s], ``gripper`` [m]), the
    same rule the simulated loop releases by; -1 when it never closes or never opens.
    """
    closed, _ = grasp_schedule(np.asarray(t, dtype=np.float64), gripper)
    run = longest_run(t, closed)
    return -1 if run is None or run[1] >= closed.shape[0] else run[1]


def _blend(
    S: FloatArray,
    dS: FloatArray,
    ddS: FloatArray,
    x: FloatArray,
    xd: FloatArray,
    xdd: FloatArray,
    target: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Correction that moves ``x`` (n, d) to ``(1 - S) x + S target`` and derivatives."""
    gap = target[None, :] - x
    S_, dS_, ddS_ = S[:, None], dS[:, None], ddS[:, None]
    return S_ * gap, dS_ * gap - S_ * xd, ddS_ * gap - 2 * dS_ * xd - S_ * xdd


def place_correction(
    t: FloatArray,
    x: FloatArray,
    xd: FloatArray,
    xdd: FloatArray,
    gripper: FloatArray,
    *,
    surface_z: float,
    object_bottom: float,
    press: float = 0.0,
    timing: PlaceTiming | None = None,
) -> PlaceCorrection:
    """Correction that sets the held object down on the surface, then lifts clear.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Plan time [s].
    x, xd, xdd : ndarray, shape (n, 3)
        Planned TCP position [m] and its time derivatives [m/s, m/s²].
    gripper : ndarray, shape (n,)
        Planned opening [m] (the learned schedule).
    surface_z : float
        Height of the surface under the place point [m].
    object_bottom : float
        Distance from the TCP down to the held object's bottom [m].
    press : float
        Depth the reference pushes the object into the surface [m] (default 0).
    timing : PlaceTiming, optional
        Lowering, settle and hold times and the approach floor (default
        ``PlaceTiming()``).

    Returns
    -------
    PlaceCorrection
        ``dz`` etc. are (n, 3): the height is blended to the resting height as
        described in the module docstring; the horizontal position is held at the
        release point from the lowering until the fingers have risen clear of the
        object (twice ``object_bottom`` plus 2 cm above the resting height), so the
        open fingers do not sweep it off the surface, then blended back to the
        learned retreat over the rest of the plan.

    Raises
    ------
    InvalidInput
        The schedule has no release, or it comes too early/late for the ramps.
    """
    k = release_index(t, gripper)
    if k < 0:
        raise InvalidInput(
            "place: the gripper schedule never opens after grasping, so there is no "
            "place point to lower onto the surface"
        )
    timing = timing or PlaceTiming()
    sch = _schedule(t, float(t[k]), timing)
    z_rest = float(surface_z + object_bottom - press)
    cz, czd, czdd = _height(t, x, xd, xdd, sch, z_rest, timing.approach)
    cxy, cxyd, cxydd = _horizontal(t, x, xd, xdd, sch, k, x[:, 2] + cz[:, 0], z_rest, object_bottom)
    return PlaceCorrection(
        dz=np.concatenate([cxy, cz], axis=1),
        dzd=np.concatenate([cxyd, czd], axis=1),
        dzdd=np.concatenate([cxydd, czdd], axis=1),
        release_t=sch.t_r,
        shift=float(cz[k, 0]),
        rest_z=z_rest,
    )


@dataclass(frozen=True, slots=True)
class _Schedule:
    """Times of the place [s].

    Lowering from ``t0`` over ``ramp``, release ``t_r``, hold until ``t_r + hold``,
    then return over ``ramp_out`` to the plan's end.
    """

    t0: float
    ramp: float
    t_r: float
    hold: float
    ramp_out: float


def _schedule(t: FloatArray, t_r: float, timing: PlaceTiming) -> _Schedule:
    """The place's times around the release ``t_r``, refused when they do not fit."""
    ramp = timing.ramp
    t0 = t_r - timing.settle - ramp
    # after the release the return may be shorter: it must end with the plan
    hold = min(timing.hold, 0.25 * (float(t[-1]) - t_r))
    ramp_out = float(t[-1]) - t_r - hold  # the whole rest: as gently as possible
    if t0 - _FLOOR_ON < t[0] or ramp_out < _MIN_RAMP:
        raise InvalidInput(
            f"place: the release at t = {t_r:.2f} s leaves no room for the {ramp:g} s "
            f"lowering before it or a {_MIN_RAMP:g} s return after it (plan "
            f"0..{t[-1]:.2f} s); lengthen the duration"
        )
    return _Schedule(t0=t0, ramp=ramp, t_r=t_r, hold=hold, ramp_out=ramp_out)


def _rise_fall(
    t: FloatArray, t_up: float, up: float, t_down: float, down: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Window rising 0 -> 1 (minimum jerk) from ``t_up`` and falling from ``t_down``.

    ``up``, ``down`` are the rise and fall times [s]; returns the window and its first
    two time derivatives [1/s, 1/s²].
    """
    S1, dS1, ddS1 = minimum_jerk((t - t_up) / up)
    S2, dS2, ddS2 = minimum_jerk((t - t_down) / down)
    return S1 - S2, dS1 / up - dS2 / down, ddS1 / up**2 - ddS2 / down**2


def _height(
    t: FloatArray,
    x: FloatArray,
    xd: FloatArray,
    xdd: FloatArray,
    sch: _Schedule,
    z_rest: float,
    approach: float,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Height correction (n, 1): the approach floor, then the blend to ``z_rest``."""
    t_back = sch.t_r + sch.hold
    S, dS, ddS = _rise_fall(t, sch.t0, sch.ramp, t_back, sch.ramp_out)
    # the learned path may bring the object no nearer than `approach` to the surface
    # (a smooth floor, switched on just before the lowering): the last part of the
    # way down is the quintic's alone, so the object meets the surface slowly however
    # fast the demonstrator came down
    zf = z_rest + approach
    r = (x[:, 2] - zf) / _SOFT
    sig = 0.5 * (1.0 + np.tanh(0.5 * r))  # logistic, overflow-free
    g = zf + _SOFT * np.logaddexp(0.0, r) - x[:, 2]  # >= 0: lift to the floor
    gd = (sig - 1.0) * xd[:, 2]
    gdd = (sig - 1.0) * xdd[:, 2] + sig * (1.0 - sig) / _SOFT * xd[:, 2] ** 2
    W, dW, ddW = _rise_fall(t, sch.t0 - _FLOOR_ON, _FLOOR_ON, t_back, sch.ramp_out)
    fz = W * g
    fzd = dW * g + W * gd
    fzdd = ddW * g + 2 * dW * gd + W * gdd
    cz, czd, czdd = _blend(
        S, dS, ddS, (x[:, 2] + fz)[:, None], (xd[:, 2] + fzd)[:, None],
        (xdd[:, 2] + fzdd)[:, None], np.array([z_rest]),
    )  # fmt: skip
    return cz + fz[:, None], czd + fzd[:, None], czdd + fzdd[:, None]


def _horizontal(
    t: FloatArray,
    x: FloatArray,
    xd: FloatArray,
    xdd: FloatArray,
    sch: _Schedule,
    k: int,
    z_new: FloatArray,
    z_rest: float,
    object_bottom: float,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Horizontal correction (n, 2): hold the release point while placing.

    Held until the fingers are clear of the object (``z_new`` the corrected height),
    reached in the first half of the lowering, before the object is near the
    surface, so it is set down vertically.
    """
    clear = z_rest + 2.0 * object_bottom + 0.02
    above = np.flatnonzero((t > sch.t_r) & (z_new >= clear))
    t_c = float(t[above[0]]) if above.size else float(t[-1])
    ramp_xy = float(t[-1]) - t_c
    if ramp_xy < 0.1 * _MIN_RAMP:
        raise InvalidInput(
            f"place: after the release at t = {sch.t_r:.2f} s the plan does not rise "
            f"{clear - z_rest:.2f} m clear of the object before it ends; lengthen the "
            "duration or choose a goal above the place point"
        )
    T, dT, ddT = _rise_fall(t, sch.t0, 0.5 * sch.ramp, t_c, ramp_xy)
    return _blend(T, dT, ddT, x[:, :2], xd[:, :2], xdd[:, :2], x[k, :2])


def set_down(
    tb: FloatArray, T: float, path: Path3, gripper: FloatArray, surface_z: float | None,
    object_bottom: float,
) -> tuple[Path3, PlaceFact | None]:  # fmt: skip
    """``path`` (x, x', x'' per normalised time ``tb``, duration ``T`` [s]) set down.

    The held object lowered onto ``surface_z`` [m] before the release
    (:func:`place_correction`; ``object_bottom`` [m] below the TCP), and the plan's fact
    of it; ``path`` and None without a surface.
    """
    if surface_z is None:
        return path, None
    x, xd, xdd = path
    t = tb * T
    pc = place_correction(
        t, x, xd / T, xdd / T**2, gripper, surface_z=surface_z, object_bottom=object_bottom
    )
    x, xd, xdd = x + pc.dz, xd + pc.dzd * T, xdd + pc.dzdd * T**2
    k_r = int(np.searchsorted(t, pc.release_t))
    info: dict[str, Any] = {
        "surface_z": surface_z,
        "object_bottom": object_bottom,
        "release_t": pc.release_t,
        "place_point": x[k_r].tolist(),
        "height_change": pc.shift,
    }
    if surface_z > TABLE_Z:
        # what the object is set down on: a support from the table up to the
        # surface under the place point (the simulator builds it from here)
        height = surface_z - TABLE_Z
        info["support"] = {
            "type": "box",
            "center": [float(x[k_r, 0]), float(x[k_r, 1]), TABLE_Z + height / 2],
            "size": [_SUPPORT_WIDTH, _SUPPORT_WIDTH, height],
        }
    logger.info(
        "place: object lowered %.3f m onto the surface at z = %.3f m before the "
        "release at t = %.2f s",
        -pc.shift, surface_z, pc.release_t,
    )  # fmt: skip
    return (x, xd, xdd), PlaceFact.from_json(info, "place")
