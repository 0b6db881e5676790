"""Settings of the 1 kHz tracking loops: rate, sensing noise, torque path, safety bounds."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dexlfd._params import check_params, param
from dexlfd.errors import InvalidInput
from dexlfd.panda import DTAU_MAX

MAX_TORQUE_DELAY = 100  # [ticks] the delay line holds one torque vector per tick

__all__ = ["LoopConfig"]


@dataclass(frozen=True, slots=True)
class LoopConfig:
    """Settings of the control loop and of the sensing it sees.

    Attributes
    ----------
    rate_hz : float
        Control rate [Hz]; the plant's time step must divide its period.
    q_noise, dq_noise : float
        Standard deviation of the joint position [rad] and velocity [rad/s]
        measurement noise (Gaussian, white).
    torque_delay : int
        Control ticks between computing a torque and the plant applying it.
    torque_rate_limit : float or None
        Commanded torques change by at most this [N·m/s] per tick, as libfranka's
        ``limit_rate`` does (its default: on, 1000 N·m/s); None switches it off.
    max_position_error : float
        TCP position error [m] that triggers the safety stop.
    max_orientation_error : float
        TCP orientation error [rad] that triggers the safety stop.
    joint_limit_margin : float
        Tolerance [rad] beyond the joint limits before the stop.
    """

    rate_hz: float = 1000.0
    q_noise: float = 1e-5
    dq_noise: float = 1e-3
    torque_delay: int = param(
        1, "torque delay in control ticks of 1 ms (0.1 s at most: far beyond any real arm's "
        "latency, and a run's memory stays bounded)", unit="ticks", lo=0, hi=MAX_TORQUE_DELAY,
        integer=True, aliases=("--torque-delay",),
    )  # fmt: skip
    torque_rate_limit: float | None = DTAU_MAX
    max_position_error: float = 0.1
    max_orientation_error: float = 0.6
    joint_limit_margin: float = 0.01

    def __post_init__(self) -> None:
        for name in ("rate_hz", "q_noise", "dq_noise", "torque_delay", "max_position_error"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float | np.number):
                raise InvalidInput(f"LoopConfig.{name} must be a number, got {v!r}")
        for name in ("rate_hz", "max_position_error", "max_orientation_error"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise InvalidInput(f"LoopConfig.{name} must be > 0, got {v!r}")
        for name in ("q_noise", "dq_noise", "joint_limit_margin"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise InvalidInput(f"LoopConfig.{name} must be >= 0, got {v!r}")
        if self.torque_rate_limit is not None and not (
            np.isfinite(self.torque_rate_limit) and self.torque_rate_limit > 0
        ):
            raise InvalidInput(
                f"LoopConfig.torque_rate_limit must be > 0 or None, got {self.torque_rate_limit!r}"
            )
        check_params(self)  # torque_delay
