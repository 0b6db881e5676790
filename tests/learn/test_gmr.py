from __future__ import annotations

import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.learn import Gmm, gmr


def _random_gmm(rng: np.random.Generator, K: int, D: int) -> Gmm:
    A = rng.normal(size=(K, D, D))
    covs = A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(D)
    w = rng.uniform(0.2, 1.0, K)
    return Gmm(weights=w / w.sum(), means=rng.normal(size=(K, D)) * 2, covariances=covs)


def test_one_component_is_gaussian_conditioning(rng: np.random.Generator) -> None:
    g = _random_gmm(rng, 1, 5)
    q = rng.normal(size=7)
    res = gmr(g, q)
    mu, S = g.means[0], g.covariances[0]
    Sii, Soi, Soo = S[0, 0], S[1:, 0], S[1:, 1:]
    for n, t in enumerate(q):
        np.testing.assert_allclose(res.mean[n], mu[1:] + Soi / Sii * (t - mu[0]), rtol=1e-12)
        np.testing.assert_allclose(res.cov[n], Soo - np.outer(Soi, Soi) / Sii, rtol=1e-11)
    np.testing.assert_allclose(res.weights, 1.0, rtol=1e-12)


def slow_gmr(g: Gmm, t: float, i: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """Eqs. (4.18)-(4.19) literally, one query, one component at a time."""
    o = [d for d in range(g.means.shape[1]) if d not in i]
    h, mus, covs = [], [], []
    x = np.atleast_1d(t)
    for k in range(g.n_components):
        mu, S = g.means[k], g.covariances[k]
        Sii = S[np.ix_(i, i)]
        diff = x - mu[i]
        dens = np.exp(-0.5 * diff @ np.linalg.inv(Sii) @ diff) / np.sqrt(
            np.linalg.det(2 * np.pi * Sii)
        )
        h.append(g.weights[k] * dens)
        mus.append(mu[o] + S[np.ix_(o, i)] @ np.linalg.inv(Sii) @ diff)
        covs.append(S[np.ix_(o, o)] - S[np.ix_(o, i)] @ np.linalg.inv(Sii) @ S[np.ix_(i, o)])
    h = np.array(h) / np.sum(h)
    mean = sum(hk * m for hk, m in zip(h, mus, strict=True))
    cov = sum(hk * (np.outer(m, m) + C) for hk, m, C in zip(h, mus, covs, strict=True)) - np.outer(
        mean, mean
    )
    return mean, cov


@pytest.mark.parametrize("in_dims", [[0], [0, 2]])
def test_matches_slow_loop(rng: np.random.Generator, in_dims: list[int]) -> None:
    g = _random_gmm(rng, 4, 5)
    q = rng.normal(size=(25, len(in_dims)))
    res = gmr(g, q, in_dims=in_dims)
    for n in range(len(q)):
        m, C = slow_gmr(g, q[n], in_dims)
        np.testing.assert_allclose(res.mean[n], m, rtol=1e-9, atol=1e-12)
        # the literal form subtracts mu mu^T: cancellation ~1e-15 * |mu|^2
        np.testing.assert_allclose(res.cov[n], C, rtol=1e-8, atol=1e-11)
        assert np.linalg.eigvalsh(res.cov[n]).min() > -1e-12


def test_between_component_spread_is_included(rng: np.random.Generator) -> None:
    # two components at the same time with different outputs: variance = within + spread
    g = Gmm(
        weights=np.array([0.5, 0.5]),
        means=np.array([[0.0, -1.0], [0.0, 1.0]]),
        covariances=np.array([np.diag([1.0, 0.01])] * 2),
    )
    res = gmr(g, np.array([0.0]))
    np.testing.assert_allclose(res.mean[0], [0.0], atol=1e-15)
    np.testing.assert_allclose(res.cov[0], [[0.01 + 1.0]], rtol=1e-12)


def test_far_queries_stay_finite(rng: np.random.Generator) -> None:
    g = _random_gmm(rng, 3, 3)
    res = gmr(g, np.array([-1e4, 1e4]))
    assert np.isfinite(res.mean).all() and np.isfinite(res.cov).all()


def test_bad_arguments(rng: np.random.Generator) -> None:
    g = _random_gmm(rng, 2, 3)
    with pytest.raises(InvalidInput, match="in_dims"):
        gmr(g, np.zeros(3), in_dims=[5])
    with pytest.raises(InvalidInput, match="no output"):
        gmr(g, np.zeros((3, 3)), in_dims=[0, 1, 2])
    with pytest.raises(InvalidInput, match="shape"):
        gmr(g, np.zeros((3, 2)), in_dims=[0])
    with pytest.raises(InvalidInput, match="finite"):
        gmr(g, np.array([np.nan]))
