"""From end-effector demonstrations to a :class:`dexlfd.io.LearnedModel` (thesis §4.3–4.4).

The pose layer around the channel-agnostic pipeline: quaternion handling
(:mod:`dexlfd.learn.poses`) before and after :func:`~dexlfd.learn.pipeline.learn_prepared`,
and the assembly of the model file: GMR mean and Σ(t), the GMM, and the
alignment and quality details in ``meta`` and ``extras``.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.io import Demonstration, LearnedModel
from dexlfd.io.model_facts import GraspEventsFound
from dexlfd.learn.config import LearnConfig
from dexlfd.learn.events import grasp_events
from dexlfd.learn.pipeline import LearnedTrajectory, learn_prepared
from dexlfd.learn.poses import (
    POSE_CHANNELS,
    POSE_GROUPS,
    QUATERNION,
    check_pose_series,
    renormalize_quaternion,
    same_hemisphere,
)
from dexlfd.learn.preprocess import demonstration_names, preprocess_set

__all__ = ["LearnResult", "learn_from_demonstrations", "learn_poses"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class LearnResult:
    """Result of :func:`learn_from_demonstrations`: the model file plus details."""

    model: LearnedModel
    trajectory: LearnedTrajectory


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
    names = demonstration_names(names, len(poses))
    if len(times) != len(poses):
        raise InvalidInput(f"got {len(times)} time vectors for {len(poses)} pose series")
    msgs: list[str] = []
    checked = []
    anchor: FloatArray | None = None
    for i, x in enumerate(poses):
        checked.append(check_pose_series(x, names[i], msgs))
        anchor = same_hemisphere(checked[-1], anchor)
    prepared, window = preprocess_set(times, checked, cfg, valid, names)
    for _, xp in prepared:
        xp[:, QUATERNION] /= np.linalg.norm(xp[:, QUATERNION], axis=1, keepdims=True)
    traj = learn_prepared(prepared, cfg, rng, names, POSE_GROUPS, callback)
    mean, cov = renormalize_quaternion(traj.mean, traj.cov)
    traj = replace(traj, mean=mean, cov=cov, warnings=tuple(msgs) + traj.warnings, window=window)
    return LearnResult(model=_build_model(traj, cfg, names, meta or {}), trajectory=traj)


def _pointwise_cov(aligned: FloatArray) -> FloatArray:
    """Sample covariance across demonstrations at each time step, (m, d, d); 0 for one demo."""
    N = aligned.shape[0]
    dev = aligned - aligned.mean(axis=0, keepdims=True)
    return np.einsum("nti,ntj->tij", dev, dev) / max(N - 1, 1)


def _model_meta(traj: LearnedTrajectory, cfg: LearnConfig, names: list[str]) -> dict[str, object]:
    """What was learned from what, how: the model's ``meta`` (JSON-able)."""
    gmm = traj.gmm_result.gmm
    ref = traj.alignment.reference_index
    sel = traj.k_selection
    return {
        "source": "dexlfd.learn",
        "method": "mean filter (4.15) -> DTW (4.16) -> GMM/EM (4.17) -> GMR (4.18-4.19)",
        "settings": asdict(cfg),
        "filter_window": traj.window,
        "channels": list(POSE_CHANNELS),
        "units": {"t": "s", "position": "m", "quaternion": "x,y,z,w", "gripper": "m"},
        "n_demonstrations": len(names),
        "demonstrations": names,
        "reference_index": ref,
        "reference": names[ref],
        "reference_selection": "medoid" if cfg.reference == "medoid" else "index",
        "n_components": gmm.n_components,
        "n_components_selection": "given"
        if sel is None
        else {
            "method": sel.method,
            "candidates": sel.candidates.astype(int).tolist(),
            "scores_nats_per_point": [round(float(v), 4) for v in sel.scores],
        },  # fmt: skip
        "gmm_iterations": traj.gmm_result.n_iter,
        "gmm_converged": traj.gmm_result.converged,
        "gmm_log_likelihood": traj.gmm_result.log_likelihood,
        "variance_from_demonstrations": int(traj.used.sum()) > 1,
        "excluded": [names[i] for i in np.flatnonzero(~traj.used)],
        "quality_note": traj.quality.note,
        "two_modes": traj.quality.modes is not None,
        "mode_separation": traj.quality.mode_separation,
        "warnings": list(traj.warnings),
        "dtw_scale_note": "per-channel divisors: RMS std of position / quaternion / gripper",
    }


def _model_extras(traj: LearnedTrajectory) -> dict[str, np.ndarray]:
    """Alignment and quality arrays stored next to the model (``extras``)."""
    al = traj.alignment
    return {
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
    }


def _build_model(
    traj: LearnedTrajectory, cfg: LearnConfig, names: list[str], extra_meta: dict[str, object]
) -> LearnedModel:
    gmm = traj.gmm_result.gmm
    return LearnedModel(
        t=traj.t,
        mean=traj.mean,
        cov=traj.cov,
        gmm_weights=gmm.weights,
        gmm_means=gmm.means,
        gmm_covs=gmm.covariances,
        meta={**_model_meta(traj, cfg, names), **extra_meta},
        extras=_model_extras(traj),
        outliers=tuple(names[i] for i in np.flatnonzero(traj.quality.outlier)),
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
        demonstrations ``aligned`` (N, m, 8) on times ``aligned_t`` (m,); its
        ``event_*`` arrays the demonstrations' grasp and release
        (:mod:`dexlfd.learn.events`; absent when none had both, said in
        ``grasp_events``).

    References
    ----------
    .. [1] Thesis §4.3 and §4.4.4–4.4.5, Eqs. (4.15)–(4.19).
    """
    if len(demos) == 0:
        raise InvalidInput("demos: need at least one demonstration, got none")
    names = demonstration_names(names, len(demos))
    for name, demo in zip(names, demos, strict=True):
        if not isinstance(demo, Demonstration):
            raise InvalidInput(f"{name}: expected a Demonstration, got {type(demo).__name__}")
    frames = sorted({d.frame or "unknown" for d in demos})
    if len(frames) > 1:
        raise InvalidInput(
            f"demos: the demonstrations are in different frames {frames}; record them with "
            "the same camera extrinsics"
        )
    if frames[0].startswith("camera"):
        logger.warning(
            "the demonstrations are in the CAMERA frame (recorded without extrinsics): the "
            "model can be inspected, but planning for the robot needs the base frame"
        )
    unusable = _unusable(demos, names)
    result = learn_poses(
        [d.t for d in demos],
        [d.pose for d in demos],
        cfg,
        rng,
        valid=[d.valid for d in demos],
        names=names,
        callback=callback,
        meta={
            "demonstration_sources": [str(d.meta.get("source", "unknown")) for d in demos],
            "unusable_demonstrations": unusable,
        },
    )
    events = grasp_events(demos, names, result.trajectory)
    model = dataclasses.replace(
        result.model,
        **(events.arrays or {}),
        frame=frames[0],
        grasp_events=GraspEventsFound.from_json(events.info, "grasp events"),
    )
    return LearnResult(model=model, trajectory=result.trajectory)


def _unusable(demos: Sequence[Demonstration], names: Sequence[str]) -> list[str]:
    """Names of the demonstrations whose own quality verdict says NOT usable.

    The verdict is ``quality.usable``; each such demonstration is logged
    as a warning with the verdict's reasons (it is still learned from: leave it out
    to follow the verdict).
    """
    bad = []
    for name, demo in zip(names, demos, strict=True):
        q = demo.quality
        if q is not None and not q.usable:
            why = "; ".join(q.warnings) or "no reason recorded"
            logger.warning(
                "%s: its quality report says NOT usable (%s); learned from all the same, "
                "leave it out unless the reasons do not matter here", name, why,
            )  # fmt: skip
            bad.append(str(name))
    return bad
