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

Phase and basis (Eq. 5.3): ``s = exp(-alpha_s tb)``; ``n_basis`` Gaussians
``psi_i(s) = exp(-h_i (s - c_i)^2)`` with centres uniform in time and widths such that
neighbours cross at 0.5. Weights by locally weighted regression (Eq. 5.4).

Integration: for fixed forcing the system is linear in ``(x, v)``, so each step uses
the exact transition of the continuous system with inputs interpolated linearly
between samples (first-order hold); the only error is the input interpolation.

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

import functools
import logging
from dataclasses import dataclass

import numba
import numpy as np
import scipy.linalg

from dexlfd._types import FloatArray
from dexlfd._validation import as_float_array, check_finite, check_trajectory
from dexlfd.errors import InvalidInput

__all__ = [
    "VARIANTS",
    "Dmp",
    "DmpConfig",
    "DmpRollout",
    "basis_functions",
    "coupling_response",
    "fit_dmp",
    "forcing",
    "phase",
    "rollout_dmp",
]

logger = logging.getLogger(__name__)

VARIANTS = ("original", "modified")
_EPS = 1e-12


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

    n_basis: int = 100
    K: float = 1.0
    D: float = 1.0
    alpha: float = 25.0
    alpha_s: float = 8.0
    variant: str = "modified"

    def __post_init__(self) -> None:
        if int(self.n_basis) < 2:
            raise InvalidInput(f"n_basis must be >= 2, got {self.n_basis}")
        for name in ("K", "D", "alpha", "alpha_s"):
            v = getattr(self, name)
            if not np.isfinite(v) or v <= 0:
                raise InvalidInput(f"DmpConfig.{name} must be > 0, got {v!r}")
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


def phase(tb: FloatArray, alpha_s: float) -> FloatArray:
    """Canonical system ``s' = -alpha_s s``, ``s(0) = 1`` (Eq. 5.3) at normalised times."""
    return np.exp(-alpha_s * np.asarray(tb, dtype=np.float64))


def basis_functions(config: DmpConfig) -> tuple[FloatArray, FloatArray]:
    """Centres ``c`` and widths ``h`` of the Gaussians in phase, each shape (n_basis,).

    Centres are uniform in normalised time; ``h`` makes neighbours cross at 0.5.
    """
    c = np.exp(-config.alpha_s * np.linspace(0.0, 1.0, int(config.n_basis)))
    gaps = np.abs(np.diff(c))
    gaps = np.append(gaps, gaps[-1])
    h = 4.0 * np.log(2.0) / gaps**2
    return c, h


_PSI_CUT = 40.0  # exp(-40) = 4e-18: basis functions this far away are skipped


def _psi(s: FloatArray, c: FloatArray, h: FloatArray) -> FloatArray:
    """Reference (NumPy) basis activations, shape (n, N) (Eq. 5.3)."""
    return np.exp(-h[None, :] * (s[:, None] - c[None, :]) ** 2)


@numba.njit(cache=True)
def _window(sk, c, h, alpha_s):  # pragma: no cover
    """Index range ``[lo, hi)`` of the basis functions with ``h (s - c)^2 < _PSI_CUT``.

    Centres are uniform in time, so the nearest is about ``-ln(s) (N-1) / alpha_s``;
    ``h (s - c)^2`` grows monotonically away from it on both sides, so the range is
    found by walking outwards until the cut.
    """
    N = c.shape[0]
    if sk > 0.0:
        ic = int(-np.log(sk) * (N - 1) / alpha_s + 0.5)
    else:
        ic = N - 1
    ic = min(max(ic, 0), N - 1)
    lo = ic
    while lo > 0 and h[lo - 1] * (sk - c[lo - 1]) ** 2 < _PSI_CUT:
        lo -= 1
    hi = ic + 1
    while hi < N and h[hi] * (sk - c[hi]) ** 2 < _PSI_CUT:
        hi += 1
    return lo, hi


@numba.njit(cache=True)
def _forcing_kernel(s, c, h, alpha_s, W, out):  # pragma: no cover
    """``out[k] = sum_i W[:, i] psi_i(s_k) / sum_i psi_i(s_k) * s_k`` (Eq. 5.3)."""
    n = s.shape[0]
    d = W.shape[0]
    for k in range(n):
        for j in range(d):
            out[k, j] = 0.0
        tot = 0.0
        lo, hi = _window(s[k], c, h, alpha_s)
        for i in range(lo, hi):
            a = h[i] * (s[k] - c[i]) ** 2
            if a < _PSI_CUT:
                p = np.exp(-a)
                tot += p
                for j in range(d):
                    out[k, j] += W[j, i] * p
        for j in range(d):
            out[k, j] = out[k, j] / (tot + 1e-300) * s[k]


@numba.njit(cache=True)
def _lwr_kernel(s, wt, F, c, h, alpha_s, out_w):  # pragma: no cover
    """Eq. (5.4): ``w_i = sum psi_i s F wt / sum psi_i s^2 wt`` for every channel."""
    n = s.shape[0]
    N = c.shape[0]
    d = F.shape[1]
    den = np.zeros(N)
    num = np.zeros((N, d))
    for k in range(n):
        sk = s[k]
        lo, hi = _window(sk, c, h, alpha_s)
        for i in range(lo, hi):
            a = h[i] * (sk - c[i]) ** 2
            if a < _PSI_CUT:
                p = np.exp(-a) * sk * wt[k]
                den[i] += p * sk
                for j in range(d):
                    num[i, j] += p * F[k, j]
    for j in range(d):
        for i in range(N):
            out_w[j, i] = num[i, j] / (den[i] + 1e-300)


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


def forcing(dmp: Dmp, s: FloatArray) -> FloatArray:
    """Forcing term ``f(s) = sum(w psi) / sum(psi) * s`` (Eq. 5.3), shape (n, d)."""
    c, h = basis_functions(dmp.config)
    s = np.ascontiguousarray(s, dtype=np.float64)
    out = np.empty((s.shape[0], dmp.n_dims))
    _forcing_kernel(s, c, h, dmp.config.alpha_s, np.ascontiguousarray(dmp.weights), out)
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
                f"x: channel(s) {np.flatnonzero(tiny).tolist()} start where they end "
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


@functools.lru_cache(maxsize=64)
def _transition(Kb: float, Db: float, h: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Exact first-order-hold discretisation of ``z' = A z + r`` over a step ``h``.

    ``z_{k+1} = Phi z_k + M0 r_k + M1 (r_{k+1} - r_k) / h`` with ``A = [[0,1],[-Kb,-Db]]``
    (from the exponential of the augmented matrix ``[[A, I, 0], [0, 0, I], [0, 0, 0]]``).
    """
    aug = np.zeros((6, 6))
    aug[0:2, 0:2] = [[0.0, 1.0], [-Kb, -Db]]
    aug[0:2, 2:4] = np.eye(2)
    aug[2:4, 4:6] = np.eye(2)
    E = scipy.linalg.expm(aug * h)
    return E[0:2, 0:2].copy(), E[0:2, 2:4].copy(), E[0:2, 4:6].copy()


@numba.njit(cache=True)
def _linear_rollout(Phi, M0, M1, h, x0, v0, rx, rv, out_x, out_v):  # pragma: no cover
    """Step ``z = (x, v)`` with inputs ``rx`` (to x') and ``rv`` (to v'), each (n, d)."""
    n, d = rx.shape
    a = (M1[0, 0] / h, M1[0, 1] / h, M1[1, 0] / h, M1[1, 1] / h)
    for j in range(d):
        x = x0[j]
        v = v0[j]
        out_x[0, j] = x
        out_v[0, j] = v
        for k in range(n - 1):
            drx = rx[k + 1, j] - rx[k, j]
            drv = rv[k + 1, j] - rv[k, j]
            xn = (
                Phi[0, 0] * x
                + Phi[0, 1] * v
                + M0[0, 0] * rx[k, j]
                + M0[0, 1] * rv[k, j]
                + a[0] * drx
                + a[1] * drv
            )
            vn = (
                Phi[1, 0] * x
                + Phi[1, 1] * v
                + M0[1, 0] * rx[k, j]
                + M0[1, 1] * rv[k, j]
                + a[2] * drx
                + a[3] * drv
            )
            x = xn
            v = vn
            out_x[k + 1, j] = x
            out_v[k + 1, j] = v


def _rollout_impl(
    dmp: Dmp,
    tb: FloatArray,
    x0: FloatArray,
    g: FloatArray,
    v0: FloatArray,
    u: FloatArray | None,
    ud: FloatArray | None,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Unchecked rollout on a uniform normalised grid; returns x, x', x'' (normalised)."""
    cfg = dmp.config
    Kb, Db = cfg.K_bar, cfg.D_bar
    n = tb.shape[0]
    s = phase(tb, cfg.alpha_s)
    f = forcing(dmp, s)
    if cfg.variant == "modified":
        rv = Kb * g[None, :] - Kb * (g - x0)[None, :] * s[:, None] + Kb * f  # Eq. (5.5)
    else:
        rv = Kb * g[None, :] + (g - x0)[None, :] * f  # Eq. (5.1)
    rx = np.zeros_like(rv) if u is None else np.ascontiguousarray(u, dtype=np.float64)
    if ud is not None:
        rv = rv + ud  # the c F' term of Eq. (5.6)
    h = float(tb[1] - tb[0])
    Phi, M0, M1 = _transition(Kb, Db, h)
    x = np.empty((n, g.shape[0]))
    v = np.empty_like(x)
    _linear_rollout(Phi, M0, M1, h, x0, v0, rx, np.ascontiguousarray(rv), x, v)
    xd: FloatArray = v + rx
    rxd: FloatArray = np.zeros_like(rx) if u is None else np.gradient(rx, h, axis=0)
    xdd: FloatArray = -Kb * x - Db * v + rv + rxd
    return x, xd, xdd


def rollout_dmp(
    dmp: Dmp,
    *,
    x0: FloatArray | None = None,
    g: FloatArray | None = None,
    duration: float | None = None,
    n_steps: int = 1001,
    v0: FloatArray | None = None,
    coupling: FloatArray | None = None,
) -> DmpRollout:
    """Integrate a fitted DMP from ``x0`` to ``g`` over ``duration``.

    Parameters
    ----------
    dmp : Dmp
    x0, g : ndarray, shape (d,), optional
        New start and goal [m]; default: the demonstration's.
    duration : float, optional
        Movement duration [s] (temporal scaling); default: the demonstration's.
    n_steps : int
        Number of output samples, uniform from 0 to ``duration``.
    v0 : ndarray, shape (d,), optional
        Initial velocity [m/s]; default: the demonstrated initial velocity,
        rescaled to the new duration.
    coupling : ndarray, shape (n_steps, d), optional
        Coupling velocity ``c F(t)`` of Eq. (5.6) per normalised time [m]; its
        derivative is added to the acceleration equation.

    Returns
    -------
    DmpRollout
    """
    d = dmp.n_dims
    x0_ = dmp.x0 if x0 is None else check_finite(as_float_array(x0, "x0", shape=(d,)), "x0")
    g_ = dmp.g if g is None else check_finite(as_float_array(g, "g", shape=(d,)), "g")
    T = dmp.duration if duration is None else float(duration)
    if not np.isfinite(T) or T <= 0:
        raise InvalidInput(f"duration must be > 0 [s], got {duration!r}")
    if int(n_steps) < 2:
        raise InvalidInput(f"n_steps must be >= 2, got {n_steps}")
    n = int(n_steps)
    v0_ = (
        dmp.v0
        if v0 is None
        else check_finite(as_float_array(v0, "v0", shape=(d,)), "v0") * T  # to per-tb
    )
    tb = np.linspace(0.0, 1.0, n)
    u = ud = None
    if coupling is not None:
        u = check_finite(as_float_array(coupling, "coupling", shape=(n, d)), "coupling")
        ud = np.gradient(u, tb, axis=0)
    x, xd, xdd = _rollout_impl(dmp, tb, x0_, g_, v0_, u, ud)
    return DmpRollout(t=tb * T, x=x, xd=xd / T, xdd=xdd / T**2)


def coupling_response(
    config: DmpConfig, n_steps: int, u: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Response of the DMP to a coupling velocity alone (zero state, no forcing).

    The DMP is linear in its state for fixed forcing, so a coupled rollout equals the
    uncoupled one plus this response; the planner uses that to scale coupling gains in
    closed form.

    Parameters
    ----------
    config : DmpConfig
    n_steps : int
        Samples on the uniform normalised grid ``[0, 1]``.
    u : ndarray, shape (n_steps, d)
        Coupling velocity per normalised time (``c F`` of Eq. 5.6).

    Returns
    -------
    x, xd, xdd : ndarray, shape (n_steps, d)
        Displacement and its first two derivatives per normalised time.
    """
    Kb, Db = config.K_bar, config.D_bar
    tb = np.linspace(0.0, 1.0, int(n_steps))
    h = float(tb[1] - tb[0])
    rx = np.ascontiguousarray(u, dtype=np.float64)
    rv = np.ascontiguousarray(np.gradient(rx, h, axis=0))  # the c F' term of Eq. (5.6)
    Phi, M0, M1 = _transition(Kb, Db, h)
    d = rx.shape[1]
    x = np.empty_like(rx)
    v = np.empty_like(rx)
    _linear_rollout(Phi, M0, M1, h, np.zeros(d), np.zeros(d), rx, rv, x, v)
    xd = v + rx
    xdd = -Kb * x - Db * v + rv + np.gradient(rx, h, axis=0)
    return x, xd, xdd
