"""The palm at its full size: a depth scale that survives world landmarks read flat."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from dexlfd.capture.palm_template import PALM, full_size_palm, palm_template
from dexlfd.capture.recording_pose import estimate_recording_pose
from dexlfd.capture.recording_pose_config import RecordingPoseConfig
from dexlfd.errors import InvalidInput

from .test_recording_pose import Clip, K, make_clip

SQUASH = 0.3  # the world landmarks' extent along the line of sight, read this short


def flattened(clip: Clip) -> Clip:
    """``clip`` with its world landmarks' depth axis (MediaPipe's: along the ray) squashed
    in most frames, as MediaPipe reads a palm turned away from the camera."""
    world = clip.world.copy()
    squash = np.arange(len(world)) % 5 != 0  # one frame in five read at full depth
    c = world[squash].mean(axis=1, keepdims=True)
    world[squash, :, 2] = c[..., 2] + SQUASH * (world[squash, :, 2] - c[..., 2])
    return replace(clip, world=world)


def palm_distances(P: np.ndarray) -> np.ndarray:
    d = np.linalg.norm(P[:, None] - P[None], axis=2)
    return d[np.triu_indices(len(P), 1)]


@pytest.fixture(scope="module")
def tilted() -> Clip:
    """The synthetic clip with the palm turned 60 deg away from the camera throughout."""
    clip = make_clip(3)
    c, s = np.cos(np.radians(60.0)), np.sin(np.radians(60.0))
    Ry = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    truth = clip.truth.copy()
    ctr = truth[:, list(PALM)].mean(axis=1, keepdims=True)
    truth = (truth - ctr) @ Ry.T + ctr
    from dexlfd.capture import project_pinhole
    from dexlfd.capture.palm_orientation import rotation_to

    uv, _ = project_pinhole(truth, K)
    rng = np.random.default_rng(3)
    uv = uv + rng.normal(0.0, 0.5, uv.shape)
    ray = ctr[:, 0] / np.linalg.norm(ctr[:, 0], axis=1, keepdims=True)
    R_ray = rotation_to(ray)
    world = np.einsum("nkj,nji->nki", truth - ctr, R_ray)  # camera -> ray-aligned
    world += rng.normal(0.0, 0.002, world.shape)
    ok = np.ones(len(truth), bool)
    return flattened(Clip(clip.t, uv, world, ok, truth, clip.score, np.zeros(len(truth), bool)))


def test_the_full_size_palm_keeps_the_distances_a_flat_reading_shortens(tilted: Clip) -> None:
    true = palm_distances(tilted.truth[0, list(PALM)])
    full = full_size_palm(tilted.world, tilted.valid)
    median, _ = palm_template(tilted.world, tilted.valid)
    got = palm_distances(np.c_[full, np.zeros(len(full))])
    short = palm_distances(median)
    # the median palm's most foreshortened distance reads well short; the full size within 6 %
    assert np.min(short / true) < 0.8
    np.testing.assert_allclose(got, true, rtol=0.06)


def test_the_depth_is_read_at_full_size_and_nothing_else_moves(tilted: Clip) -> None:
    z_true = tilted.truth[:, list(PALM), 2].mean(axis=1)
    base = estimate_recording_pose(tilted.t, tilted.uv, tilted.world, tilted.valid, K)
    cfg = RecordingPoseConfig(depth_template_quantile=90.0)
    full = estimate_recording_pose(tilted.t, tilted.uv, tilted.world, tilted.valid, K, cfg=cfg)
    assert np.median(base.depth_m / z_true) < 0.9  # the flat palm reads the hand near
    assert np.median(full.depth_m / z_true) == pytest.approx(1.0, abs=0.06)
    k = full.info["depth_scale"]
    assert base.info["depth_scale"] == 1.0 and k > 1.1
    # one factor on the depth: positions scale about the camera, directions and the palm's
    # orientation are unchanged
    np.testing.assert_allclose(full.depth_m, k * base.depth_m, rtol=1e-9)
    np.testing.assert_allclose(full.depth_std, k * base.depth_std, rtol=1e-9)
    np.testing.assert_array_equal(full.rotation, base.rotation)
    np.testing.assert_array_equal(full.orientation_set, base.orientation_set)
    move = np.diff(full.keypoints[:, 0], axis=0)
    move0 = np.diff(base.keypoints[:, 0], axis=0)
    cos = (
        np.sum(move * move0, axis=1) / np.linalg.norm(move, axis=1) / np.linalg.norm(move0, axis=1)
    )
    assert cos.min() > 0.99


def test_a_palm_read_right_keeps_its_scale() -> None:
    clip = make_clip(4)  # world landmarks true to the hand: nothing to correct
    cfg = RecordingPoseConfig(depth_template_quantile=90.0)
    est = estimate_recording_pose(clip.t, clip.uv, clip.world, clip.valid, K, clip.score, cfg=cfg)
    assert est.info["depth_scale"] == pytest.approx(1.0, abs=0.05)


def test_the_setting_is_checked() -> None:
    with pytest.raises(InvalidInput, match="depth_template_quantile"):
        RecordingPoseConfig(depth_template_quantile=120.0)
    with pytest.raises(InvalidInput, match="world_m"):
        full_size_palm(np.full((3, 21, 3), np.nan))
