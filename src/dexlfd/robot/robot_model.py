"""The controller's model of the robot: M, C·q̇ + G, G, J, J̇q̇ and the TCP pose.

A controller only ever sees a :class:`RobotModel`: something that maps the
measured ``(q, dq)`` to :class:`ModelTerms`. :class:`MujocoPandaModel` computes
them from the nominal Panda description (no payload, no friction, optionally a
deliberate mass/inertia error); a real-arm backend (libfranka's model library)
can supply the same terms later.

Frames: the TCP frame is franka_ros's ``panda_hand_tcp``: 0.1034 m past the
flange along its z axis, rotated −45° about z. Jacobians are in the base frame,
rows ``[v; ω]``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import DependencyNotInstalled, InvalidInput
from dexlfd.panda import N_JOINTS, TCP_OFFSET

__all__ = [
    "ModelTerms",
    "MujocoPandaModel",
    "RobotModel",
    "build_arm_spec",
    "import_mujoco",
    "perturbed_model",
]


def import_mujoco() -> Any:
    """Import MuJoCo or raise :class:`DependencyNotInstalled`.

    The offscreen OpenGL backend is chosen first (``MUJOCO_GL``, read by MuJoCo at
    import; :func:`dexlfd._gl.choose_gl_backend`).
    """
    from dexlfd._gl import choose_gl_backend

    choose_gl_backend()
    try:
        import mujoco
    except ImportError as exc:  # pragma: no cover - mujoco is a core dependency
        raise DependencyNotInstalled("mujoco>=4,<5", "the Panda simulation") from exc
    return mujoco


@dataclass(frozen=True, slots=True)
class ModelTerms:
    """Model terms at one state (all in the base frame, SI units).

    Attributes
    ----------
    M : ndarray, shape (7, 7)
        Joint-space inertia matrix [kg·m²].
    h : ndarray, shape (7,)
        Coriolis/centrifugal plus gravity torques C(q, q̇)q̇ + G(q) [N·m].
    g : ndarray, shape (7,)
        Gravity torques G(q) [N·m].
    J : ndarray, shape (6, 7)
        TCP Jacobian, rows linear [m/rad] then angular [-].
    Jdq : ndarray, shape (6,)
        J̇(q, q̇) q̇ [m/s², rad/s²].
    p : ndarray, shape (3,)
        TCP position [m].
    R : ndarray, shape (3, 3)
        TCP orientation (columns are the TCP axes in the base frame).
    MinvJt : ndarray, shape (7, 6), optional
        M⁻¹Jᵀ, if the backend has a cheap factorisation of M (MuJoCo does);
        controllers solve for it themselves when it is None.
    """

    M: FloatArray
    h: FloatArray
    g: FloatArray
    J: FloatArray
    Jdq: FloatArray
    p: FloatArray
    R: FloatArray
    MinvJt: FloatArray | None = None


@runtime_checkable
class RobotModel(Protocol):
    """What a controller may know about the robot: its nominal model."""

    n_joints: int

    def terms(self, q: FloatArray, dq: FloatArray) -> ModelTerms:
        """Model terms at joint positions ``q`` [rad] and velocities ``dq`` [rad/s]."""
        ...

    def tcp_pose(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """TCP position (3,) [m] and rotation matrix (3, 3) at ``q``."""
        ...

    def tcp_jacobian(self, q: FloatArray) -> FloatArray:
        """TCP Jacobian (6, 7) at ``q``."""
        ...

    def tcp_pose_jacobian(self, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """TCP position (3,), rotation (3, 3) and Jacobian (6, 7) at ``q`` together."""
        ...


def build_arm_spec(*, fixed_fingers: bool) -> Any:
    """A ``mujoco.MjSpec`` of the Panda with ``flange`` and ``tcp`` sites added."""
    mujoco = import_mujoco()
    from dexlfd.robot.description import panda_urdf_text

    spec = mujoco.MjSpec.from_string(panda_urdf_text(fixed_fingers))
    spec.body("panda_link8").add_site(name="flange", pos=[0.0, 0.0, 0.0])
    spec.body("panda_hand").add_site(name="tcp", pos=[0.0, 0.0, TCP_OFFSET])
    return spec


class MujocoPandaModel:
    """Nominal Panda model (7 joints, fingers fixed) evaluated with MuJoCo.

    Parameters
    ----------
    mass_scale : ndarray, shape (n_bodies,) or None
        Factors on the mass and rotational inertia of each moving body
        (links 1–7, hand, fingers, in that order); ``None`` = the identified values.
        Used to give a controller a deliberately wrong model.
    """

    n_joints = N_JOINTS

    def __init__(self, mass_scale: FloatArray | None = None) -> None:
        mujoco = import_mujoco()
        self._mj = mujoco
        spec = build_arm_spec(fixed_fingers=True)
        m = spec.compile()
        m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
        if m.nv != N_JOINTS:  # pragma: no cover - guards the URDF conversion
            raise InvalidInput(f"arm model must have {N_JOINTS} dofs, got {m.nv}")
        self.moving_bodies = [i for i in range(m.nbody) if m.body_mass[i] > 0 and i > 1]
        if mass_scale is not None:
            scale = np.asarray(mass_scale, dtype=np.float64)
            if scale.shape != (len(self.moving_bodies),) or not (scale > 0).all():
                raise InvalidInput(
                    f"mass_scale must have shape ({len(self.moving_bodies)},) and be > 0, "
                    f"got {scale.shape}"
                )
            for b, s in zip(self.moving_bodies, scale, strict=True):
                m.body_mass[b] *= s
                m.body_inertia[b] *= s
        self.mass_scale = None if mass_scale is None else np.asarray(mass_scale, dtype=float)
        self.description = (
            "MuJoCo Panda (franka_ros identified inertias)"
            if mass_scale is None
            else "MuJoCo Panda, link masses/inertias scaled by "
            + ", ".join(f"{s:.3f}" for s in np.asarray(mass_scale))
        )
        self.model = m
        self.data = mujoco.MjData(m)
        self._site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "tcp")
        self._body = int(m.site_bodyid[self._site])
        self._M = np.zeros((N_JOINTS, N_JOINTS))
        self._jac = np.zeros((6, N_JOINTS))
        self._jacdot = np.zeros((6, N_JOINTS))
        # views of the data (a MuJoCo attribute makes a new array object per access)
        d = self.data
        self._qpos, self._qvel = d.qpos, d.qvel
        self._tcp_p, self._tcp_R = d.site_xpos[self._site], d.site_xmat[self._site].reshape(3, 3)

    def _kin(self, q: FloatArray) -> None:
        mj, m, d = self._mj, self.model, self.data
        self._qpos[:] = q
        mj.mj_kinematics(m, d)
        mj.mj_comPos(m, d)

    def terms(self, q: FloatArray, dq: FloatArray) -> ModelTerms:
        """Model terms at ``(q, dq)``; see :class:`ModelTerms`."""
        mj, m, d = self._mj, self.model, self.data
        self._kin(q)
        mj.mj_crb(m, d)
        mj.mj_factorM(m, d)
        M = np.empty((N_JOINTS, N_JOINTS))
        mj.mj_fullM(m, d, M)
        qvel = self._qvel
        qvel[:] = 0.0
        mj.mj_comVel(m, d)
        g = np.empty(N_JOINTS)
        mj.mj_rne(m, d, 0, g)
        qvel[:] = dq
        mj.mj_comVel(m, d)
        h = np.empty(N_JOINTS)
        mj.mj_rne(m, d, 0, h)
        J = np.empty((6, N_JOINTS))
        mj.mj_jacSite(m, d, J[:3], J[3:], self._site)
        Jd = self._jacdot
        p = self._tcp_p.copy()
        mj.mj_jacDot(m, d, Jd[:3], Jd[3:], p, self._body)
        X = np.empty((6, N_JOINTS))
        mj.mj_solveM(m, d, X, J)  # rows of X = (M⁻¹ Jᵀ)ᵀ, with MuJoCo's sparse LDLᵀ of M
        return ModelTerms(
            M=M, h=h, g=g, J=J, Jdq=Jd @ dq, p=p, R=self._tcp_R.copy(), MinvJt=X.T,
        )  # fmt: skip

    def tcp_pose(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """TCP position [m] and rotation matrix at ``q``."""
        self._kin(q)
        return self._tcp_p.copy(), self._tcp_R.copy()

    def flange_pose(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Flange (Table 3.1 "Flange" frame) position [m] and rotation matrix at ``q``."""
        self._kin(q)
        sid = self._mj.mj_name2id(self.model, self._mj.mjtObj.mjOBJ_SITE, "flange")
        return self.data.site_xpos[sid].copy(), self.data.site_xmat[sid].reshape(3, 3).copy()

    def tcp_jacobian(self, q: FloatArray) -> FloatArray:
        """TCP Jacobian (6, 7) at ``q``."""
        self._kin(q)
        J = np.empty((6, N_JOINTS))
        self._mj.mj_jacSite(self.model, self.data, J[:3], J[3:], self._site)
        return J

    def tcp_pose_jacobian(self, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """:meth:`tcp_pose` and :meth:`tcp_jacobian` at ``q`` from one pass of the kinematics."""
        self._kin(q)
        J = np.empty((6, N_JOINTS))
        self._mj.mj_jacSite(self.model, self.data, J[:3], J[3:], self._site)
        return self._tcp_p.copy(), self._tcp_R.copy(), J


def perturbed_model(error: float, rng: np.random.Generator) -> MujocoPandaModel:
    """A nominal model whose link masses and inertias are off by up to ``error``.

    Each moving body's mass and inertia are scaled by ``1 + error * u`` with
    ``u ~ U(-1, 1)`` drawn from ``rng``; ``error = 0.1`` is a 10 % model error.
    """
    if not (np.isfinite(error) and 0 <= error < 1):
        raise InvalidInput(f"model error must be in [0, 1), got {error!r}")
    if error == 0:
        return MujocoPandaModel()
    n = len(MujocoPandaModel().moving_bodies)
    return MujocoPandaModel(1.0 + error * rng.uniform(-1.0, 1.0, n))
