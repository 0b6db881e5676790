"""Shaped Gams coupling: clear an obstacle by the margin, bend more where demos disagreed.

Thesis Eq. (5.7) adds ``c k2 cbrt(|Sigma|) F(t)``, ``F = k1 h(t)``, to the DMP's
velocity. That is a feed-forward push proportional to the intrusion ``h``: how far
the path moves is fixed by the gains, not by the obstacle, so the same gains pass
one obstacle with centimetres to spare and run into another. Scaling the whole
response afterwards until the worst point clears overshoots everywhere else (the
response of a DMP is a low-pass of the push, so its shape never matches the lift
the obstacle needs).

Here the coupling velocity along the avoidance direction is built from smooth,
compactly supported pieces (cubic B-splines, knots a fraction of the DMP's time
constant apart) over the time the path needs to pass the obstacle, starting early
enough for the DMP to respond and ending two time constants after it (to bring the
path back rather than let it decay)::

    u(t) = sum_j a_j B_j(t)

The DMP's response to each piece is computed once (it is linear), and the
amplitudes ``a`` solve a small linear programme:

* over the obstacle (where the nominal path is within ``margin`` of its shadow) the
  displacement ``d(t)`` lies between ``lambda(t) + kappa nu(t) / 2`` (``lambda``:
  the needed lift) and ``lambda(t) + band``: the path clears by the margin plus at
  least half the variance's extra clearance and by at most ``margin + band``;
* elsewhere ``d(t) >= 0`` (never pushed towards the obstacle's side);
* minimise ``sum_t rho(t) |d(t) - d*(t)|``, the deviation from the target
  ``d* = lambda + kappa nu`` over the obstacle and ``0`` elsewhere (the learned path).

The variance enters twice, as the thesis intends: ``nu`` (the model's normalised
variance, :func:`dexlfd.plan.obstacles.variance_level`) adds up to ``kappa`` of extra
clearance where the demonstrations disagreed ("more cautious"), and the weight
``rho = 1.1 - nu`` makes leaving the learned path cheaper where they disagreed and
dearer where they agreed ("trust the demonstrations more"). With the variance term
off, ``nu = 0``.

The result is reported as the gain it amounts to in Eq. (5.7): the coupling's peak
divided by ``c k1`` times the peak intrusion, i.e. the ``k2 cbrt(|Sigma|)`` the thesis's
law would need to push that hard (it replaces the old whole-response factor beta).

References
----------
.. [1] Gams, Nemec, Ijspeert, Ude (2014), Coupling movement primitives: interaction
   with the environment and bimanual tasks, IEEE Trans. Robot. 30(4).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import sparse
from scipy.optimize import linprog

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.plan.dmp import DmpConfig, coupling_response

__all__ = ["ShapedCoupling", "shape_coupling"]

logger = logging.getLogger(__name__)

_CUSHION = 5e-4  # [m] kept inside the band on both sides (the band is checked densely)
_MAX_LP_POINTS = 150  # the programme is posed on at most this many samples ...
_KNOTS_PER_TAU = 3.0  # ... with this many B-spline knots per DMP time constant


@dataclass(frozen=True, slots=True)
class ShapedCoupling:
    """The displacement a shaped coupling causes along the avoidance direction.

    ``x``, ``xd``, ``xdd`` (n,) [m, m, m] per normalised time (derivatives per unit of
    ``t / T``), already multiplied by the end window; ``u`` (n,) the coupling velocity
    [m per normalised time]; ``gain`` the Eq. (5.7) weight it amounts to (see the
    module docstring); ``band_met`` False when the upper bound had to be relaxed.
    """

    x: FloatArray
    xd: FloatArray
    xdd: FloatArray
    u: FloatArray
    gain: float
    band_met: bool


def _bspline(x: FloatArray) -> FloatArray:
    """Uniform cubic B-spline on knots -2..2 (C2, support [-2, 2], sums to 1)."""
    r = np.abs(x)
    return np.where(
        r < 1.0, 2.0 / 3.0 - r * r + 0.5 * r**3, np.where(r < 2.0, (2.0 - r) ** 3 / 6.0, 0.0)
    )


def _basis(tb: FloatArray, t_a: float, t_b: float, spacing: float) -> FloatArray:
    """Cubic B-splines centred ``spacing`` apart over ``[t_a, t_b]``; (n, m), 0 outside.

    The first starts at ``t_a`` (its support begins there), so nothing acts earlier.
    """
    n_int = max(1, int(np.ceil((t_b - t_a) / spacing)))
    centres = t_a + spacing * np.arange(2, n_int + 2)
    return _bspline((tb[:, None] - centres[None, :]) / spacing)


def shape_coupling(
    dmp: DmpConfig,
    tb: FloatArray,
    required: FloatArray,
    nu: FloatArray,
    window: tuple[FloatArray, FloatArray, FloatArray],
    *,
    kappa: float,
    band: float,
    lead: float,
    c: float,
    k1: float,
    h_peak: float,
    velocity: FloatArray | None = None,
    speed_cap: float | None = None,
) -> ShapedCoupling:
    """Solve for the coupling that lifts the path by ``required`` (+ ``kappa nu``).

    Parameters
    ----------
    dmp : DmpConfig
        The DMP whose response is shaped (``K``, ``D``).
    tb : ndarray, shape (n,)
        Uniform normalised time ``[0, 1]``.
    required : ndarray, shape (n,)
        Lift needed to clear the obstacle by the margin [m]; > 0 exactly over the
        obstacle.
    nu : ndarray, shape (n,)
        Normalised variance in [0, 1] (0: variance term off).
    window : tuple of 3 ndarray, shape (n,)
        End window and its two derivatives per normalised time (the displacement is
        faded out over the last part of the motion so the goal is kept).
    kappa : float
        Extra clearance at ``nu = 1`` [m], ``<= band``.
    band : float
        Allowed clearance above the margin [m].
    lead : float
        How long before the obstacle the push may start [normalised time].
    c, k1 : float
        Thesis gains, only to express the result as an Eq. (5.7) weight.
    h_peak : float
        Peak intrusion ``h`` [m] (same purpose).
    velocity : ndarray, shape (n,), optional
        The nominal path's velocity along the avoidance direction [m per normalised
        time].
    speed_cap : float, optional
        With ``velocity``: the coupled path's speed along the avoidance direction is
        kept below this [m per normalised time] (the planner passes the nominal
        path's peak speed: avoiding must not make the motion faster than the
        demonstrations); relaxed 1.5x at a time (with a warning) if infeasible.

    Raises
    ------
    InvalidInput
        No coupling lifts the path enough (the obstacle is too close to the start
        or the end of the motion for the DMP to respond).
    """
    n = tb.shape[0]
    need = required > 0
    idx = np.flatnonzero(need)
    tau = 2.0 / dmp.D_bar  # time constant of the response to a push [normalised]
    t_a = max(0.0, float(tb[idx[0]]) - lead)
    # the push may continue (either sign) for two time constants after the obstacle,
    # so the path is brought back instead of left to decay
    t_b = min(float(tb[idx[-1]]) + 2.0 * tau, 1.0)
    spacing = tau / _KNOTS_PER_TAU
    B = _basis(tb, t_a, t_b, spacing)
    rx, rxd, rxdd = coupling_response(dmp, n, B)
    win, dwin, ddwin = window
    R = rx * win[:, None]
    Rd = rxd * win[:, None] + rx * dwin[:, None]
    Rdd = rxdd * win[:, None] + 2 * rxd * dwin[:, None] + rx * ddwin[:, None]

    # the programme is posed on a subsample plus every sample over the obstacle
    # (subsampled too when there are many); the band is checked densely afterwards
    step = max(1, n // _MAX_LP_POINTS)
    pts = np.union1d(np.arange(0, n, step), idx[:: max(1, idx.size // _MAX_LP_POINTS)])
    A = R[pts]
    on = need[pts]
    target = np.where(on, required[pts] + kappa * nu[pts], 0.0)
    rho = 1.1 - nu[pts]
    m, p = A.shape[1], pts.size
    # variables [a (m, free), e (p, >= 0)]; minimise sum rho e
    cost = np.concatenate([np.zeros(m), rho / p])
    eye = sparse.identity(p, format="csr")
    zero = sparse.csr_matrix((p, p))
    As = sparse.csr_matrix(A)
    rows = [
        sparse.hstack([As, -eye]),  # A a - e <= target
        sparse.hstack([-As, -eye]),  # -A a - e <= -target
        sparse.hstack([-As, zero]),  # A a >= lower
    ]
    # half the variance's extra clearance is guaranteed, the rest is the target
    lower = np.where(on, required[pts] + 0.5 * kappa * nu[pts] + _CUSHION, 0.0)
    rhs = [target, -target, -lower]
    upper = sparse.hstack([As[on], zero[on]])  # A a <= lambda + band
    ub = required[pts][on] + band - _CUSHION
    bounds = [(None, None)] * m + [(0.0, None)] * p
    speed_rows: list[Any] = []
    speed_rhs: list[FloatArray] = []
    if velocity is not None and speed_cap is not None:
        Ds = sparse.hstack([sparse.csr_matrix(Rd[pts]), sparse.csr_matrix((p, p))])
        speed_rows = [Ds, -Ds]
        speed_rhs = [speed_cap - velocity[pts], speed_cap + velocity[pts]]
    cap = 0.0 if speed_cap is None else float(speed_cap)
    band_met = True
    res: Any = None
    for relax in (1.0, 1.5, 2.25, 3.375, None):
        extra_rows = [] if relax is None else speed_rows
        extra_rhs = [] if relax is None else [r + (relax - 1.0) * cap for r in speed_rhs]
        for with_band in (True, False):
            A_ub = sparse.vstack([*rows, *extra_rows, *([upper] if with_band else [])])
            b_ub = np.concatenate([*rhs, *extra_rhs, *([ub] if with_band else [])])
            res = linprog(cost, A_ub, b_ub, bounds=bounds, method="highs")
            if res.status == 0:
                band_met = with_band
                break
        if res.status == 0:
            if speed_rows and relax != 1.0:
                logger.warning(
                    "obstacle: passing it needs %s the nominal path's peak speed",
                    "more than 3.4x" if relax is None else f"{relax:g}x",
                )
            break
        if not speed_rows:
            break
    if res.status != 0:
        raise InvalidInput(
            "no coupling lifts the path enough to pass the obstacle "
            f"({res.message.strip()}); lengthen the duration or move the obstacle away "
            "from the start/end"
        )
    a = np.asarray(res.x[:m])
    u = B @ a
    gain = float(np.abs(u).max()) / (c * k1 * h_peak) if h_peak > 0 else 0.0
    return ShapedCoupling(x=R @ a, xd=Rd @ a, xdd=Rdd @ a, u=u, gain=gain, band_met=band_met)
