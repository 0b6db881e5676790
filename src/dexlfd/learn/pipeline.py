"""The learning stage: filter → align (DTW) → GMM (EM) → GMR, for any channel count.

Two layers:

* :func:`learn_trajectories` works on plain ``(t, x)`` series with any number
  of channels (e.g. the 2-D LASA handwriting shapes).
* :func:`learn_from_demonstrations` takes end-effector demonstrations (8
  channels: position, unit quaternion, gripper), handles the quaternion
  specifics (sign continuity within and across demonstrations, renormalising
  after filtering and after GMR, with the covariance projected accordingly) and
  builds a :class:`dexlfd.io.LearnedModel`.

Interpretations of the thesis (§4.3–4.4):

* Time: each demonstration's clock is shifted to start at 0; the aligned data
  live on the reference's time steps, so the learned motion has the
  reference's duration (as in the thesis, which regularises all series to the
  reference's length).
* K is reduced (with a warning) when the reference has fewer than 2 samples
  per component, since the time-sliced initialisation then has nothing to fit.
* One demonstration is accepted with a warning: its Σ(t) then reflects only
  how well K Gaussians fit that one curve, not the variation between
  demonstrations; ``meta["variance_from_demonstrations"]`` is false.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd._validation import as_float_array, check_time
from dexlfd.errors import InvalidDemonstration, InvalidInput
from dexlfd.io import Demonstration, LearnedModel
from dexlfd.learn.alignment import AlignmentResult, align_to_reference
from dexlfd.learn.filtering import FILTER_MODES, mean_filter
from dexlfd.learn.gaps import fill_gaps
from dexlfd.learn.gmm import GMM_INITS, GmmConfig, GmmResult, fit_gmm
from dexlfd.learn.gmr import gmr
from dexlfd.learn.model_selection import THESIS_K, KSelection, fidelity, select_n_components
from dexlfd.learn.quality import QualityReport, assess_quality
from dexlfd.rotations import quat_sign_continuous

__all__ = [
    "POSE_CHANNELS",
    "POSE_GROUPS",
    "LearnConfig",
    "LearnResult",
    "LearnedTrajectory",
    "learn_from_demonstrations",
    "learn_poses",
    "learn_trajectories",
    "preprocess_series",
]

logger = logging.getLogger(__name__)

POSE_CHANNELS = ("x", "y", "z", "qx", "qy", "qz", "qw", "gripper")
POSE_GROUPS = ((0, 1, 2), (3, 4, 5, 6), (7,))  # position [m], quaternion [-], gripper [m]
_Q = slice(3, 7)
LENGTH_RATIO_WARN = 3.0  # demonstrations differing more than this in length get a warning
_QUAT_NORM_TOL = 1e-3  # larger deviations from unit norm are reported when renormalising
_QUAT_NORM_MIN = 0.5  # below this a "quaternion" is not a rotation that was meant


@dataclass(frozen=True, slots=True)
class LearnConfig:
    """Settings of the learning stage (thesis: window 10, K = 6; ours: K chosen from the data).

    Attributes
    ----------
    n_components : int or "auto"
        K, Gaussians in the GMM; ``"auto"`` (default) chooses K among 6–20 by
        the held-out demonstrations' distance from the GMR mean
        (:func:`~dexlfd.learn.model_selection.select_n_components`).
    window : int
        Mean-filter window k in samples (Eq. 4.15); 1 disables filtering.
    filter_mode : {"linear", "shrink", "nearest"}
        End handling of the mean filter.
    reference : int or "medoid"
        Reference demonstration for DTW (the thesis picked index 4, "series 5").
    exclude_outliers : bool
        Leave demonstrations flagged as outliers out of the GMM.
    outlier_threshold : float
        Robust z-score above which a demonstration is an outlier.
    band_fraction : float or None
        Sakoe–Chiba band radius as a fraction of the longer series; None: no band.
    max_gap_s : float
        Longest run of invalid frames that is interpolated [s].
    n_query : int or None
        Number of uniformly spaced GMR query times; None: the reference's times.
    gmm_max_iter, gmm_tol, reg_covar, gmm_init
        EM settings, see :class:`~dexlfd.learn.gmm.GmmConfig`.
    """

    n_components: int | str = "auto"
    window: int = 10
    filter_mode: str = "linear"
    reference: int | str = "medoid"
    exclude_outliers: bool = False
    outlier_threshold: float = 3.5
    band_fraction: float | None = None
    max_gap_s: float = 0.5
    n_query: int | None = None
    gmm_max_iter: int = 200
    gmm_tol: float = 1e-4
    reg_covar: float = 1e-6
    gmm_init: str = "time"

    def __post_init__(self) -> None:
        if isinstance(self.n_components, str):
            if self.n_components != "auto":
                raise InvalidInput(
                    f"n_components (K) must be 'auto' or an integer, got {self.n_components!r}"
                )
        elif isinstance(self.n_components, bool) or int(self.n_components) != self.n_components:
            raise InvalidInput(f"n_components (K) must be an integer, got {self.n_components!r}")
        elif self.n_components < 1:
            raise InvalidInput(f"n_components (K) must be >= 1, got {self.n_components}")
        if isinstance(self.window, bool) or int(self.window) != self.window or self.window < 1:
            raise InvalidInput(f"window must be an integer >= 1, got {self.window!r}")
        if self.filter_mode not in FILTER_MODES:
            raise InvalidInput(
                f"filter_mode must be one of {FILTER_MODES}, got {self.filter_mode!r}"
            )
        if isinstance(self.reference, str):
            if self.reference != "medoid":
                raise InvalidInput(
                    f"reference must be 'medoid' or an index, got {self.reference!r}"
                )
        elif isinstance(self.reference, bool) or int(self.reference) != self.reference:
            raise InvalidInput(f"reference must be 'medoid' or an index, got {self.reference!r}")
        elif self.reference < 0:
            raise InvalidInput(f"reference index must be >= 0, got {self.reference}")
        if not self.outlier_threshold > 0:
            raise InvalidInput(f"outlier_threshold must be > 0, got {self.outlier_threshold}")
        if self.band_fraction is not None and not 0 < self.band_fraction <= 1:
            raise InvalidInput(f"band_fraction must be in (0, 1] or None, got {self.band_fraction}")
        if not self.max_gap_s >= 0:
            raise InvalidInput(f"max_gap_s must be >= 0, got {self.max_gap_s}")
        if self.n_query is not None and self.n_query < 2:
            raise InvalidInput(f"n_query must be >= 2 or None, got {self.n_query}")
        if self.gmm_init not in GMM_INITS:
            raise InvalidInput(f"gmm_init must be one of {GMM_INITS}, got {self.gmm_init!r}")
        # the remaining EM settings are checked by GmmConfig
        self.gmm_config(THESIS_K if isinstance(self.n_components, str) else self.n_components)

    def gmm_config(self, n_components: int) -> GmmConfig:
        """The EM settings with ``n_components`` Gaussians."""
        return GmmConfig(
            n_components=n_components,
            max_iter=self.gmm_max_iter,
            tol=self.gmm_tol,
            reg_covar=self.reg_covar,
            init=self.gmm_init,
        )


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
    """

    t: FloatArray
    mean: FloatArray
    cov: FloatArray
    t_reference: FloatArray
    series: tuple[tuple[FloatArray, FloatArray], ...]
    alignment: AlignmentResult
    quality: QualityReport
    used: BoolArray
    gmm_result: GmmResult
    warnings: tuple[str, ...]
    k_selection: KSelection | None = None


@dataclass(frozen=True, slots=True)
class LearnResult:
    """Result of :func:`learn_from_demonstrations`: the model file plus details."""

    model: LearnedModel
    trajectory: LearnedTrajectory


def _warn(msgs: list[str], msg: str) -> None:
    logger.warning("%s", msg)
    msgs.append(msg)


def preprocess_series(
    t: FloatArray,
    x: FloatArray,
    cfg: LearnConfig,
    *,
    valid: BoolArray | None = None,
    name: str = "series",
) -> tuple[FloatArray, FloatArray]:
    """Check one series, repair invalid frames, shift time to 0 and mean-filter it.

    Returns ``(t, x)`` with ``t[0] == 0`` and ``x`` finite, at least 2 samples.
    """
    t_arr = as_float_array(t, f"{name}: t", ndim=1)
    if t_arr.shape[0] < 2:
        raise InvalidDemonstration(
            f"{name}: needs at least 2 samples to learn from, got {t_arr.shape[0]}"
        )
    t_arr = check_time(t_arr, f"{name}: t")
    x_arr = as_float_array(x, f"{name}: x")
    if x_arr.ndim == 1:
        x_arr = x_arr[:, None]
    if x_arr.ndim != 2 or x_arr.shape[0] != t_arr.shape[0]:
        raise InvalidDemonstration(
            f"{name}: x must have shape ({t_arr.shape[0]}, d) to match t, got {x_arr.shape}"
        )
    if valid is not None:
        valid = np.asarray(valid, bool)
        if valid.shape != t_arr.shape:
            raise InvalidDemonstration(f"{name}: valid must have shape {t_arr.shape}")
    t_arr, x_arr = fill_gaps(t_arr, x_arr, valid, max_gap_s=cfg.max_gap_s, name=name)
    if t_arr.shape[0] < 2:
        raise InvalidDemonstration(f"{name}: fewer than 2 valid samples remain")
    if cfg.window > t_arr.shape[0] // 2:
        # a mean filter over more than half the series averages the motion away
        raise InvalidDemonstration(
            f"{name}: window {cfg.window} must be at most half the series "
            f"({t_arr.shape[0]} samples -> <= {max(1, t_arr.shape[0] // 2)})"
        )
    t0 = t_arr - t_arr[0]
    return t0, mean_filter(x_arr, cfg.window, mode=cfg.filter_mode)


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
        Samples; NaN rows are invalid frames (see :func:`~dexlfd.learn.gaps.fill_gaps`).
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
    names = _names(names, len(series))
    if len(times) != len(series):
        raise InvalidInput(f"got {len(times)} time vectors for {len(series)} series")
    if valid is not None and len(valid) != len(series):
        raise InvalidInput(f"got {len(valid)} valid masks for {len(series)} series")
    prepared = [
        preprocess_series(t, x, cfg, valid=None if valid is None else valid[i], name=names[i])
        for i, (t, x) in enumerate(zip(times, series, strict=True))
    ]
    return _learn_prepared(prepared, cfg, rng, names, groups, callback)


def _names(names: Sequence[str] | None, n: int) -> list[str]:
    if n == 0:
        raise InvalidInput("need at least one demonstration to learn from, got none")
    if names is None:
        return [f"demonstration {i}" for i in range(n)]
    if len(names) != n:
        raise InvalidInput(f"got {len(names)} names for {n} demonstrations")
    return [str(s) for s in names]


def _identical_pairs(series: Sequence[FloatArray]) -> list[tuple[int, int]]:
    """Index pairs ``(i, j)``, ``i < j``, of series with equal samples (each copy once)."""
    first: dict[bytes, int] = {}
    pairs = []
    for j, x in enumerate(series):
        key = np.ascontiguousarray(x).tobytes() + repr(x.shape).encode()
        if key in first:
            pairs.append((first[key], j))
        else:
            first[key] = j
    return pairs


def _learn_prepared(
    prepared: list[tuple[FloatArray, FloatArray]],
    cfg: LearnConfig,
    rng: np.random.Generator,
    names: list[str],
    groups: Sequence[Sequence[int]] | None,
    callback: Callable[[int, float], None] | None,
) -> LearnedTrajectory:
    msgs: list[str] = []
    N = len(prepared)
    d = prepared[0][1].shape[1]
    for name, (_, x) in zip(names, prepared, strict=True):
        if x.shape[1] != d:
            raise InvalidDemonstration(
                f"{name}: has {x.shape[1]} channels, but {names[0]} has {d}; "
                "all demonstrations must have the same channels"
            )
    lengths = np.array([x.shape[0] for _, x in prepared])
    if lengths.max() > LENGTH_RATIO_WARN * lengths.min():
        _warn(
            msgs,
            f"demonstration lengths differ {lengths.max() / lengths.min():.1f}x "
            f"({names[int(lengths.argmin())]}: {lengths.min()} samples, "
            f"{names[int(lengths.argmax())]}: {lengths.max()}); DTW stretches the short ones",
        )
    for i, j in _identical_pairs([x for _, x in prepared]):
        _warn(
            msgs,
            f"{names[j]} is identical to {names[i]}: a copy adds no variation, and the "
            "learned covariance shrinks as if the motion were more certain",
        )
    if N == 1:
        _warn(
            msgs,
            "only one demonstration: the learned covariance reflects the GMM fit of that "
            "one curve, not the variation between demonstrations",
        )
    if not isinstance(cfg.reference, str) and cfg.reference >= N:
        raise InvalidInput(
            f"reference index {cfg.reference} out of range for {N} demonstration(s) (0..{N - 1})"
        )
    logger.info(
        "learning from %d demonstration(s), %d channel(s), %d-%d samples",
        N,
        d,
        lengths.min(),
        lengths.max(),
    )
    alignment = align_to_reference(
        [x for _, x in prepared],
        reference=cfg.reference,
        groups=groups,
        band_fraction=cfg.band_fraction,
    )
    ref = alignment.reference_index
    logger.info(
        "DTW reference: %s (%s); distances %s",
        names[ref],
        "medoid" if cfg.reference == "medoid" else "chosen",
        np.array2string(alignment.distances, precision=3),
    )
    quality = assess_quality(
        alignment.distances, ref, threshold=cfg.outlier_threshold, pairwise=alignment.pairwise
    )
    if quality.modes is not None:
        groups_txt = " vs ".join(
            "[" + ", ".join(names[i] for i in np.flatnonzero(quality.modes == g)) + "]"
            for g in (0, 1)
        )
        _warn(
            msgs,
            f"the demonstrations follow two different ways: {groups_txt} (between/within "
            f"DTW distance {quality.mode_separation:.1f}); their mean may match neither, "
            "learn each group separately",
        )
    used = np.ones(N, bool)
    flagged = [names[i] for i in np.flatnonzero(quality.outlier)]
    if flagged:
        if cfg.exclude_outliers:
            used = ~quality.outlier
            _warn(msgs, f"excluded outlier demonstration(s): {', '.join(flagged)}")
        else:
            _warn(
                msgs,
                f"demonstration(s) far from the reference (robust z > "
                f"{cfg.outlier_threshold}): {', '.join(flagged)}; consider excluding them",
            )

    t_ref = prepared[ref][0]
    m = t_ref.shape[0]
    aligned = alignment.aligned[used]
    selection = None
    if isinstance(cfg.n_components, str):  # "auto"
        selection = select_n_components(
            t_ref, aligned, cfg.gmm_config(THESIS_K), rng, scale=alignment.scale,
            series=[x for (_, x), u in zip(prepared, used, strict=True) if u],
        )  # fmt: skip
        K = selection.k
        logger.info(
            "K=%d chosen by %s (candidates %s, scores %s nats/point)",
            K, selection.method, selection.candidates.astype(int).tolist(),
            np.array2string(selection.scores, precision=3),
        )  # fmt: skip
    else:
        K = int(cfg.n_components)
    if max(1, m // 2) < K:
        K_new = max(1, m // 2)
        _warn(
            msgs,
            f"n_components K={K} is more than the reference's {m} samples support "
            f"(2 per component); using K={K_new}",
        )
        K = K_new
    X = np.concatenate(
        [np.broadcast_to(t_ref[None, :, None], (aligned.shape[0], m, 1)), aligned], axis=2
    ).reshape(-1, d + 1)
    gmm_result = fit_gmm(X, cfg.gmm_config(K), rng, callback=callback)
    if selection is not None and K != THESIS_K and m // 2 >= THESIS_K:
        # keep the thesis's K unless the chosen K's mean is also closer to the demonstrations
        series = [x for (_, x), u in zip(prepared, used, strict=True) if u]
        thesis = fit_gmm(X, cfg.gmm_config(THESIS_K), rng)
        d_k = fidelity(gmr(gmm_result.gmm, t_ref).mean, series, alignment.scale)
        d_6 = fidelity(gmr(thesis.gmm, t_ref).mean, series, alignment.scale)
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
        K,
        gmm_result.n_iter,
        gmm_result.converged,
        gmm_result.log_likelihood,
    )
    if not gmm_result.converged:
        _warn(msgs, f"EM did not converge in {cfg.gmm_max_iter} iterations")
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


def _prepare_quaternions(q: FloatArray, name: str, msgs: list[str]) -> FloatArray:
    """Renormalise (with a warning) and make sign-continuous; NaN rows are kept."""
    norms = np.linalg.norm(q, axis=1)
    ok = np.isfinite(norms)
    if (norms[ok] < _QUAT_NORM_MIN).any():
        i = int(np.flatnonzero(ok & (norms < _QUAT_NORM_MIN))[0])
        raise InvalidDemonstration(
            f"{name}: quaternion at sample {i} has norm {norms[i]:.3g}; expected unit "
            "quaternions (x, y, z, w)"
        )
    dev = np.abs(norms[ok] - 1.0)
    if dev.size and dev.max() > _QUAT_NORM_TOL:
        _warn(
            msgs, f"{name}: quaternions not unit (norm off by up to {dev.max():.3g}); renormalised"
        )
    return quat_sign_continuous(q / norms[:, None])


def learn_poses(
    times: Sequence[FloatArray],
    poses: Sequence[FloatArray],
    cfg: LearnConfig,
    rng: np.random.Generator,
    *,
    valid: Sequence[BoolArray | None] | None = None,
    names: Sequence[str] | None = None,
    callback: Callable[[int, float], None] | None = None,
    meta: dict[str, object] | None = None,
) -> LearnResult:
    """Learn from end-effector pose series (n_i, 8): position, quaternion (x,y,z,w), gripper.

    Quaternions are renormalised (warning if they were off by more than 1e-3),
    made sign-continuous within each demonstration and flipped as a whole into
    the hemisphere of the first demonstration before gap filling and filtering;
    after filtering and after GMR they are renormalised again, and Σ(t) is
    mapped through the Jacobian of the normalisation (first-order propagation).

    Returns
    -------
    LearnResult
        ``model`` (with alignment information in ``extras``) and details.
    """
    names = _names(names, len(poses))
    if len(times) != len(poses):
        raise InvalidInput(f"got {len(times)} time vectors for {len(poses)} pose series")
    msgs: list[str] = []
    prepared = []
    anchor: FloatArray | None = None
    for i, (t, x) in enumerate(zip(times, poses, strict=True)):
        x_arr = as_float_array(x, f"{names[i]}: pose")
        if x_arr.ndim != 2 or x_arr.shape[1] != len(POSE_CHANNELS):
            raise InvalidDemonstration(
                f"{names[i]}: pose must have shape (n, 8) = position, quaternion, gripper; "
                f"got {x_arr.shape}"
            )
        if np.isinf(x_arr).any():
            raise InvalidDemonstration(f"{names[i]}: pose contains inf values")
        x_arr = x_arr.copy()
        x_arr[:, _Q] = _prepare_quaternions(x_arr[:, _Q], names[i], msgs)
        ok = np.isfinite(x_arr).all(axis=1)
        if ok.any():
            first_q = x_arr[int(np.argmax(ok)), _Q]
            if anchor is None:
                anchor = first_q
            elif float(first_q @ anchor) < 0:
                x_arr[:, _Q] *= -1.0  # same rotations, the first demonstration's hemisphere
        tp, xp = preprocess_series(
            t, x_arr, cfg, valid=None if valid is None else valid[i], name=names[i]
        )
        xp[:, _Q] /= np.linalg.norm(xp[:, _Q], axis=1, keepdims=True)
        prepared.append((tp, xp))
    traj = _learn_prepared(prepared, cfg, rng, names, POSE_GROUPS, callback)
    mean, cov = _renormalize_quaternion(traj.mean, traj.cov)
    traj = replace(traj, mean=mean, cov=cov, warnings=tuple(msgs) + traj.warnings)
    return LearnResult(model=_build_model(traj, cfg, names, meta or {}), trajectory=traj)


def _renormalize_quaternion(mean: FloatArray, cov: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Unit quaternion mean and Σ mapped by J = (I - q̂ q̂ᵀ)/|q| on the quaternion block."""
    q = mean[:, _Q]
    nq = np.linalg.norm(q, axis=1)
    qh = q / nq[:, None]
    T = np.broadcast_to(np.eye(mean.shape[1]), cov.shape).copy()
    T[:, _Q, _Q] = (np.eye(4)[None] - qh[:, :, None] * qh[:, None, :]) / nq[:, None, None]
    out = mean.copy()
    out[:, _Q] = qh
    cov_out = T @ cov @ np.swapaxes(T, 1, 2)
    return out, 0.5 * (cov_out + np.swapaxes(cov_out, 1, 2))


def _pointwise_cov(aligned: FloatArray) -> FloatArray:
    """Sample covariance across demonstrations at each time step, (m, d, d); 0 for one demo."""
    N = aligned.shape[0]
    dev = aligned - aligned.mean(axis=0, keepdims=True)
    return np.einsum("nti,ntj->tij", dev, dev) / max(N - 1, 1)


def _build_model(
    traj: LearnedTrajectory, cfg: LearnConfig, names: list[str], extra_meta: dict[str, object]
) -> LearnedModel:
    gmm = traj.gmm_result.gmm
    al = traj.alignment
    N = len(names)
    meta: dict[str, object] = {
        "source": "dexlfd.learn",
        "method": "mean filter (4.15) -> DTW (4.16) -> GMM/EM (4.17) -> GMR (4.18-4.19)",
        "settings": asdict(cfg),
        "channels": list(POSE_CHANNELS),
        "units": {"t": "s", "position": "m", "quaternion": "x,y,z,w", "gripper": "m"},
        "n_demonstrations": N,
        "demonstrations": names,
        "reference_index": al.reference_index,
        "reference": names[al.reference_index],
        "reference_selection": "medoid" if cfg.reference == "medoid" else "index",
        "n_components": gmm.n_components,
        "n_components_selection": (
            "given"
            if traj.k_selection is None
            else {
                "method": traj.k_selection.method,
                "candidates": traj.k_selection.candidates.astype(int).tolist(),
                "scores_nats_per_point": [round(float(v), 4) for v in traj.k_selection.scores],
            }
        ),
        "gmm_iterations": traj.gmm_result.n_iter,
        "gmm_converged": traj.gmm_result.converged,
        "gmm_log_likelihood": traj.gmm_result.log_likelihood,
        "variance_from_demonstrations": int(traj.used.sum()) > 1,
        "outliers": [names[i] for i in np.flatnonzero(traj.quality.outlier)],
        "excluded": [names[i] for i in np.flatnonzero(~traj.used)],
        "quality_note": traj.quality.note,
        "two_modes": traj.quality.modes is not None,
        "mode_separation": traj.quality.mode_separation,
        "warnings": list(traj.warnings),
        "dtw_scale_note": "per-channel divisors: RMS std of position / quaternion / gripper",
        **extra_meta,
    }
    return LearnedModel(
        t=traj.t,
        mean=traj.mean,
        cov=traj.cov,
        gmm_weights=gmm.weights,
        gmm_means=gmm.means,
        gmm_covs=gmm.covariances,
        meta=meta,
        extras={
            "reference_index": np.asarray(al.reference_index, dtype=np.int64),
            "dtw_distance": al.distances,
            "dtw_cost": al.costs,
            "dtw_scale": al.scale,
            "robust_z": traj.quality.robust_z,
            "outlier": traj.quality.outlier,
            "used": traj.used,
            "aligned_t": traj.t_reference,
            "aligned": al.aligned,
            # the demonstrations' own spread at each reference time, next to GMR's Sigma(t),
            # which also contains how badly K Gaussians fit the curve (large for small K)
            "aligned_cov": _pointwise_cov(al.aligned[traj.used]),
            "gmm_log_likelihood_history": traj.gmm_result.log_likelihood_history,
        },
    )


def learn_from_demonstrations(
    demos: Sequence[Demonstration],
    cfg: LearnConfig,
    rng: np.random.Generator,
    callback: Callable[[int, float], None] | None = None,
    *,
    names: Sequence[str] | None = None,
) -> LearnResult:
    """Learn a motion with its uncertainty from end-effector demonstrations.

    Runs mean filter (Eq. 4.15) → DTW alignment to a reference (Eq. 4.16) →
    GMM by EM (Eq. 4.17) → GMR (Eqs. 4.18–4.19) on the 8 channels position,
    quaternion and gripper opening. Invalid frames (``valid`` false) are
    trimmed at the ends and interpolated inside when short.

    Parameters
    ----------
    demos : sequence of Demonstration
        One or more demonstrations (one works, with a warning).
    cfg : LearnConfig
    rng : numpy.random.Generator
    callback : callable(iteration, log_likelihood), optional
        EM progress.
    names : sequence of str, optional
        Names (e.g. file paths) for messages and the model's meta.

    Returns
    -------
    LearnResult
        ``model`` is a :class:`~dexlfd.io.LearnedModel`; its ``extras`` hold the
        reference index, per-demonstration DTW distances, robust z-scores,
        outlier flags, which demonstrations were used, and the aligned
        demonstrations ``aligned`` (N, m, 8) on times ``aligned_t`` (m,).

    References
    ----------
    .. [1] Thesis §4.3 and §4.4.4–4.4.5, Eqs. (4.15)–(4.19).
    """
    if len(demos) == 0:
        raise InvalidInput("demos: need at least one demonstration, got none")
    names = _names(names, len(demos))
    for name, demo in zip(names, demos, strict=True):
        if not isinstance(demo, Demonstration):
            raise InvalidInput(f"{name}: expected a Demonstration, got {type(demo).__name__}")
    frames = sorted({str(d.meta.get("frame", "unknown")) for d in demos})
    if len(frames) > 1:
        raise InvalidInput(
            f"demos: the demonstrations are in different frames {frames}; record them with "
            "the same extrinsics (--extrinsics / --camera-pose)"
        )
    if frames[0].startswith("camera"):
        logger.warning(
            "the demonstrations are in the CAMERA frame (recorded without extrinsics): the "
            "model can be inspected, but planning for the robot needs the base frame"
        )
    return learn_poses(
        [d.t for d in demos],
        [d.pose for d in demos],
        cfg,
        rng,
        valid=[d.valid for d in demos],
        names=names,
        callback=callback,
        meta={
            "demonstration_sources": [str(d.meta.get("source", "unknown")) for d in demos],
            "frame": frames[0],
        },
    )
