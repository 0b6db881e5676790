"""A simulated qb SoftHand: an anthropomorphic, single-synergy, tendon-driven soft hand.

The thesis's end-effector (Section 3.1.2) is the qb SoftHand Research: five fingers
driven by one motor through one tendon (an adaptive synergy), compliant joints that
let the fingers wrap around an object and stop where they touch, and a grasp that
stops closing when the contact force reaches 3 N (Section 4.2.3). It is built here
at run time in MuJoCo, on the Panda's flange in place of the Franka Hand:

- **Size and mass.** 1:1 with an average adult hand (palm 105 x 85 mm, middle finger
  100 mm, hand length ~0.2 m), 480 g in all, the figure the maker gives ("only
  480 grams", qbrobotics' qb SoftHand ROS documentation, NMMI/ROS-SoftHand): a 300 g
  motor housing and palm, 15 phalanges of 12 g.
- **Kinematics.** Thumb and four fingers, three flexion joints each (15 hinges).
- **One synergy.** A fixed tendon ``synergy`` runs over every joint with the same
  moment arm (:data:`MOMENT_ARM`); one position actuator pulls it. The tension
  acts on every joint at once (a differential: a finger that touches stops and the
  others go on closing, as in the Pisa/IIT SoftHand's adaptive synergy).
- **Compliance and sequence.** Every joint is a spring back to open; the knuckle and
  middle joints are preloaded against their open stops (:data:`PRELOAD`), so a digit
  first curls (distal, then middle joint) and then swings in at the knuckle: its
  tip meets the object's side moving inward, above the support the object stands on
  (a finger swung in straight first would strike the support beside the object).
- **The 3 N stop.** A touch sensor on every phalanx measures its contact normal
  force; :class:`SynergyDriver` ramps the closure and stops it as soon as the grasp
  squeezes with :data:`STOP_FORCE` (the thumb against the four fingers: the smaller
  of the two sides' contact forces, low-passed over 3 ms), then holds the tendon's pull.
- **Opposition.** The thumb's pulleys (and springs) are 4 times the fingers', so it
  presses back as hard as the four fingers together.

The mount: the thesis rotates the tool frame by H_y(90 deg) from a flat demonstrating
hand (Section 4.2.2); dexlfd's plans are top grasps (tool z axis down, the
``top_grasp`` mount of :mod:`dexlfd.motion.definition`: a flat palm-down hand), so
the hand sits palm toward the tool z axis, fingers along +y and the thumb along -y:
it closes along the tool y axis, the Franka Hand's finger axis, and its grasp centre
is the Franka Hand's TCP (0.1034 m past the flange), so every plan serves both hands.
The span between thumb and knuckles (:data:`SPAN`) and the room under the palm
bound what it can hold (:func:`check_graspable`). The controllers' model keeps the
Franka Hand (0.73 kg + fingers): with the softhand the arm carries 0.28 kg less than
the model believes, a model error like an unknown payload's.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput

__all__ = [
    "CLOSE_TIME",
    "FINGERS",
    "MASS",
    "SPAN",
    "STOP_FORCE",
    "SynergyDriver",
    "add_softhand",
    "check_graspable",
]

MASS = 0.48  # [kg] the qb SoftHand Research in all (maker's figure)
PHALANX_MASS = 0.012  # [kg] each of the 15
STOP_FORCE = 3.0  # [N] the grasp stops closing at this contact force (thesis Section 4.2.3)
CLOSE_TIME = 1.0  # [s] open to fully closed (free hand)
MOMENT_ARM = 0.008  # [m] of the synergy tendon about every joint
STIFFNESS = 0.03  # [N·m/rad] of every joint spring (back to open)
DAMPING = 0.01  # [N·m·s/rad] of every joint
# soft silicone pads: a contact of 10 ms time constant that yields up to 2 mm (the
# object's stiff contact parameters give way to these, solmix)
PAD_SOLREF = (0.01, 1.0)
PAD_SOLIMP = (0.9, 0.95, 0.002, 0.5, 2.0)
# [rad] proximal, middle, distal springs held against open: a digit curls into a hook
# first (the distal joint from the first pull, the middle one from a pull worth 0.6 rad)
# and swings it in at the knuckle only once curled (a pull worth 2.2 rad): its tip
# stays within 5 cm of the knuckle, above the object's support, and meets the object's
# side moving inward (a squeeze, not a push down)
PRELOAD = (2.2, 0.6, 0.0)
FLEX_MAX = (1.6, 1.6, 1.2)  # [rad] flexion ranges, proximal to distal
TOUCH_FORCE = 0.2  # [N] a digit touches something
SQUEEZE_SLOWDOWN = 5.0  # the set point ramps this many times slower once a digit touches
SERVO_KP = 500.0  # [N/m] the motor's position servo on the tendon
FORCE_FILTER_S = 0.003  # [s] time constant of the force reading (a touch sensor's filter)
TENDON_FORCE_MAX = 60.0  # [N] the motor's pull on the tendon
# palm (tool frame of the Franka Hand: z along the tool, y the closing axis) [m]
PALM_BOTTOM = 0.0634  # palm underside and knuckles: 4 cm above the grasp centre (TCP 0.1034)
PALM_THICKNESS = 0.03
HOUSING = PALM_BOTTOM - PALM_THICKNESS  # motor housing: flange to the back of the palm
PALM_Y = (-0.06, 0.036)  # heel (thumb side) to the knuckles
PALM_HALF_X = 0.0425
# the relaxed hand, open: the digits curled (distal and middle joints), the knuckles
# straight; a grasp is the knuckles' swing (~0.15 s), the curl is not waited for
PRESHAPE = 0.6  # [-] of the tendon's travel
SPAN = 0.073  # [m] widest object across the closing axis: thumb root to the knuckles
REACH_BELOW_PALM = 0.07  # [m] tallest object under the palm the fingers wrap around


@dataclass(frozen=True, slots=True)
class Finger:
    """One digit: name, root (x, y) [m] in the tool frame, direction along y, phalanges [m]."""

    name: str
    x: float
    y: float
    direction: float  # +1 fingers (toward +y), -1 thumb (toward -y)
    lengths: tuple[float, float, float]
    radius: float
    pulley: float = 1.0  # tendon moment arm and spring stiffness, times the fingers'


FINGERS = (
    # the thumb's pulleys are 4 times the fingers' (its springs too, so it closes at the
    # fingers' pace): it presses back as hard as the four fingers together
    Finger("thumb", 0.012, -0.037, -1.0, (0.040, 0.032, 0.028), 0.010, 4.0),
    Finger("index", 0.030, 0.036, 1.0, (0.045, 0.027, 0.020), 0.009),
    Finger("middle", 0.010, 0.036, 1.0, (0.048, 0.030, 0.022), 0.009),
    Finger("ring", -0.010, 0.036, 1.0, (0.045, 0.028, 0.021), 0.009),
    Finger("little", -0.030, 0.036, 1.0, (0.036, 0.021, 0.018), 0.008),
)
PHALANGES = ("proximal", "middle", "distal")


def check_graspable(shape: str, half_size: FloatArray) -> None:
    """Refuse an object the hand cannot close around (one line, before any simulation).

    ``half_size`` [m] in the tool frame (y: the closing axis, z: along the tool).
    """
    hs = np.asarray(half_size, dtype=np.float64)
    if 2.0 * hs[1] > SPAN - 0.01:
        raise InvalidInput(
            f"the softhand cannot hold a {shape} {2 * hs[1]:.3f} m wide across its closing "
            f"axis: its span is {SPAN - 0.01:.2f} m (thumb root to knuckles, less the pads)"
        )
    if 2.0 * hs[2] > REACH_BELOW_PALM:
        raise InvalidInput(
            f"the softhand cannot hold a {shape} {2 * hs[2]:.3f} m tall under its palm: "
            f"at most {REACH_BELOW_PALM:.2f} m"
        )


def add_softhand(mj: Any, spec: Any, parent: str = "panda_hand") -> None:
    """Build the hand into ``spec`` under body ``parent`` (the Franka Hand's frame).

    ``parent`` keeps its frame and the ``tcp`` site and takes the housing and palm's
    mass; its own geoms and the Franka fingers are removed first.
    """
    hand = spec.body(parent)
    for b in [b for b in hand.bodies if "finger" in b.name]:
        spec.delete(b)
    for g in list(hand.geoms):
        spec.delete(g)
    base_mass = MASS - PHALANX_MASS * 3 * len(FINGERS)
    hand.explicitinertial = True
    hand.mass = base_mass
    hand.ipos = [0.0, 0.0, 0.04]
    hand.inertia = [base_mass * 0.05**2 / 3] * 2 + [base_mass * 0.04**2 / 3]
    hand.fullinertia = [np.nan] * 6
    skin = [0.93, 0.80, 0.70, 1.0]
    hand.add_geom(
        name="softhand_housing", type=mj.mjtGeom.mjGEOM_CYLINDER,
        size=[0.035, 0.5 * HOUSING, 0.0], pos=[0.0, 0.0, 0.5 * HOUSING],
        rgba=[0.15, 0.15, 0.17, 1.0], contype=1, conaffinity=0, mass=0.0, density=0.0,
    )  # fmt: skip
    hand.add_geom(
        name="softhand_palm", type=mj.mjtGeom.mjGEOM_BOX,
        size=[PALM_HALF_X, 0.5 * (PALM_Y[1] - PALM_Y[0]), 0.5 * PALM_THICKNESS],
        pos=[0.0, 0.5 * sum(PALM_Y), PALM_BOTTOM - 0.5 * PALM_THICKNESS], rgba=skin,
        contype=1, conaffinity=0, mass=0.0, density=0.0, friction=[1.0, 0.01, 0.0001],
    )  # fmt: skip
    tendon = spec.add_tendon(name="synergy")
    z0 = PALM_BOTTOM
    for f in FINGERS:
        body = hand
        pos = [f.x, f.y, z0]
        for i, (length, phalanx) in enumerate(zip(f.lengths, PHALANGES, strict=True)):
            body = _add_phalanx(mj, spec, body, (f, i), pos, length, skin)
            tendon.wrap_joint(f"{f.name}_{phalanx}", MOMENT_ARM * f.pulley)
            pos = [0.0, f.direction * length, 0.0]
    act = spec.add_actuator(name="synergy", target="synergy")
    act.trntype = mj.mjtTrn.mjTRN_TENDON
    act.set_to_position(kp=SERVO_KP, kv=5.0)
    act.forcelimited = True
    act.forcerange = [-TENDON_FORCE_MAX, TENDON_FORCE_MAX]
    act.ctrllimited = True
    act.ctrlrange = [0.0, full_closure_length()]


def _add_phalanx(
    mj: Any,
    spec: Any,
    parent: Any,
    which: tuple[Finger, int],
    pos: list[float],
    length: float,
    rgba: list[float],
) -> Any:
    """One phalanx (``which``: digit and index) with its spring joint, pad and touch sensor."""
    f, i = which
    name = f"{f.name}_{PHALANGES[i]}"
    body = parent.add_body(name=name, pos=pos)
    body.explicitinertial = True
    body.mass = PHALANX_MASS
    body.ipos = [0.0, f.direction * 0.5 * length, 0.0]
    i_long, i_cross = 0.5 * PHALANX_MASS * f.radius**2, PHALANX_MASS * length**2 / 12
    body.inertia = [i_cross, i_long, i_cross]
    joint = body.add_joint(name=name, type=mj.mjtJoint.mjJNT_HINGE)
    joint.axis = [f.direction, 0.0, 0.0]  # flexion turns the digit toward +z (the object)
    joint.range = [0.0, FLEX_MAX[i]]
    joint.limited = mj.mjtLimited.mjLIMITED_TRUE
    joint.stiffness = [STIFFNESS * f.pulley, 0.0, 0.0]
    joint.springref = -PRELOAD[i]  # a preloaded spring: held open until the tendon pulls
    joint.damping = [DAMPING * f.pulley, 0.0, 0.0]
    joint.armature = 1e-4
    seg = [0.0, 0.0, 0.0, 0.0, f.direction * length, 0.0]
    body.add_geom(
        name=f"{name}_pad", type=mj.mjtGeom.mjGEOM_CAPSULE, fromto=seg, size=[f.radius, 0, 0],
        rgba=rgba, contype=1, conaffinity=0, mass=0.0, density=0.0, condim=4,
        friction=[1.0, 0.01, 0.0001], solmix=100.0, solref=list(PAD_SOLREF),
        solimp=list(PAD_SOLIMP),
    )  # fmt: skip
    site = body.add_site(
        name=f"{name}_touch", type=mj.mjtGeom.mjGEOM_CAPSULE, fromto=seg,
        size=[f.radius + 0.001, 0, 0], rgba=[0, 0, 0, 0],
    )  # fmt: skip
    sensor = spec.add_sensor(name=f"{name}_force", type=mj.mjtSensor.mjSENS_TOUCH)
    sensor.objtype = mj.mjtObj.mjOBJ_SITE
    sensor.objname = site.name
    return body


def full_closure_length() -> float:
    """Synergy tendon length [m] with every joint fully flexed (open: 0)."""
    return MOMENT_ARM * sum(f.pulley for f in FINGERS) * float(sum(FLEX_MAX))


class SynergyDriver:
    """The hand's motor: closes on command, stops at the 3 N contact force, holds, opens.

    ``closure`` in [0, 1] is the tendon's set point (0 open, 1 fully closed); it ramps
    at ``1 / CLOSE_TIME`` per second. Call :meth:`update` every physics step.

    Parameters
    ----------
    mj, model
        The MuJoCo module and the compiled scene with :func:`add_softhand`.
    stop_force : float
        Fingertip contact normal force [N] at which the closure stops and holds.
    """

    def __init__(self, mj: Any, model: Any, stop_force: float = STOP_FORCE) -> None:
        self.stop_force = float(stop_force)
        self._act = mj.mj_name2id(model, mj.mjtObj.mjOBJ_ACTUATOR, "synergy")
        self._tendon = mj.mj_name2id(model, mj.mjtObj.mjOBJ_TENDON, "synergy")
        adr = {
            f"{f.name}_{p}": int(
                model.sensor_adr[
                    mj.mj_name2id(model, mj.mjtObj.mjOBJ_SENSOR, f"{f.name}_{p}_force")
                ]
            )
            for f in FINGERS
            for p in PHALANGES
        }
        self._tip = np.array([adr[f"{f.name}_distal"] for f in FINGERS])
        self._finger = np.array([[adr[f"{f.name}_{p}"] for p in PHALANGES] for f in FINGERS])
        self._qadr = np.array(
            [
                [model.jnt_qposadr[mj.mj_name2id(model, mj.mjtObj.mjOBJ_JOINT, f"{f.name}_{p}")]
                 for p in PHALANGES]
                for f in FINGERS
            ]
        )  # fmt: skip
        self._full = full_closure_length()
        self._vadr = np.array(
            [
                [model.jnt_dofadr[mj.mj_name2id(model, mj.mjtObj.mjOBJ_JOINT, f"{f.name}_{p}")]
                 for p in PHALANGES]
                for f in FINGERS
            ]
        )  # fmt: skip
        self.target = PRESHAPE  # where the closure goes (0 flat, 1 closed)
        self.setpoint = PRESHAPE  # the motor's set point now [0, 1]
        self.stopped = False  # the 3 N stop fired (holding)
        self.stop_t: float | None = None
        self.squeeze = 0.0  # low-passed squeeze force [N]

    def close(self) -> None:
        """Start closing (until the stop force or fully closed)."""
        self.target, self.stopped, self.stop_t = 1.0, False, None

    def open(self) -> None:
        """Open to the relaxed pre-shape: from where the hand is, ramped."""
        self.target, self.stopped = PRESHAPE, False

    def fingertip_forces(self, data: Any) -> FloatArray:
        """Contact normal force [N] on each distal phalanx (thumb, index .. little)."""
        return np.asarray(data.sensordata[self._tip], dtype=np.float64)

    def finger_forces(self, data: Any) -> FloatArray:
        """Contact normal force [N] on each digit (its three phalanges summed)."""
        return np.asarray(data.sensordata[self._finger].sum(axis=1), dtype=np.float64)

    def squeeze_force(self, data: Any) -> float:
        """The grasp force [N]: what the thumb and the four fingers press against each other.

        The smaller of the thumb's contact force and the four fingers' together (the
        two sides of the grasp; a finger alone on the support squeezes nothing).
        """
        f = self.finger_forces(data)
        return float(min(f[0], f[1:].sum()))

    def touching(self, data: Any, threshold: float = 0.05) -> bool:
        """Whether the thumb and at least one finger touch something (an opposed grasp)."""
        f = self.finger_forces(data)
        return bool(f[0] > threshold and (f[1:] > threshold).any())

    def closure(self, data: Any) -> float:
        """How far the tendon is pulled [0, 1] (0 open, 1 every joint fully flexed)."""
        return float(data.ten_length[self._tendon]) / self._full

    def update(self, data: Any, dt: float) -> None:
        """One physics step: ramp the set point, stop and hold at the stop force."""
        a = dt / (FORCE_FILTER_S + dt)  # the force reading, low-passed (no impact spikes)
        self.squeeze += a * (self.squeeze_force(data) - self.squeeze)
        if self.target > self.setpoint and not self.stopped:
            if self.squeeze >= self.stop_force:
                # stop closing and hold the tendon's pull of this instant (the set point
                # that gives it at rest), not the set point the fingers were chasing
                self.stopped, self.stop_t = True, float(data.time)
                pull = float(data.actuator_force[self._act])
                self.setpoint = (
                    float(data.ten_length[self._tendon]) + pull / SERVO_KP
                ) / self._full
            else:  # fast until a digit touches, then squeeze slowly (no overshoot)
                slow = self.finger_forces(data).max() > TOUCH_FORCE
                rate = 1.0 / (CLOSE_TIME * (SQUEEZE_SLOWDOWN if slow else 1.0))
                self.setpoint = min(self.target, self.setpoint + rate * dt)
        elif self.target < self.setpoint:
            self.setpoint = max(
                self.target, min(self.setpoint, self.closure(data)) - dt / CLOSE_TIME
            )
        data.ctrl[self._act] = self.setpoint * self._full

    def set_pose(self, data: Any, closure: float) -> None:
        """Put the fingers at a free-hand closure in [0, 1], set point there (no dynamics).

        The joints take the tendon's travel in the preload's order: distal, middle,
        then knuckle (the free hand's pose, up to the springs' overlap).
        """
        c = float(np.clip(closure, 0.0, 1.0))
        travel = c * float(sum(FLEX_MAX))  # [rad] per digit
        flex = np.empty(3)
        for i in (2, 1, 0):
            flex[i] = min(travel, FLEX_MAX[i])
            travel -= flex[i]
        data.qpos[self._qadr] = flex[None, :]
        data.qvel[self._vadr] = 0.0
        data.ctrl[self._act] = c * self._full
        self.setpoint = c

    def opening(self, data: Any) -> float:
        """Width [m] the hand leaves between thumb and fingers: ``SPAN`` open, 0 closed.

        Open is the relaxed pre-shape (:data:`PRESHAPE`); the knuckles' swing closes it.
        """
        c = (self.closure(data) - PRESHAPE) / (1.0 - PRESHAPE)
        return SPAN * float(np.clip(1.0 - c, 0.0, 1.0))

    def closure_at(self, opening: float) -> float:
        """The closure of a recorded ``opening`` [m] (the inverse of :meth:`opening`)."""
        return PRESHAPE + (1.0 - PRESHAPE) * (1.0 - float(np.clip(opening / SPAN, 0.0, 1.0)))
