"""The simulated plant: a MuJoCo Panda with hand, joint friction and an unknown payload.

What is simulated is deliberately *not* what the controller believes
(:class:`~dexlfd.robot.model.MujocoPandaModel`): the plant adds the joint
friction identified by Gaz et al. (2019), a payload box that the gripper picks up
(squeezed between the fingers with the hand's 70 N and carried by contact
friction, or optionally welded to the hand at the grasp instant),
contacts with the floor, a pedestal and obstacles, and the finger dynamics.

Joint torques are applied directly as generalized forces (``qfrc_applied``),
saturated to the Panda's limits; friction is evaluated from the true joint
velocity at every physics step.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd._validation import as_float_array, check_finite
from dexlfd.errors import InvalidInput
from dexlfd.panda import FINGER_MAX, MAX_PAYLOAD, N_JOINTS, TAU_MAX
from dexlfd.robot.friction import friction_torque
from dexlfd.robot.model import build_arm_spec, import_mujoco

logger = logging.getLogger(__name__)

__all__ = ["Obstacle", "PandaSim", "PlantConfig", "SimState", "obstacles_from_plan_meta"]

HOLD_DISTANCE = 0.04  # [m] object centre to TCP beyond which it is not in the hand
FINGER_SPEED = 0.1  # [m/s] per finger set-point rate (URDF limit 0.2 m/s); no tunnelling


@dataclass(frozen=True, slots=True)
class Obstacle:
    """A static box in the scene: centre [m] and half sizes [m], base frame."""

    center: tuple[float, float, float]
    half_size: tuple[float, float, float]


def obstacles_from_plan_meta(meta: dict[str, Any]) -> tuple[Obstacle, ...]:
    """Scene obstacles from a plan file's ``meta["settings"]["obstacles"]``.

    Boxes (``center``, ``size`` = edge lengths [m]) become scene boxes; a sphere
    becomes its bounding cube (conservative: the arm may touch air, never pass
    through the sphere), with a warning. A plan that places its object on a raised
    surface (``meta["place"]["support"]``, a box from the table up to the surface)
    brings that support along.
    """
    out = []
    support = (meta.get("place") or {}).get("support")
    for ob in [
        *((meta.get("settings") or {}).get("obstacles") or []),
        *([support] if support else []),
    ]:
        center = tuple(float(c) for c in ob["center"])
        if ob.get("type") == "box":
            half = tuple(0.5 * float(s) for s in ob["size"])
        elif ob.get("type") == "sphere":
            r = float(ob["radius"])
            half = (r, r, r)
            logger.warning("sphere obstacle at %s simulated as its bounding cube", center)
        else:
            raise InvalidInput(f"plan meta: unknown obstacle type {ob.get('type')!r}")
        out.append(Obstacle(center=center, half_size=half))  # type: ignore[arg-type]
    return tuple(out)


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
    obstacles : tuple of Obstacle
        Static boxes (shown in videos; they collide with the arm and object).
    grasp : {"weld", "contact"}
        How the object is held: ``"contact"`` (default) squeezes it between the
        fingers with ``grip_force`` and lets friction carry it (it may slip, ~2 mm
        over the 1.2 kg lift); ``"weld"`` attaches it to the hand at the grasp
        instant (an ideal, stiff grasp).
    grip_force : float
        Finger force in ``"contact"`` mode [N] (the Panda hand: 70 N continuous).
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

    def __post_init__(self) -> None:
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
        if hs.shape != (3,) or not (hs > 0).all() or hs[1] > FINGER_MAX:
            raise InvalidInput(
                f"payload_half_size must be 3 positive half sizes with width 2*y <= "
                f"{2 * FINGER_MAX} m (the gripper's opening), got {self.payload_half_size!r}"
            )
        com = np.asarray(self.payload_com, dtype=np.float64)
        if com.shape != (3,) or not np.isfinite(com).all() or (np.abs(com) > hs).any():
            raise InvalidInput(
                f"payload_com must lie inside the box (|com| <= half size), got "
                f"{self.payload_com!r}"
            )

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
            "obstacles": [[list(o.center), list(o.half_size)] for o in self.obstacles],
            "grasp": self.grasp,
            **({"grip_force_n": self.grip_force} if self.grasp == "contact" else {}),
        }


@dataclass(frozen=True, slots=True)
class SimState:
    """True state of the simulated arm."""

    t: float  # [s]
    q: FloatArray  # (7,) [rad]
    dq: FloatArray  # (7,) [rad/s]


class PandaSim:
    """MuJoCo Panda plant. Use as a context manager (releases the renderer).

    Parameters
    ----------
    config : PlantConfig
        The simulated world.
    q0 : ndarray, shape (7,)
        Initial joint configuration [rad]; the object (if any) is placed between
        the fingers at this configuration's TCP, on a pedestal.
    payload_at : (position (3,), rotation (3, 3)), optional
        TCP pose where the object waits to be grasped; default the pose at ``q0``.
    gripper0 : float, optional
        Initial finger opening [m]; default closed on the object (or fully open
        without one).
    """

    def __init__(
        self,
        config: PlantConfig,
        q0: FloatArray,
        payload_at: tuple[FloatArray, FloatArray] | None = None,
        gripper0: float | None = None,
    ) -> None:
        mj = import_mujoco()
        self._mj = mj
        self.config = config
        q0 = check_finite(as_float_array(q0, "q0", shape=(N_JOINTS,)), "q0")
        spec = build_arm_spec(fixed_fingers=False)
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
        for i, ob in enumerate(config.obstacles):
            world.add_geom(
                name=f"obstacle{i}", type=mj.mjtGeom.mjGEOM_BOX, pos=list(ob.center),
                size=list(ob.half_size), rgba=[0.55, 0.55, 0.6, 1.0], contype=0, conaffinity=3,
            )  # fmt: skip
        self._has_payload = config.payload_kg > 0
        # a throwaway model for the TCP pose at q0 (where the object waits)
        probe = spec.compile()
        pd = mj.MjData(probe)
        pd.qpos[:N_JOINTS] = q0
        mj.mj_kinematics(probe, pd)
        tcp = mj.mj_name2id(probe, mj.mjtObj.mjOBJ_SITE, "tcp")
        if payload_at is None:
            p_obj, R_obj = pd.site_xpos[tcp].copy(), pd.site_xmat[tcp].reshape(3, 3).copy()
        else:
            p_obj, R_obj = (np.asarray(a, dtype=np.float64) for a in payload_at)
        if self._has_payload:
            hs = np.asarray(config.payload_half_size)
            m = float(config.payload_kg)
            body = world.add_body(name="payload", pos=list(p_obj), quat=_wxyz(R_obj))
            body.add_freejoint(name="payload_free")
            body.explicitinertial = True
            body.mass = m
            body.ipos = list(config.payload_com)
            body.inertia = [  # solid box about its centre (offset kept as given)
                m / 3.0 * (hs[1] ** 2 + hs[2] ** 2),
                m / 3.0 * (hs[0] ** 2 + hs[2] ** 2),
                m / 3.0 * (hs[0] ** 2 + hs[1] ** 2),
            ]
            body.add_geom(
                type=mj.mjtGeom.mjGEOM_BOX, size=list(hs), rgba=[0.85, 0.35, 0.2, 1.0],
                contype=2, conaffinity=1 if config.grasp == "contact" else 0,
                mass=0.0, density=0.0, condim=4, friction=[1.0, 0.01, 0.0001],
                solref=[2.0 * config.timestep, 1.0], solimp=[0.99, 0.999, 0.0005, 0.5, 2.0],
            )  # fmt: skip
            top = p_obj[2] - hs[2]
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
        for i in (1, 2):  # one servo per finger (symmetric squeeze; the mimic stays)
            act = spec.add_actuator(name=f"finger{i}", target=f"panda_finger_joint{i}")
            act.trntype = mj.mjtTrn.mjTRN_JOINT
            if config.grasp == "contact":
                # stiff position servo, force-limited: squeezes with grip_force when closed
                act.set_to_position(kp=4000.0, kv=20.0)
                act.forcelimited = True
                act.forcerange = [-config.grip_force, config.grip_force]
            else:
                act.set_to_position(kp=200.0, kv=5.0)
        self.model = spec.compile()
        self.data = mj.MjData(self.model)
        self._arm_q = np.arange(N_JOINTS)  # arm joints come first in qpos/qvel
        self.data.qpos[:N_JOINTS] = q0
        self._tcp = mj.mj_name2id(self.model, mj.mjtObj.mjOBJ_SITE, "tcp")
        self._hand = mj.mj_name2id(self.model, mj.mjtObj.mjOBJ_BODY, "panda_hand")
        self._finger_q = [
            int(self.model.jnt_qposadr[mj.mj_name2id(self.model, mj.mjtObj.mjOBJ_JOINT, n)])
            for n in ("panda_finger_joint1", "panda_finger_joint2")
        ]
        if self._has_payload:
            self._payload = mj.mj_name2id(self.model, mj.mjtObj.mjOBJ_BODY, "payload")
            self._eq = mj.mj_name2id(self.model, mj.mjtObj.mjOBJ_EQUALITY, "grasp")
        width = float(config.payload_half_size[1]) if self._has_payload else FINGER_MAX
        half = width if gripper0 is None else float(np.clip(0.5 * gripper0, 0.0, FINGER_MAX))
        if self._has_payload:
            half = max(half, width)  # the fingers start outside the object
        for a in self._finger_q:
            self.data.qpos[a] = half
        self.data.ctrl[:] = half
        self._finger_target = half
        self.attached = False
        self._renderer: Any = None
        mj.mj_forward(self.model, self.data)

    # -- context manager -------------------------------------------------
    def __enter__(self) -> PandaSim:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Release the offscreen renderer, if one was made."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    # -- state -----------------------------------------------------------
    @property
    def t(self) -> float:
        """Simulation time [s]."""
        return float(self.data.time)

    def state(self) -> SimState:
        """True arm state (copies)."""
        d = self.data
        return SimState(float(d.time), d.qpos[:N_JOINTS].copy(), d.qvel[:N_JOINTS].copy())

    def tcp_pose(self) -> tuple[FloatArray, FloatArray]:
        """True TCP position [m] and rotation matrix at the current state."""
        d = self.data
        return d.site_xpos[self._tcp].copy(), d.site_xmat[self._tcp].reshape(3, 3).copy()

    def payload_position(self) -> FloatArray | None:
        """Object centre [m] (None without an object)."""
        return self.data.xpos[self._payload].copy() if self._has_payload else None

    def payload_pose(self) -> tuple[FloatArray, FloatArray] | None:
        """Object pose: centre [m] and quaternion (x, y, z, w); None without an object."""
        if not self._has_payload:
            return None
        w, x, y, z = self.data.xquat[self._payload]
        return self.data.xpos[self._payload].copy(), np.array([x, y, z, w])

    def set_pose(
        self, q: FloatArray, gripper: float, payload: tuple[FloatArray, FloatArray] | None
    ) -> None:
        """Put the scene in a recorded configuration (for replay/rendering), no dynamics."""
        d = self.data
        d.qpos[:N_JOINTS] = q
        for a in self._finger_q:
            d.qpos[a] = float(np.clip(0.5 * gripper, 0.0, FINGER_MAX))
        if self._has_payload and payload is not None:
            adr = int(self.model.jnt_qposadr[self.model.body_jntadr[self._payload]])
            p, (x, y, z, w) = payload
            d.qpos[adr : adr + 7] = [*p, w, x, y, z]
        self._mj.mj_kinematics(self.model, d)

    @property
    def gripper_opening(self) -> float:
        """Distance between the fingers [m]."""
        return float(sum(self.data.qpos[a] for a in self._finger_q))

    # -- actions ---------------------------------------------------------
    def set_gripper(self, opening: float) -> None:
        """Command the finger distance [m] (clipped to 0..0.08; held on the object)."""
        half = float(np.clip(0.5 * opening, 0.0, FINGER_MAX))
        if self.attached:
            # contact: keep squeezing (target fully closed); weld: rest on the faces
            half = (
                0.0
                if self.config.grasp == "contact"
                else max(half, float(self.config.payload_half_size[1]))
            )
        self._finger_target = half

    def grasp(self) -> bool:
        """Grasp the object: weld it at the current relative pose, or close the fingers.

        Returns False (and does nothing) without an object or if already held.
        """
        if not self._has_payload or self.attached:
            return False
        if self.config.grasp == "contact":
            self._finger_target = 0.0
            self.attached = True
            return True
        mj, m, d = self._mj, self.model, self.data
        R_h = d.xmat[self._hand].reshape(3, 3)
        R_o = d.xmat[self._payload].reshape(3, 3)
        rel_p = R_h.T @ (d.xpos[self._payload] - d.xpos[self._hand])
        q = np.empty(4)
        mj.mju_mat2Quat(q, (R_h.T @ R_o).ravel())
        # weld data: anchor (3), relpos (3) and relquat (4) of body2 in body1's frame
        m.eq_data[self._eq, 0:3] = 0.0
        m.eq_data[self._eq, 3:6] = rel_p
        m.eq_data[self._eq, 6:10] = q
        m.eq_data[self._eq, 10] = 1.0
        d.eq_active[self._eq] = 1
        self.attached = True
        return True

    @property
    def holding(self) -> bool:
        """True while the object is really in the hand, not just commanded to be.

        A weld holds by construction. In contact mode the object must sit between
        the fingers (its centre within ``HOLD_DISTANCE`` of the TCP) and the fingers
        must rest on it, not be closed on nothing (opening at least half the
        object's width): a grasp that missed, or an object that slipped out, is
        not reported as carried.
        """
        if not self.attached:
            return False
        return self.holds(
            self.gripper_opening, self.data.xpos[self._payload], self.data.site_xpos[self._tcp]
        )

    def holds(self, opening: float, p_object: FloatArray, p_tcp: FloatArray) -> bool:
        """:attr:`holding` from values the caller already read this tick (the 1 kHz loop).

        ``opening`` [m] is the finger distance, ``p_object`` and ``p_tcp`` [m] the
        object centre and TCP position.
        """
        if not self.attached:
            return False
        if self.config.grasp == "weld":
            return True
        if opening < self.config.payload_half_size[1]:
            return False  # the fingers closed on nothing (or the object slipped out)
        d = p_object - p_tcp
        return float(d @ d) <= HOLD_DISTANCE**2

    def release(self) -> bool:
        """Let go of the object (it falls under gravity and contacts)."""
        if not self.attached:
            return False
        if self.config.grasp == "contact":
            # drop the squeeze at once (set point to where the fingers are), then open
            self.data.ctrl[:] = float(self.data.qpos[self._finger_q[0]])
            self._finger_target = FINGER_MAX
        else:
            self.data.eq_active[self._eq] = 0
        self.attached = False
        return True

    def step(self, tau: FloatArray, n_substeps: int = 1) -> None:
        """Apply joint torques ``tau`` (7,) [N·m] (saturated) for ``n_substeps`` steps."""
        mj, m, d = self._mj, self.model, self.data
        tau_sat = np.clip(tau, -TAU_MAX, TAU_MAX)
        cfg = self.config
        for _ in range(n_substeps):
            # the fingers' set point moves at most FINGER_SPEED (as the real hand does)
            step = FINGER_SPEED * m.opt.timestep
            d.ctrl[:] += np.clip(self._finger_target - d.ctrl[0], -step, step)
            dq = d.qvel[:N_JOINTS]
            tf = (
                friction_torque(dq, cfg.friction_scale, cfg.viscous)
                if cfg.friction_scale or cfg.viscous
                else 0.0
            )
            d.qfrc_applied[:N_JOINTS] = tau_sat - tf
            mj.mj_step(m, d)
        # mj_step leaves poses of the state before its integration: refresh them
        mj.mj_kinematics(m, d)

    # -- rendering -------------------------------------------------------
    def render(
        self, width: int = 640, height: int = 480, camera: dict[str, float] | None = None
    ) -> np.ndarray:
        """An RGB frame (height, width, 3) uint8 from a free camera (needs an OpenGL context).

        ``camera`` holds ``lookat_x/y/z`` [m], ``distance`` [m], ``azimuth_deg``,
        ``elevation_deg``. Set ``MUJOCO_GL=egl`` on a machine without a display.
        """
        mj = self._mj
        if self._renderer is None:
            self._renderer = mj.Renderer(self.model, height, width)
        cam = mj.MjvCamera()
        c = {
            "lookat_x": 0.3, "lookat_y": 0.0, "lookat_z": 0.3, "distance": 1.7,
            "azimuth_deg": 200.0, "elevation_deg": -18.0, **(camera or {}),
        }  # fmt: skip
        cam.lookat[:] = [c["lookat_x"], c["lookat_y"], c["lookat_z"]]
        cam.distance, cam.azimuth, cam.elevation = (
            c["distance"], c["azimuth_deg"], c["elevation_deg"],
        )  # fmt: skip
        self._renderer.update_scene(self.data, camera=cam)
        return np.asarray(self._renderer.render())


def _wxyz(R: FloatArray) -> list[float]:
    from dexlfd.rotations import quat_from_matrix

    x, y, z, w = quat_from_matrix(R)
    return [float(w), float(x), float(y), float(z)]
