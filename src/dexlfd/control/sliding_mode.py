"""Sliding-mode laws on translation with a rotational PD: SM-PD, NTSM-PD and NTSM-PD-I.

All three command a TCP force ``F`` on translation, the rotational PD moment of
Eq. (5.9), and add ``C q̇ + G`` from the nominal model (Eq. 5.26):
``τ = J_pᵀ F + J_Hᵀ m + C q̇ + G + τ_null``.

NTSM, Eqs. (5.23)–(5.25), with ``e = p − p_d``::

    s = e + β sig(ė)^α
    F = M̄_p (p̈_d − sig(ė)^(2−α) / (αβ) − κ tanh(k_s s)) − λ tanh(k_s s)

``sig(x)^a = sign(x)|x|^a`` (the thesis's ``x^a`` with α = p/q a ratio of odd
integers is that for real x). ``M̄_p = (J_p M⁻¹ J_pᵀ)⁻¹`` is the translational
operational-space inertia. The printed ``|M̄_p|^{-T} λ tanh(k_s s)`` inside the
bracket has three readings, selected by ``reading``:

* ``"force"`` (default): ``M̄_p⁻¹ λ tanh(k_s s)``, i.e. a plain force
  ``λ tanh(k_s s)`` after the multiplication by ``M̄_p`` (units of λ: N);
* ``"determinant"`` (the print taken literally, ``|A|`` = det A, the transpose
  of a scalar is itself): ``M̄_p (… − λ tanh(k_s s)/det M̄_p …)``, i.e. the force
  ``M̄_p λ tanh(k_s s) / det M̄_p`` (kg/kg³ · λ: its size depends on the
  posture; along the Table 5.1 lift det M̄_p = 3.8–8.1 kg³ and M̄_p,zz =
  4.4–6.2 kg, so on z it is 0.5–1.6 λ tanh(k_s s));
* ``"matrix"`` (``|A|`` = elementwise absolute value, ``^{-T}`` = inverse
  transpose): the force ``M̄_p |M̄_p|^{-T} λ tanh(k_s s)``, equal to the
  ``"force"`` reading where M̄_p has no negative entries.

SM (the linear surface of Eqs. (5.16)–(5.22) moved to Cartesian space with
the same gains, as the thesis's comparison does): ``s = e + β ė`` and
``F = M̄_p (p̈_d − ė/β − κ tanh(k_s s)) − λ tanh(k_s s)`` (λ term as ``reading``
says). At rest (ė = 0) both surfaces are ``s = e``: SM-PD and NTSM-PD have the
same static stiffness. ``surface="slope"`` reads Eq. (5.17) ``s = c x₁ + x₂``
literally with ``c = 1/β``: ``s = e/β + ė`` (the same line, scaled by 1/β, so
the switching term ``tanh(k_s s)`` is 1/β = 5 times steeper in e).

NTSM-PD-I (ours, beyond the thesis): the NTSM-PD force plus an integral of the
surface, ``F_I = −k_I ∫ s dt`` with anti-windup at ``F_I,max``, which removes
the steady sag an unknown payload causes. (k_I = 5000 N/(m·s): at 10000 and
more a 1.2 kg object and the joint friction excite a ~5 Hz lateral limit cycle.)

``decouple`` (ours; on in NTSM-PD-I, off in the thesis's laws): the rotational
PD moment ``J_Hᵀ m`` also accelerates the TCP by ``J_p M⁻¹ J_Hᵀ m``; subtracting
it from the commanded translational acceleration removes a ±5 mm cross-talk
seen on the x axis while z and y move.

One tick of any of these laws is a single call of a numba kernel
(:func:`dexlfd.control.tick_kernels.sliding_tick`, the same equations in plain loops);
:func:`sig`, :func:`lambda_force` and each law's ``_surface`` are the NumPy forms.

References
----------
.. [1] Thesis §5.2.4–5.2.5, Eqs. (5.16)–(5.26); gains §5.3.3.
.. [2] Y. Feng, X. Yu, Z. Man, "Non-singular terminal sliding mode control of
   rigid manipulators", Automatica 38(12), 2002.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.control.base import (
    Reference,
    RobotState,
    check_gains,
    describe_gains,
    minv_jt,
    null_reference,
)
from dexlfd.control.pd import NullState
from dexlfd.errors import InvalidInput
from dexlfd.panda import N_JOINTS
from dexlfd.robot.robot_model import ModelTerms

__all__ = [
    "LAW_NTSM",
    "LAW_SM",
    "LAW_SM_SLOPE",
    "READINGS",
    "READING_CODES",
    "NtsmPd",
    "NtsmPdI",
    "NtsmState",
    "SmPd",
    "lambda_force",
    "sig",
]

READINGS = ("force", "determinant", "matrix")  # of Eq. (5.25)'s |M̄_p|^{-T} λ tanh(k_s s)
# the tick kernel's codes (:func:`dexlfd.control.tick_kernels.sliding_tick` reads these)
READING_CODES = {r: i for i, r in enumerate(READINGS)}
LAW_SM, LAW_SM_SLOPE, LAW_NTSM = 0, 1, 2  # s = e + β ė, s = e/β + ė, s = e + β sig(ė)^α
_ZEROS3, _ZEROS7 = np.zeros(3), np.zeros(N_JOINTS)
_SUFFIX = {"determinant": "det", "matrix": "matrix"}
SURFACES = ("beta", "slope")  # SM: s = e + β ė, or Eq. (5.17) s = e/β + ė


@functools.cache
def _kernel() -> Callable[..., None]:
    """:func:`~dexlfd.control.tick_kernels.sliding_tick` (numba is imported at the first tick)."""
    from dexlfd.control.tick_kernels import sliding_tick

    return sliding_tick


def sig(x: FloatArray, a: float) -> FloatArray:
    """Signed power ``sign(x)|x|^a`` (elementwise)."""
    return np.copysign(np.abs(x) ** a, x)  # = sign(x)|x|^a, one ufunc fewer


def lambda_force(Mp: FloatArray, lam: float, sat: FloatArray, reading: str) -> FloatArray:
    """The force [N] of Eq. (5.25)'s λ term, ``M̄_p |M̄_p|^{-T} λ tanh(k_s s)``, per reading.

    Parameters
    ----------
    Mp : ndarray (3, 3)
        Translational operational-space inertia M̄_p [kg].
    lam : float
        λ.
    sat : ndarray (3,)
        ``tanh(k_s s)`` [-].
    reading : {"force", "determinant", "matrix"}
        See the module docstring.
    """
    if reading == "force":
        return lam * sat
    if reading == "determinant":
        return Mp @ (lam * sat) / float(np.linalg.det(Mp))  # |M̄_p|^{-T} = 1/det M̄_p
    return Mp @ np.linalg.solve(np.abs(Mp).T, lam * sat)  # |M̄_p|^{-T} = (abs M̄_p)^{-T}


@dataclass(frozen=True, slots=True)
class _SlidingBase:
    alpha: float = 1.66  # [-], 1 < α < 2
    beta: float = 0.2  # [s^α / m^(α-1)]
    k_s: float = 10.0  # [1/m]
    lam: float = 6.0  # λ [N]
    kappa: float = 48.0  # κ [m/s²]
    K_H: float = 30.0  # [N·m]
    D_H: float = 3.5  # [N·m·s/rad]
    k_null: float = 10.0  # [N·m/rad]
    d_null: float = 6.3  # [N·m·s/rad]
    decouple: bool = False
    reading: str = "force"
    needs_joint_reference: bool = field(default=False, init=False)

    def __post_init__(self) -> None:
        check_gains(self, ("beta", "k_s", "lam", "kappa", "K_H"), ("D_H", "k_null", "d_null"))
        for name in ("alpha", "beta", "k_s", "lam", "kappa", "K_H", "D_H", "k_null", "d_null"):
            if np.ndim(getattr(self, name)) != 0:  # the tick's kernel takes one value each
                raise InvalidInput(
                    f"{type(self).__name__}.{name} must be a number, got {getattr(self, name)!r}"
                )
        if not 1.0 < float(self.alpha) < 2.0:
            raise InvalidInput(f"{type(self).__name__}.alpha must be in (1, 2), got {self.alpha!r}")
        if self.reading not in READINGS:
            raise InvalidInput(
                f"{type(self).__name__}.reading must be one of {READINGS}, got {self.reading!r}"
            )
        if self.reading != "force":  # the registry key of this reading, e.g. ntsm-pd-det
            name = f"{self.name}-{_SUFFIX[self.reading]}"  # type: ignore[attr-defined]
            object.__setattr__(self, "name", name)

    def _surface(self, e: FloatArray, de: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Sliding variable s (3,) and the equivalent-control acceleration (3,)."""
        raise NotImplementedError

    def _law(self) -> int:
        """The kernel's surface code (:mod:`dexlfd.control.tick_kernels`)."""
        raise NotImplementedError

    def _gains(self, k_I: float = 0.0, zmax: float = 0.0, dt: float = 0.0) -> FloatArray:
        """The kernel's ``gains`` (12,): these, the integral's gain, bound [m·s] and step [s]."""
        return np.array([
            self.alpha, self.beta, self.k_s, self.lam, self.kappa, self.K_H, self.D_H,
            self.k_null, self.d_null, k_I, zmax, dt,
        ], dtype=np.float64)  # fmt: skip

    def _tick(
        self, robot_state: RobotState, reference: Reference, terms: ModelTerms,
        q_rest: FloatArray, gains: FloatArray, z: FloatArray,
    ) -> FloatArray:  # fmt: skip
        """The saturated torque of Eq. (5.26), by the kernel (:mod:`.tick_kernels`).

        ``z`` (the integral, NTSM-PD-I) is updated in place.
        """
        q_null, dq_null = null_reference(reference, q_rest)
        tau = np.empty(N_JOINTS)
        _kernel()(
            terms.p, terms.R, terms.J, np.ascontiguousarray(minv_jt(terms).T), terms.h,
            robot_state.q, robot_state.dq, reference.p, reference.v, reference.a,
            reference.R, reference.w, q_null, _ZEROS7 if dq_null is None else dq_null,
            gains, self._law(), READING_CODES[self.reading], self.decouple, z, tau,
        )  # fmt: skip
        return tau

    def init(self, robot_state: RobotState, terms: ModelTerms) -> Any:
        """No memory beyond the start posture."""
        return NullState(robot_state.q.copy())

    def step(
        self, ctrl_state: Any, robot_state: RobotState, reference: Reference, terms: ModelTerms
    ) -> tuple[FloatArray, Any]:
        """Sliding-mode force on translation + rotational PD + C q̇ + G."""
        tau = self._tick(
            robot_state, reference, terms, ctrl_state.q_null, self._gains(), _ZEROS3.copy()
        )
        return tau, ctrl_state

    def describe(self) -> dict[str, Any]:
        """Name and gains."""
        return describe_gains(self)


@dataclass(frozen=True, slots=True)
class SmPd(_SlidingBase):
    """Linear sliding mode on translation (s = e + β ė) + rotational PD (thesis's SM-PD)."""

    surface: str = "beta"
    name: str = field(default="sm-pd", init=False)

    def __post_init__(self) -> None:
        _SlidingBase.__post_init__(self)
        if self.surface not in SURFACES:
            raise InvalidInput(f"SmPd.surface must be one of {SURFACES}, got {self.surface!r}")
        if self.surface == "slope":
            object.__setattr__(self, "name", f"{self.name}-slope")

    def _surface(self, e: FloatArray, de: FloatArray) -> tuple[FloatArray, FloatArray]:
        s = e + self.beta * de  # [1] Eq. (5.17) with c = 1/β, scaled by β
        if self.surface == "slope":
            s = s / self.beta  # [1] Eq. (5.17) as printed: s = c e + ė
        return s, -de / self.beta  # ṡ = 0 ⇒ ë = −ė/β

    def _law(self) -> int:
        return LAW_SM_SLOPE if self.surface == "slope" else LAW_SM


@dataclass(frozen=True, slots=True)
class NtsmPd(_SlidingBase):
    """Non-singular terminal sliding mode on translation + rotational PD (Eq. 5.26)."""

    name: str = field(default="ntsm-pd", init=False)

    def _surface(self, e: FloatArray, de: FloatArray) -> tuple[FloatArray, FloatArray]:
        ad = np.abs(de)  # sig(ė)^a = copysign(|ė|^a, ė), |ė| once for both powers
        s = e + self.beta * np.copysign(ad**self.alpha, de)  # [1] Eq. (5.25)
        # −sig(ė)^(2−α) / (αβ) (a negated quotient is the quotient by the negated divisor)
        a_eq = np.copysign(ad ** (2.0 - self.alpha), de) / -(self.alpha * self.beta)
        return s, a_eq

    def _law(self) -> int:
        return LAW_NTSM


@dataclass(frozen=True, slots=True)
class NtsmState:
    """NTSM-PD-I state: null-space posture [rad], ∫ s dt [m·s], last time [s]."""

    q_null: FloatArray
    z: FloatArray
    t: float


@dataclass(frozen=True, slots=True)
class NtsmPdI(NtsmPd):
    """NTSM-PD plus an integral of the sliding variable (ours; rejects a constant load).

    ``k_I`` [N/(m·s)] integral gain, ``F_I_max`` [N] anti-windup bound per axis.
    """

    k_I: float = 5000.0  # noqa: N815 (the paper's symbol)
    F_I_max: float = 60.0
    decouple: bool = True
    name: str = field(default="ntsm-pd-i", init=False)

    def __post_init__(self) -> None:
        NtsmPd.__post_init__(self)
        check_gains(self, ("F_I_max",), ("k_I",))

    def init(self, robot_state: RobotState, terms: ModelTerms) -> NtsmState:
        """Zero integral."""
        return NtsmState(robot_state.q.copy(), np.zeros(3), robot_state.t)

    def step(
        self, ctrl_state: NtsmState, robot_state: RobotState, reference: Reference,
        terms: ModelTerms,
    ) -> tuple[FloatArray, NtsmState]:  # fmt: skip
        """NTSM-PD torque with the integral force ``−k_I ∫ s dt``."""
        dt = max(robot_state.t - ctrl_state.t, 0.0)
        zmax = self.F_I_max / self.k_I if self.k_I > 0 else 0.0
        z = ctrl_state.z.copy()  # the kernel adds dt s, with anti-windup at zmax
        gains = self._gains(float(self.k_I), zmax, dt)
        tau = self._tick(robot_state, reference, terms, ctrl_state.q_null, gains, z)
        return tau, NtsmState(ctrl_state.q_null, z, robot_state.t)
