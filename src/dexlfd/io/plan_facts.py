"""The typed facts of a plan file: what planning decided and later stages read.

Each is a frozen :class:`~dexlfd.io._facts.Fact` held by a field of
:class:`~dexlfd.io.plan.Plan` (its ``FACTS``), checked on load; a field's unit is
in its metadata. The entry names are those the plan's ``meta`` held before version
3, so an older file's entries are lifted into them as they are.

A time on the plan's clock [s from its start] says so in its metadata (``AT`` an
instant, ``SPAN`` an interval or a tuple of them): a part of a plan carries the facts
on its own clock (:func:`dexlfd.io._clock.on_part_clock`, :meth:`Plan.part
<dexlfd.io.plan.Plan.part>`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from dexlfd.io._facts import Fact

__all__ = [
    "Approach",
    "ArmPosture",
    "EventErrors",
    "Feasibility",
    "GraspSchedule",
    "Limits",
    "ObstaclePass",
    "PlaceCorrection",
    "Retimed",
    "Slowdown",
    "SupportBox",
    "TaskPose",
    "TimeScaling",
]

M = {"unit": "m"}
S = {"unit": "s"}  # a duration
AT = {"unit": "s", "clock": "at"}  # an instant on the plan's clock
SPAN = {"unit": "s", "clock": "span"}  # an interval (or a tuple of them) on it
DEG = {"unit": "deg"}
Vec3 = tuple[float, float, float]
Interval = tuple[float, float]


@dataclass(frozen=True)
class ObstaclePass(Fact):
    """How the plan passes one obstacle (one per obstacle, in the order given).

    The obstacle (``type``, ``center``, a box's ``size`` or a sphere's ``radius``,
    the requested ``direction``), the side the coupling pushed along
    (``direction_used``), the nominal path's ``max_intrusion`` into the margin and the
    ``required_lift``, the normalised variance ``variance_level`` and the thesis
    weight ``k2 nu`` where a lift was needed, the coupling (``shaped`` or ``thesis``,
    Eq. 5.7) with its ``gain`` and whether the shaped push kept within the band
    (``band_met``), the push's ``displacement``, the plan's ``min_clearance`` from it
    and the ``margin`` it was to keep.
    """

    type: Literal["box", "sphere"]
    center: Vec3 = field(metadata=M)
    size: Vec3 | None = field(default=None, metadata=M)
    radius: float | None = field(default=None, metadata=M)
    direction: str = "+z"
    direction_used: str = "+z"
    max_intrusion: float = field(default=0.0, metadata=M)
    required_lift: float = field(default=0.0, metadata=M)
    variance_level: float | None = None
    thesis_weight: float | None = None
    coupling: Literal["shaped", "thesis"] = "shaped"
    gain: float | None = None
    band_met: bool | None = None
    displacement: float = field(default=0.0, metadata=M)
    min_clearance: float | None = field(default=None, metadata=M)
    margin: float | None = field(default=None, metadata=M)


@dataclass(frozen=True)
class GraspSchedule(Fact):
    """How a grasp schedule was decided, and its closed intervals.

    A plan's: ``method`` ("plan levels": read from its gripper channel's
    ``closed_level`` and ``open_level`` with the Schmitt thresholds ``close_below``,
    ``open_above``, or ``single_state`` when it never changes; "model events": a
    task's, ``hold_s`` at each switch), ``intervals_s`` the closed runs. A rollout's
    adds its ``source`` ("plan" or "gripper levels") and the main grasp on the control
    grid: ``grasp_t``, ``grasp_position``, ``release_t``, ``release_position``.
    """

    method: str = "plan levels"
    closed_level: float | None = field(default=None, metadata=M)
    open_level: float | None = field(default=None, metadata=M)
    close_below: float | None = field(default=None, metadata=M)
    open_above: float | None = field(default=None, metadata=M)
    single_state: str | None = None
    hold_s: float | None = field(default=None, metadata=S)
    intervals_s: tuple[Interval, ...] = field(default=(), metadata=SPAN)
    source: str | None = None
    grasp_t: float | None = field(default=None, metadata=AT)
    grasp_position: Vec3 | None = field(default=None, metadata=M)
    release_t: float | None = field(default=None, metadata=AT)
    release_position: Vec3 | None = field(default=None, metadata=M)


@dataclass(frozen=True)
class SupportBox(Fact):
    """A box the object is set down on: ``center`` and ``size`` [m]."""

    center: Vec3 = field(metadata=M)
    size: Vec3 = field(metadata=M)
    type: Literal["box"] = "box"


@dataclass(frozen=True)
class PlaceCorrection(Fact):
    """A motion plan's place: the held object lowered onto a surface before release.

    ``surface_z`` [m] the surface, ``object_bottom`` [m] the object's bottom below the
    TCP, ``release_t`` [s], the TCP's ``place_point`` [m] there, the path's
    ``height_change`` [m] and the ``support`` built under the place (above the table).
    """

    surface_z: float = field(metadata=M)
    object_bottom: float = field(metadata=M)
    release_t: float = field(metadata=AT)
    place_point: Vec3 = field(metadata=M)
    height_change: float = field(metadata=M)
    support: SupportBox | None = None


@dataclass(frozen=True)
class TaskPose(Fact):
    """A pick-and-place pose: TCP ``position`` [m], ``quaternion`` (x, y, z, w).

    ``yaw_deg`` its heading, ``tilt_deg`` from vertical, ``given`` (by the caller,
    not demonstrated), ``t`` [s] when the plan is there, ``source`` and
    ``why_not_demonstrated`` (a start or retreat end not the demonstrated one).
    """

    position: Vec3 = field(metadata=M)
    quaternion: tuple[float, float, float, float]
    yaw_deg: float = field(metadata=DEG)
    tilt_deg: float = field(metadata=DEG)
    given: bool | None = None
    t: float | None = field(default=None, metadata=AT)
    source: str | None = None
    why_not_demonstrated: str | None = None


@dataclass(frozen=True)
class Limits(Fact):
    """The plan's peaks against the Panda's Cartesian limits (SI units by name)."""

    peaks: dict[str, float] = field(default_factory=dict)
    exceeded: tuple[str, ...] = ()


@dataclass(frozen=True)
class Slowdown(Fact):
    """One slow-down: ``factor`` over ``t_s`` [s] for ``limit``, adding ``added_s`` [s].

    ``stage``: "cartesian" (a task part's, named ``part``) or "joint" (joint space).
    """

    t_s: Interval = field(metadata=SPAN)
    factor: float
    added_s: float = field(metadata=S)
    limit: str = "cartesian"
    stage: Literal["cartesian", "joint"] | None = None
    part: str | None = None


@dataclass(frozen=True)
class Feasibility(Fact):
    """The joint-space time scaling (:func:`dexlfd.plan.feasibility.make_feasible`).

    ``stretches`` every slow-down applied, ``added_s`` their sum, the durations
    before and after, the joint peaks as shares of the limits after scaling and the
    share planned for (``joint_margin``).
    """

    needed: bool
    largest: float
    stretches: tuple[Slowdown, ...]
    added_s: float = field(metadata=S)
    duration_before_s: float = field(metadata=S)
    duration_s: float = field(metadata=S)
    joint_velocity_ratio: float
    joint_acceleration_ratio: float
    joint_margin: float


@dataclass(frozen=True)
class TimeScaling(Fact):
    """Every slow-down of the plan and its total growth.

    ``slowdowns`` the Cartesian ones of a task's parts then the joint-space ones,
    ``per_part`` each part's Cartesian factor, ``added_s`` their sum,
    ``duration_unscaled_s`` the plan without any, ``duration_s`` the plan's.
    """

    slowdowns: tuple[Slowdown, ...] = ()
    per_part: dict[str, float] | None = None
    added_s: float | None = field(default=None, metadata=S)
    duration_s: float | None = field(default=None, metadata=S)
    duration_unscaled_s: float | None = field(default=None, metadata=S)
    needed: bool | None = None
    largest: float | None = None
    joint_space: bool | None = None


@dataclass(frozen=True)
class Retimed(Fact):
    """A retiming: ``factors`` over ``stretches_s`` [s] (in the retimed time)."""

    stretches_s: tuple[Interval, ...] = field(metadata=SPAN)
    factors: tuple[float, ...] = field(metadata={"per": "stretches_s"})
    largest: float
    duration_before_s: float = field(metadata=S)
    duration_s: float = field(metadata=S)


@dataclass(frozen=True)
class Approach(Fact):
    """A task's final approach to the pick: unit ``direction`` and its ``length_m``."""

    direction: Vec3
    from_vertical_deg: float = field(metadata=DEG)
    length_m: float = field(metadata=M)
    demonstrated_direction: Vec3 | None = None
    demonstrated_from_vertical_deg: float | None = field(default=None, metadata=DEG)


@dataclass(frozen=True)
class EventErrors(Fact):
    """How far a task plan is from its pick and place poses at the grasp and release."""

    pick_position_error_m: float = field(metadata=M)
    place_position_error_m: float = field(metadata=M)
    pick_angle_error_deg: float = field(metadata=DEG)
    place_angle_error_deg: float = field(metadata=DEG)


@dataclass(frozen=True)
class ArmPosture(Fact):
    """The arm's planned posture (the plan's ``joint_posture``) and what it clears.

    ``planned``: false where no elbow posture keeps the links out of an obstacle
    along the path (the plan then has no ``joint_posture``; the clearances are the
    inverse kinematics' posture's). The links' least clearance from the obstacles
    with it (``min_clearance``) and with the inverse kinematics' own posture
    (``default_min_clearance``), the ``margin`` they were to keep, the nearest
    ``link`` (e.g. ``"link 5"``), the
    ``obstacle`` (its index) and when (``t_s``); the largest elbow swivel used
    (``max_swivel``, joint-space length of the self-motion), the posture's joint
    velocity peak as a share of the limits and the rate of its joint samples.
    ``hold_s``: the spans [s from the plan's start] round a grasp or a release where the
    controllers hold the arm's own posture still instead of following the planned one
    (the links checked clear with it, :mod:`dexlfd.robot.posture_hold`).
    """

    planned: bool
    margin: float = field(metadata=M)
    min_clearance: float = field(metadata=M)
    default_min_clearance: float = field(metadata=M)
    link: str = ""
    obstacle: int = 0
    t_s: float = field(default=0.0, metadata=AT)
    max_swivel: float = field(default=0.0, metadata={"unit": "rad"})
    joint_velocity_ratio: float = 0.0
    rate_hz: float = field(default=0.0, metadata={"unit": "Hz"})
    hold_s: tuple[Interval, ...] = field(default=(), metadata=SPAN)
