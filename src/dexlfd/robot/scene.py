"""The MuJoCo scene of the simulated plant, built from a :class:`~dexlfd.robot.plant.PlantConfig`.

The arm (with movable fingers) from :func:`~dexlfd.robot.robot_model.build_arm_spec`,
solver options for friction grasps, lights, the floor, the obstacles (a sphere
as its bounding cube, :func:`dexlfd.geometry.half_extents`), the object on its
pedestal with the grasp weld, and the finger servos.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.geometry import half_extents
from dexlfd.panda import N_JOINTS
from dexlfd.robot.plant import PlantConfig
from dexlfd.robot.robot_model import build_arm_spec
from dexlfd.robot.softhand import add_softhand
from dexlfd.rotations import quat_from_matrix, wxyz_from_xyzw

__all__ = ["add_finger_servos", "add_payload", "scene_spec", "tcp_pose_at"]


def _wxyz(R: FloatArray) -> list[float]:
    return [float(v) for v in wxyz_from_xyzw(quat_from_matrix(R))]


def scene_spec(mj: Any, config: PlantConfig) -> Any:
    """The arm's MuJoCo spec with the solver options, lights, floor and obstacles."""
    spec = build_arm_spec(fixed_fingers=config.hand == "softhand")
    if config.hand == "softhand":  # the qb SoftHand in place of the Franka Hand
        add_softhand(mj, spec)
    spec.option.timestep = config.timestep
    spec.option.integrator = mj.mjtIntegrator.mjINT_IMPLICITFAST
    if not config.contacts:
        spec.option.disableflags |= mj.mjtDisableBit.mjDSBL_CONTACT
    if config.grasp == "contact":
        # friction grasps need elliptic cones and a high impedance ratio, or the
        # object creeps out of MuJoCo's soft contacts
        spec.option.cone = mj.mjtCone.mjCONE_ELLIPTIC
        spec.option.impratio = 10.0
        spec.option.noslip_iterations = 3
    for g in spec.geoms:  # the arm touches the world, never itself
        g.contype, g.conaffinity = 1, 0
    world = spec.worldbody
    world.add_light(pos=[0.5, -0.5, 2.0], dir=[-0.2, 0.2, -1.0], diffuse=[0.7, 0.7, 0.7])
    world.add_light(pos=[-0.5, 0.8, 2.5], dir=[0.3, -0.3, -1.0], diffuse=[0.4, 0.4, 0.4])
    world.add_geom(
        name="floor", type=mj.mjtGeom.mjGEOM_PLANE, size=[2.0, 2.0, 0.05],
        rgba=[0.82, 0.84, 0.86, 1.0], contype=0, conaffinity=3,
    )  # fmt: skip
    for i, ob in enumerate(config.obstacles):  # a sphere as its bounding cube
        world.add_geom(
            name=f"obstacle{i}", type=mj.mjtGeom.mjGEOM_BOX, pos=list(ob.center),
            size=list(half_extents(ob)), rgba=[0.55, 0.55, 0.6, 1.0], contype=0, conaffinity=3,
        )  # fmt: skip
    return spec


def tcp_pose_at(mj: Any, spec: Any, q0: FloatArray) -> tuple[FloatArray, FloatArray]:
    """TCP position [m] and rotation at ``q0``, from a throwaway compiled model."""
    probe = spec.compile()
    pd = mj.MjData(probe)
    pd.qpos[:N_JOINTS] = q0
    mj.mj_kinematics(probe, pd)
    tcp = mj.mj_name2id(probe, mj.mjtObj.mjOBJ_SITE, "tcp")
    return pd.site_xpos[tcp].copy(), pd.site_xmat[tcp].reshape(3, 3).copy()


def add_payload(
    mj: Any, spec: Any, config: PlantConfig, p_obj: FloatArray, R_obj: FloatArray
) -> None:
    """The object (a free box, cylinder or sphere) at ``p_obj``, ``R_obj``, its pedestal, the weld.

    The pedestal (from the floor up to the object's bottom) is built only with
    ``config.pedestal`` (a plan's world brings its own supports) and above the floor.
    """
    world = spec.worldbody
    hs = np.asarray(config.payload_half_size)
    m = float(config.payload_kg)
    body = world.add_body(name="payload", pos=list(p_obj), quat=_wxyz(R_obj))
    body.add_freejoint(name="payload_free")
    body.explicitinertial = True
    body.mass = m
    body.ipos = list(config.payload_com)
    geom_type, size, body.inertia = _solid(mj, config.payload_shape, hs, m)
    body.add_geom(
        type=geom_type, size=size, rgba=[0.85, 0.35, 0.2, 1.0],
        contype=2, conaffinity=1 if config.grasp == "contact" else 0,
        mass=0.0, density=0.0, condim=4, friction=[1.0, 0.01, 0.0001],
        solref=[2.0 * config.timestep, 1.0], solimp=[0.99, 0.999, 0.0005, 0.5, 2.0],
    )  # fmt: skip
    top = p_obj[2] - hs[2]
    if config.pedestal and top > 1e-3:
        world.add_geom(
            name="pedestal", type=mj.mjtGeom.mjGEOM_BOX,
            pos=[p_obj[0], p_obj[1], top / 2.0 - 1e-4], size=[0.05, 0.05, top / 2.0],
            rgba=[0.35, 0.45, 0.6, 1.0], contype=0, conaffinity=3,
        )  # fmt: skip
    eq = spec.add_equality(name="grasp", type=mj.mjtEq.mjEQ_WELD, active=False)
    eq.objtype = mj.mjtObj.mjOBJ_BODY
    eq.name1, eq.name2 = "panda_hand", "payload"
    # a stiff grasp (time constant 2 steps): the default (20 ms) lets a heavy
    # object swing in the fingers at ~8 Hz, a compliance a firm grasp lacks
    eq.solref = [2.0 * config.timestep, 1.0]
    eq.solimp = [0.99, 0.999, 0.001, 0.5, 2.0]


def _solid(mj: Any, shape: str, hs: FloatArray, m: float) -> tuple[Any, list[float], list[float]]:
    """MuJoCo geom type, size and principal inertia [kg·m²] of a solid ``shape`` of mass ``m``."""
    if shape == "sphere":
        r = float(hs[0])
        return mj.mjtGeom.mjGEOM_SPHERE, [r, 0.0, 0.0], [0.4 * m * r * r] * 3
    if shape == "cylinder":  # upright: axis along the object's z
        r, h = float(hs[0]), float(hs[2])
        i_xy = m * (3.0 * r * r + 4.0 * h * h) / 12.0
        return mj.mjtGeom.mjGEOM_CYLINDER, [r, h, 0.0], [i_xy, i_xy, 0.5 * m * r * r]
    return (
        mj.mjtGeom.mjGEOM_BOX,
        [float(v) for v in hs],
        [  # about its centre
            m / 3.0 * (hs[1] ** 2 + hs[2] ** 2),
            m / 3.0 * (hs[0] ** 2 + hs[2] ** 2),
            m / 3.0 * (hs[0] ** 2 + hs[1] ** 2),
        ],
    )


def add_finger_servos(mj: Any, spec: Any, config: PlantConfig) -> None:
    """One position servo per finger (symmetric squeeze; the mimic stays); none for the softhand.

    The softhand's one synergy actuator is part of its build
    (:func:`~dexlfd.robot.softhand.add_softhand`).
    """
    if config.hand == "softhand":
        return
    for i in (1, 2):
        act = spec.add_actuator(name=f"finger{i}", target=f"panda_finger_joint{i}")
        act.trntype = mj.mjtTrn.mjTRN_JOINT
        if config.grasp == "contact":
            # stiff position servo, force-limited: squeezes with grip_force when closed
            act.set_to_position(kp=4000.0, kv=20.0)
            act.forcelimited = True
            act.forcerange = [-config.grip_force, config.grip_force]
        else:
            act.set_to_position(kp=200.0, kv=5.0)
