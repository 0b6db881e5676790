from __future__ import annotations

import numpy as np
import pytest

from dexlfd.plan import (
    Box,
    Sphere,
    intrusion,
    signed_distance,
    variance_level,
    variance_weight,
)

Z = np.array([0.0, 0.0, 1.0])


def test_signed_distance_closed_forms() -> None:
    box = Box((0.0, 0.0, 0.0), (0.2, 0.4, 0.6))
    p = np.array([[0.0, 0.0, 0.0], [0.3, 0.0, 0.0], [0.2, 0.3, 0.0], [0.05, 0.0, 0.0]])
    np.testing.assert_allclose(
        signed_distance(box, p), [-0.1, 0.2, np.hypot(0.1, 0.1), -0.05], atol=1e-15
    )
    sph = Sphere((1.0, 0.0, 0.0), 0.5)
    np.testing.assert_allclose(
        signed_distance(sph, [[1.0, 0.0, 0.0], [1.0, 2.0, 0.0]]), [-0.5, 1.5], atol=1e-15
    )


def test_intrusion_box_is_lift_over_inflated_top() -> None:
    box = Box((0.0, 0.0, 0.2), (0.1, 0.1, 0.4))  # top at z = 0.4
    p = np.array([[0.0, 0.0, 0.3], [0.0, 0.0, 0.5], [0.0, 0.065, 0.3], [0.0, 0.2, 0.3]])
    h, req = intrusion(box, p, Z, margin=0.02, influence=0.03)
    # inside the inflated footprint: exit distance to z = 0.42
    np.testing.assert_allclose([h[0], req[0]], [0.12, 0.12], atol=1e-12)
    assert h[1] == 0 and req[1] == 0  # already above
    # 1.5 cm beside the face, within the margin: the rounded (Euclidean) offset needs
    # z = 0.4 + sqrt(0.02^2 - 0.015^2), less than over the top
    lift = 0.1 + np.sqrt(0.02**2 - 0.015**2)
    assert req[2] == pytest.approx(lift, abs=1e-12) and h[2] == pytest.approx(lift, abs=1e-12)
    assert h[3] == 0 and req[3] == 0  # beyond the influence distance


def test_intrusion_is_continuous_across_the_footprint_edge() -> None:
    box = Box((0.0, 0.0, 0.2), (0.1, 0.1, 0.4))
    y = np.linspace(-0.2, 0.2, 4001)
    p = np.stack([np.zeros_like(y), y, np.full_like(y, 0.3)], axis=1)
    h, _ = intrusion(box, p, Z, margin=0.02, influence=0.03)
    # continuous; the rounded edge rises like sqrt(2 margin dy) at the margin's edge
    assert np.abs(np.diff(h)).max() <= np.sqrt(2 * 0.02 * 1e-4) + 1e-9


def test_intrusion_sphere() -> None:
    s = Sphere((0.0, 0.0, 0.3), 0.1)
    h, req = intrusion(s, np.array([[0.0, 0.0, 0.3], [0.06, 0.0, 0.3]]), Z, 0.02, 0.03)
    np.testing.assert_allclose(req, [0.12, np.sqrt(0.12**2 - 0.06**2)], atol=1e-12)
    np.testing.assert_allclose(h, req, atol=1e-12)


def test_variance_level_is_relative_to_the_model_and_scale_free() -> None:
    sigma = np.linspace(0.001, 0.03, 21)
    cov = np.stack([np.diag([s**2, s**2, s**2]) for s in sigma])
    nu = variance_level(cov)
    # cbrt of an isotropic determinant is sigma^2; the reference is the 90th percentile
    # of the variance (nu = 1 over the tenth of the movement that disagrees most)
    ref = np.quantile(sigma**2, 0.9)
    np.testing.assert_allclose(nu, np.minimum(sigma**2 / ref, 1.0), rtol=1e-12)
    assert nu.min() > 0.0 and np.all(np.diff(nu) >= 0) and (nu == 1.0).sum() == 3
    # the same model in other units (x1000, variance x1e6) has the same level
    np.testing.assert_allclose(variance_level(cov * 1e6), nu, rtol=1e-9)
    # along a direction n: n^T Sigma n (isotropic: the same as without a direction)
    z = np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(variance_level(cov, z), nu, rtol=1e-12)
    aniso = np.stack([np.diag([0.01**2, 0.02**2, s**2]) for s in sigma])
    np.testing.assert_allclose(variance_level(aniso, z), nu, rtol=1e-12)
    np.testing.assert_allclose(variance_level(aniso, np.array([1.0, 0.0, 0.0])), 1.0)
    n = np.array([0.0, 0.6, 0.8])
    v = 0.36 * 0.02**2 + 0.64 * sigma**2
    np.testing.assert_allclose(
        variance_level(aniso, n), np.minimum(v / np.quantile(v, 0.9), 1.0), rtol=1e-12
    )
    v = np.cbrt(0.01**2 * 0.02**2 * sigma**2)
    np.testing.assert_allclose(
        variance_level(aniso), np.minimum(v / np.quantile(v, 0.9), 1.0), rtol=1e-12
    )
    # demonstrations that agree exactly: no variance term
    np.testing.assert_array_equal(variance_level(np.zeros((5, 3, 3)), z), np.zeros(5))
    np.testing.assert_allclose(variance_weight(cov, 15.0), 15.0 * nu, rtol=1e-12)
    np.testing.assert_allclose(variance_weight(aniso, 15.0, n), 15.0 * variance_level(aniso, n))
