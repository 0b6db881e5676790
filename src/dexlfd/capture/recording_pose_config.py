"""Settings of the whole-recording hand pose (:mod:`dexlfd.capture.recording_pose`)."""

from __future__ import annotations

from dataclasses import dataclass

from dexlfd._validation import check_positive
from dexlfd.errors import InvalidInput

__all__ = ["RecordingPoseConfig"]


@dataclass(frozen=True, slots=True)
class RecordingPoseConfig:
    """Settings of :func:`estimate_recording_pose` (defaults tuned on real recordings).

    Depth noise is relative (log-depth) before the per-recording calibration; image noise
    and its prior are in pixels, the depth prior in metres.
    """

    depth_noise: float = 0.06  # base std of a frame's log-depth (MediaPipe scale noise) [-]
    depth_accel: float = 0.25  # motion prior: depth acceleration noise density [m/s^1.5]
    image_noise_px: float = 3.0  # base std of the palm centre's pixel [px]
    image_accel_px: float = 1200.0  # motion prior: pixel acceleration density [px/s^1.5]
    measured_depth_noise: float = 0.01  # relative std of an RGB-D depth reading [-]
    level_window: int = 31  # frames of the running median that makes relative noise metric
    border_margin_px: float = 8.0  # a palm point this close to the border is cut [px]
    border_factor: float = 6.0  # std multiplier of a frame whose palm is cut by the border
    hand_cut_factor: float = 2.0  # std multiplier where only a finger is outside the image
    min_score: float = 0.6  # tracker confidence below which a frame is down-weighted
    low_score_factor: float = 3.0  # std multiplier of a low-confidence frame
    edge_on_deg: float = 72.0  # palm normal this far from the viewing ray: seen edge-on [deg]
    max_shape_rel: float = 0.25  # palm shape residual over template radius: inconsistent [-]
    max_tilt_disagreement: float = 0.35  # |cos tilt| of world landmarks vs image: inconsistent
    max_orientation_step_deg: float = 30.0  # a run turning this far from the kept ones: flip
    cauchy_c: float = 2.5  # Cauchy scale of the reweighting, in residual stds [-]
    min_noise_scale: float = 0.05  # lowest calibration of the depth noise level [-]
    curl_prior: float = 0.3  # prior std of the finger-curl depth bias (log-depth per unit)
    curl_iterations: int = 4  # alternations of curl bias and smooth depth (0: no correction)
    curl_ref_accel: float = 0.06  # depth prior of the reference the curl bias is fit to
    iterations: int = 6  # reweighting passes of the smoother
    template_iterations: int = 3  # Procrustes passes of the palm template
    # the whole hand's depth reading (palm_fit.hand_scale of the hand at its size over the
    # clip: the palm template and palm_fit.rigid_fingers) mixed into the palm's in
    # log-depth with the weight depth_hand_weight * (1 - |cos| of the palm normal to the
    # ray): 0, the default, the palm's alone. At 1, carried distances over a person's
    # estimates on 9 real carries are within 0.7-1.4x in 7 (palm alone: 3), but the task
    # frame's camera pitch drops from 25/22 to 7/-4 deg on the frontal lfo videos and
    # from 28 to 3 on llama: not the default
    depth_hand_weight: float = 0.0
    # the clip's depth read against the palm at its full size (palm_template.full_size_palm:
    # each palm distance at this percentile over the clip less its noise; MediaPipe's world
    # landmarks read the palm's extent along the line of sight short, so the clip's median
    # palm is too narrow and the depth reads near): one factor on the smoothed depth
    # (palm_fit.full_size_scale), the motion's directions and the palm's orientation
    # unchanged; the task frame measures the lifts over the same stretch (lifts.py). 0:
    # off. At 90 the carries over a person's estimates on 9 real carries are within
    # 0.7-1.4x in 6 (off: 3; the percentile picked by leave-one-recording-out over 75, 90
    # and 95 in 6 of 7 folds); benchmarks/carry_scale_results.md
    depth_template_quantile: float = 90.0

    def __post_init__(self) -> None:
        for name in (
            "depth_noise",
            "depth_accel",
            "image_noise_px",
            "image_accel_px",
            "measured_depth_noise",
            "border_factor",
            "hand_cut_factor",
            "low_score_factor",
            "max_shape_rel",
            "max_tilt_disagreement",
            "max_orientation_step_deg",
            "cauchy_c",
            "min_noise_scale",
            "curl_prior",
            "curl_ref_accel",
        ):
            check_positive(getattr(self, name), name)
        check_positive(self.border_margin_px, "border_margin_px", strict=False)
        if not 0.0 <= self.min_score <= 1.0:
            raise InvalidInput(f"min_score must be in [0, 1], got {self.min_score}")
        if not 0.0 < self.edge_on_deg < 90.0:
            raise InvalidInput(f"edge_on_deg must be in (0, 90), got {self.edge_on_deg}")
        if int(self.curl_iterations) < 0:
            raise InvalidInput(f"curl_iterations must be >= 0, got {self.curl_iterations}")
        if not 0.0 <= self.depth_template_quantile <= 100.0:
            raise InvalidInput(
                f"depth_template_quantile must be in [0, 100], got {self.depth_template_quantile}"
            )
        if not 0.0 <= self.depth_hand_weight <= 1.0:
            raise InvalidInput(f"depth_hand_weight must be in [0, 1], got {self.depth_hand_weight}")
        for name in ("iterations", "template_iterations", "level_window"):
            if int(getattr(self, name)) < 1:
                raise InvalidInput(f"{name} must be >= 1, got {getattr(self, name)}")
