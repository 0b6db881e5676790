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
from dexlfd.capture.lifting import lift_assumed_depth, lift_world_fit, two_webcams_side_depth
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
    with pytest.raises(InvalidInput, match="rigid"):
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
