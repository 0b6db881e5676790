"""Generalized-momentum disturbance observer around any controller (ours).

The plant obeys ``M q̈ + C q̇ + G = τ + τ_d`` (Eq. 3.1) with τ_d lumping the
unknown payload, friction and model error. With the momentum ``p = M q̇``,
``ṗ = τ + τ_d − (C q̇ + G) + Ṁ q̇``; the observer

    p̂' = τ − h + Ṁ q̇ + r,   r = K_O (M q̇ − p̂)

makes the residual ``r`` a first-order low-pass estimate of τ_d (bandwidth K_O
[1/s]), which the wrapped law then cancels: ``τ = τ_inner − r``. Ṁ is the finite
difference of the model's M between control ticks (needs only M and h, so any
:class:`~dexlfd.robot.robot_model.RobotModel` backend works).

References
----------
.. [1] A. De Luca, R. Mattone, "Sensorless robot collision detection and hybrid
   force/motion control", ICRA 2005.
.. [2] S. Haddadin, A. De Luca, A. Albu-Schäffer, "Robot collisions: a survey on
   detection, isolation, and identification", IEEE T-RO 33(6), 2017, §IV-C.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.control.base import Controller, Reference, RobotState, check_gains, saturate
from dexlfd.robot.robot_model import ModelTerms

__all__ = ["DisturbanceObserver", "ObserverState", "momentum_residual", "observer_at_rest"]


@dataclass(frozen=True, slots=True)
class ObserverState:
    """Observer memory plus the wrapped controller's state."""

    inner: Any
    p_hat: FloatArray  # (7,) [N·m·s]
    r: FloatArray  # (7,) [N·m], estimate of τ_d
    M_prev: FloatArray  # (7, 7) [kg·m²]
    tau_prev: FloatArray  # (7,) [N·m], last command
    t: float  # [s]


def momentum_residual(
    st: ObserverState, robot_state: RobotState, terms: ModelTerms, K_O: float
) -> tuple[FloatArray, FloatArray]:
    """One observer update: the new momentum estimate p̂ (7,) and residual r (7,) [N·m].

    ``st`` holds the previous tick's p̂, r, M and commanded torque; ``r`` low-passes
    the unknown joint torque τ_d of ``M q̈ + C q̇ + G = τ + τ_d`` with bandwidth
    ``K_O`` [1/s] ([1]).
    """
    dq = robot_state.dq
    dt = robot_state.t - st.t
    if dt > 0:
        Mdot_dq = (terms.M - st.M_prev) @ dq / dt
        p_hat = st.p_hat + dt * (st.tau_prev - terms.h + Mdot_dq + st.r)  # [1]
    else:
        p_hat = st.p_hat
    return p_hat, K_O * (terms.M @ dq - p_hat)  # [1] residual


def observer_at_rest(inner: Any, robot_state: RobotState, terms: ModelTerms) -> ObserverState:
    """Observer state at start: p̂ = M q̇, r = 0, last command G(q)."""
    return ObserverState(
        inner=inner,
        p_hat=terms.M @ robot_state.dq,
        r=np.zeros_like(robot_state.dq),
        M_prev=terms.M.copy(),
        tau_prev=terms.g.copy(),
        t=robot_state.t,
    )


@dataclass(frozen=True, slots=True)
class DisturbanceObserver:
    """Wrap ``inner`` with a momentum observer of bandwidth ``K_O`` [1/s]."""

    inner: Controller
    K_O: float = 60.0
    name: str = field(default="", init=False)
    needs_joint_reference: bool = field(default=False, init=False)

    def __post_init__(self) -> None:
        check_gains(self, ("K_O",))
        object.__setattr__(self, "name", f"{self.inner.name}-dob")
        object.__setattr__(self, "needs_joint_reference", self.inner.needs_joint_reference)

    def init(self, robot_state: RobotState, terms: ModelTerms) -> ObserverState:
        """Observer at rest: p̂ = M q̇, r = 0."""
        return observer_at_rest(self.inner.init(robot_state, terms), robot_state, terms)

    def step(
        self, ctrl_state: ObserverState, robot_state: RobotState, reference: Reference,
        terms: ModelTerms,
    ) -> tuple[FloatArray, ObserverState]:  # fmt: skip
        """Inner torque minus the disturbance estimate."""
        st = ctrl_state
        p_hat, r = momentum_residual(st, robot_state, terms, self.K_O)
        tau_in, inner = self.inner.step(st.inner, robot_state, reference, terms)
        tau = saturate(tau_in - r)
        return tau, ObserverState(inner, p_hat, r, terms.M.copy(), tau, robot_state.t)

    def describe(self) -> dict[str, Any]:
        """Name, observer bandwidth and the wrapped law's gains."""
        return {"name": self.name, "K_O": self.K_O, "inner": self.inner.describe()}
