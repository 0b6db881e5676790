"""The simulated Panda as an :class:`~dexlfd.robot.arm.Arm`: :class:`SimArm`.

The MuJoCo plant (:class:`~dexlfd.robot.sim.PandaSim`: friction, payload,
contacts) behind the sensing and actuation a real arm has: Gaussian measurement
noise on what the controller sees, libfranka's torque rate limit and a delay of
whole ticks (one by default: the command of tick k acts during tick k+1). It runs
in lock-step: each :meth:`SimArm.act` advances the plant one tick period.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.panda import N_JOINTS, TAU_MAX
from dexlfd.robot.actuation import TorqueDelay
from dexlfd.robot.arm import ArmState, Tick, run_lockstep
from dexlfd.robot.plant import PlantConfig
from dexlfd.robot.sim import PandaSim

__all__ = ["SimArm", "SimSensing", "plant_arm", "substeps"]


@functools.cache
def _rate_limit_into() -> Any:
    """:func:`~dexlfd.robot.plant_kernels.rate_limit_into` (numba imported at the first tick)."""
    from dexlfd.robot.plant_kernels import rate_limit_into

    return rate_limit_into


def substeps(dt: float, timestep: float) -> int:
    """Physics steps per control period; raises unless ``dt`` is a whole multiple."""
    n_sub_f = dt / timestep
    n_sub = int(round(n_sub_f))
    if n_sub < 1 or abs(n_sub_f - n_sub) > 1e-9:
        raise InvalidInput(
            f"control period {dt} s must be a whole multiple of the physics step {timestep} s"
        )
    return n_sub


@dataclass(frozen=True, slots=True)
class SimSensing:
    """Sensing and actuation of the simulated arm (the loop's ``LoopConfig`` fields).

    Attributes
    ----------
    period : float
        Tick period [s]; a whole multiple of the plant's physics step.
    q_noise, dq_noise : float
        Standard deviations of the joint position [rad] and velocity [rad/s] noise.
    torque_delay : int
        Ticks between a command and the plant applying it.
    torque_rate_limit : float or None
        Largest torque change [N·m/s] (None: off).
    """

    period: float = 1e-3
    q_noise: float = 0.0
    dq_noise: float = 0.0
    torque_delay: int = 1
    torque_rate_limit: float | None = None


class SimArm:
    """The MuJoCo Panda behind noisy sensing, a rate limit and a torque delay.

    Parameters
    ----------
    sim : PandaSim
        The plant (owned: :meth:`close` closes it).
    sensing : SimSensing
    hold : ndarray, shape (7,)
        Torque [N·m] the plant receives before the first command (the delay line
        is primed with it; the rate limit starts from it).
    rng : numpy.random.Generator
        Source of the measurement noise, drawn in blocks of ``noise_block`` ticks
        (joint positions first, then velocities).
    noise_block : int
    """

    def __init__(
        self,
        sim: PandaSim,
        sensing: SimSensing,
        hold: FloatArray,
        *,
        rng: np.random.Generator,
        noise_block: int = 1000,
    ) -> None:
        if int(noise_block) < 1:
            raise InvalidInput(f"noise_block must be >= 1, got {noise_block}")
        self.sim = sim
        self.sensing = sensing
        self._n_sub = substeps(sensing.period, sim.config.timestep)
        self._rng = rng
        self._block = int(noise_block)
        self._drawn = -1  # index of the noise block drawn
        self._noise_q = self._noise_dq = np.zeros((0, N_JOINTS))
        self._delay = TorqueDelay(int(sensing.torque_delay), hold)
        self._max_step = (sensing.torque_rate_limit or 0.0) * sensing.period
        self.commanded = np.asarray(hold, dtype=np.float64).copy()  # after the rate limit
        self.k = 0  # ticks done

    @property
    def period(self) -> float:
        """Tick period [s]."""
        return self.sensing.period

    def sense(self) -> ArmState:
        """True state and TCP pose of this tick, with the noisy state the controller sees."""
        q, dq, p, R = self.sim.arm_and_tcp()
        nq, ndq = self._noise(self.k)
        period = self.sensing.period
        return ArmState(self.k * period, q, dq, p, R, q + nq, dq + ndq, period)

    def act(self, tau: FloatArray | None, last: bool = False) -> FloatArray | None:
        """Rate-limit ``tau``, delay it and step the plant one period (None: nothing).

        Returns the torque applied during this tick (the one ``torque_delay``
        ticks earlier); :attr:`commanded` is this tick's command after the limit.
        """
        if tau is None:
            return None
        if self.sensing.torque_rate_limit is not None:  # rate_limit's values, one call
            limited = np.empty(N_JOINTS)
            _rate_limit_into()(tau, self.commanded, self._max_step, TAU_MAX, limited)
            tau = limited
        self.commanded = tau
        applied = self._delay.push(tau)
        self.sim.step(applied, self._n_sub)
        self.k += 1
        return applied

    def run(self, tick: Tick, n_ticks: int) -> None:
        """Lock-step ticks (:func:`~dexlfd.robot.arm.run_lockstep`)."""
        run_lockstep(self, tick, n_ticks)

    def close(self) -> None:
        """Close the plant (its renderer)."""
        self.sim.close()

    def _noise(self, k: int) -> tuple[FloatArray, FloatArray]:
        block, i = divmod(k, self._block)
        if block != self._drawn:
            s, shape = self.sensing, (self._block, N_JOINTS)
            self._noise_q = (
                self._rng.normal(0.0, s.q_noise, shape) if s.q_noise else np.zeros(shape)
            )
            self._noise_dq = (
                self._rng.normal(0.0, s.dq_noise, shape) if s.dq_noise else np.zeros(shape)
            )
            self._drawn = block
        return self._noise_q[i], self._noise_dq[i]


def plant_arm(
    plant: PlantConfig,
    sensing: SimSensing,
    q0: FloatArray,
    hold: FloatArray,
    *,
    rng: np.random.Generator,
    noise_block: int = 1000,
    payload_at: tuple[FloatArray, FloatArray] | None = None,
    gripper0: float | None = None,
) -> SimArm:
    """A :class:`SimArm` on a new plant built from ``plant`` at joints ``q0`` [rad]."""
    substeps(sensing.period, plant.timestep)
    sim = PandaSim(plant, q0, payload_at=payload_at, gripper0=gripper0)
    return SimArm(sim, sensing, hold, rng=rng, noise_block=noise_block)
