import numpy as np
import pytest

from dexlfd.trajectory import MIN_JERK_PEAK_SPEED, minimum_jerk, resample


def test_minimum_jerk_closed_form_and_derivatives() -> None:
    u = np.linspace(0.0, 1.0, 20001)
    s, ds, dds = minimum_jerk(u)
    # rest to rest: value 0 -> 1, first and second derivative 0 at both ends
    assert (s[0], s[-1]) == (0.0, 1.0)
    np.testing.assert_allclose([ds[0], ds[-1], dds[0], dds[-1]], 0.0, atol=1e-12)
    assert s[10000] == pytest.approx(0.5)
    assert ds.max() == pytest.approx(MIN_JERK_PEAK_SPEED)
    # derivatives agree with finite differences of the profile
    # (interior points: np.gradient is one-sided and first order at the ends)
    np.testing.assert_allclose(np.gradient(s, u)[1:-1], ds[1:-1], atol=1e-6)
    np.testing.assert_allclose(np.gradient(ds, u)[1:-1], dds[1:-1], atol=1e-6)
    # held before and after the move
    assert minimum_jerk(np.array([-1.0, 2.0]))[0].tolist() == [0.0, 1.0]


def test_resample_is_columnwise_interp(rng: np.random.Generator) -> None:
    t = np.sort(rng.uniform(0, 2, 40))
    x = rng.normal(size=(40, 3, 2))
    t_new = np.linspace(-0.5, 2.5, 77)
    out = resample(t_new, t, x)
    assert out.shape == (77, 3, 2)
    for i in range(3):
        for j in range(2):
            np.testing.assert_array_equal(out[:, i, j], np.interp(t_new, t, x[:, i, j]))
    np.testing.assert_array_equal(resample(t_new, t, x[:, 0, 0]), np.interp(t_new, t, x[:, 0, 0]))
