"""Which libfranka binding drives which Franka generation, and how a mismatch is reported.

A Franka Emika Panda (FER, the thesis's arm) runs system images whose Franka
Control Interface speaks robot protocol 5 at most: libfranka < 0.10 (0.9.2 is
the last), in Python ``panda-python`` (its PyPI wheels bundle libfranka 0.9.2).
A Franka Research 3 (FR3) speaks protocol 6 and later: libfranka >= 0.10, in
Python the official ``pylibfranka`` (0.21.3 speaks protocol 10). A libfranka of
the other generation is refused in the connect handshake with libfranka's
``IncompatibleVersionException`` ("server version: N"): :func:`mismatch_message`
turns it into one line naming the generation found and the extra to install.

The two bindings expose the same robot calls (``Robot(host, RealtimeConfig)``,
``read_once``, ``load_model``, ``set_collision_behavior``, ``set_load``,
``stop``, ``automatic_error_recovery``, ``Torques``, ``Gripper``); they differ in
the torque stream (pylibfranka's ``start_torque_control()`` read/write object,
libfranka 0.9's ``Robot.control(callback)``) and in the model calls (0.9 takes a
``Frame`` for the Jacobian and the gravity vector as an argument).

References
----------
.. [1] Franka Robotics, "Compatibility with libfranka",
   https://frankarobotics.github.io/docs/compatibility.html
.. [2] J. Elsner, panda-py, https://github.com/JeanElsner/panda-py (libfranka builds
   per robot protocol version).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from types import ModuleType

from dexlfd.errors import InvalidInput

__all__ = [
    "BINDINGS",
    "GENERATIONS",
    "FrankaBinding",
    "generation_of_protocol",
    "import_binding",
    "mismatch_message",
    "server_version_of",
]

GENERATIONS = ("fer", "fr3", "auto")  # what --franka-generation accepts
LAST_FER_PROTOCOL = 5  # libfranka 0.9.x; 0.10 and later (protocol >= 6) serve only the FR3


@dataclass(frozen=True, slots=True)
class FrankaBinding:
    """One generation's Python binding of libfranka."""

    generation: str  # "fer" or "fr3"
    label: str  # what a person calls the arm
    module: str  # import name
    requirement: str  # pip requirement
    extra: str  # dexlfd's optional-dependency group
    libfranka: str  # bundled libfranka version
    protocol: int  # robot protocol version it speaks
    callback_stream: bool  # torque stream by Robot.control(callback) (libfranka < 0.13)


BINDINGS: dict[str, FrankaBinding] = {
    "fr3": FrankaBinding(
        "fr3", "Franka Research 3 (FR3)", "pylibfranka", "pylibfranka==0.21.3", "franka",
        "0.21.3", 10, callback_stream=False,
    ),
    "fer": FrankaBinding(
        "fer", "Franka Emika Panda (FER)", "panda_py.libfranka", "panda-python==1.1.1",
        "franka-fer", "0.9.2", 5, callback_stream=True,
    ),
}  # fmt: skip


def generation_of_protocol(version: int) -> str:
    """``"fer"`` for robot protocol <= 5 (libfranka < 0.10), else ``"fr3"``."""
    return "fer" if version <= LAST_FER_PROTOCOL else "fr3"


_SERVER_VERSION = re.compile(r"server version:?\s*(\d+)", re.IGNORECASE)
_SPEAKS = re.compile(r"robot speaks protocol version (\d+)", re.IGNORECASE)


def server_version_of(exc: BaseException) -> int | None:
    """The robot's protocol version from a version-mismatch error, or None if it is not one.

    pylibfranka passes libfranka's text ("Incompatible library version (server
    version: 5, library version: 10)"); panda-python raises its
    ``IncompatibleVersionError`` with a ``server_version`` attribute.
    """
    version = getattr(exc, "server_version", None)
    if isinstance(version, int):
        return version
    text = str(exc)
    match = _SERVER_VERSION.search(text) or _SPEAKS.search(text)
    return int(match.group(1)) if match else None


def mismatch_message(host: str, used: FrankaBinding, server_version: int) -> str:
    """One line: the generation found at ``host``, and what to install and pass instead."""
    found = BINDINGS[generation_of_protocol(server_version)]
    if found.generation == used.generation:  # same generation, another protocol release
        return (
            f"Franka at {host} speaks robot protocol {server_version}, {used.requirement} "
            f"(libfranka {used.libfranka}) speaks {used.protocol}: update the robot's system "
            f"image or install the {used.module} build for protocol {server_version}"
        )
    return (
        f"Franka at {host} is a {found.label} (robot protocol {server_version}), not a "
        f"{used.label}: pip install 'dexlfd[{found.extra}]' ({found.requirement}) and pass "
        f"--franka-generation {found.generation} (or auto)"
    )


def import_binding(binding: FrankaBinding) -> ModuleType:
    """Import the binding or raise :class:`DependencyNotInstalled` naming its extra."""
    from dexlfd._extras import import_extra

    return import_extra(binding.module, f"the {binding.label} path", package=binding.requirement)


def binding_for(generation: str) -> FrankaBinding:
    """The binding of ``"fer"`` or ``"fr3"`` (``"auto"`` is resolved by connecting)."""
    if generation not in BINDINGS:
        raise InvalidInput(f"Franka generation must be one of {GENERATIONS}, got {generation!r}")
    return BINDINGS[generation]
