from __future__ import annotations

import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.learn import mean_filter
from dexlfd.learn.filtering import _trace, filter_reduces_risk
from dexlfd.trajectory import FILTER_MODES


def naive_centred_mean(x: np.ndarray, k: int) -> np.ndarray:
    """Eq. (4.15) where the full window fits; even k: mean of the two straddling windows."""
    n = len(x)
    out = np.full(x.shape, np.nan)
    r = k // 2
    for i in range(r, n - r):
        if k % 2:
            out[i] = x[i - r : i + r + 1].mean(axis=0)
        else:
            out[i] = 0.5 * (x[i - r : i + r].mean(axis=0) + x[i - r + 1 : i + r + 1].mean(axis=0))
    return out


@pytest.mark.parametrize("k", [1, 2, 3, 5, 10, 11])
@pytest.mark.parametrize("mode", FILTER_MODES)
def test_interior_is_eq_4_15(rng: np.random.Generator, k: int, mode: str) -> None:
    x = rng.normal(size=(60, 3))
    y = mean_filter(x, k, mode=mode)
    assert y.shape == x.shape
    ref = naive_centred_mean(x, k)
    inner = ~np.isnan(ref[:, 0])
    np.testing.assert_allclose(y[inner], ref[inner], rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("mode", ["linear", "shrink"])
def test_linear_ramp_and_constant_pass_unchanged(mode: str) -> None:
    t = np.linspace(0, 3, 47)
    x = np.stack([2.0 + 0.7 * t, np.full_like(t, -1.5)], 1)
    np.testing.assert_allclose(mean_filter(x, 10, mode=mode), x, rtol=1e-12, atol=1e-12)


def test_nearest_mode_pulls_ramp_ends_inwards() -> None:
    x = np.arange(30.0)
    y = mean_filter(x, 10, mode="nearest")
    assert y[0] > x[0] and y[-1] < x[-1]
    np.testing.assert_allclose(y[5:-5], x[5:-5], rtol=1e-12)


def test_noise_is_reduced_everywhere_linear_mode(rng: np.random.Generator) -> None:
    noise = rng.normal(size=(40, 4000))  # 4000 independent series of 40 samples
    y = mean_filter(noise, 10)
    sd = y.std(axis=1)
    # interior: 2x10 moving average, sum of squared weights 0.095; ends: LS line at the end
    # of a 10-point fit, variance (4k-2)/(k(k+1)) = 38/110. Sample std of 4000: ~2 % error.
    np.testing.assert_allclose(sd[10:30], np.sqrt(0.095), rtol=0.06)
    np.testing.assert_allclose(sd[[0, -1]], np.sqrt(38 / 110), rtol=0.06)
    assert (sd < 0.65).all()


def test_short_series_and_identity(rng: np.random.Generator) -> None:
    x = rng.normal(size=(3, 2))
    for mode in FILTER_MODES:
        assert mean_filter(x, 10, mode=mode).shape == (3, 2)
    np.testing.assert_array_equal(mean_filter(x, 1), x)
    np.testing.assert_array_equal(mean_filter(np.zeros((0, 2)), 5), np.zeros((0, 2)))
    one = mean_filter(np.array([[1.0, 2.0]]), 10)
    np.testing.assert_array_equal(one, [[1.0, 2.0]])
    v = rng.normal(size=20)
    assert mean_filter(v, 4).shape == (20,)


def test_does_not_mutate_input(rng: np.random.Generator) -> None:
    x = rng.normal(size=(30, 2))
    before = x.copy()
    mean_filter(x, 10)
    np.testing.assert_array_equal(x, before)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"k": 0}, "window"),
        ({"k": 2.5}, "window"),
        ({"k": True}, "window"),
        ({"k": 3, "mode": "reflect"}, "mode"),
    ],
)
def test_bad_arguments(kwargs: dict, match: str) -> None:
    with pytest.raises(InvalidInput, match=match):
        mean_filter(np.zeros((10, 2)), **kwargs)


def test_bad_data() -> None:
    with pytest.raises(InvalidInput, match="finite"):
        mean_filter(np.array([0.0, np.nan, 1.0]), 3)
    with pytest.raises(InvalidInput, match="shape"):
        mean_filter(np.zeros((3, 2, 2)), 3)


@pytest.mark.parametrize("mode", FILTER_MODES)
@pytest.mark.parametrize(("n", "k"), [(40, 10), (41, 7), (25, 4)])
def test_trace_of_the_filter_matches_the_filtered_identity(n: int, k: int, mode: str) -> None:
    # oracle: the filter is linear, so S = mean_filter(I) and tr S is its diagonal sum
    assert _trace(n, k, mode) == pytest.approx(np.trace(mean_filter(np.eye(n), k, mode=mode)))


def test_filter_is_chosen_only_where_there_is_noise_to_remove() -> None:
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 2.0, 300)
    smooth = np.stack([np.sin(3 * t), np.cos(2 * t), np.full_like(t, 0.7)], axis=1)
    noisy = [smooth + rng.normal(0.0, 0.01, smooth.shape) * [1, 1, 0] for _ in range(3)]
    assert filter_reduces_risk(noisy, 10)
    assert not filter_reduces_risk([smooth, smooth[::-1]], 10)  # noise-free: only bias
    assert not filter_reduces_risk([np.ones((50, 2))], 10)  # constant: no noise at all
    assert not filter_reduces_risk([noisy[0][:15]], 10)  # shorter than 2 windows
    # the rule is SURE(S) < SURE(I): on the noisy set the filtered series is indeed
    # closer to the noise-free one than the raw samples are
    err_raw = np.mean([(x - smooth)[:, :2] ** 2 for x in noisy])
    err_filt = np.mean([(mean_filter(x, 10) - smooth)[:, :2] ** 2 for x in noisy])
    assert err_filt < err_raw
