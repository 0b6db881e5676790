from __future__ import annotations

import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.learn import assess_quality


def test_far_demo_is_flagged_reference_never() -> None:
    d = np.array([0.10, 0.11, 0.0, 0.09, 0.105, 0.5, 0.095])
    q = assess_quality(d, reference_index=2)
    assert q.outlier.tolist() == [False, False, False, False, False, True, False]
    # modified z by hand over the 6 non-reference distances
    v = np.delete(d, 2)
    med = np.median(v)
    mad = max(np.median(np.abs(v - med)), 0.1 * med)  # floored MAD
    np.testing.assert_allclose(q.robust_z[5], 0.6745 * (0.5 - med) / mad, rtol=1e-12)
    assert q.robust_z[2] == 0.0


def test_close_demo_is_not_an_outlier() -> None:
    d = np.array([0.0, 0.1, 0.1, 0.1, 0.1, 0.001])
    q = assess_quality(d, 0)
    assert not q.outlier.any()


def test_too_few_demos_gives_note() -> None:
    q = assess_quality(np.array([0.0, 0.1, 5.0]), 0)
    assert not q.outlier.any() and "at least" in q.note


def test_small_mad_is_floored() -> None:
    # five inliers agree closely by chance; one 45 % further is not an outlier, 9x is
    d = np.array([0.0, 0.122, 0.118, 1.47, 0.178, 0.123])
    q = assess_quality(d, 0)
    assert q.outlier.tolist() == [False, False, False, True, False, False]
    d0 = np.array([0.0, 0.1, 0.1, 0.1, 0.1, 0.1, 0.9])  # MAD exactly 0
    q0 = assess_quality(d0, 0)
    assert q0.outlier.tolist() == [False] * 6 + [True]
    np.testing.assert_allclose(q0.robust_z[6], 0.6745 * 0.8 / 0.01, rtol=1e-12)
    q2 = assess_quality(np.array([0.0, 0.0, 0.0, 0.0, 0.0]), 0)
    assert not q2.outlier.any() and "0: no outliers" in q2.note


def test_bad_input() -> None:
    with pytest.raises(InvalidInput, match="reference_index"):
        assess_quality(np.array([0.0, 1.0]), 5)
    with pytest.raises(InvalidInput, match="finite"):
        assess_quality(np.array([0.0, np.nan]), 0)
    with pytest.raises(InvalidInput, match="threshold"):
        assess_quality(np.array([0.0, 1.0]), 0, threshold=0)


def test_two_modes_are_detected(rng: np.random.Generator) -> None:
    # two groups of 3: close within, far between
    pts = np.concatenate([rng.normal(0, 0.01, (3, 2)), rng.normal(1, 0.01, (3, 2))])
    P = np.linalg.norm(pts[:, None] - pts[None], axis=2)
    q = assess_quality(P[0], 0, pairwise=P)
    assert q.modes is not None and q.mode_separation > 5
    assert len(set(q.modes[:3])) == 1 and len(set(q.modes[3:])) == 1 and q.modes[0] != q.modes[3]
    # one group with spread: no modes
    one = rng.normal(0, 1, (6, 2))
    P1 = np.linalg.norm(one[:, None] - one[None], axis=2)
    q1 = assess_quality(P1[0], 0, pairwise=P1)
    assert q1.modes is None and q1.mode_separation < 5
