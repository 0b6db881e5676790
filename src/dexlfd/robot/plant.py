"""What the simulated world is like: payload, friction, contacts, obstacles (:class:`PlantConfig`).

None of it is known to the controller. Obstacles are :mod:`dexlfd.geometry`
shapes, the same the planner bends its path around; :func:`plan_world` takes them
from a plan's arrays.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.geometry import Box, Obstacle, Sphere, half_extents
from dexlfd.io import Plan
from dexlfd.panda import FINGER_MAX, MAX_PAYLOAD
from dexlfd.robot.softhand import check_graspable

logger = logging.getLogger(__name__)

__all__ = ["HALF_SIZES", "HANDS", "SHAPES", "PlantConfig", "plan_world"]

HANDS = ("franka", "softhand")  # end-effectors of the simulated plant
SHAPES = ("box", "cylinder", "sphere")  # objects it picks
# [m] half sizes of each shape's default object (y across the fingers): the payload
# study's 6 x 5 x 6 cm box, a cylinder and a sphere 6 cm across
HALF_SIZES: dict[str, tuple[float, float, float]] = {
    "box": (0.03, 0.025, 0.03),
    "cylinder": (0.03, 0.03, 0.03),
    "sphere": (0.03, 0.03, 0.03),
}


def plan_world(plan: Plan) -> tuple[Obstacle, ...]:
    """What the simulated scene holds for ``plan``: its obstacles and its supports.

    Both are the plan's typed arrays (:attr:`dexlfd.io.Plan.obstacles`,
    :attr:`~dexlfd.io.Plan.supports`: the place surface the object is set down on);
    the scene holds a sphere as its bounding cube, see :class:`PlantConfig`.
    """
    return (*plan.obstacles, *plan.supports)


@dataclass(frozen=True, slots=True)
class PlantConfig:
    """What the simulated world is like (none of it is known to the controller).

    Attributes
    ----------
    payload_kg : float
        Mass of the object to pick [kg], 0 (no object) to 3 (Panda's payload).
    payload_com : tuple of 3 floats
        Offset of the object's centre of mass from the box centre [m], box frame.
    payload_half_size : tuple of 3 floats
        Half sizes of the box [m] in the TCP frame; the fingers close along y.
    friction_scale : float
        Factor on the identified sigmoid friction levels of Gaz et al. (2019) [-];
        0 switches friction off.
    viscous : float
        Extra linear viscous joint friction [N·m·s/rad].
    contacts : bool
        Simulate contacts (object on its pedestal, arm with floor/obstacles).
    timestep : float
        Physics step [s].
    obstacles : tuple of Box or Sphere
        Static obstacles (:mod:`dexlfd.geometry`; shown in videos, they collide
        with the arm and object). A sphere is simulated as its bounding cube
        (conservative: the arm may touch air, never pass through it), with a warning.
    grasp : {"weld", "contact"}
        How the object is held: ``"contact"`` (default) squeezes it between the
        fingers with ``grip_force`` and lets friction carry it (it may slip, ~2 mm
        over the 1.2 kg lift); ``"weld"`` attaches it to the hand at the grasp
        instant (an ideal, stiff grasp).
    grip_force : float
        Finger force in ``"contact"`` mode [N] (the Panda hand: 70 N continuous).
    pedestal : bool
        Stand the object on a 10 cm pedestal of its own (True); False when the world
        already holds its support (a plan's ``support_center``/``support_size``).
    hand : {"franka", "softhand"}
        The end-effector: the Franka Hand (parallel fingers, ``grip_force``) or the
        qb SoftHand (:mod:`dexlfd.robot.softhand`: one synergy, stops closing at
        ``stop_force``). An object the softhand cannot close around is refused here.
    stop_force : float
        Softhand: fingertip contact force [N] at which its closure stops and holds
        (the thesis's 3 N, Section 4.2.3).
    payload_shape : {"box", "cylinder", "sphere"}
        The object: a box of ``payload_half_size``; an upright cylinder (radius
        ``payload_half_size[0]`` = ``[1]``, half height ``[2]``); a sphere (all three equal).
    """

    payload_kg: float = 0.0
    payload_com: tuple[float, float, float] = (0.0, 0.0, 0.0)
    payload_half_size: tuple[float, float, float] = (0.03, 0.025, 0.03)
    friction_scale: float = 1.0
    viscous: float = 0.0
    contacts: bool = True
    timestep: float = 1e-3
    obstacles: tuple[Obstacle, ...] = field(default_factory=tuple)
    grasp: str = "contact"
    grip_force: float = 70.0
    pedestal: bool = True
    hand: str = "franka"
    stop_force: float = 3.0
    payload_shape: str = "box"

    def __post_init__(self) -> None:
        for ob in self.obstacles:
            if not isinstance(ob, Box | Sphere):
                raise InvalidInput(f"obstacles must be geometry.Box or Sphere, got {ob!r}")
            if isinstance(ob, Sphere):
                logger.warning("sphere obstacle at %s simulated as its bounding cube", ob.center)
        if self.grasp not in ("weld", "contact"):
            raise InvalidInput(f"grasp must be 'weld' or 'contact', got {self.grasp!r}")
        if not (np.isfinite(self.grip_force) and 0 < self.grip_force <= 140):
            raise InvalidInput(f"grip_force must be in (0, 140] N, got {self.grip_force!r}")
        m = float(self.payload_kg)
        if not np.isfinite(m) or m < 0 or m > MAX_PAYLOAD:
            raise InvalidInput(
                f"payload_kg must be in [0, {MAX_PAYLOAD}] kg (the Panda's rated payload), "
                f"got {self.payload_kg!r}"
            )
        if not (np.isfinite(self.friction_scale) and self.friction_scale >= 0):
            raise InvalidInput(f"friction_scale must be >= 0, got {self.friction_scale!r}")
        if not (np.isfinite(self.viscous) and self.viscous >= 0):
            raise InvalidInput(f"viscous must be >= 0, got {self.viscous!r}")
        if not (np.isfinite(self.timestep) and 0 < self.timestep <= 0.01):
            raise InvalidInput(f"timestep must be in (0, 0.01] s, got {self.timestep!r}")
        hs = np.asarray(self.payload_half_size, dtype=np.float64)
        if hs.shape != (3,) or not (hs > 0).all():
            raise InvalidInput(
                f"payload_half_size must be 3 positive half sizes, got {self.payload_half_size!r}"
            )
        self._check_hand(hs)
        com = np.asarray(self.payload_com, dtype=np.float64)
        if com.shape != (3,) or not np.isfinite(com).all() or (np.abs(com) > hs).any():
            raise InvalidInput(
                f"payload_com must lie inside the box (|com| <= half size), got "
                f"{self.payload_com!r}"
            )

    def _check_hand(self, hs: FloatArray) -> None:
        """The hand, the object's shape and whether the hand can hold it (one line each)."""
        if self.hand not in HANDS:
            raise InvalidInput(f"hand must be one of {', '.join(HANDS)}, got {self.hand!r}")
        if self.payload_shape not in SHAPES:
            raise InvalidInput(
                f"payload_shape must be one of {', '.join(SHAPES)}, got {self.payload_shape!r}"
            )
        if self.payload_shape == "cylinder" and not np.isclose(hs[0], hs[1]):
            raise InvalidInput(f"a cylinder's half sizes x and y (its radius) differ: {hs[:2]}")
        if self.payload_shape == "sphere" and not np.allclose(hs, hs[0]):
            raise InvalidInput(f"a sphere's three half sizes (its radius) differ: {hs}")
        if not (np.isfinite(self.stop_force) and 0 < self.stop_force <= 50):
            raise InvalidInput(f"stop_force must be in (0, 50] N, got {self.stop_force!r}")
        if self.hand == "franka" and hs[1] > FINGER_MAX:
            raise InvalidInput(
                f"the Franka Hand cannot hold an object {2 * hs[1]:.3f} m wide: its opening "
                f"is {2 * FINGER_MAX} m (payload_half_size y <= {FINGER_MAX})"
            )
        if self.hand == "softhand" and self.payload_kg > 0:
            check_graspable(self.payload_shape, hs)

    def describe(self) -> dict[str, Any]:
        """JSON-able summary for rollout metadata."""
        return {
            "payload_kg": float(self.payload_kg),
            "payload_com_m": list(self.payload_com),
            "payload_half_size_m": list(self.payload_half_size),
            "friction": f"Gaz et al. 2019 sigmoid x{self.friction_scale:g}"
            + (f" + viscous {self.viscous:g} N m s/rad" if self.viscous else ""),
            "contacts": bool(self.contacts),
            "timestep_s": float(self.timestep),
            "obstacles": [[list(o.center), list(half_extents(o))] for o in self.obstacles],
            "grasp": self.grasp,
            "hand": self.hand,
            "payload_shape": self.payload_shape,
            **(
                {"stop_force_n": self.stop_force}
                if self.hand == "softhand"
                else {"grip_force_n": self.grip_force}
                if self.grasp == "contact"
                else {}
            ),
        }
