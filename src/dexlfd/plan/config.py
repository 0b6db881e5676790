"""What to plan and how: :class:`PlanConfig`, the settings of :func:`~dexlfd.plan.plan_from_model`.

A frozen, validated dataclass: start/goal pose, duration and rate, obstacles with
the coupling gains and clearances (:mod:`dexlfd.plan.clearance`), and the place
surface (:mod:`dexlfd.plan.place`). Every bad value is refused here, named by its
field.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dexlfd._params import check_params, param
from dexlfd._validation import check_positive
from dexlfd.errors import InvalidInput
from dexlfd.geometry import Box, Obstacle, Sphere
from dexlfd.io.plan import MAX_DURATION_S
from dexlfd.plan.dmp_config import DmpConfig

__all__ = ["COUPLING_RANGE", "MAX_MOTION_S", "MAX_RATE_HZ", "PlanConfig"]

logger = logging.getLogger(__name__)

# [s] the longest motion planned: a plan file lasts at most MAX_DURATION_S, and a
# pick-and-place adds up to a minute to its motion (holds, vertical moves, time scaling)
MAX_MOTION_S = MAX_DURATION_S - 60.0

# k1, k2, c of Eqs. (5.6)-(5.7) may be chosen in (0, 1000] (thesis: 10, 15, 1)
COUPLING_RANGE = (0.0, 1000.0)
MAX_RATE_HZ = 10_000.0  # [Hz] the output rate; the control loop runs at 1 kHz
_COUPLING_HELP = (
    "coupling gain {} of Eqs. 5.6-5.7 (thesis and default; shapes the path with --coupling "
    "thesis, reported with shaped)"
)

_START_VELOCITY = ("model", "zero")
_ON_LIMIT = ("warn", "raise", "scale")
_TASK = ("auto", "motion")
_START_WORDS = ("ready", "demonstrated")
GRASP_ORIENTATIONS = ("top-down", "demonstrated")
_VARIANCE_MEASURES = ("metres", "relative")


def _opt_vec(value: Any, name: str, size: int) -> tuple[float, ...] | None:
    if value is None:
        return None
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise InvalidInput(f"{name} must be {size} numbers, got {value!r}", param=name) from exc
    if arr.shape != (size,) or not np.isfinite(arr).all():
        raise InvalidInput(f"{name} must be {size} finite numbers, got {value!r}", param=name)
    return tuple(float(v) for v in arr)


def _unit_quat(value: tuple[float, ...], name: str) -> tuple[float, ...]:
    q = np.asarray(value)
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > 1e-2:
        raise InvalidInput(
            f"{name} must be a unit quaternion (x, y, z, w), its norm is {norm:.4g}", param=name
        )
    if abs(norm - 1.0) > 1e-9:
        logger.warning("%s has norm %.6f; normalised to 1", name, norm)
    return tuple(float(v) for v in q / norm)


@dataclass(frozen=True)
class PlanConfig:
    """What to plan and how.

    Attributes
    ----------
    start : tuple of 3 float or str, optional
        Start position [m], base frame, or ``"ready"`` (the TCP at the Panda's ready
        pose) or ``"demonstrated"`` (the model's first position). Default (None): a
        pick-and-place plan starts at the ready pose (the robot moves from its own
        pose), one motion at the model's first position (the thesis's plans).
    goal : tuple of 3 float, optional
        Goal position [m], base frame; default: the model's (one motion) or, for a
        pick-and-place, the demonstrated end relative to the place when the arm can
        end there clear of every obstacle, else the ready pose
        (:func:`dexlfd.plan.task_poses.retreat_end`).
    start_quat, goal_quat : tuple of 4 float, optional
        Start and goal orientation (x, y, z, w); default: the model's.
    duration : float, optional
        Movement duration [s] (temporal scaling), at most :data:`MAX_MOTION_S`;
        default: the model's.
    rate_hz : float
        Output sample rate [Hz] (1 kHz matches the control loop).
    obstacles : tuple of Box/Sphere
    dmp : DmpConfig
        ``K``, ``D`` (thesis: 1, 1), basis functions, phase decay.
    k1, k2, c : float
        Coupling gains of Eqs. (5.6)-(5.7) (thesis: 10, 15, 1).
    variance_aware : bool
        Scale the coupling by the GMR variance (Eq. 5.7); False: Eq. (5.6).
    margin : float
        Clearance to keep from every obstacle [m].
    band : float
        The shaped coupling passes an obstacle by at most ``margin + band`` [m].
    variance_clearance : float
        Extra clearance [m] (``<= band``) where the demonstrations disagreed most
        (variance level 1, :func:`~dexlfd.plan.obstacles.variance_level`),
        proportionally less where they agreed.
    variance_measure : str
        ``"metres"`` (default): the level is the demonstrations' standard deviation
        along the push direction over ``variance_clearance``, so the extra clearance
        is their spread in metres, capped there; ``"relative"``: against the model's
        own 90th percentile (the same bend for a model whose demonstrations agree to
        1 mm as for one whose disagree by 3 cm).
    influence : float
        Distance beyond the inflated obstacle over which the push fades in [m].
    enforce_clearance : bool
        Shape the coupling so the margin holds (see module doc); False: the thesis's
        proportional law, no guarantee.
    start_velocity : str
        ``"model"``: keep the GMR mean's initial velocity (rescaled to the duration);
        ``"zero"``: start at rest.
    on_limit : str
        ``"warn"`` (log and record in ``meta``) or ``"raise"`` when the plan exceeds
        the Panda's Cartesian limits; ``"scale"``: record only, the caller slows the
        plan (:func:`dexlfd.plan.feasibility.make_feasible`, ``feasible``).
    place_surface_z : float, optional
        Height of the surface under the place point [m]. Given, the held object is
        lowered onto it before the gripper opens (:mod:`dexlfd.plan.place`); a
        pick-and-place sets it down there (the place TCP ``object_bottom`` above it).
    object_bottom : float
        Distance from the TCP down to the held object's bottom [m] (the simulated
        box: its half height, 0.03 m).
    z_floor : float, optional
        The lowest TCP height [m] of the motion: where the planned path dips under it,
        it is lifted above it (:mod:`dexlfd.plan.floor`), not refused. A pick-and-place
        gives each part the lower of the pick and place heights (the held object's
        bottom never goes below the surface it leaves or meets).
    descend_to_goal : bool
        From its highest point on, the path's height never rises again: where it comes
        down past a height it climbs back to later, it is bridged above that stretch
        (:mod:`dexlfd.plan.descent`). A pick-and-place sets it for the carry (the held
        object comes down onto the place once).
    top_down_reach : bool
        Keep the path outside the nearest the Panda takes a top-down TCP to its base's
        axis (:mod:`dexlfd.plan.reach`): moved outward there. A top-down
        pick-and-place sets it for each part.
    object_half_width : float
        The object's half footprint [m] (the simulated box: 0.03 m): its support is
        never narrower, and it must stand clear of obstacles.
    task : str
        ``"auto"``: a model with grasp events is planned as pick-and-place
        (:mod:`dexlfd.plan.task`), one without as one motion; ``"motion"``: always
        one motion (the events ignored).
    pick, place : tuple of 3 float, optional
        TCP position [m] where the gripper closes on the object and where it opens;
        default: the demonstrated ones (the model's events).
    pick_yaw, place_yaw : float, optional
        The TCP's heading about the base z axis there [rad]; default: the demonstrated.
    grasp_orientation : str
        ``"top-down"`` (default): the pick and place orientation is a top-down grasp
        (TCP z straight down) with the demonstrated (or given) heading about the
        base z axis; ``"demonstrated"``: the demonstrated orientation, tilt included.
    object_size : tuple of 3 float, optional
        Width (across the fingers), depth and height [m] of the object; default:
        width = depth = the learned closed gripper level, height ``2 object_bottom``.
        The placed object is an obstacle of this size for the retreat.
    feasible : bool, optional
        Slow the plan where the Panda's joint limits need it (inverse kinematics along
        the plan, :func:`dexlfd.plan.feasibility.make_feasible`), as ``dexlfd plan``
        does. Default (None): a pick-and-place plan always; one motion (the thesis's
        DMP plans, kept as planned) only with ``on_limit="scale"``.
    hold : float
        Time [s] the arm holds still at the pick before and after the gripper closes,
        and at the place before and after it opens.
    approach : float
        Height [m] of the straight vertical lift off the pick and lowering onto the
        place (the object leaves and meets its support vertically).
    """

    start: tuple[float, ...] | str | None = None
    goal: tuple[float, ...] | None = None
    start_quat: tuple[float, ...] | None = None
    goal_quat: tuple[float, ...] | None = None
    duration: float | None = param(
        None, "movement duration (default: the model's); the plan, with its holds and "
        "vertical moves and slowed where the Panda's limits need it, lasts at most "
        f"{MAX_DURATION_S:g} s", unit="s", lo=0.0, hi=MAX_MOTION_S, lo_open=True,
    )  # fmt: skip
    rate_hz: float = param(1000.0, "output rate", unit="Hz", lo=1.0, hi=MAX_RATE_HZ)
    obstacles: tuple[Obstacle, ...] = ()
    dmp: DmpConfig = field(default_factory=DmpConfig)
    k1: float = param(10.0, _COUPLING_HELP.format("k1"), lo=0.0, hi=1000.0, lo_open=True)
    k2: float = param(15.0, _COUPLING_HELP.format("k2"), lo=0.0, hi=1000.0, lo_open=True)
    c: float = param(
        1.0, _COUPLING_HELP.format("c"), lo=0.0, hi=1000.0, lo_open=True, flag="--coupling-c"
    )
    variance_aware: bool = True
    margin: float = param(0.02, "clearance to keep from every obstacle", unit="m", lo=0.0, hi=1.0)
    band: float = 0.02
    variance_clearance: float = 0.015
    variance_measure: str = "metres"
    influence: float = param(
        0.03, "distance beyond the inflated obstacle over which the push fades in", unit="m",
        lo=0.0, hi=1.0, lo_open=True,
    )  # fmt: skip
    enforce_clearance: bool = True
    start_velocity: str = "model"
    on_limit: str = "warn"
    place_surface_z: float | None = param(
        None, "height of the surface under the place point (the table is 0): lower the held "
        "object onto it before the gripper opens (default: release where the demonstrations "
        "did)", unit="m", lo=0.0, hi=2.0, hi_open=True, flag="--place-surface-m",
    )  # fmt: skip
    object_bottom: float = param(
        0.03, "distance from the TCP down to the held object's bottom (the simulated box's "
        "half height)", unit="m", lo=0.0, hi=2.0, hi_open=True,
    )  # fmt: skip
    z_floor: float | None = None
    descend_to_goal: bool = False
    top_down_reach: bool = False
    object_half_width: float = 0.03
    task: str = "auto"
    pick: tuple[float, ...] | None = None
    place: tuple[float, ...] | None = None
    pick_yaw: float | None = None
    place_yaw: float | None = None
    hold: float = param(
        0.3, "time the arm holds still at the pick and the place while the gripper "
        "closes/opens", unit="s", lo=0.0, hi=5.0, lo_open=True,
    )  # fmt: skip
    approach: float = 0.04
    grasp_orientation: str = "top-down"
    object_size: tuple[float, ...] | None = None
    feasible: bool | None = None

    def __post_init__(self) -> None:
        if isinstance(self.start, str):
            if self.start not in _START_WORDS:
                raise InvalidInput(
                    f"start must be x,y,z [m] or one of {_START_WORDS}, got {self.start!r}"
                )
        else:
            object.__setattr__(self, "start", _opt_vec(self.start, "start", 3))
        object.__setattr__(self, "goal", _opt_vec(self.goal, "goal", 3))
        for name in ("start_quat", "goal_quat"):
            q = _opt_vec(getattr(self, name), name, 4)
            object.__setattr__(self, name, None if q is None else _unit_quat(q, name))
        check_params(self)  # the ranges of duration, rate_hz, k1, k2, c, margin, ...
        if self.duration is not None:
            object.__setattr__(self, "duration", float(self.duration))
        check_positive(self.band, "band")
        check_positive(self.variance_clearance, "variance_clearance", strict=False)
        if self.variance_clearance > self.band:
            raise InvalidInput(
                f"variance_clearance {self.variance_clearance} m must not exceed band "
                f"{self.band} m (the clearance above the margin)"
            )
        obstacles = tuple(self.obstacles)
        for i, ob in enumerate(obstacles):
            if not isinstance(ob, Box | Sphere):
                raise InvalidInput(f"obstacles[{i}] must be a Box or Sphere, got {type(ob)}")
        object.__setattr__(self, "obstacles", obstacles)
        if self.start_velocity not in _START_VELOCITY:
            raise InvalidInput(f"start_velocity must be one of {_START_VELOCITY}")
        if self.on_limit not in _ON_LIMIT:
            raise InvalidInput(f"on_limit must be one of {_ON_LIMIT}")
        if self.z_floor is not None:
            zf = float(self.z_floor)
            if not np.isfinite(zf) or zf < 0.0:
                raise InvalidInput(f"z_floor must be >= 0 m (the table is z = 0), got {zf!r}")
            object.__setattr__(self, "z_floor", zf)
        check_positive(self.object_half_width, "object_half_width", strict=False)
        check_positive(self.approach, "approach [m]")
        if self.variance_measure not in _VARIANCE_MEASURES:
            raise InvalidInput(
                f"variance_measure must be one of {_VARIANCE_MEASURES}, got "
                f"{self.variance_measure!r}"
            )
        if self.task not in _TASK:
            raise InvalidInput(f"task must be one of {_TASK}, got {self.task!r}")
        if self.grasp_orientation not in GRASP_ORIENTATIONS:
            raise InvalidInput(
                f"grasp_orientation must be one of {GRASP_ORIENTATIONS}, got "
                f"{self.grasp_orientation!r}"
            )
        size = _opt_vec(self.object_size, "object_size", 3)
        if size is not None and not all(0.005 <= v <= 0.5 for v in size):
            raise InvalidInput(
                f"object_size must be width,depth,height in [0.005, 0.5] m, got {size}"
            )
        object.__setattr__(self, "object_size", size)
        object.__setattr__(self, "pick", _opt_vec(self.pick, "pick", 3))
        object.__setattr__(self, "place", _opt_vec(self.place, "place", 3))
        for name in ("pick_yaw", "place_yaw"):
            yaw = getattr(self, name)
            if yaw is not None:
                try:
                    v = float(yaw)
                except (TypeError, ValueError) as exc:
                    raise InvalidInput(f"{name} must be a finite angle [rad], got {yaw!r}") from exc
                if not np.isfinite(v):
                    raise InvalidInput(f"{name} must be a finite angle [rad], got {yaw!r}")
                object.__setattr__(self, name, float(np.arctan2(np.sin(v), np.cos(v))))
