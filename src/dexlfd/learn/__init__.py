"""Learning from several demonstrations: mean filter, DTW, GMM (EM), GMR (thesis §4.3).

Example::

    from dexlfd.learn import LearnConfig, learn_from_demonstrations
    result = learn_from_demonstrations(demos, LearnConfig(), np.random.default_rng(0))
    result.model.mean.shape  # (m, 8): position, quaternion, gripper
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from dexlfd._lazy import lazy_package

if TYPE_CHECKING:  # the names below are imported on first use (``__getattr__``)
    from dexlfd.learn.alignment import (
        AlignmentResult,
        align_to_reference,
        pairwise_dtw,
        select_medoid,
        warp_to_reference,
    )
    from dexlfd.learn.config import LearnConfig
    from dexlfd.learn.dtw import (
        DtwResult,
        accumulated_cost,
        channel_scales,
        dtw,
        sakoe_chiba_bounds,
    )
    from dexlfd.learn.gmm import Gmm, GmmConfig, GmmResult, fit_gmm, gmm_log_likelihood
    from dexlfd.learn.gmr import GmrResult, gmr
    from dexlfd.learn.model import LearnResult, learn_from_demonstrations, learn_poses
    from dexlfd.learn.pipeline import LearnedTrajectory, learn_trajectories
    from dexlfd.learn.poses import POSE_CHANNELS, POSE_GROUPS
    from dexlfd.learn.preprocess import preprocess_series
    from dexlfd.learn.quality import QualityReport, assess_quality
    from dexlfd.motion.gaps import fill_gaps
    from dexlfd.trajectory import mean_filter

# name -> the module it comes from: numba and SciPy are imported when a name is first
# used, so a command that only reads LearnConfig (teach before it records) waits for neither
_EXPORTS = {
    "AlignmentResult": "dexlfd.learn.alignment",
    "DtwResult": "dexlfd.learn.dtw",
    "Gmm": "dexlfd.learn.gmm",
    "GmmConfig": "dexlfd.learn.gmm",
    "GmmResult": "dexlfd.learn.gmm",
    "GmrResult": "dexlfd.learn.gmr",
    "LearnConfig": "dexlfd.learn.config",
    "LearnResult": "dexlfd.learn.model",
    "LearnedTrajectory": "dexlfd.learn.pipeline",
    "POSE_CHANNELS": "dexlfd.learn.poses",
    "POSE_GROUPS": "dexlfd.learn.poses",
    "QualityReport": "dexlfd.learn.quality",
    "accumulated_cost": "dexlfd.learn.dtw",
    "align_to_reference": "dexlfd.learn.alignment",
    "assess_quality": "dexlfd.learn.quality",
    "channel_scales": "dexlfd.learn.dtw",
    "dtw": "dexlfd.learn.dtw",
    "fill_gaps": "dexlfd.motion.gaps",
    "fit_gmm": "dexlfd.learn.gmm",
    "gmm_log_likelihood": "dexlfd.learn.gmm",
    "gmr": "dexlfd.learn.gmr",
    "learn_from_demonstrations": "dexlfd.learn.model",
    "learn_poses": "dexlfd.learn.model",
    "learn_trajectories": "dexlfd.learn.pipeline",
    "mean_filter": "dexlfd.trajectory",
    "pairwise_dtw": "dexlfd.learn.alignment",
    "preprocess_series": "dexlfd.learn.preprocess",
    "sakoe_chiba_bounds": "dexlfd.learn.dtw",
    "select_medoid": "dexlfd.learn.alignment",
    "warp_to_reference": "dexlfd.learn.alignment",
}

__getattr__, __dir__ = lazy_package(__name__, _EXPORTS)

__all__ = [
    "POSE_CHANNELS",
    "POSE_GROUPS",
    "AlignmentResult",
    "DtwResult",
    "Gmm",
    "GmmConfig",
    "GmmResult",
    "GmrResult",
    "LearnConfig",
    "LearnResult",
    "LearnedTrajectory",
    "QualityReport",
    "accumulated_cost",
    "align_to_reference",
    "assess_quality",
    "channel_scales",
    "dtw",
    "fill_gaps",
    "fit_gmm",
    "gmm_log_likelihood",
    "gmr",
    "learn_from_demonstrations",
    "learn_poses",
    "learn_trajectories",
    "mean_filter",
    "pairwise_dtw",
    "preprocess_series",
    "sakoe_chiba_bounds",
    "select_medoid",
    "warp_to_reference",
]
