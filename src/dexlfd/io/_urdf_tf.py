"""The Panda's packaged URDF as a kinematic tree: each joint's parent-to-child transform.

What ``robot_state_publisher`` computes from ``/joint_states`` and
``/robot_description``, for the ROS 2 bags' ``/tf`` and ``/tf_static``: a joint's
transform is its ``<origin>`` (``xyz``, and ``rpy`` as fixed-axis roll, pitch,
yaw: ``R = Rz(yaw) Ry(pitch) Rx(roll)``, URDF's convention) followed by the motion
along its ``<axis>`` (a rotation by ``q`` for revolute joints, a translation by
``q`` for prismatic ones; ``<mimic>`` joints follow their leader,
``multiplier * q + offset``). Fixed joints give the static transforms.
"""

from __future__ import annotations

import functools
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from importlib import resources

import numpy as np
from scipy.spatial.transform import Rotation

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidFile

__all__ = ["FINGER_JOINTS", "UrdfJoint", "panda_urdf", "panda_joints", "joint_transforms"]

FINGER_JOINTS = ("panda_finger_joint1", "panda_finger_joint2")  # each half the opening [m]


@dataclass(frozen=True)
class UrdfJoint:
    """One ``<joint>``: its frames, origin, axis and (for a mimic joint) its leader."""

    name: str
    type: str  # "revolute", "continuous", "prismatic" or "fixed"
    parent: str
    child: str
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float]
    axis: tuple[float, float, float]
    mimic: tuple[str, float, float] | None = None  # (leader, multiplier, offset)


@functools.lru_cache(maxsize=1)
def panda_urdf() -> str:
    """The packaged franka_ros Panda URDF, unchanged (``/robot_description``)."""
    path = resources.files("dexlfd.data").joinpath("panda/urdf/panda.urdf")
    try:
        return path.read_text(encoding="utf-8")
    except OSError as exc:  # pragma: no cover - a broken install
        raise InvalidFile(f"the packaged Panda URDF cannot be read: {exc}") from exc


def _floats(text: str | None, default: str) -> tuple[float, float, float]:
    a, b, c = (float(v) for v in (text or default).split())
    return a, b, c


def parse_joints(urdf: str) -> list[UrdfJoint]:
    """Every joint of the URDF text ``urdf``, in document order."""
    out = []
    for j in ET.fromstring(urdf).iter("joint"):
        origin, axis, mimic = j.find("origin"), j.find("axis"), j.find("mimic")
        parent, child = j.find("parent"), j.find("child")
        if parent is None or child is None:
            raise InvalidFile(f"URDF joint {j.get('name')!r} has no parent or child link")
        out.append(
            UrdfJoint(
                name=str(j.get("name")),
                type=str(j.get("type")),
                parent=str(parent.get("link")),
                child=str(child.get("link")),
                xyz=_floats(None if origin is None else origin.get("xyz"), "0 0 0"),
                rpy=_floats(None if origin is None else origin.get("rpy"), "0 0 0"),
                axis=_floats(None if axis is None else axis.get("xyz"), "1 0 0"),
                mimic=None
                if mimic is None
                else (
                    str(mimic.get("joint")),
                    float(mimic.get("multiplier", 1.0)),
                    float(mimic.get("offset", 0.0)),
                ),
            )
        )
    return out


@functools.lru_cache(maxsize=1)
def panda_joints() -> tuple[UrdfJoint, ...]:
    """The joints of :func:`panda_urdf`."""
    return tuple(parse_joints(panda_urdf()))


def joint_transforms(
    joint: UrdfJoint, q: FloatArray | None = None
) -> tuple[FloatArray, FloatArray]:
    """Parent-to-child translation ``(n, 3)`` [m] and quaternion ``(n, 4)`` (x, y, z, w).

    ``q`` ``(n,)``: the joint's positions [rad or m] (``None``: a fixed joint, n = 1).
    """
    r_o = Rotation.from_euler("xyz", joint.rpy)  # extrinsic x, y, z = Rz Ry Rx
    p_o = np.asarray(joint.xyz, dtype=np.float64)
    if joint.type == "fixed" or q is None:
        return p_o[None, :], r_o.as_quat()[None, :]
    q = np.asarray(q, dtype=np.float64).reshape(-1)
    axis = np.asarray(joint.axis, dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    if joint.type == "prismatic":
        p = p_o + r_o.apply(np.outer(q, axis))
        return p, np.tile(r_o.as_quat(), (q.size, 1))
    r = r_o * Rotation.from_rotvec(np.outer(q, axis))
    return np.tile(p_o, (q.size, 1)), r.as_quat()
