from __future__ import annotations

import numpy as np
import pytest

from dexlfd.capture import (
    AngleModel,
    Intrinsics,
    LiftConfig,
    LiftInput,
    TwoWebcamModel,
    deproject_angle,
    deproject_pinhole,
    lift,
    lift_two_webcams,
    project_angle,
    project_pinhole,
    project_two_webcams,
    robust_depth,
    top_down_camera2base,
)
from dexlfd.capture.camera_models import two_webcams_side_depth
from dexlfd.capture.rgb_lifting import (
    PnPConfig,
    PnPTracker,
    fit_hand_pose,
    lift_assumed_depth,
    lift_world_fit,
)
from dexlfd.capture.transforms import check_rigid_transform
from dexlfd.errors import InvalidInput

# thesis Table 4.1: measured points [cm] (x, y, height above the table)
TABLE_4_1 = np.array(
    [(2.0, 8.0, 9.0), (-5.0, 0.0, 9.0), (-6.0, -9.0, 34.5), (-19.0, 7.0, 26.5),
     (20.0, 10.0, 26.5), (11.0, -10.0, 12.5), (-14.0, -8.0, 12.5), (27.0, -14.0, 34.5)]
) / 100  # fmt: skip


def _points(rng: np.random.Generator, n: int = 50) -> np.ndarray:
    return np.column_stack(
        [rng.uniform(-0.2, 0.2, n), rng.uniform(-0.15, 0.15, n), rng.uniform(0.3, 1.5, n)]
    )


def test_pinhole_round_trip_below_1mm(rng: np.random.Generator) -> None:
    K = Intrinsics(640, 480, 615.3, 614.9, 321.7, 238.2)
    P = _points(rng)
    uv, z = project_pinhole(P, K)
    np.testing.assert_allclose(deproject_pinhole(uv, z, K), P, atol=1e-9)
    # the principal point (OpenCV convention) is pixel centre (cx, cy): corner coords + 0.5
    uv0, _ = project_pinhole(np.array([[0.0, 0.0, 1.0]]), K)
    np.testing.assert_allclose(uv0, [[K.cx + 0.5, K.cy + 0.5]], atol=1e-12)


def test_intrinsics_from_fov_and_scaling() -> None:
    K = Intrinsics.from_fov(640, 480, 69.0, 42.0)
    assert K.approximate
    # a ray at half the field of view hits the image edge
    uv, _ = project_pinhole(np.array([[np.tan(np.radians(34.5)), 0.0, 1.0]]), K)
    assert uv[0, 0] == pytest.approx(640.0, abs=1e-9)
    # the same ray in a downscaled stream lands on the scaled pixel
    P = np.array([[0.1, -0.05, 0.7]])
    half = K.scaled(320, 240)
    np.testing.assert_allclose(project_pinhole(P, half)[0], project_pinhole(P, K)[0] / 2, atol=1e-9)
    with pytest.raises(InvalidInput, match="fx"):
        Intrinsics(640, 480, 0.0, 1.0, 0.0, 0.0)


def test_angle_model_round_trip_and_agreement_with_pinhole(rng: np.random.Generator) -> None:
    m = AngleModel()
    P = _points(rng)
    uv, d = project_angle(P, m)
    np.testing.assert_allclose(deproject_angle(uv, d, m), P, atol=1e-9)
    # Eq. (4.9) equals an ideal pinhole with the same field of view at the centre and edges
    K = Intrinsics.from_fov(640, 480, m.fov_x_deg, m.fov_y_deg)
    edge = np.array([[320.0, 240.0], [640.0, 240.0], [0.0, 480.0]])
    np.testing.assert_allclose(
        deproject_angle(edge, np.ones(3), m), deproject_pinhole(edge, np.ones(3), K), atol=1e-9
    )


def test_table_4_1_with_an_ideal_camera() -> None:
    # Thesis setup: camera 1 m above the table, D435i FOV 69 x 42 deg, 640 x 480, Eq. (4.9).
    # Image the measured points with an ideal pinhole camera and lift them with Eq. (4.9):
    # the model's own error is the same size as Table 4.1's (max 1.8 cm, mean ~1 cm).
    T = top_down_camera2base(1.0)
    K = Intrinsics.from_fov(640, 480, 69.0, 42.0)
    cam = (TABLE_4_1 - T[:3, 3]) @ T[:3, :3]  # base -> camera (T is orthonormal)
    uv, d = project_pinhole(cam, K)
    cfg = LiftConfig(model="angle", camera2base=T)
    est = np.stack([lift(LiftInput(uv[k : k + 1], d[k : k + 1]), cfg)[0] for k in range(8)])
    err = np.abs(est - TABLE_4_1)
    assert err.max() < 0.025  # x: 2.3 cm at 27 cm off-axis (tan is not linear in angle)
    assert err.mean(axis=0)[0] < 0.015 and err[:, 2].max() < 1e-9  # height is exact: z = H - d
    # the pinhole model recovers them exactly
    cfg_p = LiftConfig(model="pinhole", intrinsics=K, camera2base=T)
    est_p = lift(LiftInput(uv, d), cfg_p)
    np.testing.assert_allclose(est_p, TABLE_4_1, atol=1e-9)


def test_two_webcams_round_trip_below_1mm(rng: np.random.Generator) -> None:
    m = TwoWebcamModel()
    P = np.column_stack(
        [rng.uniform(-0.1, 0.2, 40), rng.uniform(-0.1, 0.2, 40), rng.uniform(0.3, 0.6, 40)]
    )
    top, side = project_two_webcams(P, m)
    np.testing.assert_allclose(lift_two_webcams(top, side, m), P, atol=1e-9)
    # d1 (4.6) and d3 (4.7) satisfy the four relations (4.1), (4.2), (4.4), (4.5)
    d1 = m.H_top - P[:, 2]
    d3 = two_webcams_side_depth(top, side, m)
    tx, ty = np.radians(m.fov_x_deg), np.radians(m.fov_y_deg)
    d2 = d3 * np.tan((m.height_px / 2 - side[:, 1]) / m.height_px * ty)
    d4 = d1 * np.tan((top[:, 0] - m.width_px / 2) / m.width_px * tx)
    np.testing.assert_allclose(d1, m.H - d2, atol=1e-12)
    np.testing.assert_allclose(d3, m.D - d4, atol=1e-12)
    # thesis origin pixel (520, 130) maps to x = y = 0
    o = lift_two_webcams(np.array([[520.0, 130.0]]), side[:1], m)
    np.testing.assert_allclose(o[0, :2], 0.0, atol=1e-12)


def test_world_fit_recovers_translation(rng: np.random.Generator) -> None:
    K = Intrinsics(1280, 720, 900.0, 905.0, 640.2, 359.7)
    W = rng.normal(0, 0.04, (21, 3))
    W -= W.mean(axis=0)
    T = np.array([0.05, -0.03, 0.62])
    uv, _ = project_pinhole(W + T, K)
    np.testing.assert_allclose(lift_world_fit(uv, W, K), W + T, atol=1e-9)


def test_assumed_depth_puts_wrist_on_its_ray() -> None:
    K = Intrinsics.from_fov(640, 360, 60.0)
    W = np.zeros((21, 3))
    W[4] = [0.05, -0.02, 0.01]
    uv = np.full((21, 2), 100.0)
    uv[0] = [400.0, 200.0]
    P = lift_assumed_depth(uv, W, K, 0.5)
    assert P[0, 2] == pytest.approx(0.5)
    np.testing.assert_allclose(project_pinhole(P[:1], K)[0], uv[:1], atol=1e-9)
    np.testing.assert_allclose(P[4] - P[0], W[4], atol=1e-15)


def test_robust_depth_median_holes_and_edges() -> None:
    D = np.full((40, 60), 0.8, dtype=np.float32)
    D[10:15, 20:25] = 0.0  # a hole of zeros
    D[30:35, 40:45] = np.nan
    D[0:5, 0:5] = [[0.5, 0.6, 0.7, 0.0, 0.0]] * 5  # near the corner
    D[20, 30] = 9.0  # a single outlier in an otherwise flat patch
    uv = np.array(
        [[22.5, 12.5], [42.5, 32.5], [0.5, 0.5], [30.5, 20.5], [-3.0, 5.0], [np.nan, 1.0]]
    )
    z = robust_depth(D, uv, patch_px=5)
    assert np.isnan(z[0]) and np.isnan(z[1])  # all zeros / all NaN: no reading
    assert z[2] == pytest.approx(0.6)  # border patch: only in-image pixels, 0 ignored
    assert z[3] == pytest.approx(0.8)  # the median ignores the outlier
    assert np.isnan(z[4]) and np.isnan(z[5])  # outside the image / unknown pixel
    z_out = robust_depth(D, uv[3:4], patch_px=5, depth_range_m=(0.1, 0.5))
    assert np.isnan(z_out[0])  # readings outside the accepted range are ignored


def test_lift_config_errors() -> None:
    with pytest.raises(InvalidInput, match="lift model must be one of .*pinhole"):
        LiftConfig(model="stereo")
    bad = np.eye(4)
    bad[0, 0] = 2.0
    with pytest.raises(InvalidInput, match="camera2base: the rotation block is not orthonormal"):
        LiftConfig(camera2base=bad)
    with pytest.raises(InvalidInput, match="shape"):
        LiftConfig(camera2base=np.eye(3))
    with pytest.raises(InvalidInput, match="needs camera intrinsics"):
        lift(LiftInput(np.zeros((21, 2)), np.ones(21)), LiftConfig(model="pinhole"))
    with pytest.raises(InvalidInput, match="needs a depth image"):
        lift(LiftInput(np.zeros((21, 2))), LiftConfig(model="angle"))
    with pytest.raises(InvalidInput, match="side camera"):
        lift(LiftInput(np.zeros((21, 2))), LiftConfig(model="two_webcams"))


def test_top_down_extrinsic_is_eq_4_9_height() -> None:
    T = top_down_camera2base(1.0)
    p = np.array([0.1, 0.2, 0.7]) @ T[:3, :3].T + T[:3, 3]
    np.testing.assert_allclose(p, [0.1, -0.2, 0.3], atol=1e-15)  # z = H - d
    assert np.linalg.det(T[:3, :3]) == pytest.approx(1.0)


# ---------------------------------------------------------------- RGB-only PnP lift


def _hand(rng: np.random.Generator) -> np.ndarray:
    """21 landmarks of a synthetic right hand (wrist at the origin), camera-aligned [m]."""
    from dexlfd.datasets.hands import hand_keypoints_from_pose

    q = np.array([[0.0, 0.0, 0.0, 1.0]])
    kp = hand_keypoints_from_pose(np.zeros((1, 3)), q, np.array([0.08]), rng)[0]
    return kp - kp[0]


def _rot(axis: str, deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


def _observe(
    hand: np.ndarray, wrist: np.ndarray, K: Intrinsics, R_world: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(pixels, MediaPipe-like world landmarks) of ``hand`` with its wrist at ``wrist``.

    World landmarks are hand-centred (centroid origin) and, when ``R_world`` is
    given, expressed in a frame rotated by it from the camera's.
    """
    P = hand + wrist
    uv, _ = project_pinhole(P, K)
    W = hand - hand.mean(axis=0)
    if R_world is not None:
        W = W @ R_world  # W_world = R^T W_cam, row-wise
    return uv, W


@pytest.mark.parametrize("depth", [0.4, 0.7, 1.0])
@pytest.mark.parametrize("direction", [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)])
def test_pnp_recovers_a_20_cm_move_at_any_depth(
    rng: np.random.Generator, depth: float, direction: tuple[float, float, float]
) -> None:
    K = Intrinsics(1280, 720, 910.0, 905.0, 641.3, 358.7)
    hand = _hand(rng)
    start = np.array([-0.05, 0.02, depth])
    travel = 0.20 * np.asarray(direction)
    wrists = start + np.linspace(0.0, 1.0, 31)[:, None] * travel
    tracker = PnPTracker()
    got = np.array([tracker.lift(*_observe(hand, w, K), K)[0] for w in wrists])
    # exact inputs: the trajectory itself (closed form), to well under a millimetre
    np.testing.assert_allclose(got, wrists, atol=1e-6)
    assert tracker.counts == {"fitted": 31, "gated": 0, "failed": 0}
    # the old constant-depth lift moves the wrist by 0.5/depth of the lateral travel and not
    # at all in depth: the defect this model removes
    old = np.array([lift_assumed_depth(*_observe(hand, w, K), K, 0.5)[0] for w in wrists])
    old_ratio = np.linalg.norm(old[-1] - old[0]) / 0.20
    assert old_ratio < 0.9 or depth == pytest.approx(0.4)


@pytest.mark.parametrize("depth", [0.4, 0.7, 1.0])
def test_pnp_travel_within_25_percent_with_noisy_landmarks(
    rng: np.random.Generator, depth: float
) -> None:
    """Pixel noise 1.5 px, world-landmark noise 3 mm, a 25 deg rotated world frame."""
    K = Intrinsics.from_fov(1280, 720, 65.0)
    hand = _hand(rng)
    R_world = _rot("y", 25.0) @ _rot("x", -10.0)
    travel = np.array([0.12, -0.06, 0.14])  # |travel| = 0.194 m, diagonal incl. depth
    wrists = np.array([0.03, 0.05, depth]) + np.linspace(0, 1, 61)[:, None] * travel
    tracker = PnPTracker()
    got = []
    for w in wrists:
        uv, W = _observe(hand, w, K, R_world)
        uv = uv + rng.normal(0, 1.5, uv.shape)
        W = W + rng.normal(0, 0.003, W.shape)
        got.append(tracker.lift(uv, W, K)[0])
    P = np.array(got)
    # end points as the mean of 5 frames (the motion stage smooths; this tests the lift's bias)
    moved = P[-5:].mean(axis=0) - P[:5].mean(axis=0)
    true = wrists[-3] - wrists[2]
    ratio = np.linalg.norm(moved) / np.linalg.norm(true)
    assert 0.75 < ratio < 1.25
    cos = moved @ true / np.linalg.norm(moved) / np.linalg.norm(true)
    assert cos > 0.95  # the direction, depth included
    assert np.abs(P[:, 2] - wrists[:, 2]).max() < 0.25 * depth


def test_pnp_recovers_a_rotated_world_frame_exactly(rng: np.random.Generator) -> None:
    K = Intrinsics(640, 480, 600.0, 600.0, 319.5, 239.5)
    hand = _hand(rng)
    R_world = _rot("z", 30.0) @ _rot("y", -20.0)
    uv, W = _observe(hand, np.array([0.1, -0.05, 0.6]), K, R_world)
    fit = fit_hand_pose(uv, W, K)
    assert fit is not None
    R, t, rms = fit
    np.testing.assert_allclose(R, R_world, atol=1e-6)
    assert rms < 1e-6
    np.testing.assert_allclose(W @ R.T + t, hand + [0.1, -0.05, 0.6], atol=1e-7)
    # beyond the plausibility bound the pose is refused, not flipped
    assert fit_hand_pose(uv, W, K, max_rotation_deg=20.0) is None


def test_pnp_gates_an_implausible_depth_jump(rng: np.random.Generator) -> None:
    K = Intrinsics.from_fov(640, 480, 60.0)
    hand = _hand(rng)
    tracker = PnPTracker(PnPConfig(max_depth_step=0.2, reset_after=3))
    wrist = np.array([0.0, 0.0, 0.6])
    for _ in range(3):
        tracker.lift(*_observe(hand, wrist, K), K)
    # a bad frame: the world landmarks twice too large (a misfit hand) -> depth would double
    uv, W = _observe(hand, wrist, K)
    P = tracker.lift(uv, 2.0 * W, K)
    assert tracker.counts["gated"] == 1
    # a 2x hand at 2x the distance looks the same: the fit says 2x as deep, the gate keeps
    # the hand's ray and the last accepted depth, i.e. the true hand centre
    np.testing.assert_allclose(P.mean(axis=0), hand.mean(axis=0) + wrist, atol=1e-6)
    # a hand that really stays at the new depth is accepted after reset_after frames
    for _ in range(4):
        P = tracker.lift(uv, 2.0 * W, K)
    assert tracker.counts["gated"] == 3
    assert P[0, 2] == pytest.approx(1.2, rel=0.01)
    # no plausible pose (too few finite landmarks): NaN, counted as failed
    bad = uv.copy()
    bad[3:] = np.nan
    assert np.isnan(tracker.lift(bad, W, K)).all()
    assert tracker.counts["failed"] == 1


def test_pnp_is_the_lift_model_and_meta_says_approximate(rng: np.random.Generator) -> None:
    K = Intrinsics(640, 480, 600.0, 600.0, 319.5, 239.5)
    hand = _hand(rng)
    uv, W = _observe(hand, np.array([0.0, 0.1, 0.8]), K)
    cfg = LiftConfig(model="pnp", intrinsics=K, camera2base=top_down_camera2base(1.0))
    assert cfg.approximate
    P = lift(LiftInput(uv, world_m=W), cfg)
    np.testing.assert_allclose(P[0], [0.0, -0.1, 0.2], atol=1e-6)
    with pytest.raises(InvalidInput, match="needs MediaPipe world landmarks"):
        lift(LiftInput(uv), cfg)


def test_check_rigid_transform_names_the_defect() -> None:
    T = np.eye(4)
    T[:3, 3] = [0.1, 0.2, 0.3]
    np.testing.assert_array_equal(check_rigid_transform(T, "x"), T)
    cases = {
        "shape \\(3, 4\\)": T[:3],
        "NaN": np.where(np.eye(4) == 1, np.nan, 0.0),
        "last row": np.vstack([T[:3], [0, 0, 1, 1]]),
        "not orthonormal": np.diag([1.0, 1.0, 1.1, 1.0]),
        "det -1": np.diag([1.0, 1.0, -1.0, 1.0]),
    }
    for why, A in cases.items():
        with pytest.raises(InvalidInput, match=f"^--extrinsics f.npy: .*{why}"):
            check_rigid_transform(A, "--extrinsics f.npy")


def test_pnp_depth_varies_on_the_real_video(hand_video) -> None:
    """The shared real video (one hand held ~0.5-1 m before a webcam; no ground truth).

    Depth must follow the hand (vary, no constant), stay plausible for a hand held before
    a camera, and move smoothly at 30 fps (no PnP flips: the wrist moves < 8 cm per frame).
    """
    from dexlfd.capture import CaptureConfig, open_source, track_source

    cfg = CaptureConfig(lift=LiftConfig(model="pnp"))
    with open_source(hand_video, resize_width=640) as src:
        series = track_source(src, cfg)
    z = series.keypoints[series.valid, 0, 2]
    assert series.valid.mean() > 0.95
    assert series.meta["lift_model"] == "pnp" and series.meta["depth"] == "approximate"
    assert series.meta["pnp_frames"]["failed"] == 0
    assert np.percentile(z, 1) > 0.2 and np.percentile(z, 99) < 2.0
    assert np.ptp(z) > 0.05 and np.std(z) > 0.01  # not constant
    step = np.linalg.norm(np.diff(series.keypoints[:, 0], axis=0), axis=1)
    assert np.nanmax(step) < 0.08


def test_record_scales_an_intrinsics_file_to_the_processed_frames(hand_video, tmp_path) -> None:
    """A K file for the full 1280x720 video, frames resized to 640x360: K is halved."""
    import json

    from dexlfd.cli import main
    from dexlfd.io import load_demonstration

    kfile = tmp_path / "K.json"
    kfile.write_text(json.dumps({"fx": 1000.0, "fy": 1000.0, "cx": 639.5, "cy": 359.5,
                                 "width": 1280, "height": 720}))  # fmt: skip
    out = tmp_path / "d.npz"
    argv = ["record", str(hand_video), "-o", str(out), "--max-frames", "3", "--resize-width-px"]
    assert main([*argv, "640", "--intrinsics", str(kfile)]) == 0
    demo = load_demonstration(out)
    cap = {**demo.meta["capture"], **demo.capture.to_json()}
    assert cap["lift_model"] == "pnp" and cap["pnp_frames"]["fitted"] == 3
    K = cap["intrinsics"]
    assert (K["width"], K["height"], K["fx"], K["cx"]) == (640, 360, 500.0, 319.5)
    assert K["approximate"] is False
