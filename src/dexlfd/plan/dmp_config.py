"""The settings of a DMP (:class:`DmpConfig`), apart from the numba kernels that run it.

The command line reads these to build its flags (``dexlfd plan --help``) without
importing numba; :mod:`dexlfd.plan.dmp` has the equations and re-exports them.
"""

from __future__ import annotations

from dataclasses import dataclass

from dexlfd._params import check_params, param
from dexlfd.errors import InvalidInput

__all__ = ["GAIN_RANGE", "N_BASIS_RANGE", "VARIANTS", "DmpConfig"]

VARIANTS = ("original", "modified")
# what a user may choose (the CLI's flags read these): basis count 2..1000 and the
# relative gains K, D in (0, 100] (K = D = 1 is the thesis's critically damped system)
N_BASIS_RANGE = (2, 1000)
GAIN_RANGE = (0.0, 100.0)


@dataclass(frozen=True, slots=True)
class DmpConfig:
    """Settings of a DMP (see the module docstring for the equations).

    Attributes
    ----------
    n_basis : int
        Number of Gaussian basis functions (Eq. 5.3).
    K, D : float
        Relative stiffness and damping; ``Kb = K alpha^2/4``, ``Db = D alpha`` [-].
    alpha : float
        Reference gain of the critically damped system per normalised time [-].
    alpha_s : float
        Phase decay per normalised time; ``s(1) = exp(-alpha_s)`` [-].
    variant : str
        ``"modified"`` (Eq. 5.5, default) or ``"original"`` (Eq. 5.1).
    """

    n_basis: int = param(
        100, "Gaussian basis functions of the forcing term (Eq. 5.3)", lo=N_BASIS_RANGE[0],
        hi=N_BASIS_RANGE[1], integer=True, flag="--dmp-basis",
    )  # fmt: skip
    K: float = param(
        1.0, "relative stiffness K of the DMP (thesis: 1; 1, 1 is critically damped)",
        lo=GAIN_RANGE[0], hi=GAIN_RANGE[1], lo_open=True, flag="--dmp-k",
    )  # fmt: skip
    D: float = param(
        1.0, "relative damping D of the DMP (thesis: 1)", lo=GAIN_RANGE[0], hi=GAIN_RANGE[1],
        lo_open=True, flag="--dmp-d",
    )  # fmt: skip
    alpha: float = param(25.0, "reference gain per normalised time", lo=0.0, lo_open=True)
    alpha_s: float = param(8.0, "phase decay per normalised time", lo=0.0, lo_open=True)
    variant: str = "modified"

    def __post_init__(self) -> None:
        check_params(self)
        if self.variant not in VARIANTS:
            raise InvalidInput(f"variant must be one of {VARIANTS}, got {self.variant!r}")

    @property
    def K_bar(self) -> float:
        """Stiffness per normalised time squared, ``K alpha^2 / 4``."""
        return self.K * self.alpha**2 / 4.0

    @property
    def D_bar(self) -> float:
        """Damping per normalised time, ``D alpha``."""
        return self.D * self.alpha
