"""The Panda's top-down reach near its base: the band, a path kept outside it, the refusal."""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.apps.teach_frame import _default_pick, _top_down_fits
from dexlfd.errors import InvalidInput
from dexlfd.plan.feasibility import reachable
from dexlfd.plan.reach import RADIUS_MARGIN, check_top_down, push_outside_radius, top_down_radius
from dexlfd.plan.task_poses import top_down


@pytest.mark.parametrize("z", [0.06, 0.1, 0.15])
def test_inside_the_band_ik_from_the_ready_pose_reaches_nearer_it_does_not(z: float) -> None:
    lo, hi = (float(v) for v in top_down_radius(z))
    assert 0.2 < lo < 0.35 and 0.7 < hi < 0.86  # the Panda's: 0.28 at 6 cm, reach 0.855
    for ang in (-30.0, 0.0, 30.0):
        a = np.radians(ang)
        for yaw in (-60.0, 0.0, 60.0):
            q = top_down(np.radians(yaw + ang))
            near = np.array([np.cos(a), np.sin(a), 0.0])
            assert reachable((lo + 0.01) * near + [0, 0, z], q) is None
            assert reachable((lo - 0.02) * near + [0, 0, z], q) is not None


def _path(tb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """From (0.5, -0.2, 0.3) to (0.45, 0.2, 0.1), bowing in to 0.15 m from the axis."""
    a, b = np.array([0.5, -0.2, 0.3]), np.array([0.45, 0.2, 0.1])
    bow = np.sin(np.pi * tb) ** 2
    x = a + (b - a) * tb[:, None]
    x[:, 0] -= 0.33 * bow
    return x, np.gradient(x, tb, axis=0), np.gradient(np.gradient(x, tb, axis=0), tb, axis=0)


def test_a_path_through_the_inner_edge_is_moved_outward_ends_kept() -> None:
    tb = np.linspace(0.0, 1.0, 1001)
    path = _path(tb)
    r0 = np.hypot(path[0][:, 0], path[0][:, 1])
    inner = top_down_radius(path[0][:, 2])[0]
    assert (r0 < inner).any()  # it did pass too near
    (x, xd, _), pushed = push_outside_radius(tb, path)
    assert pushed > 0.0
    r = np.hypot(x[:, 0], x[:, 1])
    assert np.all(r >= inner + RADIUS_MARGIN - 1e-9)
    np.testing.assert_allclose(x[[0, -1]], path[0][[0, -1]], atol=1e-12)
    np.testing.assert_allclose(xd[[0, -1]], path[1][[0, -1]], atol=1e-12)
    np.testing.assert_allclose(x[:, 2], path[0][:, 2])  # only moved horizontally
    # a path that keeps clear is left as it is
    far = (path[0] + [0.4, 0.0, 0.0], path[1], path[2])
    same, none = push_outside_radius(tb, far)
    assert none == 0.0 and np.array_equal(same[0], far[0])


def test_a_carry_that_comes_back_out_to_a_place_on_the_inner_edge_is_not_jerked() -> None:
    # a learned carry that overshoots past its place towards the base and comes back
    # out to it, the place just on the band's inner edge (+ margin): the push eases
    # out as the path comes out, at rest at the place, not in the last milliseconds
    T, tb = 1.367, np.linspace(0.0, 1.0, 1368)
    a, place = np.array([0.5, -0.15, 0.136]), np.array([0.0, 0.0, 0.136])
    r_place = float(top_down_radius(0.136)[0]) + RADIUS_MARGIN + 2e-4
    place[:2] = r_place * np.array([0.905, -0.426])
    deep = place.copy()
    deep[:2] *= (r_place - 0.09) / r_place  # 9 cm nearer the axis than the place

    def mj(u: np.ndarray) -> np.ndarray:
        u = np.clip(u, 0.0, 1.0)
        return 10 * u**3 - 15 * u**4 + 6 * u**5

    # out to the overshoot by 0.6, back out to the place over the last quarter
    x = a + mj(tb / 0.6)[:, None] * (deep - a) + mj((tb - 0.75) / 0.25)[:, None] * (place - deep)
    xd = np.gradient(x, tb, axis=0)
    xdd = np.gradient(xd, tb, axis=0)
    (y, _, ydd), pushed = push_outside_radius(tb, (x, xd, xdd))
    assert pushed > 0.05
    np.testing.assert_allclose(y[-1], place, atol=1e-12)
    before = np.linalg.norm(xdd, axis=1).max() / T**2
    # the pushed carry's acceleration stays of the order of the carry's own (a push of
    # ~9 cm over the 10 ms after its last sample inside: ~5000 m/s^2)
    assert np.linalg.norm(ydd, axis=1).max() / T**2 < 2.0 * before


def test_a_top_down_pick_nearer_than_the_band_is_refused_in_one_line() -> None:
    with pytest.raises(InvalidInput, match=r"pick .* from the Panda's axis: a top-down hand"):
        check_top_down("pick", np.array([0.2, 0.09, 0.023]), 0.04)
    check_top_down("pick", np.array([0.45, -0.1, 0.023]), 0.04)


def test_a_long_carry_gets_a_default_pick_where_both_ends_are_in_reach() -> None:
    """A 0.61 m carry centred at (0.5, 0) would start 0.23 m from the axis, out of reach."""
    displacement = np.array([0.58, -0.18, 0.0])
    size = (0.046, 0.046, 0.046)
    pick = _default_pick(size, displacement, None)
    place = pick + displacement
    assert _top_down_fits(np.stack([pick, place])).all()
    for p in (pick, place):
        assert reachable(p, top_down(0.0)) is None
