"""Dynamic movement primitives for position-like channels (Eqs. 5.1-5.7).

Time is normalised by the movement duration ``delta`` [s]: ``tb = t / delta`` runs
from 0 to 1 and ``'`` is ``d/dtb``. Per channel, the transformation system is

* ``original`` (Ijspeert et al., thesis Eq. 5.1)::

      v' = Kb (g - x) - Db v + (g - x0) f(s)               x' = v + u

* ``modified`` (Eq. 5.5 in the published decoupled form of Hoffmann et al. 2009 /
  Pastor et al. 2009)::

      v' = Kb (g - x) - Db v - Kb (g - x0) s + Kb f(s) + u'     x' = v + u

  The thesis prints ``-(g - x0) x`` for the third term; that is a typo (it would make
  the system's stiffness depend on the start-goal distance and destroy goal
  convergence). The published term is ``-Kb (g - x0) s``: it cancels the spring's jump
  at the start and fades with the phase, so ``f`` is learned independently of
  ``g - x0``. A start near the goal, or a start-goal difference of the other sign,
  therefore neither collapses nor mirrors the shape.

``u`` is an optional coupling velocity (the Gams et al. term ``c F`` of Eqs. 5.6/5.7,
built in :mod:`dexlfd.plan.obstacles`); its derivative ``u'`` enters the acceleration
equation as in Eq. (5.6). For ``original`` the ``u'`` term is added the same way.

Gains
-----
``K`` and ``D`` are the thesis's stiffness and damping (defaults 1 and 1). The thesis
does not state its time unit; literal values K = D = 1 per normalised time would
make the spring far too slow to reach a new goal within the movement. We therefore
read them as *relative* gains of the critically damped reference of Ijspeert et al.
(2013): ``Kb = K * alpha**2 / 4`` and ``Db = D * alpha`` with ``alpha = 25`` per unit
of normalised time. ``K = D = 1`` is the standard critically damped DMP (damping ratio
``D / sqrt(K)``); doubling ``K`` stiffens the spring by 2.

The forcing term ``f(s)`` (phase, basis, Eqs. 5.3-5.4) is in :mod:`dexlfd.plan.forcing`;
rolling a fitted DMP out (exact discretisation) in :mod:`dexlfd.plan.dmp_rollout`.

References
----------
.. [1] Ijspeert, Nakanishi, Hoffmann, Pastor, Schaal (2013), Dynamical movement
   primitives: learning attractor models for motor behaviors, Neural Comput. 25(2).
.. [2] Hoffmann, Pastor, Park, Schaal (2009), Biologically-inspired dynamical systems
   for movement generation: automatic real-time goal adaptation and obstacle
   avoidance, ICRA.
.. [3] Pastor, Hoffmann, Asfour, Schaal (2009), Learning and generalization of motor
   skills by learning from demonstration, ICRA.
.. [4] Gams, Nemec, Ijspeert, Ude (2014), Coupling movement primitives: interaction
   with the environment and bimanual tasks, IEEE Trans. Robot. 30(4).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numba
import numpy as np

from dexlfd._types import FloatArray
from dexlfd._validation import check_trajectory
from dexlfd.errors import InvalidInput
from dexlfd.plan.dmp_config import DmpConfig
from dexlfd.plan.forcing import _lwr_kernel, basis_functions, forcing, phase

__all__ = ["Dmp", "DmpRollout", "fit_dmp"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class Dmp:
    """A fitted DMP over ``d`` independent channels.

    Attributes
    ----------
    config : DmpConfig
    weights : ndarray, shape (d, n_basis)
        Forcing-term weights (Eq. 5.4).
    x0, g : ndarray, shape (d,)
        Start and goal of the demonstration.
    v0 : ndarray, shape (d,)
        Demonstrated initial velocity per normalised time ``dx/dtb`` [m].
    duration : float
        Demonstration duration [s].
    fit_residual : ndarray, shape (d,)
        Max abs difference between the fitted and the target forcing term over the
        demonstration (forcing units; for ``modified`` these are metres).
    """

    config: DmpConfig
    weights: FloatArray
    x0: FloatArray
    g: FloatArray
    v0: FloatArray
    duration: float
    fit_residual: FloatArray

    @property
    def n_dims(self) -> int:
        """Number of channels."""
        return int(self.weights.shape[0])


@dataclass(frozen=True, eq=False)
class DmpRollout:
    """Result of :func:`rollout_dmp`, in physical units.

    ``t`` (n,) [s]; ``x`` (n, d) [m]; ``xd`` (n, d) [m/s]; ``xdd`` (n, d) [m/s²].
    """

    t: FloatArray
    x: FloatArray
    xd: FloatArray
    xdd: FloatArray


@numba.njit(cache=True)
def _gradient(x, t, out):  # pragma: no cover
    """``np.gradient(x, t, axis=0, edge_order=2)`` for (n, d) ``x``, n >= 3."""
    n, d = x.shape
    for k in range(1, n - 1):
        h1 = t[k] - t[k - 1]
        h2 = t[k + 1] - t[k]
        a = -h2 / (h1 * (h1 + h2))
        b = (h2 - h1) / (h1 * h2)
        cc = h1 / (h2 * (h1 + h2))
        for j in range(d):
            out[k, j] = a * x[k - 1, j] + b * x[k, j] + cc * x[k + 1, j]
    h1 = t[1] - t[0]
    h2 = t[2] - t[1]
    a = -(2.0 * h1 + h2) / (h1 * (h1 + h2))
    b = (h1 + h2) / (h1 * h2)
    cc = -h1 / (h2 * (h1 + h2))
    for j in range(d):
        out[0, j] = a * x[0, j] + b * x[1, j] + cc * x[2, j]
    h1 = t[n - 2] - t[n - 3]
    h2 = t[n - 1] - t[n - 2]
    a = h2 / (h1 * (h1 + h2))
    b = -(h2 + h1) / (h1 * h2)
    cc = (2.0 * h2 + h1) / (h2 * (h1 + h2))
    for j in range(d):
        out[n - 1, j] = a * x[n - 3, j] + b * x[n - 2, j] + cc * x[n - 1, j]


def _grad(x: FloatArray, t: FloatArray) -> FloatArray:
    out: FloatArray = np.empty_like(x)
    _gradient(np.ascontiguousarray(x), t, out)
    return out


def _forcing_target(
    tb: FloatArray, x: FloatArray, g: FloatArray, x0: FloatArray, cfg: DmpConfig
) -> tuple[FloatArray, FloatArray]:
    """Return the forcing target (n, d) and the demonstrated velocity x' (n, d)."""
    xd: FloatArray = _grad(x, tb)
    xdd: FloatArray = _grad(xd, tb)
    s = phase(tb, cfg.alpha_s)
    Kb, Db = cfg.K_bar, cfg.D_bar
    if cfg.variant == "modified":
        # Eq. (5.5), published form: Kb f = x'' - Kb (g - x) + Db x' + Kb (g - x0) s
        f_t = np.asarray((xdd + Db * xd) / Kb - (g - x) + (g - x0) * s[:, None], np.float64)
        return f_t, xd
    # Eq. (5.2) without the division: (g - x0) f = x'' - Kb (g - x) + Db x'
    target = np.asarray(xdd - Kb * (g - x) + Db * xd, dtype=np.float64)
    return target, xd


def fit_dmp(t: FloatArray, x: FloatArray, config: DmpConfig | None = None) -> Dmp:
    """Fit a DMP to a demonstration by locally weighted regression (Eqs. 5.2-5.4).

    Parameters
    ----------
    t : ndarray, shape (n,)
        Sample times [s], strictly increasing (need not be uniform).
    x : ndarray, shape (n, d)
        Demonstration [m] (any position-like unit).
    config : DmpConfig, optional

    Returns
    -------
    Dmp
        Includes the demonstrated initial velocity ``v0``: a GMR mean may already be
        moving at its first sample, and dropping that velocity costs centimetres in the
        first second.

    Raises
    ------
    InvalidInput
        Bad shapes, NaN, fewer than 4 samples; for ``original``, a channel whose
        start equals its goal (Eq. 5.1 cannot represent it: use ``modified``).
    """
    cfg = config or DmpConfig()
    t, x = check_trajectory(t, x, min_len=4)
    duration = float(t[-1] - t[0])
    tb = (t - t[0]) / duration
    x0, g = x[0].copy(), x[-1].copy()
    f_t, xd = _forcing_target(tb, x, g, x0, cfg)
    s = phase(tb, cfg.alpha_s)
    c, h = basis_functions(cfg)
    # Eq. (5.4): w_i = s^T Gamma_i f / s^T Gamma_i s for every i and channel. Sample
    # weights dt make the regression independent of the sampling density.
    dt = np.gradient(tb)
    w = np.empty((x.shape[1], c.shape[0]))
    _lwr_kernel(s, dt, np.ascontiguousarray(f_t), c, h, cfg.alpha_s, w)
    if cfg.variant == "original":
        span = g - x0
        tiny = np.abs(span) < 1e-6
        if tiny.any():
            raise InvalidInput(
                f"x: channel(s) {np.flatnonzero(tiny).tolist()} begin where they end "
                "(g - x0 = 0); the original DMP (Eq. 5.1) cannot represent them, use "
                "variant='modified'"
            )
        w = w / span[:, None]
    dmp = Dmp(
        config=cfg,
        weights=w,
        x0=x0,
        g=g,
        v0=xd[0].copy(),
        duration=duration,
        fit_residual=np.zeros(x.shape[1]),
    )
    f_fit = forcing(dmp, s)
    if cfg.variant == "original":
        f_fit = f_fit * (g - x0)
    residual = np.max(np.abs(f_fit - f_t), axis=0)
    object.__setattr__(dmp, "fit_residual", residual)
    logger.debug("DMP fit: %d samples, %d channels, residual %s", len(t), x.shape[1], residual)
    return dmp
