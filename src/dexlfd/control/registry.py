"""Controllers by name: ``make_controller("ntsm-pd", kappa=40.0)``.

``sm-pd-det`` / ``ntsm-pd-det`` / ``*-matrix`` / ``sm-pd-slope`` are the laws
with one reading of the printed equations preset (``reading=`` / ``surface=``,
see :mod:`dexlfd.control.sliding_mode`); the plain names are our default reading.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from dexlfd.control.base import Controller
from dexlfd.control.impedance import Impedance
from dexlfd.control.observer import DisturbanceObserver
from dexlfd.control.pd import CartesianPd, JointPd
from dexlfd.control.sliding_mode import NtsmPd, NtsmPdI, SmPd
from dexlfd.control.sliding_mode_joint import JointSlidingMode
from dexlfd.errors import InvalidInput

__all__ = ["CONTROLLERS", "make_controller"]


def _ntsm_pd_dob(**gains: Any) -> Controller:
    k_o = gains.pop("K_O", 60.0)
    gains.setdefault("decouple", True)
    return DisturbanceObserver(NtsmPd(**gains), K_O=k_o)


def _reading(
    cls: type[SmPd] | type[NtsmPd] | type[Impedance], **preset: Any
) -> Callable[..., Controller]:
    """A sliding-mode law with one reading of the printed equations preset."""

    def make(**gains: Any) -> Controller:
        return cls(**{**preset, **gains})

    return make


def _pd_dob(**gains: Any) -> Controller:
    k_o = gains.pop("K_O", 60.0)
    return DisturbanceObserver(CartesianPd(**gains), K_O=k_o)


CONTROLLERS: dict[str, Callable[..., Controller]] = {
    "joint-pd": JointPd,
    "pd": CartesianPd,
    "impedance": Impedance,
    # Eq. (5.15) with F_ext estimated by the momentum observer (the thesis ran F_ext = 0)
    "impedance-fext": _reading(Impedance, external_force="observer"),
    "sm-pd": SmPd,
    "ntsm-pd": NtsmPd,
    # readings of the printed Eqs. (5.17) and (5.25), see dexlfd.control.sliding_mode
    "sm-pd-det": _reading(SmPd, reading="determinant"),
    "ntsm-pd-det": _reading(NtsmPd, reading="determinant"),
    "sm-pd-matrix": _reading(SmPd, reading="matrix"),
    "ntsm-pd-matrix": _reading(NtsmPd, reading="matrix"),
    "sm-pd-slope": _reading(SmPd, surface="slope"),
    "sm-joint": JointSlidingMode,  # Eqs. (5.21)-(5.22) as printed, in joint space
    "ntsm-pd-i": NtsmPdI,
    "ntsm-pd-dob": _ntsm_pd_dob,
    "pd-dob": _pd_dob,
}


def make_controller(name: str, **gains: Any) -> Controller:
    """Build the controller ``name`` with its default gains overridden by ``gains``.

    Raises
    ------
    InvalidInput
        Unknown name (the message lists the valid ones), unknown gain or a bad value.
    """
    try:
        factory = CONTROLLERS[name]
    except KeyError:
        raise InvalidInput(
            f"unknown controller {name!r}; choose one of {', '.join(sorted(CONTROLLERS))}"
        ) from None
    try:
        return factory(**gains)
    except TypeError as exc:
        raise InvalidInput(f"controller {name!r}: {exc}") from exc
