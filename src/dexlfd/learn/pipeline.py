"""The learning pipeline: filter → align (DTW) → GMM (EM) → GMR, for any channel count.

:func:`learn_trajectories` works on plain ``(t, x)`` series with any number of
channels (e.g. the 2-D LASA handwriting shapes); :func:`learn_prepared` is its
core on already preprocessed series, which the pose layer
(:mod:`dexlfd.learn.model`) calls after its quaternion handling.

Interpretations of the thesis (§4.3–4.4):

* Time: each demonstration's clock is shifted to start at 0; the aligned data
  live on the reference's time steps, so the learned motion has the
  reference's duration (as in the thesis, which regularises all series to the
  reference's length).
* K is reduced (with a warning) when the reference has fewer than 2 samples
  per component, since the time-sliced initialisation then has nothing to fit.
* One demonstration is accepted with a warning: its Σ(t) then reflects only
  how well K Gaussians fit that one curve, not the variation between
  demonstrations; the meta entry ``variance_from_demonstrations`` is false.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.learn.alignment import AlignmentResult, align_to_reference
from dexlfd.learn.config import THESIS_K, LearnConfig
from dexlfd.learn.gmm import GmmResult, fit_gmm
from dexlfd.learn.gmr import gmr
from dexlfd.learn.model_selection import KSelection, fidelity, select_n_components
from dexlfd.learn.preprocess import (
    check_demonstration_set,
    demonstration_names,
    preprocess_set,
    warn,
)
from dexlfd.learn.quality import QualityReport, assess_quality

__all__ = ["LearnedTrajectory", "learn_prepared", "learn_trajectories"]

logger = logging.getLogger(__name__)

Series = tuple[FloatArray, FloatArray]  # (t (n,) [s] from 0, x (n, d))


@dataclass(frozen=True, slots=True)
class LearnedTrajectory:
    """Result of learning from series with any channel count.

    Attributes
    ----------
    t : ndarray, shape (q,)
        GMR query times [s], from 0.
    mean : ndarray, shape (q, d)
        GMR mean (Eq. 4.19).
    cov : ndarray, shape (q, d, d)
        GMR covariance Σ(t) (Eq. 4.19).
    t_reference : ndarray, shape (m,)
        Times of the aligned samples (the reference's, from 0) [s].
    series : tuple of (t, x)
        The preprocessed (gap-filled, filtered) inputs, times from 0.
    alignment : AlignmentResult
        DTW alignment of every series to the reference.
    quality : QualityReport
        Distances to the reference and outlier flags.
    used : ndarray of bool, shape (N,)
        Series that entered the GMM.
    gmm_result : GmmResult
        The EM fit over (t, channels) of the used aligned series.
    warnings : tuple of str
        The problems recovered from (also logged as WARNING).
    k_selection : KSelection or None
        How K was chosen (``n_components="auto"``); None when K was given.
    window : int or None
        Mean-filter window applied [samples] (1: none); None when the caller filtered.
    """

    t: FloatArray
    mean: FloatArray
    cov: FloatArray
    t_reference: FloatArray
    series: tuple[Series, ...]
    alignment: AlignmentResult
    quality: QualityReport
    used: BoolArray
    gmm_result: GmmResult
    warnings: tuple[str, ...]
    k_selection: KSelection | None = None
    window: int | None = None


def learn_trajectories(
    times: Sequence[FloatArray],
    series: Sequence[FloatArray],
    cfg: LearnConfig,
    rng: np.random.Generator,
    *,
    valid: Sequence[BoolArray | None] | None = None,
    names: Sequence[str] | None = None,
    groups: Sequence[Sequence[int]] | None = None,
    callback: Callable[[int, float], None] | None = None,
) -> LearnedTrajectory:
    """Learn a mean trajectory and its covariance from several series (any channel count).

    Parameters
    ----------
    times : sequence of ndarray (n_i,)
        Time of each series [s], strictly increasing.
    series : sequence of ndarray (n_i, d)
        Samples; NaN rows are invalid frames (see :func:`~dexlfd.motion.gaps.fill_gaps`).
    cfg : LearnConfig
    rng : numpy.random.Generator
        For the GMM initialisation.
    valid : sequence of bool arrays or None, optional
        Validity masks.
    names : sequence of str, optional
        Names (e.g. files) used in messages; default ``series[i]``.
    groups : sequence of sequences of int, optional
        Channel groups that share one DTW scale (default: all channels one group).
    callback : callable(iteration, log_likelihood), optional
        EM progress.

    Returns
    -------
    LearnedTrajectory
    """
    names = demonstration_names(names, len(series))
    if len(times) != len(series):
        raise InvalidInput(f"got {len(times)} time vectors for {len(series)} series")
    if valid is not None and len(valid) != len(series):
        raise InvalidInput(f"got {len(valid)} valid masks for {len(series)} series")
    prepared, window = preprocess_set(times, series, cfg, valid, names)
    return replace(learn_prepared(prepared, cfg, rng, names, groups, callback), window=window)


def learn_prepared(
    prepared: Sequence[Series],
    cfg: LearnConfig,
    rng: np.random.Generator,
    names: Sequence[str],
    groups: Sequence[Sequence[int]] | None = None,
    callback: Callable[[int, float], None] | None = None,
) -> LearnedTrajectory:
    """The pipeline on preprocessed series (:func:`~dexlfd.learn.preprocess.preprocess_series`).

    Steps: check the set → align to the reference (DTW, Eq. 4.16) → screen for
    outliers and two modes → choose K and fit the GMM (Eq. 4.17) → GMR at the
    query times (Eqs. 4.18–4.19).
    """
    msgs: list[str] = []
    check_demonstration_set([x for _, x in prepared], names, cfg, msgs)
    alignment = _align(prepared, cfg, names, groups)
    quality, used = _screen(alignment, cfg, names, msgs)
    t_ref = prepared[alignment.reference_index][0]
    data = _FitData(
        t_ref=t_ref,
        aligned=alignment.aligned[used],
        series=[x for (_, x), u in zip(prepared, used, strict=True) if u],
        scale=alignment.scale,
    )
    gmm_result, selection = _fit(data, cfg, rng, msgs, callback)
    t_query = t_ref if cfg.n_query is None else np.linspace(0.0, t_ref[-1], cfg.n_query)
    reg = gmr(gmm_result.gmm, t_query)
    return LearnedTrajectory(
        t=np.array(t_query, dtype=np.float64),
        mean=reg.mean,
        cov=reg.cov,
        t_reference=t_ref,
        series=tuple(prepared),
        alignment=alignment,
        quality=quality,
        used=used,
        gmm_result=gmm_result,
        warnings=tuple(msgs),
        k_selection=selection,
    )


def _align(
    prepared: Sequence[Series],
    cfg: LearnConfig,
    names: Sequence[str],
    groups: Sequence[Sequence[int]] | None,
) -> AlignmentResult:
    """Every series onto the reference's time steps by DTW (Eq. 4.16)."""
    alignment = align_to_reference(
        [x for _, x in prepared],
        reference=cfg.reference,
        groups=groups,
        band_fraction=cfg.band_fraction,
        names=names,
    )
    logger.info(
        "DTW reference: %s (%s); distances %s",
        names[alignment.reference_index],
        "medoid" if cfg.reference == "medoid" else "chosen",
        np.array2string(alignment.distances, precision=3),
    )
    return alignment


def _screen(
    alignment: AlignmentResult, cfg: LearnConfig, names: Sequence[str], msgs: list[str]
) -> tuple[QualityReport, BoolArray]:
    """Outliers and two modes among the demonstrations; which ones enter the GMM."""
    quality = assess_quality(
        alignment.distances,
        alignment.reference_index,
        threshold=cfg.outlier_threshold,
        pairwise=alignment.pairwise,
    )
    if quality.modes is not None:
        groups_txt = " vs ".join(
            "[" + ", ".join(names[int(i)] for i in np.flatnonzero(quality.modes == g)) + "]"
            for g in (0, 1)
        )
        warn(
            msgs,
            f"the demonstrations follow two different ways: {groups_txt} (between/within "
            f"DTW distance {quality.mode_separation:.1f}); their mean may match neither, "
            "learn each group separately",
        )
    used = np.ones(len(names), bool)
    flagged = [names[int(i)] for i in np.flatnonzero(quality.outlier)]
    if flagged and cfg.exclude_outliers:
        used = ~quality.outlier
        warn(msgs, f"excluded outlier demonstration(s): {', '.join(flagged)}")
    elif flagged:
        warn(
            msgs,
            f"demonstration(s) far from the reference (robust z > "
            f"{cfg.outlier_threshold}): {', '.join(flagged)}; consider excluding them",
        )
    return quality, used


@dataclass(frozen=True, slots=True)
class _FitData:
    """What the GMM is fitted to: the used demonstrations, aligned and as recorded."""

    t_ref: FloatArray  # (m,) reference time steps [s]
    aligned: FloatArray  # (N_used, m, d) on the reference's time steps
    series: list[FloatArray]  # the used demonstrations before alignment, (n_i, d)
    scale: FloatArray  # (d,) DTW channel divisors

    def points(self) -> FloatArray:
        """The (t, channels) points of EM, (N_used * m, d + 1)."""
        n, m, d = self.aligned.shape
        t = np.broadcast_to(self.t_ref[None, :, None], (n, m, 1))
        return np.concatenate([t, self.aligned], axis=2).reshape(-1, d + 1)


def _choose_k(
    data: _FitData, cfg: LearnConfig, rng: np.random.Generator, msgs: list[str]
) -> tuple[int, KSelection | None]:
    """K given, or chosen by held-out error; at most half the reference's samples."""
    selection = None
    if isinstance(cfg.n_components, str):  # "auto"
        selection = select_n_components(
            data.t_ref, data.aligned, cfg.gmm_config(THESIS_K), rng,
            scale=data.scale, series=data.series,
        )  # fmt: skip
        K = selection.k
        logger.info(
            "K=%d chosen by %s (candidates %s, scores %s nats/point)",
            K, selection.method, selection.candidates.astype(int).tolist(),
            np.array2string(selection.scores, precision=3),
        )  # fmt: skip
    else:
        K = int(cfg.n_components)
    m = data.t_ref.shape[0]
    if max(1, m // 2) < K:
        K_new = max(1, m // 2)
        warn(
            msgs,
            f"n_components K={K} is more than the reference's {m} samples support "
            f"(2 per component); using K={K_new}",
        )
        K = K_new
    return K, selection


def _fit(
    data: _FitData,
    cfg: LearnConfig,
    rng: np.random.Generator,
    msgs: list[str],
    callback: Callable[[int, float], None] | None,
) -> tuple[GmmResult, KSelection | None]:
    """EM over (t, channels) of the aligned series (Eq. 4.17) with the chosen K.

    A chosen K other than the thesis's is kept only if its GMR mean is also
    closer to the demonstrations (in sample) than K = 6's.
    """
    K, selection = _choose_k(data, cfg, rng, msgs)
    X = data.points()
    gmm_result = fit_gmm(X, cfg.gmm_config(K), rng, callback=callback)
    if selection is not None and K != THESIS_K and data.t_ref.shape[0] // 2 >= THESIS_K:
        thesis = fit_gmm(X, cfg.gmm_config(THESIS_K), rng)
        d_k = fidelity(gmr(gmm_result.gmm, data.t_ref).mean, data.series, data.scale)
        d_6 = fidelity(gmr(thesis.gmm, data.t_ref).mean, data.series, data.scale)
        if d_6 < d_k:
            logger.info(
                "K=%d: GMR mean farther from the demonstrations than with K=%d "
                "(%.4g vs %.4g per sample, scaled); keeping K=%d",
                K, THESIS_K, d_k, d_6, THESIS_K,
            )  # fmt: skip
            K, gmm_result = THESIS_K, thesis
            selection = replace(selection, k=THESIS_K, method=selection.method + ", kept K=6")
    logger.info(
        "GMM K=%d: %d EM iterations, converged=%s, log-likelihood %.3f",
        K, gmm_result.n_iter, gmm_result.converged, gmm_result.log_likelihood,
    )  # fmt: skip
    if not gmm_result.converged:
        warn(msgs, f"EM did not converge in {cfg.gmm_max_iter} iterations")
    return gmm_result, selection
