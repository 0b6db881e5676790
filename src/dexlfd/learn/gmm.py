"""Gaussian mixture model fitted by expectation–maximisation (Eq. 4.17).

Written in NumPy rather than using scikit-learn: on the synthetic set (1422
points × 9 dimensions, K = 6) this fit takes about 8 ms, scikit-learn's
``GaussianMixture`` with its default k-means initialisation 130–170 ms on the
same machine (benchmarks/bench_learn.py; the sklearn figure measured ad hoc).
Per iteration: one batched Cholesky of the K covariances, one GEMM for all
Mahalanobis terms and K small GEMMs for the covariances.

Covariance floor: every component's covariance has an inverse-Wishart-type
prior ``p(Sigma_k) ∝ exp(-tr(Psi Sigma_k^-1) / 2)`` with ``Psi = diag(n/K *
floor_d)`` and ``floor_d = max(reg_covar * var_d, reg_covar_abs)`` (``var_d``
is the data's variance in dimension ``d``). The M-step then gives
``Sigma_k = (S_k + Psi) / N_k``: a component of average size ``N_k = n/K`` gets
exactly ``floor_d`` added to its diagonal, a small component more. Being
relative to the data the floor is unit-independent (seconds and metres alike);
it keeps every covariance positive definite, so EM never breaks on a
collapsing component or constant channel. Because it is a proper prior, EM
(then MAP-EM) still increases its objective, the penalised log-likelihood,
at every iteration; a floor simply added after the M-step does not guarantee
that. With ``reg_covar = reg_covar_abs = 0`` this is plain EM.

Constant columns (e.g. the z of planar handwriting, a quaternion that never
changes, a gripper that stays open) are left out of EM and put back with their
value as every component's mean and ``reg_covar_abs`` as variance, no
covariance with the other columns. Fitted with the rest, their variance would
be the prior alone, ``Psi_d / N_k``: each constant column adds ``½ log N_k``
to component k's log-density, so EM favours large components (six constant
channels: a factor ``N_k³``) and the fit of the varying columns degrades. The
reported log-likelihood is that of the varying columns.

Initialisation: ``"time"`` splits the data into K equal slices of the first
column (time) and takes each slice's mean and covariance — the usual choice
for trajectories, and deterministic; ``"kmeans++"`` seeds K centres with the
k-means++ rule from ``rng`` and refines them by a few Lloyd iterations.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any, cast

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd._validation import as_float_array, check_finite
from dexlfd.errors import InvalidInput

__all__ = [
    "GMM_INITS",
    "Gmm",
    "GmmConfig",
    "GmmResult",
    "constant_columns",
    "fit_gmm",
    "gmm_log_likelihood",
]

GMM_INITS = ("time", "kmeans++")
_LOG_2PI = float(np.log(2.0 * np.pi))
_WEIGHT_EPS = 10.0 * np.finfo(np.float64).eps


@dataclass(frozen=True, slots=True)
class GmmConfig:
    """EM settings.

    Attributes
    ----------
    n_components : int
        K, the number of Gaussians (thesis: 6).
    max_iter : int
        Maximum number of EM iterations.
    tol : float
        Stop when the EM objective per data point improves by less [nats].
    reg_covar : float
        Covariance floor relative to each dimension's data variance.
    reg_covar_abs : float
        Absolute lower bound of the floor (for constant dimensions).
    init : {"time", "kmeans++"}
        Initialisation, see the module docstring.
    """

    n_components: int = 6
    max_iter: int = 200
    tol: float = 1e-4
    reg_covar: float = 1e-6
    reg_covar_abs: float = 1e-12
    init: str = "time"

    def __post_init__(self) -> None:
        if isinstance(self.n_components, bool) or int(self.n_components) != self.n_components:
            raise InvalidInput(f"n_components must be an integer, got {self.n_components!r}")
        if self.n_components < 1:
            raise InvalidInput(f"n_components (K) must be >= 1, got {self.n_components}")
        if self.max_iter < 1:
            raise InvalidInput(f"max_iter must be >= 1, got {self.max_iter}")
        if not self.tol >= 0:
            raise InvalidInput(f"tol must be >= 0, got {self.tol}")
        if not (self.reg_covar >= 0 and self.reg_covar_abs >= 0):
            raise InvalidInput(
                f"reg_covar and reg_covar_abs must be >= 0, got {self.reg_covar}, "
                f"{self.reg_covar_abs}"
            )
        if self.init not in GMM_INITS:
            raise InvalidInput(f"init must be one of {GMM_INITS}, got {self.init!r}")


@dataclass(frozen=True, slots=True)
class Gmm:
    """Mixture parameters.

    Attributes
    ----------
    weights : ndarray, shape (K,)
        Mixing coefficients pi_k, summing to 1.
    means : ndarray, shape (K, D)
        Component means mu_k.
    covariances : ndarray, shape (K, D, D)
        Component covariances Sigma_k (symmetric positive definite).
    """

    weights: FloatArray
    means: FloatArray
    covariances: FloatArray

    @property
    def n_components(self) -> int:
        """K."""
        return int(self.weights.shape[0])


@dataclass(frozen=True, slots=True)
class GmmResult:
    """Outcome of EM.

    Attributes
    ----------
    gmm : Gmm
        The fitted mixture (the parameters whose log-likelihood is last in
        ``log_likelihood_history``).
    n_iter : int
        Number of M-steps after initialisation.
    converged : bool
        Whether the improvement fell below ``tol`` before ``max_iter``.
    log_likelihood : float
        Total log-likelihood of the data under ``gmm`` [nats].
    log_likelihood_history : ndarray, shape (n_iter + 1,)
        Total log-likelihood after initialisation and after each M-step.
    objective_history : ndarray, shape (n_iter + 1,)
        The objective EM maximises: log-likelihood plus the log of the
        covariance-floor prior (equal to the log-likelihood without a floor).
        It never decreases.
    """

    gmm: Gmm
    n_iter: int
    converged: bool
    log_likelihood: float
    log_likelihood_history: FloatArray
    objective_history: FloatArray


_BLAS: list[Any] = []  # the process's BLAS libraries, found once (a /proc scan)


def _one_blas_thread() -> Any:
    """A context that runs BLAS on one thread (threadpoolctl's controller, made once)."""
    if not _BLAS:
        from threadpoolctl import ThreadpoolController

        _BLAS.append(ThreadpoolController())
    return _BLAS[0].limit(limits=1, user_api="blas")


def _cholesky(Sigma: FloatArray) -> FloatArray:
    try:
        return cast(FloatArray, np.linalg.cholesky(Sigma))
    except np.linalg.LinAlgError as exc:  # only possible with reg_covar = reg_covar_abs = 0
        raise InvalidInput(
            "a GMM covariance became singular; use a covariance floor (reg_covar > 0)"
        ) from exc


def _log_gauss(X: FloatArray, mu: FloatArray, L: FloatArray, L_inv: FloatArray) -> FloatArray:
    """Log-density log N(x_n | mu_k, L_k L_k^T) as (n, K) from Cholesky factors L (K, D, D).

    ``L_inv`` are the factors' inverses (K small triangular factors: cheaper than K
    solves over n).
    """
    n, D = X.shape
    K = mu.shape[0]
    # y_nk = L_k^-1 (x_n - mu_k) = x_n L_k^-T - mu_k L_k^-T: all K at once in one GEMM
    LT = np.swapaxes(L_inv, 1, 2)  # (K, D, D)
    y = (X @ np.concatenate(list(LT), axis=1)).reshape(n, K, D)
    y -= np.einsum("kd,kde->ke", mu, LT)[None, :, :]
    maha = np.einsum("nkd,nkd->nk", y, y)
    logdet = 2.0 * np.log(np.diagonal(L, axis1=1, axis2=2)).sum(axis=1)
    return -0.5 * (D * _LOG_2PI + logdet[None, :] + maha)


def _e_step(X: FloatArray, gmm: Gmm, psi: FloatArray) -> tuple[float, float, FloatArray]:
    """Log-likelihood, penalised log-likelihood (MAP objective) and responsibilities (n, K)."""
    L = _cholesky(gmm.covariances)
    L_inv = cast(FloatArray, np.linalg.inv(L))
    log_p = _log_gauss(X, gmm.means, L, L_inv) + np.log(gmm.weights)[None, :]
    top = log_p.max(axis=1, keepdims=True)
    log_norm = top[:, 0] + np.log(np.exp(log_p - top).sum(axis=1))
    resp = np.exp(log_p - log_norm[:, None])
    ll = float(log_norm.sum())
    # prior term -tr(Psi Sigma_k^-1)/2 with diagonal Psi;
    # diag(Sigma^-1) = column sums of (L^-1)^2
    penalty = 0.5 * float((np.square(L_inv).sum(axis=1) * psi[None, :]).sum())
    return ll, ll - penalty, resp


def _m_step(X: FloatArray, resp: FloatArray, psi: FloatArray) -> Gmm:
    n = X.shape[0]
    Nk = resp.sum(axis=0) + _WEIGHT_EPS  # keeps an emptied component finite
    mu = (resp.T @ X) / Nk[:, None]
    S = np.empty((mu.shape[0], X.shape[1], X.shape[1]))
    for k in range(mu.shape[0]):  # K GEMMs of (D, n) @ (n, D): BLAS, unlike a stacked matmul
        diff = X - mu[k]
        S[k] = (diff * resp[:, k : k + 1]).T @ diff
    idx = np.arange(X.shape[1])
    S[:, idx, idx] += psi[None, :]  # MAP with the floor prior: (S_k + Psi) / N_k
    Sigma = S / Nk[:, None, None]
    Sigma = 0.5 * (Sigma + np.swapaxes(Sigma, 1, 2))
    return Gmm(weights=Nk / (n + Nk.size * _WEIGHT_EPS), means=mu, covariances=Sigma)


def _init_resp(X: FloatArray, K: int, init: str, rng: np.random.Generator) -> FloatArray:
    n = X.shape[0]
    resp = np.zeros((n, K))
    if init == "time":
        t = X[:, 0]
        edges = np.linspace(t.min(), t.max(), K + 1)
        label = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, K - 1)
        # equal-time slices can be empty (gaps in t): fall back to equal-count slices
        if np.bincount(label, minlength=K).min() == 0:
            label = np.empty(n, np.intp)
            label[np.argsort(t, kind="stable")] = np.arange(n) * K // n
    else:
        scale = X.std(axis=0)
        Z = X / np.where(scale > 0, scale, 1.0)
        centres = np.empty((K, X.shape[1]))
        centres[0] = Z[rng.integers(n)]
        d2 = ((Z - centres[0]) ** 2).sum(axis=1)
        for k in range(1, K):
            total = d2.sum()
            c = rng.integers(n) if total <= 0 else rng.choice(n, p=d2 / total)
            centres[k] = Z[c]
            d2 = np.minimum(d2, ((Z - centres[k]) ** 2).sum(axis=1))
        for _ in range(10):  # Lloyd refinement
            label = np.argmin(((Z[:, None, :] - centres[None]) ** 2).sum(axis=2), axis=1)
            for k in range(K):
                if (label == k).any():
                    centres[k] = Z[label == k].mean(axis=0)
        label = np.argmin(((Z[:, None, :] - centres[None]) ** 2).sum(axis=2), axis=1)
    resp[np.arange(n), label] = 1.0
    return resp


def constant_columns(X: FloatArray, rtol: float = 1e-12) -> BoolArray:
    """Columns of ``X`` (n, D) whose range is at most ``rtol`` × their largest magnitude."""
    span = X.max(axis=0) - X.min(axis=0)
    return np.asarray(span <= rtol * np.abs(X).max(axis=0), dtype=bool)


def _embed_constant(gmm: Gmm, x0: FloatArray, const: BoolArray, var: float) -> Gmm:
    """The mixture over all columns: constant ones at ``x0`` with variance ``var``, uncorrelated."""
    K, D = gmm.n_components, const.size
    keep = np.flatnonzero(~const)
    means = np.broadcast_to(x0, (K, D)).copy()
    means[:, keep] = gmm.means
    covs = np.zeros((K, D, D))
    covs[np.ix_(np.arange(K), keep, keep)] = gmm.covariances
    idx = np.flatnonzero(const)
    covs[:, idx, idx] = max(var, np.finfo(np.float64).tiny)
    return Gmm(weights=gmm.weights, means=means, covariances=covs)


def fit_gmm(
    X: FloatArray,
    cfg: GmmConfig,
    rng: np.random.Generator,
    callback: Callable[[int, float], None] | None = None,
) -> GmmResult:
    """Fit a K-component full-covariance GMM to ``X`` by EM (Eq. 4.17).

    Parameters
    ----------
    X : ndarray, shape (n, D)
        Data points, finite; for trajectories column 0 is time [s].
    cfg : GmmConfig
        K, stopping rule, covariance floor and initialisation.
    rng : numpy.random.Generator
        Used by the ``"kmeans++"`` initialisation.
    callback : callable(iteration, log_likelihood), optional
        Called after each EM iteration.

    Returns
    -------
    GmmResult

    Raises
    ------
    InvalidInput
        ``X`` not 2-D and finite, or fewer points than components.

    References
    ----------
    .. [1] Thesis Eq. (4.17); Dempster, Laird & Rubin (1977), J. R. Stat. Soc. B 39(1);
       Arthur & Vassilvitskii (2007), k-means++, SODA.
    """
    X = check_finite(as_float_array(X, "X", ndim=2), "X")
    n, D = X.shape
    K = int(cfg.n_components)
    if D < 1:
        raise InvalidInput("X must have at least one column")
    if n < K:
        raise InvalidInput(
            f"cannot fit K={K} Gaussian components (n_components) to {n} data point(s): "
            f"need at least K points; lower K"
        )
    const = constant_columns(X)
    if const.any() and not const.all():
        res = fit_gmm(X[:, ~const], cfg, rng, callback)
        return replace(res, gmm=_embed_constant(res.gmm, X[0], const, cfg.reg_covar_abs))
    floor = np.maximum(cfg.reg_covar * X.var(axis=0), cfg.reg_covar_abs)
    psi = floor * (n / K)  # prior scale: an average-size component gets `floor` added
    # EM's GEMMs are tiny (n x 9 x 54): BLAS threads only add synchronisation, and on a
    # busy machine they stall (20 vs 28-49 ms per learn step measured under load)
    with _one_blas_thread():
        gmm = _m_step(X, _init_resp(X, K, cfg.init, rng), psi)
        history: list[float] = []
        objective: list[float] = []
        converged = False
        n_iter = 0
        while True:
            ll, obj, resp = _e_step(X, gmm, psi)
            history.append(ll)
            objective.append(obj)
            if callback is not None:
                callback(n_iter, ll)
            if n_iter > 0 and abs(objective[-1] - objective[-2]) < cfg.tol * n:
                converged = True
                break
            if n_iter >= cfg.max_iter:
                break
            gmm = _m_step(X, resp, psi)
            n_iter += 1
    return GmmResult(
        gmm=gmm,
        n_iter=n_iter,
        converged=converged,
        log_likelihood=history[-1],
        log_likelihood_history=np.asarray(history),
        objective_history=np.asarray(objective),
    )


def gmm_log_likelihood(X: FloatArray, gmm: Gmm) -> float:
    """Total log-likelihood of points ``X`` (n, D) under ``gmm`` [nats]."""
    X = check_finite(as_float_array(X, "X", ndim=2), "X")
    if X.shape[1] != gmm.means.shape[1]:
        raise InvalidInput(f"X must have {gmm.means.shape[1]} columns, got {X.shape[1]}")
    return _e_step(X, gmm, np.zeros(X.shape[1]))[0]
