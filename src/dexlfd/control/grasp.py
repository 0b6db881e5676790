"""The simulated loop's grasp: grasp and release from the referenced opening, and watch the hold.

The object is grasped when the referenced opening first drops below
``grasp_below`` (with ``regrasp``, again whenever it closes after a release)
and released when it opens. A grasp that closes on nothing ("missed") or an
object that leaves the hand while still commanded held ("dropped") is logged
once per grasp and kept in :attr:`GraspMonitor.events`.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.robot.sim import PandaSim

__all__ = ["GraspMonitor"]

logger = logging.getLogger(__name__)


class GraspMonitor:
    """Grasp state of one tracking run.

    Parameters
    ----------
    grasp_below : float
        Referenced opening [m] below which the hand is grasping.
    regrasp : bool
        Grasp again when the opening closes after a release.
    """

    def __init__(self, grasp_below: float, regrasp: bool) -> None:
        self.grasp_below = grasp_below
        self.regrasp = regrasp
        self.grasps = 0
        self._was_closed = False
        self._holding: bool | None = False  # None: this grasp already reported lost
        self.events: list[dict[str, Any]] = []  # missed grasps and drops

    def command(self, sim: PandaSim, opening: float) -> None:
        """Grasp or release in ``sim`` as the referenced ``opening`` [m] closes or opens."""
        closed = opening < self.grasp_below
        if closed and not self._was_closed and (self.regrasp or self.grasps == 0):
            sim.grasp()
            self.grasps += 1
        elif self.grasps and sim.attached and not closed:
            sim.release()
        self._was_closed = closed

    def observe(
        self,
        sim: PandaSim,
        t: float,
        opening: float,
        payload: tuple[FloatArray, FloatArray] | None,
        p_tcp: FloatArray,
    ) -> bool:
        """Whether the object is really in the hand at time ``t`` [s]; logs a miss or drop.

        ``opening`` [m], the object's pose ``payload`` and the TCP position
        ``p_tcp`` [m] are values the loop already read this tick.
        """
        holding = payload is not None and sim.holds(opening, payload[0], p_tcp)
        if sim.attached and not holding and self._holding is not None:
            event = "dropped" if self._holding else "missed"
            pos = sim.payload_position()
            dist = float(np.linalg.norm(pos - p_tcp)) if pos is not None else float("nan")
            logger.warning(
                "grasp %s at t=%.3f s: the object is %.3f m from the TCP, gripper %.3f m",
                event, t, dist, sim.gripper_opening,
            )  # fmt: skip
            self.events.append({"event": event, "t": t, "distance_m": dist})
            self._holding = None  # report once per grasp
        elif holding:
            self._holding = True
        elif not sim.attached:
            self._holding = False
        return holding
