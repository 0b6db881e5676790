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


def flattened(clip: Clip) -> Clip:
    """``clip`` with its world landmarks' depth axis (MediaPipe's: along the ray) read
    short by a factor that wanders over 0.2-1, near 1 in a few stretches only (as
    MediaPipe reads a palm turned away from the camera)."""
    world = clip.world.copy()
    n = len(world)
    wave = 0.5 + 0.5 * np.sin(np.linspace(0.0, 7.0 * np.pi, n))[:, None]
    squash = 0.2 + 0.8 * wave**4
    c = world.mean(axis=1, keepdims=True)
    world[..., 2] = c[..., 2] + squash * (world[..., 2] - c[..., 2])
    return replace(clip, world=world)


def palm_distances(P: np.ndarray) -> np.ndarray:
    d = np.linalg.norm(P[:, None] - P[None], axis=2)
    return d[np.triu_indices(len(P), 1)]


@pytest.fixture(scope="module")
def tilted() -> Clip:
    """The synthetic clip with the palm turned 70 deg away from the camera throughout."""
    clip = make_clip(3)
    c, s = np.cos(np.radians(70.0)), np.sin(np.radians(70.0))
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
    # the median palm's most foreshortened distance reads well short; the full size's
    # errs by less than half as much, and never long
    assert np.min(short / true) < 0.7
    assert np.max(got / true) < 1.03
    assert np.mean(np.abs(np.log(got / true))) < 0.5 * np.mean(np.abs(np.log(short / true)))


def test_the_depth_is_read_at_full_size_and_nothing_else_moves(tilted: Clip) -> None:
    z_true = tilted.truth[:, list(PALM), 2].mean(axis=1)
    off = RecordingPoseConfig(depth_template_quantile=0.0)
    base = estimate_recording_pose(tilted.t, tilted.uv, tilted.world, tilted.valid, K, cfg=off)
    full = estimate_recording_pose(tilted.t, tilted.uv, tilted.world, tilted.valid, K)
    assert np.median(base.depth_m / z_true) < 0.9  # the flat palm reads the hand near
    assert np.median(full.depth_m / z_true) == pytest.approx(1.0, abs=0.06)
    k = full.info["depth_scale"]
    assert base.info["depth_scale"] == 1.0 and k > 1.1
    assert base.info["depth_scale_sd"] == 0.0 and 0.0 < full.info["depth_scale_sd"] < 0.2
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
    est = estimate_recording_pose(clip.t, clip.uv, clip.world, clip.valid, K, clip.score)
    assert est.info["depth_scale"] == pytest.approx(1.0, abs=0.02)


def test_the_setting_is_checked() -> None:
    with pytest.raises(InvalidInput, match="depth_template_quantile"):
        RecordingPoseConfig(depth_template_quantile=120.0)
    with pytest.raises(InvalidInput, match="world_m"):
        full_size_palm(np.full((3, 21, 3), np.nan))


def test_record_carries_the_factor_and_its_uncertainty_on_a_real_recording(
    shared_data, monkeypatch
) -> None:  # type: ignore[no-untyped-def]
    """``record`` on a real landmark recording (three pick-and-places, the palm mostly
    turned from the camera): each demonstration names the factor and its uncertainty as
    typed facts, its carry grows by the factor with that uncertainty in its 1-sigma, and
    the task frame's up is within a few degrees of the unscaled recording's."""
    import dexlfd.capture.recording_pose as rp
    from dexlfd.apps.record import RecordConfig, record_demonstration
    from dexlfd.motion import estimate_task_frame

    path = shared_data / "landmarks" / "breakfast.npz"
    if not path.is_file():
        pytest.skip(f"real landmark recording not found at {path}")

    def run() -> list:  # type: ignore[type-arg]
        res = record_demonstration(str(path), RecordConfig())
        return [d for d in res.demos if d.quality.pick_and_place]

    full = run()
    monkeypatch.setattr(
        rp, "RecordingPoseConfig", lambda: RecordingPoseConfig(depth_template_quantile=0.0)
    )
    off = run()
    assert len(full) == len(off) == 3
    k = full[0].capture.depth_scale
    assert k is not None and k > 1.2 and all(d.capture.depth_scale == k for d in full)
    assert off[0].capture.depth_scale is None
    sd = full[0].capture.depth_scale_sd
    assert sd is not None and 0.0 < sd < 0.3
    for a, b in zip(full, off, strict=True):
        # (the motion stage's metric settings move the grasp's ends by a frame or two)
        assert a.quality.carry_m == pytest.approx(k * b.quality.carry_m, rel=0.06)
        assert a.quality.carry_std_m / a.quality.carry_m > b.quality.carry_std_m / b.quality.carry_m
    up_full = estimate_task_frame(full).up_camera
    up_off = estimate_task_frame(off).up_camera
    assert np.degrees(np.arccos(np.clip(np.dot(up_full, up_off), -1, 1))) < 3.0
