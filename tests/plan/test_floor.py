"""A planned motion that dips under its floor is lifted above it, smoothly, ends kept."""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.io import LearnedModel
from dexlfd.plan.floor import RAMP, floor_lift, lift_above_floor

from .conftest import planned_with_carry


def _dip(tb: np.ndarray, depth: float, centre: float, width: float) -> np.ndarray:
    """0.2 m high path with a cosine dip of ``depth`` [m] around ``centre``."""
    u = np.clip((tb - centre) / width + 0.5, 0.0, 1.0)
    return 0.2 - depth * np.sin(np.pi * u) ** 2


def test_lift_takes_every_sample_above_the_floor_and_keeps_the_ends() -> None:
    tb = np.linspace(0.0, 1.0, 2001)
    z = _dip(tb, 0.25, 0.5, 0.4)  # down to -0.05 m
    lift, d_lift, dd_lift = floor_lift(tb, z, 0.03)
    assert np.all(z + lift >= 0.03 - 1e-12)
    assert lift.max() == pytest.approx(0.03 - z.min())  # the deepest dip, no more
    # the ends, their velocity and acceleration are untouched
    for a in (lift, d_lift, dd_lift):
        assert a[0] == 0.0 and a[-1] == 0.0
    # the derivatives are the lift's (closed form against finite differences)
    h = tb[1] - tb[0]
    np.testing.assert_allclose(np.gradient(lift, h)[2:-2], d_lift[2:-2], atol=2e-3)
    np.testing.assert_allclose(np.gradient(d_lift, h)[2:-2], dd_lift[2:-2], atol=0.3)
    # it ramps over at most RAMP before and after the dip, and is flat under it
    below = np.flatnonzero(z < 0.03)
    lifted = np.flatnonzero(lift > 0)
    assert tb[below[0]] - tb[lifted[0]] <= RAMP + h
    assert tb[lifted[-1]] - tb[below[-1]] <= RAMP + h
    assert np.ptp(lift[below]) == pytest.approx(0.0, abs=1e-12)


def test_no_dip_no_lift_and_a_dip_near_an_end_ramps_within_the_motion() -> None:
    tb = np.linspace(0.0, 1.0, 1001)
    path = (np.zeros((tb.size, 3)), np.zeros((tb.size, 3)), np.zeros((tb.size, 3)))
    path[0][:, 2] = _dip(tb, 0.1, 0.5, 0.4)
    same, peak = lift_above_floor(tb, path, 0.05)
    assert peak == 0.0
    for a, b in zip(same, path, strict=True):
        np.testing.assert_array_equal(a, b)
    assert lift_above_floor(tb, path, None) == (path, 0.0)
    # a dip 0.05 from the start: the ramp in fits in 0.05, the start stays at rest
    z = _dip(tb, 0.25, 0.1, 0.1)
    lift, d_lift, _ = floor_lift(tb, z, 0.03)
    assert np.all(z + lift >= 0.03 - 1e-12)
    assert lift[0] == 0.0 and d_lift[0] == 0.0


def test_a_dip_that_runs_into_the_end_eases_out_instead_of_jumping() -> None:
    # a path that ends on the floor, coming up from 8.7 cm below it over the last
    # quarter (a carry that approaches its place from inside the unreachable band):
    # the lift eases down with the path instead of dropping the whole dip in the few
    # samples after its last one below the floor
    tb = np.linspace(0.0, 1.0, 1368)
    u = np.clip((tb - 0.75) / 0.25, 0.0, 1.0)
    z = np.where(tb < 0.5, 0.1 - 0.187 * np.sin(np.pi * tb) ** 2, -0.087 * (1.0 - u) ** 3)
    z[-12:] = np.linspace(-1e-4, 2e-4, 12)  # just under, then on the floor at the end
    lift, d_lift, dd_lift = floor_lift(tb, z, 0.0)
    assert np.all(z + lift >= -1e-12)
    assert lift[-1] == 0.0 and d_lift[-1] == 0.0 and dd_lift[-1] == 0.0
    # the ramp down is no steeper than a minimum-jerk ramp of the dip over 5 % of the
    # motion (a squeezed one: over the 12 samples left, about 1e4 times this)
    assert np.abs(dd_lift).max() <= 5.78 * 0.087 / 0.05**2


def test_an_end_below_the_floor_stays_where_it_is() -> None:
    tb = np.linspace(0.0, 1.0, 501)
    x = np.zeros((tb.size, 3))
    x[:, 2] = np.linspace(0.01, 0.2, tb.size)  # starts under the floor 0.05
    (lifted, _, _), peak = lift_above_floor(tb, (x, x * 0, x * 0), 0.05)
    assert peak == 0.0 and lifted[0, 2] == pytest.approx(0.01)


def test_a_sagging_carry_is_planned_above_the_pick_not_refused(event_model: LearnedModel) -> None:
    """A learned carry that sags 25 cm, planned from a pick on the table: lifted, not refused.

    Without the floor the carry went 77 mm under the table and the plan was refused.
    """
    planned_with_carry(event_model, lambda u: -0.25 * np.sin(np.pi * u) ** 2)
