"""A carry comes down onto its place once: no dip under the place and back up before it."""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.io import LearnedModel
from dexlfd.plan.descent import RISE_TOL, climbs_back, descend_once

from .conftest import planned_with_carry


def _path(z: np.ndarray, tb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A vertical path (x, x', x'') with height ``z``, its derivatives by differences."""
    x = np.zeros((tb.size, 3))
    x[:, 2] = z
    xd, xdd = np.zeros_like(x), np.zeros_like(x)
    xd[:, 2] = np.gradient(z, tb)
    xdd[:, 2] = np.gradient(xd[:, 2], tb)
    return x, xd, xdd


def _smooth(u: np.ndarray) -> np.ndarray:
    u = np.clip(u, 0.0, 1.0)
    return u**3 * (10 - 15 * u + 6 * u * u)


def _check_bridged(tb: np.ndarray, before: tuple, after: tuple) -> None:
    """Non-increasing after the top, never lower than planned, ends kept, derivatives its own."""
    z0, z = before[0][:, 2], after[0][:, 2]
    p = int(np.argmax(z))
    assert np.all(np.diff(z[p:]) <= 1e-12)
    assert np.all(z >= z0 - 1e-9)
    # the ends (at rest; the test paths' derivatives are differences, one-sided there)
    for a, b, tol in zip(before, after, (1e-12, 1e-4, 0.1), strict=True):
        np.testing.assert_allclose(b[[0, -1]], a[[0, -1]], atol=tol)
    h = tb[1] - tb[0]
    np.testing.assert_allclose(np.gradient(z, h)[2:-2], after[1][2:-2, 2], atol=2e-3)
    np.testing.assert_allclose(np.gradient(after[1][:, 2], h)[2:-2], after[2][2:-2, 2], atol=0.3)


def test_a_descent_past_the_goal_that_climbs_back_is_bridged_above_it() -> None:
    # down from 0.3 m to 4 cm under the goal 0.05 m, then back up to it at the end
    tb = np.linspace(0.0, 1.0, 2001)
    z = 0.3 - 0.29 * _smooth((tb - 0.2) / 0.6) + 0.04 * _smooth((tb - 0.8) / 0.2)
    path = _path(z, tb)
    assert climbs_back(z) == pytest.approx(0.04, abs=1e-6)
    bridged, lift, ok = descend_once(tb, path)
    assert ok and lift == pytest.approx(0.04, abs=1e-3)
    _check_bridged(tb, path, bridged)


def test_a_dip_before_the_rest_of_the_descent_is_bridged_and_the_descent_resumes() -> None:
    # down to 0.1 m, 4 cm under it and back, then on down to 0.05 m
    tb = np.linspace(0.0, 1.0, 2001)
    z = (0.3 - 0.2 * _smooth(tb / 0.4) - 0.04 * np.sin(np.pi * np.clip((tb - 0.4) / 0.2, 0, 1)) ** 4
         - 0.05 * _smooth((tb - 0.6) / 0.4))  # fmt: skip
    path = _path(z, tb)
    bridged, lift, ok = descend_once(tb, path)
    assert ok and lift > 0.03
    _check_bridged(tb, path, bridged)
    # the descent after the dip is the planned one again
    late = tb > 0.9
    np.testing.assert_array_equal(bridged[0][late], path[0][late])


def test_two_stretches_that_climb_back_are_bridged_each() -> None:
    # a 2 mm sag while the path hovers at 0.2 m, then on down to 0.12 m, 8 mm under it
    # and back up at the end (seen on a real carry): one bridge for all would have to
    # leave the hover early and pass under it
    tb = np.linspace(0.0, 1.0, 4001)

    def bump(c: float, w: float) -> np.ndarray:
        return np.sin(np.pi * np.clip((tb - c) / w + 0.5, 0, 1)) ** 4

    z = (0.3 - 0.1 * _smooth(tb / 0.3) - 0.002 * bump(0.45, 0.2)
         - 0.08 * _smooth((tb - 0.6) / 0.2) - 0.008 * bump(0.9, 0.2))  # fmt: skip
    path = _path(z, tb)
    bridged, lift, ok = descend_once(tb, path)
    assert ok and lift == pytest.approx(0.008, abs=1e-3)
    _check_bridged(tb, path, bridged)
    # the descent between them is the planned one
    middle = (tb > 0.62) & (tb < 0.7)
    np.testing.assert_array_equal(bridged[0][middle], path[0][middle])


def test_a_path_that_descends_once_is_kept() -> None:
    tb = np.linspace(0.0, 1.0, 1001)
    path = _path(0.05 + 0.2 * np.sin(np.pi * tb) ** 2 * (tb < 0.5) + 0.2 * (tb >= 0.5)
                 - 0.2 * _smooth((tb - 0.5) / 0.5), tb)  # fmt: skip
    same, lift, ok = descend_once(tb, path)
    assert ok and lift == 0.0 and same is path
    # a rise within the tolerance is no second descent
    z = path[0][:, 2] + 0.5 * RISE_TOL * np.sin(np.pi * np.clip((tb - 0.7) / 0.1, 0, 1))
    assert descend_once(tb, _path(z, tb))[1] == 0.0


def test_a_carry_that_dips_under_its_place_comes_down_onto_it_once(
    event_model: LearnedModel,
) -> None:
    """The learned carry dips 9 cm under the place and climbs back before the release.

    A person's carry off a shelf onto the table as taught from a real video: the
    demonstrated place 0.3 m under the pick and the learned mean under the place
    before it. Planned between a pick and a place on the table, the carry came down to
    the table 2 cm before the place, was lifted back up by the approach height (40
    mm) and lowered again: the robot set the object down twice.
    """
    plan = planned_with_carry(
        event_model,
        lambda u: -0.3 * _smooth(u) - 0.09 * np.sin(np.pi * np.clip((u - 0.6) / 0.4, 0, 1)) ** 2,
    )
    held = np.flatnonzero(plan.grasp)
    z = plan.position[held[0] : held[-1] + 1, 2]
    # from its highest point to the place the held object only comes down
    assert climbs_back(z) <= 1e-3
