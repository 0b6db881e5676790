from __future__ import annotations

import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.learn import align_to_reference, dtw, warp_to_reference


def _curve(u: np.ndarray) -> np.ndarray:
    return np.stack([np.sin(2 * np.pi * u), u**2, np.cos(np.pi * u)], 1)


def test_many_to_one_matches_are_averaged() -> None:
    x = np.array([[0.0], [1.0], [2.0], [3.0], [10.0]])
    # samples 1, 2, 3 of x all match reference sample 1; sample 4 matches reference 2 and 3
    path = np.array([[0, 0], [1, 1], [2, 1], [3, 1], [4, 2], [4, 3]])
    out = warp_to_reference(x, path, 4)
    np.testing.assert_allclose(out[:, 0], [0.0, 2.0, 10.0, 10.0], rtol=1e-12)
    with pytest.raises(InvalidInput, match="cover"):
        warp_to_reference(x, path, 5)


def test_warped_copies_are_put_back_on_the_reference(rng: np.random.Generator) -> None:
    ref_u = np.linspace(0, 1, 200)
    series = [_curve(ref_u)]
    for n, p in [(150, 1.4), (260, 0.7), (180, 1.2)]:
        u = np.linspace(0, 1, n)
        series.append(_curve(u**p))
    res = align_to_reference(series, reference=0)
    assert res.aligned.shape == (4, 200, 3) and res.reference_index == 0
    np.testing.assert_array_equal(res.aligned[0], series[0])
    # time-warped copies of the same curve: aligned within a few sampling steps of the curve
    assert np.abs(res.aligned[1:] - series[0][None]).max() < 0.08
    assert res.distances[0] == 0 and (res.distances[1:] > 0).all()
    for i, path in enumerate(res.paths):
        assert path[-1].tolist() == [len(series[i]) - 1, 199]


def test_medoid_is_least_total_distance(rng: np.random.Generator) -> None:
    base = np.linspace(0, 1, 100)
    series = [_curve(base) + rng.normal(0, s, (100, 3)) for s in (0.05, 0.01, 0.02, 0.08, 0.3)]
    res = align_to_reference(series)
    scale = res.scale
    N = len(series)
    brute = np.zeros((N, N))
    for a in range(N):
        for b in range(N):
            if a != b:
                brute[a, b] = dtw(series[a], series[b], scale=scale).normalized_cost
    assert res.pairwise is not None
    np.testing.assert_allclose(res.pairwise, brute, rtol=1e-12, atol=1e-15)
    assert res.reference_index == int(np.argmin(brute.sum(axis=1)))
    # the paths to the reference are oriented (series sample, reference sample)
    for i, path in enumerate(res.paths):
        assert path[-1].tolist() == [len(series[i]) - 1, len(series[res.reference_index]) - 1]
        np.testing.assert_allclose(
            res.distances[i], brute[i, res.reference_index], rtol=1e-12, atol=1e-15
        )


def test_reference_by_index_and_band(rng: np.random.Generator) -> None:
    series = [rng.normal(size=(n, 2)) for n in (30, 40, 35)]
    res = align_to_reference(series, reference=2, band_fraction=0.2)
    assert res.reference_index == 2 and res.aligned.shape == (3, 35, 2)
    assert res.pairwise is None


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"reference": 3}, "out of range"),
        ({"reference": "first"}, "medoid"),
        ({"reference": 1.5}, "index"),
        ({"band_fraction": 0.0}, "band_fraction"),
        ({"scale": np.array([1.0, -1.0])}, "scale"),
    ],
)
def test_bad_arguments(rng: np.random.Generator, kwargs: dict, match: str) -> None:
    series = [rng.normal(size=(10, 2)) for _ in range(3)]
    with pytest.raises(InvalidInput, match=match):
        align_to_reference(series, **kwargs)


def test_bad_series(rng: np.random.Generator) -> None:
    with pytest.raises(InvalidInput, match="at least one"):
        align_to_reference([])
    with pytest.raises(InvalidInput, match=r"series\[1\] has 3 channels"):
        align_to_reference([rng.normal(size=(10, 2)), rng.normal(size=(10, 3))])
    bad = rng.normal(size=(10, 2))
    bad[3, 1] = np.nan
    with pytest.raises(InvalidInput, match=r"series\[1\].*finite"):
        align_to_reference([rng.normal(size=(10, 2)), bad])
