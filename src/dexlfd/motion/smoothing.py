"""Smoothing of tracked keypoints: the One Euro filter, beside the thesis's mean filter.

Hand trackers jitter by a few millimetres from frame to frame while the hand
rests, and the hand moves fast when it carries. A fixed low-pass filter trades
one against the other; the One Euro filter (Casiez, Roussel and Vogel, CHI 2012)
adapts its cut-off to the speed: ``f_c = f_min + beta * |dx/dt|`` (Eq. 1 below),
so a resting hand is smoothed hard and a moving one is followed with little lag.
Each coordinate is an exponential smoother ``x_hat = a x + (1 - a) x_hat_prev``
with ``a = 1 / (1 + tau / dt)``, ``tau = 1 / (2 pi f_c)`` (Eq. 2); the speed is
itself smoothed with a fixed cut-off ``d_cutoff``.

:class:`OneEuroFilter` runs on a stream (one sample at a time, e.g. teleoperation);
:func:`smooth_keypoints` runs a whole series, restarting after every unseen
frame (NaN rows stay NaN), with ``method="one_euro"``, the thesis's centred mean
filter (``"mean"``, Eq. 4.15, :func:`dexlfd.trajectory.mean_filter`, applied
to each seen run) or ``"none"``.

References
----------
.. [1] G. Casiez, N. Roussel, D. Vogel, "1 Euro Filter: A Simple Speed-based
   Low-pass Filter for Noisy Input in Interactive Systems", CHI 2012.
.. [2] Thesis Eq. (4.15) (mean filter).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dexlfd._types import FloatArray
from dexlfd._validation import check_positive
from dexlfd.errors import InvalidInput
from dexlfd.trajectory import mean_filter

__all__ = ["SMOOTHING_METHODS", "OneEuroFilter", "SmoothingConfig", "smooth_keypoints"]

SMOOTHING_METHODS = ("one_euro", "mean", "none")


@dataclass(frozen=True, slots=True)
class SmoothingConfig:
    """Settings of :func:`smooth_keypoints` (One Euro in metres and seconds)."""

    method: str = "one_euro"  # one of SMOOTHING_METHODS
    min_cutoff_hz: float = 1.5  # cut-off of a resting hand [Hz]
    beta: float = 10.0  # cut-off increase per unit speed [Hz per (m/s)]
    d_cutoff_hz: float = 1.0  # cut-off of the speed estimate [Hz]
    window: int = 5  # "mean": window length [frames]

    def __post_init__(self) -> None:
        if self.method not in SMOOTHING_METHODS:
            raise InvalidInput(
                f"smoothing method must be one of {SMOOTHING_METHODS}, got {self.method!r}"
            )
        check_positive(self.min_cutoff_hz, "min_cutoff_hz")
        check_positive(self.beta, "beta", strict=False)
        check_positive(self.d_cutoff_hz, "d_cutoff_hz")
        if self.window < 1:
            raise InvalidInput(f"window must be >= 1 frame, got {self.window}")


def _alpha(cutoff_hz: FloatArray | float, dt: float) -> FloatArray:
    tau = 1.0 / (2.0 * np.pi * np.asarray(cutoff_hz, dtype=np.float64))
    return 1.0 / (1.0 + tau / dt)  # (2)


class OneEuroFilter:
    """One Euro filter over arrays of any shape: ``filter(x, t) -> x_hat``.

    Call :meth:`reset` after a gap (the next sample is passed through).
    """

    def __init__(self, cfg: SmoothingConfig | None = None) -> None:
        self.cfg = cfg or SmoothingConfig()
        self.reset()

    def reset(self) -> None:
        """Forget the state (after a gap)."""
        self._x: FloatArray | None = None
        self._dx: FloatArray | None = None
        self._t = 0.0

    def filter(self, x: FloatArray, t: float) -> FloatArray:
        """The filtered value of sample ``x`` at time ``t`` [s] (increasing)."""
        x = np.asarray(x, dtype=np.float64)
        if self._x is None or self._dx is None:
            self._x, self._dx, self._t = x.copy(), np.zeros_like(x), t
            return x.copy()
        dt = t - self._t
        if not dt > 0:
            raise InvalidInput(f"OneEuroFilter: times must increase, got {self._t} then {t}")
        dx = (x - self._x) / dt
        a_d = _alpha(self.cfg.d_cutoff_hz, dt)
        self._dx = a_d * dx + (1 - a_d) * self._dx
        cutoff = self.cfg.min_cutoff_hz + self.cfg.beta * np.abs(self._dx)  # (1)
        a = _alpha(cutoff, dt)
        self._x = a * x + (1 - a) * self._x  # (2)
        self._t = t
        return self._x.copy()


def _runs(valid: np.ndarray) -> list[tuple[int, int]]:
    m = np.concatenate([[0], valid.astype(np.int8), [0]])
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True))


def smooth_keypoints(
    t: FloatArray, keypoints: FloatArray, valid: np.ndarray, cfg: SmoothingConfig | None = None
) -> FloatArray:
    """Smoothed copy of ``keypoints`` ``(n, ...)`` over each run of ``valid`` frames.

    Unseen frames stay as they are (NaN); every run restarts the filter, so
    nothing is carried across a gap.
    """
    cfg = cfg or SmoothingConfig()
    kp = np.array(keypoints, dtype=np.float64, copy=True)
    v = np.asarray(valid, dtype=bool)
    if cfg.method == "none":
        return kp
    tt = np.asarray(t, dtype=np.float64)
    for a, b in _runs(v):
        if cfg.method == "mean":
            seg = kp[a:b].reshape(b - a, -1)
            kp[a:b] = mean_filter(seg, min(cfg.window, b - a)).reshape(kp[a:b].shape)
        else:
            f = OneEuroFilter(cfg)
            for i in range(a, b):
                kp[i] = f.filter(kp[i], float(tt[i]))
    return kp
