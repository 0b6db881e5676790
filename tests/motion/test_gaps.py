"""One gap rule for the motion stage (keypoints) and the learning stage (demonstrations)."""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.errors import InvalidDemonstration
from dexlfd.learn import fill_gaps as learn_fill_gaps
from dexlfd.motion.gaps import fill_gaps, fill_short_gaps, find_gaps


def _series() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(30) / 10.0  # 10 Hz
    x = np.stack([np.sin(t), t**2, np.cos(3 * t)], axis=1)
    valid = np.ones(30, bool)
    valid[[0, 1, 7, 8, 15, 16, 17, 29]] = False  # ends, a 0.3 s gap, a 0.4 s gap
    return t, x, valid


def test_learning_uses_the_motion_stages_gap_filling() -> None:
    assert learn_fill_gaps is fill_gaps


def test_both_policies_fill_the_same_short_gaps_the_same_way() -> None:
    t, x, valid = _series()
    raw = np.where(valid[:, None], x, np.nan)
    tt, filled = fill_gaps(t, raw, valid, max_gap_s=0.4)
    kp, v, mark = fill_short_gaps(t, raw[:, :, None], valid, max_gap_s=0.4)
    # the learning policy trims the invalid ends (2 at the start, 1 at the end)
    np.testing.assert_array_equal(tt, t[2:29])
    np.testing.assert_allclose(filled, kp[2:29, :, 0], rtol=0, atol=1e-15)
    assert mark.tolist() == [i in (7, 8, 15, 16, 17) for i in range(30)]
    assert not v[[0, 1, 29]].any()  # the motion policy invents nothing at the ends
    # linear in time between the seen neighbours (closed form)
    w = (t[7] - t[6]) / (t[9] - t[6])
    np.testing.assert_allclose(filled[7 - 2], (1 - w) * x[6] + w * x[9])


def test_a_gap_longer_than_the_limit_is_kept_or_rejected() -> None:
    t, x, valid = _series()
    raw = np.where(valid[:, None], x, np.nan)
    gaps = [g for g in find_gaps(t, valid) if g.interior]
    assert [round(g.duration_s, 9) for g in gaps] == [0.3, 0.4]
    assert [g.is_short(0.3) for g in gaps] == [True, False]
    kp, v, _ = fill_short_gaps(t, raw, valid, max_gap_s=0.3)
    assert v[7:9].all() and not v[15:18].any() and np.isnan(kp[15:18]).all()
    with pytest.raises(InvalidDemonstration, match=r"demo: invalid frames from t=1.400 s"):
        fill_gaps(t, raw, valid, max_gap_s=0.3, name="demo")
