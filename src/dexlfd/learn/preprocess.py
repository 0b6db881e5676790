"""Series made ready for learning: checked, gaps repaired, time from 0, mean-filtered.

Also the checks across demonstrations that are recovered from with a warning
(very different lengths, identical copies, a single demonstration) and the
one way such warnings are reported: logged as WARNING and collected for the
model's meta.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd._validation import as_float_array, check_time
from dexlfd.errors import InvalidDemonstration, InvalidInput
from dexlfd.learn.config import THESIS_WINDOW, LearnConfig
from dexlfd.learn.filtering import filter_reduces_risk
from dexlfd.motion.gaps import fill_gaps
from dexlfd.trajectory import mean_filter

__all__ = [
    "LENGTH_RATIO_WARN",
    "check_demonstration_set",
    "demonstration_names",
    "filter_window",
    "preprocess_series",
    "preprocess_set",
    "repair_series",
    "warn",
]

logger = logging.getLogger(__name__)

LENGTH_RATIO_WARN = 3.0  # demonstrations differing more than this in length get a warning


def warn(msgs: list[str], msg: str) -> None:
    """Log ``msg`` as a WARNING and collect it in ``msgs`` (a problem recovered from)."""
    logger.warning("%s", msg)
    msgs.append(msg)


def demonstration_names(names: Sequence[str] | None, n: int) -> list[str]:
    """``names`` checked against the ``n`` demonstrations, default ``demonstration i``."""
    if n == 0:
        raise InvalidInput("need at least one demonstration to learn from, got none")
    if names is None:
        return [f"demonstration {i}" for i in range(n)]
    if len(names) != n:
        raise InvalidInput(f"got {len(names)} names for {n} demonstrations")
    return [str(s) for s in names]


def repair_series(
    t: FloatArray, x: FloatArray, valid: BoolArray | None, name: str, cfg: LearnConfig
) -> tuple[FloatArray, FloatArray]:
    """Check one series, repair invalid frames and shift its time to 0 (no filter).

    Returns ``(t, x)`` with ``t[0] == 0`` and ``x`` (n, d) finite, at least 2 samples.
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
    if not isinstance(cfg.window, str) and cfg.window > t_arr.shape[0] // 2:
        # a mean filter over more than half the series averages the motion away
        raise InvalidDemonstration(
            f"{name}: window {cfg.window} must be at most half the series "
            f"({t_arr.shape[0]} samples -> <= {max(1, t_arr.shape[0] // 2)})",
            param="window",
        )
    return t_arr - t_arr[0], x_arr


def filter_window(series: Sequence[FloatArray], cfg: LearnConfig) -> int:
    """The mean-filter window for ``series``: ``cfg.window``, or decided for ``"auto"``."""
    if not isinstance(cfg.window, str):
        return int(cfg.window)
    if filter_reduces_risk(series, THESIS_WINDOW, mode=cfg.filter_mode):
        window = THESIS_WINDOW
    else:
        window = 1
    logger.info(
        "mean filter: window %d (%s)", window,
        "removes noise" if window > 1 else "no noise to remove, it would only bend the motion",
    )  # fmt: skip
    return window


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
    With ``window="auto"`` the filter is decided on this series alone
    (:func:`filter_window`); the pipeline decides once for all demonstrations.
    """
    t0, x_arr = repair_series(t, x, valid, name, cfg)
    return t0, mean_filter(x_arr, filter_window([x_arr], cfg), mode=cfg.filter_mode)


def preprocess_set(
    times: Sequence[FloatArray],
    series: Sequence[FloatArray],
    cfg: LearnConfig,
    valid: Sequence[BoolArray | None] | None,
    names: Sequence[str],
) -> tuple[list[tuple[FloatArray, FloatArray]], int]:
    """Every series repaired, then mean-filtered with one window; returns them and the window."""
    repaired = [
        repair_series(t, x, None if valid is None else valid[i], names[i], cfg)
        for i, (t, x) in enumerate(zip(times, series, strict=True))
    ]
    _check_channels([x for _, x in repaired], names)
    window = filter_window([x for _, x in repaired], cfg)
    return [(t, mean_filter(x, window, mode=cfg.filter_mode)) for t, x in repaired], window


def _check_channels(series: Sequence[FloatArray], names: Sequence[str]) -> None:
    d = series[0].shape[1]
    for name, x in zip(names, series, strict=True):
        if x.shape[1] != d:
            raise InvalidDemonstration(
                f"{name}: has {x.shape[1]} channels, but {names[0]} has {d}; "
                "all demonstrations must have the same channels"
            )


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


def check_demonstration_set(
    series: Sequence[FloatArray], names: Sequence[str], cfg: LearnConfig, msgs: list[str]
) -> None:
    """Check that the preprocessed series can be learned from together.

    Different channel counts and a reference index out of range are errors;
    lengths differing more than ``LENGTH_RATIO_WARN`` times, identical copies
    and a single demonstration are warnings (collected in ``msgs``).
    """
    N, d = len(series), series[0].shape[1]
    _check_channels(series, names)
    lengths = np.array([x.shape[0] for x in series])
    if lengths.max() > LENGTH_RATIO_WARN * lengths.min():
        warn(
            msgs,
            f"demonstration lengths differ {lengths.max() / lengths.min():.1f}x "
            f"({names[int(lengths.argmin())]}: {lengths.min()} samples, "
            f"{names[int(lengths.argmax())]}: {lengths.max()}); DTW stretches the short ones",
        )
    for i, j in _identical_pairs(series):
        warn(
            msgs,
            f"{names[j]} is identical to {names[i]}: a copy adds no variation, and the "
            "learned covariance shrinks as if the motion were more certain",
        )
    if N == 1:
        warn(
            msgs,
            "only one demonstration: the learned covariance reflects the GMM fit of that "
            "one curve, not the variation between demonstrations",
        )
    if not isinstance(cfg.reference, str) and cfg.reference >= N:
        raise InvalidInput(
            f"reference index {cfg.reference} out of range for {N} demonstration(s) (0..{N - 1})",
            param="reference",
        )
    logger.info(
        "learning from %d demonstration(s), %d channel(s), %d-%d samples",
        N, d, lengths.min(), lengths.max(),
    )  # fmt: skip
