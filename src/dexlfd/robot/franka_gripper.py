"""The Franka Hand over its own protocol (port 1338), with the Panda hand's limits."""

from __future__ import annotations

import logging
from collections.abc import Callable
from types import ModuleType

from dexlfd.errors import InvalidInput
from dexlfd.panda import GRIPPER_FORCE_MAX, GRIPPER_OPENING_MAX, GRIPPER_SPEED_MAX
from dexlfd.robot.libfranka import RobotConnectionError

__all__ = ["FrankaGripper"]

logger = logging.getLogger(__name__)


class FrankaGripper:
    """The Franka Hand over its own protocol (port 1338).

    Every command blocks until the hand finishes, and pylibfranka holds
    Python's GIL while it waits (measured: a grasp stalls a concurrent
    1 kHz loop for 0.7 s), so gripper commands run between arm motions.
    """

    def __init__(self, host: str, plf: ModuleType) -> None:
        self._plf = plf
        try:
            self._gripper = plf.Gripper(host)
        except Exception as exc:
            raise RobotConnectionError(f"gripper at {host}: {exc}") from exc
        self.host = host

    def _call(self, what: str, fn: Callable[[], bool]) -> bool:
        try:
            ok = bool(fn())
        except Exception as exc:
            raise RobotConnectionError(f"gripper at {self.host}: {what} failed: {exc}") from exc
        logger.info("gripper %s -> %s (width %.4f m)", what, ok, self.width())
        return ok

    def homing(self) -> bool:
        """Calibrate the fingers (moves to the maximum width and back)."""
        return self._call("homing", self._gripper.homing)

    def move(self, width: float, speed: float = 0.05) -> bool:
        """Move the fingers to ``width`` [m] at ``speed`` [m/s]."""
        if not (0.0 <= width <= GRIPPER_OPENING_MAX and 0.0 < speed <= GRIPPER_SPEED_MAX):
            raise InvalidInput(
                f"gripper move: width must be in [0, {GRIPPER_OPENING_MAX:g}] m and speed in "
                f"(0, {GRIPPER_SPEED_MAX:g}] m/s, got {width}, {speed}"
            )
        return self._call(f"move({width:.4f})", lambda: self._gripper.move(width, speed))

    def grasp(
        self,
        width: float = 0.0,
        speed: float = 0.05,
        force: float = 40.0,
        epsilon_inner: float = GRIPPER_OPENING_MAX,
        epsilon_outer: float = GRIPPER_OPENING_MAX,
    ) -> bool:
        """Close on an object: True if it is held with a width in [width − ε_in, width + ε_out]."""
        if not (
            0.0 <= width <= GRIPPER_OPENING_MAX
            and 0.0 < speed <= GRIPPER_SPEED_MAX
            and 0.0 < force <= GRIPPER_FORCE_MAX
        ):
            raise InvalidInput(
                f"gripper grasp: width in [0, {GRIPPER_OPENING_MAX:g}] m, speed in "
                f"(0, {GRIPPER_SPEED_MAX:g}] m/s, force in (0, {GRIPPER_FORCE_MAX:g}] N; "
                f"got {width}, {speed}, {force}"
            )
        return self._call(
            f"grasp({width:.4f}, {force:.0f} N)",
            lambda: self._gripper.grasp(width, speed, force, epsilon_inner, epsilon_outer),
        )

    def width(self) -> float:
        """Current finger opening [m]."""
        try:
            return float(self._gripper.read_once().width)
        except Exception as exc:
            raise RobotConnectionError(f"gripper at {self.host}: read failed: {exc}") from exc

    def is_grasped(self) -> bool:
        """Whether the hand reports holding an object."""
        return bool(self._gripper.read_once().is_grasped)
