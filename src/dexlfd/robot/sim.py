"""The simulated plant: a MuJoCo Panda with hand, joint friction and an unknown payload.

What is simulated is deliberately *not* what the controller believes
(:class:`~dexlfd.robot.robot_model.MujocoPandaModel`): the plant adds the joint
friction identified by Gaz et al. (2019), a payload box that the gripper picks up
(squeezed between the fingers with the hand's 70 N and carried by contact
friction, or optionally welded to the hand at the grasp instant; or, with
``PlantConfig.hand = "softhand"``, wrapped by the qb SoftHand's fingers until a
fingertip presses with 3 N, :mod:`dexlfd.robot.softhand`),
contacts with the floor, a pedestal and obstacles, and the finger dynamics.

Joint torques are applied directly as generalized forces (``qfrc_applied``),
saturated to the Panda's limits; friction is evaluated from the true joint
velocity at every physics step.
"""

from __future__ import annotations

import functools
import logging
from dataclasses import dataclass
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd._validation import as_float_array, check_finite
from dexlfd.panda import FINGER_MAX, N_JOINTS, TAU_MAX
from dexlfd.robot.friction import FrictionLaw
from dexlfd.robot.plant import PlantConfig
from dexlfd.robot.robot_model import import_mujoco
from dexlfd.robot.scene import add_finger_servos, add_payload, scene_spec, tcp_pose_at
from dexlfd.robot.softhand import SynergyDriver

logger = logging.getLogger(__name__)

__all__ = ["PandaSim", "SimState"]

HOLD_DISTANCE = 0.04  # [m] object centre to TCP beyond which it is not in the hand
LOST_AFTER = 0.1  # [s] softhand: thumb or fingers off the object this long: not held
FINGER_SPEED = 0.1  # [m/s] per finger set-point rate (URDF limit 0.2 m/s); no tunnelling
_XYZW = np.array([1, 2, 3, 0])  # a MuJoCo quaternion (w, x, y, z) as x, y, z, w


@functools.cache
def _plant_forces() -> Any:
    """:func:`~dexlfd.robot.plant_kernels.plant_forces` (numba is imported at the first step)."""
    from dexlfd.robot.plant_kernels import plant_forces

    return plant_forces


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
        spec = scene_spec(mj, config)
        self._has_payload = config.payload_kg > 0
        if payload_at is None:
            p_obj, R_obj = tcp_pose_at(mj, spec, q0)  # where the object waits
        else:
            p_obj, R_obj = (np.asarray(a, dtype=np.float64) for a in payload_at)
        if self._has_payload:
            add_payload(mj, spec, config, p_obj, R_obj)
        add_finger_servos(mj, spec, config)
        self.model = spec.compile()
        self.data = mj.MjData(self.model)
        self._arm_q = np.arange(N_JOINTS)  # arm joints come first in qpos/qvel
        self.data.qpos[:N_JOINTS] = q0
        self._tcp = mj.mj_name2id(self.model, mj.mjtObj.mjOBJ_SITE, "tcp")
        self._hand = mj.mj_name2id(self.model, mj.mjtObj.mjOBJ_BODY, "panda_hand")
        self.synergy: SynergyDriver | None = None  # the softhand's motor, or None
        self._finger_q: list[int] = []
        if config.hand == "softhand":
            self.synergy = SynergyDriver(mj, self.model, config.stop_force)
        else:
            self._finger_q = [
                int(self.model.jnt_qposadr[mj.mj_name2id(self.model, mj.mjtObj.mjOBJ_JOINT, n)])
                for n in ("panda_finger_joint1", "panda_finger_joint2")
            ]
        if self._has_payload:
            self._payload = mj.mj_name2id(self.model, mj.mjtObj.mjOBJ_BODY, "payload")
            self._eq = mj.mj_name2id(self.model, mj.mjtObj.mjOBJ_EQUALITY, "grasp")
        self._open_fingers(gripper0)
        self.attached = False
        self._lost = False  # softhand: the object left the hand during this grasp
        self._touched_t = 0.0  # softhand: when thumb and fingers last both touched [s]
        self._renderer: Any = None
        self._friction = (
            FrictionLaw(config.friction_scale, config.viscous)
            if config.friction_scale or config.viscous
            else None
        )
        self._friction_rows = (
            np.zeros((5, N_JOINTS)) if self._friction is None else self._friction.rows()
        )
        # views the 1 kHz loop reads and writes (a MuJoCo attribute makes a new array
        # object on every access; these stay valid as long as the data does)
        d = self.data
        self._qpos, self._qpos_arm, self._qvel_arm = d.qpos, d.qpos[:N_JOINTS], d.qvel[:N_JOINTS]
        self._qfrc_arm, self._ctrl = d.qfrc_applied[:N_JOINTS], d.ctrl
        self._tcp_p, self._tcp_R = d.site_xpos[self._tcp], d.site_xmat[self._tcp].reshape(3, 3)
        self._dt = float(self.model.opt.timestep)
        self._finger_step = FINGER_SPEED * self._dt  # [m] per physics step
        mj.mj_forward(self.model, self.data)

    def _open_fingers(self, gripper0: float | None) -> None:
        """Initial finger opening: ``gripper0`` [m], never inside the object (softhand: open)."""
        cfg = self.config
        if self.synergy is not None:
            self.synergy.set_pose(self.data, self.synergy.target)  # relaxed, open
            return
        width = float(cfg.payload_half_size[1]) if self._has_payload else FINGER_MAX
        half = width if gripper0 is None else float(np.clip(0.5 * gripper0, 0.0, FINGER_MAX))
        if self._has_payload:
            half = max(half, width)  # the fingers start outside the object
        for a in self._finger_q:
            self.data.qpos[a] = half
        self.data.ctrl[:] = half
        self._finger_target = half

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
        return SimState(float(self.data.time), self._qpos_arm.copy(), self._qvel_arm.copy())

    def tcp_pose(self) -> tuple[FloatArray, FloatArray]:
        """True TCP position [m] and rotation matrix at the current state."""
        return self._tcp_p.copy(), self._tcp_R.copy()

    def arm_and_tcp(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Copies of :meth:`state`'s joints and velocities and :meth:`tcp_pose` in one call."""
        return (self._qpos_arm.copy(), self._qvel_arm.copy(), self._tcp_p.copy(),
                self._tcp_R.copy())  # fmt: skip

    def payload_position(self) -> FloatArray | None:
        """Object centre [m] (None without an object)."""
        return self.data.xpos[self._payload].copy() if self._has_payload else None

    def payload_pose(self) -> tuple[FloatArray, FloatArray] | None:
        """Object pose: centre [m] and quaternion (x, y, z, w); None without an object."""
        if not self._has_payload:
            return None
        xyzw = self.data.xquat[self._payload].take(_XYZW)  # MuJoCo's is w, x, y, z
        return self.data.xpos[self._payload].copy(), xyzw

    def set_pose(
        self, q: FloatArray, gripper: float, payload: tuple[FloatArray, FloatArray] | None
    ) -> None:
        """Put the scene in a recorded configuration (for replay/rendering), no dynamics."""
        d = self.data
        d.qpos[:N_JOINTS] = q
        if self.synergy is not None:
            self.synergy.set_pose(d, self.synergy.closure_at(gripper))
        for a in self._finger_q:
            d.qpos[a] = float(np.clip(0.5 * gripper, 0.0, FINGER_MAX))
        if self._has_payload and payload is not None:
            adr = int(self.model.jnt_qposadr[self.model.body_jntadr[self._payload]])
            p, (x, y, z, w) = payload
            d.qpos[adr : adr + 7] = [*p, w, x, y, z]
        self._mj.mj_kinematics(self.model, d)

    @property
    def gripper_opening(self) -> float:
        """Distance between the fingers [m] (softhand: its span times how open it is)."""
        if self.synergy is not None:
            return self.synergy.opening(self.data)
        qpos = self._qpos
        a, b = self._finger_q
        return float(qpos[a] + qpos[b])

    # -- actions ---------------------------------------------------------
    def set_gripper(self, opening: float) -> None:
        """Command the finger distance [m] (clipped to 0..0.08; held on the object)."""
        if self.synergy is not None:
            return  # the softhand opens and closes with the grasp only (one synergy)
        half = min(max(0.5 * float(opening), 0.0), FINGER_MAX)  # np.clip's value, 20x cheaper
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
        if self.synergy is not None:
            self.synergy.close()  # closes until it squeezes with the stop force
            self._lost = False
            self._touched_t = self.t
            if self.config.grasp == "contact":
                self.attached = True
                return True
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
        if self.synergy is not None:
            syn = self.synergy
            closing = syn.target > syn.setpoint and not syn.stopped  # not decided yet
            if closing or syn.touching(self.data):
                self._touched_t = self.t
            # a grasp lost for LOST_AFTER (not a moment's gap while the object shifts
            # between thumb and fingers): closed on nothing, or it slipped out
            self._lost = self._lost or self.t - self._touched_t > LOST_AFTER
            if self._lost:  # until released
                return False
        elif opening < self.config.payload_half_size[1]:
            return False  # the fingers closed on nothing (or the object slipped out)
        d = p_object - p_tcp
        return float(d @ d) <= HOLD_DISTANCE**2

    def release(self) -> bool:
        """Let go of the object (it falls under gravity and contacts)."""
        if not self.attached:
            return False
        if self.synergy is not None:
            self.synergy.open()
            if self.config.grasp == "weld":
                self.data.eq_active[self._eq] = 0
        elif self.config.grasp == "contact":
            # drop the squeeze at once (set point to where the fingers are), then open
            self.data.ctrl[:] = float(self.data.qpos[self._finger_q[0]])
            self._finger_target = FINGER_MAX
        else:
            self.data.eq_active[self._eq] = 0
        self.attached = False
        return True

    def step(self, tau: FloatArray, n_substeps: int = 1) -> None:
        """Apply joint torques ``tau`` (7,) [N·m] (saturated) for ``n_substeps`` steps.

        At every step the fingers' set point moves at most ``FINGER_SPEED`` towards
        its target (as the real hand does) and the friction is taken at the joint
        velocity; both by :func:`~dexlfd.robot.plant_kernels.plant_forces`.
        """
        mj, m, d = self._mj, self.model, self.data
        forces = _plant_forces()
        tau = np.asarray(tau, dtype=np.float64)
        fingers = self.synergy is None  # the Franka Hand's set point (the softhand's: its motor)
        target = self._finger_target if fingers else 0.0
        for _ in range(n_substeps):
            if not fingers:
                self.synergy.update(d, self._dt)  # type: ignore[union-attr]
            forces(
                tau, self._qvel_arm, TAU_MAX, self._friction_rows, self._friction is not None,
                self._ctrl, target, self._finger_step, fingers, self._qfrc_arm,
            )  # fmt: skip
            mj.mj_step(m, d)
        # mj_step leaves poses of the state before its integration: refresh them
        mj.mj_kinematics(m, d)

    # -- rendering -------------------------------------------------------
    def render(
        self, width: int = 640, height: int = 480, camera: dict[str, float] | None = None
    ) -> np.ndarray:
        """An RGB frame (height, width, 3) uint8 from a free camera (needs an OpenGL context).

        ``camera`` holds ``lookat_x/y/z`` [m], ``distance`` [m], ``azimuth_deg``,
        ``elevation_deg``. Without a display the backend is EGL or OSMesa
        (:func:`dexlfd._gl.choose_gl_backend`).
        """
        from dexlfd._gl import make_renderer

        mj = self._mj
        if self._renderer is None:
            self._renderer = make_renderer(mj, self.model, height, width)
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
