"""libfranka's Python bindings as dexlfd sees them: the import, the protocol and a state.

:func:`import_pylibfranka` names the pin when the bindings are missing,
:class:`FrankaState` converts libfranka's column-major lists, and
:class:`RobotConnectionError` / :class:`RobotStopped` are the errors of the
real-arm path (:mod:`dexlfd.robot.franka`, :mod:`dexlfd.control.arm_loop`).

References
----------
.. [1] Franka Robotics, libfranka 0.21 and pylibfranka documentation,
   https://frankarobotics.github.io/docs/ ("Control parameters", "libfranka").
"""

from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import DexlfdError, SimulationDiverged
from dexlfd.io import Rollout

__all__ = [
    "CONTROL_PERIOD_S",
    "PYLIBFRANKA_REQUIREMENT",
    "ROBOT_PROTOCOL_VERSION",
    "FrankaState",
    "RobotConnectionError",
    "RobotStopped",
    "import_pylibfranka",
    "state_from",
]

PYLIBFRANKA_REQUIREMENT = "pylibfranka==0.21.3"
ROBOT_PROTOCOL_VERSION = 10  # libfranka 0.21.x speaks robot protocol 10
CONTROL_PERIOD_S = 1e-3  # [s] libfranka's control cycle


class RobotConnectionError(DexlfdError):
    """The arm cannot be reached, refuses the connection or speaks another protocol version."""


class RobotStopped(SimulationDiverged):
    """A motion on the arm ended early; ``rollout`` holds the samples up to the stop."""

    def __init__(self, message: str, rollout: Rollout | None) -> None:
        super().__init__(message)
        self.rollout = rollout


def import_pylibfranka() -> ModuleType:
    """Import ``pylibfranka`` or raise :class:`DependencyNotInstalled` naming the pin."""
    from dexlfd._extras import import_extra

    return import_extra(
        "pylibfranka", "the real-arm (Franka) path", package=PYLIBFRANKA_REQUIREMENT
    )


@dataclass(frozen=True, slots=True)
class FrankaState:
    """One robot state, converted from libfranka's column-major lists.

    Attributes
    ----------
    q, dq, tau_J : ndarray, shape (7,)
        Joint positions [rad], velocities [rad/s], measured link-side torques [N·m].
    O_T_EE : ndarray, shape (4, 4)
        Base-to-end-effector (TCP) transform, translation [m].
    F_T_EE : ndarray, shape (4, 4)
        Flange-to-end-effector transform (the configured hand/TCP).
    mode : str
        Robot mode (``"Idle"``, ``"Move"``, ``"Reflex"``, ...).
    errors : str
        Active error flags as libfranka prints them (``"[]"`` when none).
    """

    q: FloatArray
    dq: FloatArray
    tau_J: FloatArray  # noqa: N815 - libfranka's name
    O_T_EE: FloatArray
    F_T_EE: FloatArray
    mode: str
    errors: str


def state_from(raw: Any) -> FrankaState:
    """A :class:`FrankaState` from a libfranka ``RobotState`` (pylibfranka or panda-python)."""
    return FrankaState(
        q=np.array(raw.q),
        dq=np.array(raw.dq),
        tau_J=np.array(raw.tau_J),
        O_T_EE=np.array(raw.O_T_EE).reshape(4, 4, order="F"),
        F_T_EE=np.array(raw.F_T_EE).reshape(4, 4, order="F"),
        mode=_mode_name(raw.robot_mode),
        errors=str(raw.current_errors) if raw.current_errors else "[]",
    )


def _mode_name(mode: Any) -> str:
    """``"Move"`` from pylibfranka's ``RobotMode.Move`` and libfranka 0.9's ``RobotMode.kMove``."""
    name = str(mode).rsplit(".", 1)[-1]
    return name[1:] if len(name) > 1 and name[0] == "k" and name[1].isupper() else name
