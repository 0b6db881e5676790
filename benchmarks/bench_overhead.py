"""Overhead of the learning chain: dexlfd's steps against plain NumPy/numba/SciPy ones.

On the same synthetic set (six pick-and-place demonstrations, 8 channels), one
thread, each step of the chain (mean filter, DTW alignment to the medoid, GMM by
EM, GMR, DMP fit) is timed twice: through dexlfd's public functions (with their
input checks, copies and dispatch) and as a plain implementation of the same
computation with no checks (``scipy.ndimage.uniform_filter1d`` for the filter, a
plain numba DTW written here, a plain NumPy EM, GMR and locally weighted
regression). Prints per step: median time ours, plain, their ratio; then the
whole chain. The plain steps compute the same quantities (the filter: SciPy's
edge-padded running mean, the peer the filter is measured against), so the
ratio is what checks, copies and dispatch cost on top of the kernels.

    OMP_NUM_THREADS=1 python benchmarks/bench_overhead.py [--repeat 15]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import timeit  # noqa: E402
from collections.abc import Callable  # noqa: E402

import numba  # noqa: E402
import numpy as np  # noqa: E402
from scipy.linalg import solve_triangular  # noqa: E402
from scipy.ndimage import uniform_filter1d  # noqa: E402

from dexlfd.datasets import pick_place_demonstrations  # noqa: E402
from dexlfd.learn import (  # noqa: E402
    POSE_GROUPS,
    GmmConfig,
    align_to_reference,
    channel_scales,
    fit_gmm,
    gmr,
    mean_filter,
)
from dexlfd.plan import DmpConfig, fit_dmp  # noqa: E402

WINDOW = 10  # the thesis's mean-filter window [samples]
K = 6  # GMM components
N_QUERY = 200  # GMR queries


# ------------------------------------------------------------------ plain steps


@numba.njit(cache=True)
def _plain_dtw(x, y):  # pragma: no cover
    """Full-matrix DTW (Euclidean) with backtrack; returns (path (L, 2), cost)."""
    n, m, d = x.shape[0], y.shape[0], x.shape[1]
    C = np.full((n + 1, m + 1), np.inf)
    C[0, 0] = 0.0
    for i in range(1, n + 1):
        for j in range(1, m + 1):
            e = 0.0
            for c in range(d):
                diff = x[i - 1, c] - y[j - 1, c]
                e += diff * diff
            best = min(C[i - 1, j - 1], C[i - 1, j], C[i, j - 1])
            C[i, j] = np.sqrt(e) + best
    path = np.empty((n + m - 1, 2), np.intp)
    i, j, k = n, m, 0
    while True:
        path[k, 0], path[k, 1] = i - 1, j - 1
        k += 1
        if i == 1 and j == 1:
            break
        dg, up, lf = C[i - 1, j - 1], C[i - 1, j], C[i, j - 1]
        if dg <= up and dg <= lf:
            i, j = i - 1, j - 1
        elif up <= lf:
            i -= 1
        else:
            j -= 1
    return path[:k][::-1], C[n, m]


def plain_filter(series: list[np.ndarray]) -> list[np.ndarray]:
    """SciPy's running mean of every series (edge-padded)."""
    return [uniform_filter1d(x, WINDOW, axis=0, mode="nearest") for x in series]


def plain_align(series: list[np.ndarray], scale: np.ndarray) -> np.ndarray:
    """All pairs by plain DTW, the medoid as reference, every series warped onto it."""
    scaled = [x / scale for x in series]
    N = len(series)
    D = np.zeros((N, N))
    paths = {}
    for a in range(N):
        for b in range(a + 1, N):
            p, c = _plain_dtw(scaled[a], scaled[b])
            paths[a, b] = p
            D[a, b] = D[b, a] = c / p.shape[0]
    ref = int(np.argmin(D.sum(axis=1)))
    m = series[ref].shape[0]
    out = np.empty((N, m, series[0].shape[1]))
    for i in range(N):
        if i == ref:
            out[i] = series[i]
            continue
        p = paths[min(i, ref), max(i, ref)]
        if i > ref:
            p = p[:, ::-1]
        starts = np.flatnonzero(np.r_[True, p[1:, 1] != p[:-1, 1]])
        out[i] = (
            np.add.reduceat(series[i][p[:, 0]], starts, axis=0)
            / np.diff(np.r_[starts, p.shape[0]])[:, None]
        )
    return out


def plain_em(X: np.ndarray, K: int, n_iter: int) -> tuple:
    """Full-covariance EM, equal-time-slice initialisation, the same covariance floor.

    Runs ``n_iter`` EM iterations after the initial M-step (as many as dexlfd's fit
    took to converge), so both do the same work.
    """
    n, D = X.shape
    psi = np.maximum(1e-6 * X.var(axis=0), 1e-12) * (n / K)
    label = np.minimum((X[:, 0] - X[0, 0]) * K // (np.ptp(X[:, 0]) + 1e-300), K - 1).astype(int)
    resp = np.zeros((n, K))
    resp[np.arange(n), label] = 1.0
    eye = np.eye(D)
    for _ in range(n_iter + 1):
        Nk = resp.sum(axis=0) + 1e-15  # M-step
        mu = resp.T @ X / Nk[:, None]
        Sigma = np.empty((K, D, D))
        for k in range(K):
            diff = X - mu[k]
            Sigma[k] = ((resp[:, k, None] * diff).T @ diff + np.diag(psi)) / Nk[k]
        w = Nk / n
        log_p = np.empty((n, K))  # E-step, with precision Cholesky factors (scikit-learn's way)
        for k in range(K):
            P = solve_triangular(np.linalg.cholesky(Sigma[k]), eye, lower=True).T
            y = X @ P - mu[k] @ P
            log_p[:, k] = (
                np.log(w[k])
                + np.log(np.diag(P)).sum()
                - 0.5 * (D * np.log(2 * np.pi) + (y * y).sum(axis=1))
            )
        top = log_p.max(axis=1, keepdims=True)
        log_norm = top[:, 0] + np.log(np.exp(log_p - top).sum(axis=1))
        resp = np.exp(log_p - log_norm[:, None])
    return w, mu, Sigma


def plain_gmr(w: np.ndarray, mu: np.ndarray, Sigma: np.ndarray, q: np.ndarray) -> tuple:
    """Condition on column 0: mean (q, Do) and covariance (q, Do, Do)."""
    K = w.size
    var_t = Sigma[:, 0, 0]
    A = Sigma[:, 1:, 0] / var_t[:, None]  # (K, Do)
    Sb = Sigma[:, 1:, 1:] - A[:, :, None] * Sigma[:, None, 0, 1:]
    dt = q[:, None] - mu[None, :, 0]  # (q, K)
    log_h = np.log(w) - 0.5 * (np.log(2 * np.pi * var_t) + dt**2 / var_t)
    h = np.exp(log_h - log_h.max(axis=1, keepdims=True))
    h /= h.sum(axis=1, keepdims=True)
    mk = mu[None, :, 1:] + dt[:, :, None] * A[None]  # (q, K, Do)
    mean = np.einsum("qk,qkd->qd", h, mk)
    dev = mk - mean[:, None]
    cov = np.einsum("qk,kde->qde", h, Sb) + np.einsum("qk,qkd,qke->qde", h, dev, dev)
    del K
    return mean, cov


def plain_dmp(t: np.ndarray, x: np.ndarray, n_basis: int = 100, alpha: float = 25.0) -> tuple:
    """Modified DMP (Eq. 5.5) weights by locally weighted regression, NumPy only."""
    tb = (t - t[0]) / (t[-1] - t[0])
    xd = np.gradient(x, tb, axis=0, edge_order=2)
    xdd = np.gradient(xd, tb, axis=0, edge_order=2)
    Kb, Db, alpha_s = alpha**2 / 4.0, alpha, 8.0
    g, x0 = x[-1], x[0]
    s = np.exp(-alpha_s * tb)
    f = (xdd + Db * xd) / Kb - (g - x) + (g - x0) * s[:, None]
    c = np.exp(-alpha_s * np.linspace(0, 1, n_basis))
    gaps = np.abs(np.diff(c))
    h = 4 * np.log(2) / np.append(gaps, gaps[-1]) ** 2
    psi = np.exp(-h * (s[:, None] - c) ** 2)  # (n, N)
    dtb = np.gradient(tb)
    sw = (psi * (s * s * dtb)[:, None]).sum(axis=0)
    return ((psi * (s * dtb)[:, None]).T @ f) / sw[:, None]


# ------------------------------------------------------------------ timing


def _median_ms(fn: Callable[[], object], repeat: int) -> float:
    fn()  # warm-up (numba compile, caches)
    number = 3
    runs = np.array(timeit.repeat(fn, number=number, repeat=repeat)) / number * 1e3
    return float(np.median(runs))


def main() -> None:
    """Time every step ours vs plain and print the ratios."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=15, help="timed repeats per step")
    args = ap.parse_args()
    demos = pick_place_demonstrations(6, np.random.default_rng(0))
    raw = [
        np.concatenate([d.position, d.quaternion, d.gripper[:, None]], axis=1).astype(np.float64)
        for d in demos
    ]
    times = [d.t - d.t[0] for d in demos]
    print(f"synthetic set: 6 demos, lengths {[x.shape[0] for x in raw]}, 8 channels, 1 thread")

    filtered = [mean_filter(x, WINDOW) for x in raw]
    scale = channel_scales(filtered, POSE_GROUPS)
    al = align_to_reference(filtered, groups=POSE_GROUPS)
    t_ref = times[al.reference_index]
    n_demo, m, d = al.aligned.shape
    X = np.concatenate(
        [np.broadcast_to(t_ref[None, :, None], (n_demo, m, 1)), al.aligned], axis=2
    ).reshape(-1, d + 1)
    fit = fit_gmm(X, GmmConfig(n_components=K), np.random.default_rng(0))
    gmm, n_iter = fit.gmm, fit.n_iter
    q = np.linspace(0.0, t_ref[-1], N_QUERY)
    mean = gmr(gmm, q).mean
    p_w, p_mu, p_S = plain_em(X, K, n_iter)
    p_mean = plain_gmr(p_w, p_mu, p_S, q)[0]

    rng = np.random.default_rng(0)
    steps: list[tuple[str, Callable[[], object], Callable[[], object]]] = [
        ("mean filter (6 series)", lambda: [mean_filter(x, WINDOW) for x in raw],
         lambda: plain_filter(raw)),
        ("DTW align 6 demos (medoid)", lambda: align_to_reference(filtered, groups=POSE_GROUPS),
         lambda: plain_align(filtered, scale)),
        (f"GMM EM (K={K}, {X.shape[0]}x{X.shape[1]}, {n_iter} it.)",
         lambda: fit_gmm(X, GmmConfig(n_components=K), rng), lambda: plain_em(X, K, n_iter)),
        (f"GMR ({N_QUERY} queries)", lambda: gmr(gmm, q),
         lambda: plain_gmr(p_w, p_mu, p_S, q)),
        ("DMP fit (3 channels)", lambda: fit_dmp(q, mean[:, :3], DmpConfig()),
         lambda: plain_dmp(q, p_mean[:, :3])),
    ]  # fmt: skip
    print(f"{'step':34s} {'ours [ms]':>10s} {'plain [ms]':>11s} {'ratio':>7s}")
    total_ours = total_plain = 0.0
    for name, ours, plain in steps:
        a, b = _median_ms(ours, args.repeat), _median_ms(plain, args.repeat)
        total_ours += a
        total_plain += b
        print(f"{name:34s} {a:10.3f} {b:11.3f} {a / b:7.2f}")
    print(f"{'chain (sum of steps)':34s} {total_ours:10.3f} {total_plain:11.3f} "
          f"{total_ours / total_plain:7.2f}")  # fmt: skip


if __name__ == "__main__":
    main()
