"""Speed and memory of the learning stage on the synthetic set (6 demos x 150-300 x 8 channels).

Prints the median (and mean ± std) of repeated runs after warm-up, the numba
compile time in a fresh process (cold cache) and the cached load time, and the
DTW peak memory at n = m = 4000 measured with tracemalloc.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import timeit
import tracemalloc
from collections.abc import Callable

import numpy as np

from dexlfd.datasets import pick_place_demonstrations
from dexlfd.learn import (
    POSE_GROUPS,
    GmmConfig,
    LearnConfig,
    align_to_reference,
    channel_scales,
    dtw,
    fit_gmm,
    gmr,
    learn_from_demonstrations,
)

TARGETS_MS = {
    "DTW path, 250 x 250 x 8": 0.4,
    "align 6 demos, medoid reference": 3.0,
    "align 6 demos, given reference": 3.0,
    "GMM K=6 fit (EM)": 20.0,
    "GMR mean + cov, 200 queries": 1.0,
    "whole learn step": 25.0,
}


def _time(fn: Callable[[], object], number: int, repeat: int = 15) -> tuple[float, float, float]:
    fn()
    runs = np.array(timeit.repeat(fn, number=number, repeat=repeat)) / number * 1e3
    return float(np.median(runs)), float(runs.mean()), float(runs.std())


def _report(name: str, stats: tuple[float, float, float]) -> None:
    med, mean, std = stats
    target = TARGETS_MS.get(name)
    verdict = (
        ""
        if target is None
        else f"  (target <= {target} ms: {'ok' if med <= target else 'MISSED'})"
    )
    print(f"{name:34s} median {med:8.3f} ms   mean {mean:8.3f} ± {std:.3f} ms{verdict}")


def _first_call_s(cache_dir: str) -> float:
    code = (
        "import time, numpy as np; t0 = time.perf_counter(); "
        "from dexlfd.learn import dtw; t1 = time.perf_counter(); "
        "dtw(np.zeros((5, 8)), np.ones((6, 8))); t2 = time.perf_counter(); "
        "print(t2 - t1, t1 - t0)"
    )
    env = {**os.environ, "NUMBA_CACHE_DIR": cache_dir}
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, check=True, capture_output=True, text=True
    ).stdout.split()
    return float(out[0])


def main() -> None:
    demos = pick_place_demonstrations(6, np.random.default_rng(0))
    print(f"synthetic set: {len(demos)} demos, lengths {[d.n_samples for d in demos]}, 8 channels")
    print(f"numpy {np.__version__}, OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}")

    with tempfile.TemporaryDirectory() as cache:
        cold = _first_call_s(cache)
        warm = _first_call_s(cache)
    print(f"numba DTW first call: cold cache {cold:.2f} s, cached (new process) {warm:.3f} s")

    cfg = LearnConfig()
    res = learn_from_demonstrations(demos, cfg, np.random.default_rng(0))
    series = [x for _, x in res.trajectory.series]
    scale = channel_scales(series, POSE_GROUPS)

    u = np.linspace(0, 1, 250)
    a, b = (
        np.stack([np.interp(u, np.linspace(0, 1, len(x)), x[:, c]) for c in range(8)], 1)
        for x in series[:2]
    )
    _report("DTW path, 250 x 250 x 8", _time(lambda: dtw(a, b, scale=scale), number=50))
    _report(
        "align 6 demos, medoid reference",
        _time(lambda: align_to_reference(series, groups=POSE_GROUPS), number=10),
    )
    _report(
        "align 6 demos, given reference",
        _time(lambda: align_to_reference(series, reference=4, groups=POSE_GROUPS), number=10),
    )
    t_ref = res.trajectory.t_reference
    aligned = res.trajectory.alignment.aligned
    X = np.concatenate(
        [np.broadcast_to(t_ref[None, :, None], (6, t_ref.size, 1)), aligned], axis=2
    ).reshape(-1, 9)
    gmm_res = fit_gmm(X, GmmConfig(), np.random.default_rng(0))
    print(f"GMM data {X.shape}, {gmm_res.n_iter} EM iterations, converged={gmm_res.converged}")
    _report("GMM K=6 fit (EM)", _time(lambda: fit_gmm(X, GmmConfig(), np.random.default_rng(0)), 5))
    q = np.linspace(0, t_ref[-1], 200)
    _report("GMR mean + cov, 200 queries", _time(lambda: gmr(gmm_res.gmm, q), number=50))
    _report(
        "whole learn step",
        _time(lambda: learn_from_demonstrations(demos, cfg, np.random.default_rng(0)), number=5),
    )

    # last: scikit-learn's BLAS/OpenMP threads must not disturb the figures above
    from sklearn.mixture import GaussianMixture

    _report(
        "  for reference: sklearn K=6 fit",
        _time(lambda: GaussianMixture(6, covariance_type="full", random_state=0).fit(X), 3, 5),
    )

    rng = np.random.default_rng(1)
    x, y = rng.normal(size=(4000, 8)), rng.normal(size=(4000, 8))
    tracemalloc.start()
    dtw(x, y)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    t4000 = _time(lambda: dtw(x, y), number=1, repeat=5)
    print(
        f"DTW n=m=4000 x 8: peak traced memory {peak / 1e6:.2f} MB (target <= 10 MB: "
        f"{'ok' if peak <= 10e6 else 'MISSED'}), {t4000[0]:.0f} ms; a float64 cost matrix "
        f"alone would be {4000 * 4000 * 8 / 1e6:.0f} MB"
    )


if __name__ == "__main__":
    main()
