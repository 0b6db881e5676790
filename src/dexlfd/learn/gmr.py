"""Gaussian mixture regression: mean and full covariance of outputs given inputs (Eqs. 4.18–4.19).

For a query ``t*`` each component gives a conditional Gaussian with mean
``mu_k(t*) = mu_o,k + Sigma_oi,k Sigma_ii,k^-1 (t* - mu_i,k)`` and covariance
``Sigma_bar_k = Sigma_oo,k - Sigma_oi,k Sigma_ii,k^-1 Sigma_io,k``, weighted by
``h_k(t*)`` (Eq. 4.18). Eq. (4.19) moment-matches the mixture with one
Gaussian::

    mu_hat    = sum_k h_k mu_k
    Sigma_hat = sum_k h_k (mu_k mu_k^T + Sigma_bar_k) - mu_hat mu_hat^T

which we evaluate in the algebraically equal, cancellation-free form
``sum_k h_k Sigma_bar_k + sum_k h_k (mu_k - mu_hat)(mu_k - mu_hat)^T``: the
second sum is the spread *between* components, which is where most of the
variance of a trajectory lies when components overlap.

Everything is vectorised over queries; the weights ``h_k`` use log-sum-exp so
far-away queries do not underflow to 0/0 (they then follow the nearest
component).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from dexlfd._types import FloatArray
from dexlfd._validation import as_float_array, check_finite
from dexlfd.errors import InvalidInput
from dexlfd.learn.gmm import Gmm

__all__ = ["GmrResult", "gmr"]

_LOG_2PI = float(np.log(2.0 * np.pi))


@dataclass(frozen=True, slots=True)
class GmrResult:
    """Conditional distribution of the outputs at each query.

    Attributes
    ----------
    mean : ndarray, shape (q, Do)
        mu_hat (Eq. 4.19).
    cov : ndarray, shape (q, Do, Do)
        Sigma_hat (Eq. 4.19), symmetric positive semi-definite.
    weights : ndarray, shape (q, K)
        Responsibilities h_k(t*) (Eq. 4.18).
    """

    mean: FloatArray
    cov: FloatArray
    weights: FloatArray


def gmr(gmm: Gmm, query: FloatArray, in_dims: Sequence[int] = (0,)) -> GmrResult:
    """Condition a GMM on input dimensions ``in_dims`` at ``query`` points.

    Parameters
    ----------
    gmm : Gmm
        Mixture over D dimensions.
    query : ndarray, shape (q,) or (q, Di)
        Input values (for trajectories: times [s]).
    in_dims : sequence of int
        Input dimensions (default: column 0, time); the others are outputs,
        in increasing order.

    Returns
    -------
    GmrResult

    References
    ----------
    .. [1] Thesis Eqs. (4.18)–(4.19); Calinon (2016), A tutorial on task-parameterized
       movement learning and retrieval, Intell. Serv. Robot. 9(1).
    """
    D = gmm.means.shape[1]
    i_idx = np.asarray(list(in_dims), dtype=np.intp)
    if (
        i_idx.size == 0
        or len(set(i_idx.tolist())) != i_idx.size
        or (i_idx < 0).any()
        or (i_idx >= D).any()
    ):
        raise InvalidInput(f"in_dims must be distinct indices in 0..{D - 1}, got {list(in_dims)}")
    inputs = set(i_idx.tolist())
    o_idx = np.array([d for d in range(D) if d not in inputs], dtype=np.intp)  # sorted
    if o_idx.size == 0:
        raise InvalidInput("in_dims leaves no output dimension")
    Q = as_float_array(query, "query")
    if Q.ndim == 1 and i_idx.size == 1:
        Q = Q[:, None]
    if Q.ndim != 2 or Q.shape[1] != i_idx.size:
        raise InvalidInput(f"query must have shape (q, {i_idx.size}), got {Q.shape}")
    Q = check_finite(Q, "query")

    mu_i = gmm.means[:, i_idx]  # (K, Di)
    mu_o = gmm.means[:, o_idx]  # (K, Do)
    S = gmm.covariances
    S_ii = S[:, i_idx][:, :, i_idx]
    S_oi = S[:, o_idx][:, :, i_idx]
    S_oo = S[:, o_idx][:, :, o_idx]
    # A_k = S_oi S_ii^-1 via a solve (S_ii symmetric): A^T = S_ii^-1 S_io
    A = np.swapaxes(np.linalg.solve(S_ii, np.swapaxes(S_oi, 1, 2)), 1, 2)  # (K, Do, Di)
    Sigma_bar = S_oo - A @ np.swapaxes(S_oi, 1, 2)  # [1] Eq. (4.18), Sigma_bar_k
    Sigma_bar = 0.5 * (Sigma_bar + np.swapaxes(Sigma_bar, 1, 2))

    # h_k(t*) (Eq. 4.18): log pi_k + log N(t* | mu_i,k, S_ii,k), normalised over k
    L = np.linalg.cholesky(S_ii)
    diff = Q[None, :, :] - mu_i[:, None, :]  # (K, q, Di)
    y = np.linalg.solve(L, np.swapaxes(diff, 1, 2))  # (K, Di, q)
    maha = np.einsum("kdq,kdq->qk", y, y)
    logdet = 2.0 * np.log(np.diagonal(L, axis1=1, axis2=2)).sum(axis=1)
    log_h = np.log(gmm.weights)[None, :] - 0.5 * (i_idx.size * _LOG_2PI + logdet + maha)
    log_h -= log_h.max(axis=1, keepdims=True)
    h = np.exp(log_h)
    h /= h.sum(axis=1, keepdims=True)

    mu_k = mu_o[None, :, :] + np.swapaxes(diff @ np.swapaxes(A, 1, 2), 0, 1)  # (q, K, Do)
    mean = (h[:, :, None] * mu_k).sum(axis=1)  # [1] Eq. (4.19), mu_hat
    dev = mu_k - mean[:, None, :]
    within = (h @ Sigma_bar.reshape(Sigma_bar.shape[0], -1)).reshape(-1, *Sigma_bar.shape[1:])
    wdev = np.sqrt(h)[:, :, None] * dev  # (q, K, Do)
    cov = within + np.swapaxes(wdev, 1, 2) @ wdev  # [1] Eq. (4.19), Sigma_hat
    return GmrResult(mean=mean, cov=cov, weights=h)
