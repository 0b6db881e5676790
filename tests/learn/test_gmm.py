from __future__ import annotations

import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.learn import GmmConfig, fit_gmm, gmm_log_likelihood
from dexlfd.learn.gmm import _init_resp, _m_step


def _trajectory_data(rng: np.random.Generator, n_demos: int = 5, m: int = 120) -> np.ndarray:
    t = np.linspace(0, 4, m)
    rows = []
    for _ in range(n_demos):
        x = np.stack([np.sin(t) + rng.normal(0, 0.05, m), 0.3 * t**2 + rng.normal(0, 0.05, m)], 1)
        rows.append(np.column_stack([t, x]))
    return np.concatenate(rows)


@pytest.mark.parametrize("init", ["time", "kmeans++"])
def test_objective_never_decreases(rng: np.random.Generator, init: str) -> None:
    X = _trajectory_data(rng)
    res = fit_gmm(X, GmmConfig(n_components=5, tol=0.0, max_iter=60, init=init), rng)
    assert res.n_iter == 60 and not res.converged
    assert (np.diff(res.objective_history) >= -1e-9 * np.abs(res.objective_history[1:])).all()
    # without a floor the objective is the plain log-likelihood and EM is monotone in it
    res0 = fit_gmm(
        X,
        GmmConfig(n_components=5, tol=0.0, max_iter=60, reg_covar=0, reg_covar_abs=0, init=init),
        rng,
    )
    np.testing.assert_array_equal(res0.objective_history, res0.log_likelihood_history)
    h = res0.log_likelihood_history
    assert (np.diff(h) >= -1e-9 * np.abs(h[1:])).all()
    np.testing.assert_allclose(gmm_log_likelihood(X, res0.gmm), h[-1], rtol=1e-12)


def test_one_component_is_sample_mean_and_covariance(rng: np.random.Generator) -> None:
    X = rng.normal(size=(300, 4)) @ rng.normal(size=(4, 4))
    res = fit_gmm(X, GmmConfig(n_components=1, reg_covar=1e-6), rng)
    np.testing.assert_allclose(res.gmm.weights, [1.0], rtol=1e-12)
    np.testing.assert_allclose(res.gmm.means[0], X.mean(axis=0), rtol=1e-10, atol=1e-12)
    # the floor prior adds exactly reg_covar * var_d to the diagonal when K = 1
    expected = np.cov(X.T, bias=True) + np.diag(1e-6 * X.var(axis=0))
    np.testing.assert_allclose(res.gmm.covariances[0], expected, rtol=1e-10, atol=1e-12)
    assert res.converged and res.n_iter <= 2


def test_matches_sklearn_oracle(rng: np.random.Generator) -> None:
    import warnings

    mixture = pytest.importorskip("sklearn.mixture", reason="scikit-learn (the oracle) missing")
    exceptions = pytest.importorskip("sklearn.exceptions")
    X = _trajectory_data(rng, n_demos=4, m=100)
    K, n_iter = 4, 25
    # plain EM (no floor) for exactly n_iter iterations from the same starting point
    cfg = GmmConfig(n_components=K, reg_covar=0.0, reg_covar_abs=0.0, tol=0.0, max_iter=n_iter)
    ours = fit_gmm(X, cfg, rng)
    init = _m_step(X, _init_resp(X, K, "time", rng), np.zeros(X.shape[1]))
    with warnings.catch_warnings():  # tol=0 never converges, by design
        warnings.simplefilter("ignore", exceptions.ConvergenceWarning)
        sk = mixture.GaussianMixture(
            K,
            covariance_type="full",
            reg_covar=0.0,
            tol=0.0,
            max_iter=n_iter,
            weights_init=init.weights,
            means_init=init.means,
            precisions_init=np.linalg.inv(init.covariances),
        ).fit(X)
    assert ours.n_iter == n_iter and sk.n_iter_ == n_iter
    # identical arithmetic up to summation order and sklearn's 10*eps on N_k
    np.testing.assert_allclose(ours.gmm.weights, sk.weights_, rtol=1e-9)
    np.testing.assert_allclose(ours.gmm.means, sk.means_, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(ours.gmm.covariances, sk.covariances_, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(ours.log_likelihood, sk.score(X) * len(X), rtol=1e-10)


def test_floor_keeps_degenerate_data_fit(rng: np.random.Generator) -> None:
    t = np.linspace(0, 1, 50)
    X = np.column_stack([t, np.zeros(50), np.ones(50)])  # two constant channels
    res = fit_gmm(X, GmmConfig(n_components=3), rng)
    assert np.isfinite(res.log_likelihood)
    for S in res.gmm.covariances:
        assert np.linalg.eigvalsh(S).min() > 0
    # more components than distinct points: still finite and positive definite
    Y = np.repeat(rng.normal(size=(3, 2)), 10, axis=0)
    Y = np.column_stack([np.arange(30.0), Y])
    res2 = fit_gmm(Y, GmmConfig(n_components=8, init="kmeans++"), rng)
    assert np.isfinite(res2.log_likelihood)
    np.testing.assert_allclose(res2.gmm.weights.sum(), 1.0, rtol=1e-12)


def test_deterministic_and_callback(rng: np.random.Generator) -> None:
    X = _trajectory_data(rng)
    calls: list[tuple[int, float]] = []
    a = fit_gmm(
        X,
        GmmConfig(init="kmeans++"),
        np.random.default_rng(3),
        callback=lambda i, v: calls.append((i, v)),
    )
    b = fit_gmm(X, GmmConfig(init="kmeans++"), np.random.default_rng(3))
    np.testing.assert_array_equal(a.gmm.means, b.gmm.means)
    np.testing.assert_array_equal(a.log_likelihood_history, b.log_likelihood_history)
    assert [c[0] for c in calls] == list(range(a.n_iter + 1))
    np.testing.assert_allclose([c[1] for c in calls], a.log_likelihood_history, rtol=0)


def test_bad_input(rng: np.random.Generator) -> None:
    with pytest.raises(InvalidInput, match="K=6.*5 data point"):
        fit_gmm(rng.normal(size=(5, 3)), GmmConfig(n_components=6), rng)
    X = rng.normal(size=(20, 3))
    X[4, 1] = np.inf
    with pytest.raises(InvalidInput, match="finite"):
        fit_gmm(X, GmmConfig(n_components=2), rng)
    with pytest.raises(InvalidInput, match="n_components"):
        GmmConfig(n_components=0)
    with pytest.raises(InvalidInput, match="init"):
        GmmConfig(init="random")
    with pytest.raises(InvalidInput, match="dimensions"):
        fit_gmm(np.zeros(10), GmmConfig(n_components=1), rng)


def test_constant_columns_do_not_change_the_fit(rng: np.random.Generator) -> None:
    """Constant channels (planar z, fixed quaternion) are left out of EM and put back exactly.

    Fitted with the rest, their prior-only variance Psi/N_k would add ½ log N_k per column
    to each component's log-density and bias EM towards large components.
    """
    X = _trajectory_data(rng)
    const = np.column_stack([np.zeros(len(X)), np.full(len(X), 0.04), np.ones(len(X))])
    Xc = np.column_stack([X[:, :2], const[:, :2], X[:, 2:], const[:, 2:]])
    cfg = GmmConfig(n_components=5)
    ref = fit_gmm(X, cfg, rng)
    res = fit_gmm(Xc, cfg, rng)
    keep = [0, 1, 4]
    np.testing.assert_allclose(res.gmm.weights, ref.gmm.weights, rtol=1e-12)
    np.testing.assert_allclose(res.gmm.means[:, keep], ref.gmm.means, rtol=1e-12)
    np.testing.assert_allclose(res.gmm.means[:, [2, 3, 5]], [[0.0, 0.04, 1.0]] * 5)
    C = res.gmm.covariances
    np.testing.assert_allclose(C[np.ix_(range(5), keep, keep)], ref.gmm.covariances, rtol=1e-12)
    np.testing.assert_array_equal(C[:, 2, keep], 0.0)
    np.testing.assert_allclose(C[:, 2, 2], cfg.reg_covar_abs)
    assert np.isfinite(gmm_log_likelihood(Xc, res.gmm))
    # without the split the constant columns change the fit (the bias this removes)
    from dexlfd.learn.gmm import constant_columns

    np.testing.assert_array_equal(constant_columns(Xc), [False, False, True, True, False, True])
