"""Settings of the learning stage (thesis §4.3–4.4): one frozen, validated config."""

from __future__ import annotations

from dataclasses import dataclass

from dexlfd._params import check_params, param
from dexlfd.errors import InvalidInput
from dexlfd.learn.gmm import GMM_INITS, GmmConfig
from dexlfd.trajectory import FILTER_MODES

__all__ = ["THESIS_K", "THESIS_WINDOW", "LearnConfig"]

THESIS_WINDOW = 10  # mean-filter window of the thesis [samples]
THESIS_K = 6  # Gaussians of the thesis (§4.3, "Here we set K = 6")
MAX_K = 50  # Gaussians: EM's cost grows with K; a demo has a handful of motion phases
MAX_WINDOW = 10_000  # [samples]; learning also refuses a window over half a demonstration
MAX_QUERY = 100_000  # GMR time samples (the model stores an 8x8 covariance per sample)


def _check_int_or_word(
    value: object, name: str, word: str, what: str, minimum: int, int_name: str
) -> None:
    """``value`` is ``word`` or an integer >= ``minimum`` (``what``/``int_name`` name it)."""
    if isinstance(value, str):
        if value != word:
            raise InvalidInput(f"{name} must be {word!r} or {what}, got {value!r}")
    elif isinstance(value, bool) or not isinstance(value, (int, float)) or int(value) != value:
        raise InvalidInput(f"{name} must be {word!r} or {what}, got {value!r}")
    elif value < minimum:
        raise InvalidInput(f"{int_name} must be >= {minimum}, got {value}")


@dataclass(frozen=True, slots=True)
class LearnConfig:
    """Settings of the learning stage (thesis: window 10, K = 6; ours: K chosen from the data).

    Attributes
    ----------
    n_components : int or "auto"
        K, Gaussians in the GMM; ``"auto"`` (default) chooses K among 6–20 by
        the held-out demonstrations' distance from the GMR mean
        (:func:`~dexlfd.learn.model_selection.select_n_components`).
    window : int or "auto"
        Mean-filter window k in samples (Eq. 4.15); 1 disables filtering.
        ``"auto"`` (default): the thesis's k = 10 where it lowers Stein's
        unbiased risk estimate of the demonstrations (they carry noise for it
        to remove), else no filter
        (:func:`~dexlfd.learn.filtering.filter_reduces_risk`).
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

    n_components: int | str = param(
        "auto", "Gaussian components K (auto: chosen from 6-20 by the held-out demonstrations' "
        "distance from the GMR mean; the thesis used 6)", lo=1, hi=MAX_K, integer=True,
        words=("auto",), flag="--k",
    )  # fmt: skip
    window: int | str = param(
        "auto", "mean-filter window [samples], at most half the shortest demonstration; 1 = "
        "no filter (auto: the thesis's 10 where it lowers Stein's risk estimate of the "
        "demonstrations, i.e. they carry noise to remove, else 1)", lo=1, hi=MAX_WINDOW,
        integer=True, words=("auto",),
    )  # fmt: skip
    filter_mode: str = "linear"
    reference: int | str = "medoid"
    exclude_outliers: bool = False
    outlier_threshold: float = 3.5
    band_fraction: float | None = param(
        None, "Sakoe-Chiba band radius for DTW as a fraction of the longer demo (default: "
        "none); a narrower band aligns longer demos", lo=0.0, hi=1.0, lo_open=True,
    )  # fmt: skip
    max_gap_s: float = param(
        0.5, "longest run of invalid frames to interpolate", unit="s", lo=0.0, hi=60.0
    )
    n_query: int | None = param(
        None, "GMR time samples (default: the reference's)", lo=2, hi=MAX_QUERY, integer=True
    )
    gmm_max_iter: int = 200
    gmm_tol: float = 1e-4
    reg_covar: float = 1e-6
    gmm_init: str = "time"

    def __post_init__(self) -> None:
        check_params(self)  # n_components, window, band_fraction, max_gap_s, n_query
        if self.filter_mode not in FILTER_MODES:
            raise InvalidInput(
                f"filter_mode must be one of {FILTER_MODES}, got {self.filter_mode!r}"
            )
        _check_int_or_word(self.reference, "reference", "medoid", "an index", 0, "reference index")
        if not self.outlier_threshold > 0:
            raise InvalidInput(f"outlier_threshold must be > 0, got {self.outlier_threshold}")
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
