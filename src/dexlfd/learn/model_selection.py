"""Choosing K, the number of Gaussians, by held-out-demonstration regression error.

The thesis fixes K = 6. A handwriting shape or a pick-and-place with several
segments needs more; a single straight stroke fewer. Information criteria
computed on the dense trajectory samples mislead: consecutive samples of one
demonstration are not independent, so BIC's ``½ p log n`` penalty is far too
weak for n = (samples × demonstrations) and the criterion keeps adding
components. The held-out *likelihood* of a demonstration does not work either
(measured): the demonstrations differ more from each other than the samples
of one from its smooth curve, so with more components the mixture becomes
confident about the training demonstrations and a new one falls in its
tails; it picked K = 6 (the floor) on the synthetic pick-and-place, where
K = 6 leaves the demonstrations by 4 cm. What the GMR mean has to do is pass
where a *new* demonstration passes, so we score that directly
(cross-validation over demonstrations):

* the aligned demonstrations (all on the reference's time steps) are
  subsampled to at most ``max_steps`` time steps (EM cost; neighbouring samples
  carry almost the same information);
* the demonstrations are split into at most ``max_folds`` groups (every
  ``max_folds``-th one; one demonstration per group when there are few); for
  every candidate K and every group, a GMM is fitted to the other
  demonstrations and its GMR mean (at the reference's time steps) is compared
  with each held-out demonstration as recorded (``series``): DTW cost per
  sample, channels divided by ``scale`` (the DTW scales, so metres and
  quaternions weigh alike). This is the fidelity figure of
  ``benchmarks/bench_lasa.py``, out of sample. Without ``series`` the held-out
  aligned samples are compared time step by time step (mean squared distance);
* the score of K is the mean over the held-out demonstrations; the K with the
  smallest error is chosen (ties: the smaller). The error is the
  between-demonstration spread plus the GMR mean's bias, which vanishes once
  the curve is resolved; where demonstrations disagree a lot (LASA
  Multi_Models_1) more components follow the training demonstrations'
  quirks and the error grows again.

Candidates are ``K_CANDIDATES`` (6 to 20): the thesis's K = 6 is the floor, the
value fewer components would have to beat.
EM for the selection stops at a 10x looser tolerance than the final fit
(at most 100 iterations).

With one demonstration nothing is held out: the thesis's K = 6 is used. The
learning pipeline then keeps the thesis's K = 6 if its GMR mean, fitted to all
demonstrations, is closer to them (:func:`fidelity`) than the chosen K's: on
LASA Multi_Models_1, whose demonstrations disagree by ~1 cm, every K > 6 is
farther from them in sample although K = 20 scores best held out.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.learn.config import THESIS_K
from dexlfd.learn.dtw import dtw
from dexlfd.learn.gmm import GmmConfig, fit_gmm
from dexlfd.learn.gmr import gmr

__all__ = ["K_CANDIDATES", "KSelection", "fidelity", "select_n_components"]

K_CANDIDATES = (6, 8, 10, 12, 15, 20)
_FIDELITY_SAMPLES = 2000  # samples of a series compared by fidelity (a 2000 x 2000 DTW grid)


@dataclass(frozen=True, slots=True)
class KSelection:
    """Outcome of :func:`select_n_components`.

    Attributes
    ----------
    k : int
        The chosen number of components.
    candidates : ndarray (c,)
        The K tried (empty when nothing could be held out).
    scores : ndarray (c,)
        Held-out distance of the GMR mean per sample (DTW cost per sample, or
        mean squared distance without ``series``), in scaled units [-].
    method : str
        ``"held-out demonstration error"`` or why the default was used.
    """

    k: int
    candidates: FloatArray
    scores: FloatArray
    method: str


def fidelity(mean: FloatArray, series: Sequence[FloatArray], scale: FloatArray) -> float:
    """Mean over ``series`` of the DTW cost per sample from ``mean`` (channels / ``scale``).

    Series longer than ``_FIDELITY_SAMPLES`` are compared at every k-th sample (the
    smallest k that keeps them within it): a score needs the shape, not every frame,
    and the DTW grid stays small whatever the demonstrations' length.
    """
    m = _thinned(mean)
    return float(np.mean([dtw(m, x := _thinned(s), scale=scale).cost / len(x) for s in series]))


def _thinned(x: FloatArray) -> FloatArray:
    """Every k-th row of ``x``, the smallest k that leaves at most ``_FIDELITY_SAMPLES``."""
    step = -(-len(x) // _FIDELITY_SAMPLES)
    return np.asarray(x)[::step]


def select_n_components(
    t: FloatArray,
    aligned: FloatArray,
    gmm_config: GmmConfig,
    rng: np.random.Generator,
    *,
    scale: FloatArray | None = None,
    series: Sequence[FloatArray] | None = None,
    candidates: tuple[int, ...] = K_CANDIDATES,
    max_steps: int = 50,
    max_folds: int = 4,
) -> KSelection:
    """Choose K by the held-out demonstrations' distance from the GMR mean.

    Parameters
    ----------
    t : ndarray (m,)
        Common time steps of the aligned demonstrations [s].
    aligned : ndarray (N, m, d)
        The demonstrations aligned to the reference (DTW).
    gmm_config : GmmConfig
        EM settings (its ``n_components`` is ignored).
    rng : numpy.random.Generator
        For a k-means++ initialisation (the default time-sliced one uses none).
    scale : ndarray (d,), optional
        Channel divisors for the distance (default 1).
    series : sequence of ndarray (n_i, d), optional
        The demonstrations before alignment (same order as ``aligned``).
    candidates : tuple of int
        K tried (those above half the kept time steps are dropped).
    max_steps : int
        Time steps kept for the selection (uniformly subsampled).
    max_folds : int
        Most held-out groups (EM fits per candidate).

    Returns
    -------
    KSelection
    """
    aligned = np.asarray(aligned, np.float64)
    if aligned.ndim != 3 or aligned.shape[1] != np.asarray(t).shape[0]:
        raise InvalidInput(f"aligned must have shape (N, {np.asarray(t).shape[0]}, d)")
    N, m, _ = aligned.shape
    if N < 2:
        return KSelection(THESIS_K, np.zeros(0), np.zeros(0), "one demonstration: thesis K")
    idx = np.unique(np.linspace(0, m - 1, min(m, max_steps)).round().astype(int))
    ts = np.asarray(t, np.float64)[idx]
    pts = np.concatenate(
        [np.broadcast_to(ts[None, :, None], (N, idx.size, 1)), aligned[:, idx]], axis=2
    )  # (N, s, d + 1)
    ks = np.array([k for k in candidates if 1 <= k <= idx.size // 2] or [max(1, idx.size // 2)])
    scores = np.empty(ks.size)
    n_folds = min(N, max(2, max_folds))
    d = aligned.shape[2]
    sc = np.broadcast_to(np.ones(d) if scale is None else np.asarray(scale, np.float64), (d,))
    w = 1.0 / sc**2
    if series is not None and len(series) != N:
        raise InvalidInput(f"got {len(series)} series for {N} aligned demonstrations")
    for j, K in enumerate(ks):
        cfg = GmmConfig(
            n_components=int(K), max_iter=min(gmm_config.max_iter, 100), tol=10 * gmm_config.tol,
            reg_covar=gmm_config.reg_covar, reg_covar_abs=gmm_config.reg_covar_abs,
            init=gmm_config.init,
        )  # fmt: skip
        fold = []
        for g in range(n_folds):
            held = np.arange(g, N, n_folds)
            train = np.delete(pts, held, axis=0).reshape(-1, pts.shape[2])
            gmm = fit_gmm(train, cfg, rng).gmm
            if series is None:
                mean = gmr(gmm, ts).mean
                err = ((aligned[held][:, idx] - mean) ** 2 * w).sum(axis=2).mean(axis=1)
            else:
                mean = gmr(gmm, np.asarray(t, np.float64)).mean
                err = np.array([fidelity(mean, [series[i]], sc) for i in held])
            fold.extend(err.tolist())
        scores[j] = float(np.mean(fold))
    k = int(ks[int(np.argmin(scores))])
    return KSelection(k, ks.astype(np.float64), scores, "held-out demonstration error")
