"""The Panda's top-down reach near its base: the band, a path kept outside it, the refusal."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dexlfd.apps.teach_frame import _default_pick, _top_down_fits
from dexlfd.errors import InvalidInput
from dexlfd.geometry import Box
from dexlfd.io import LearnedModel
from dexlfd.plan.config import PlanConfig
from dexlfd.plan.feasibility import reachable
from dexlfd.plan.obstacles import distance
from dexlfd.plan.planner import plan_motion
from dexlfd.plan.reach import (
    RADIUS_MARGIN,
    check_top_down,
    push_outside_radius,
    reach_clear,
    top_down_radius,
)
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


def _carry_past_the_place() -> LearnedModel:
    """A carry over a box that overshoots past its place towards the base and comes back.

    As a real recording's (its pick at (0.5, -0.15), its place 0.3 m from the axis): up
    to 0.18 m, across, down to 0.22 m from the axis and back out to the place.
    """
    T, m = 1.4, 300
    t = np.linspace(0.0, T, m)
    u = t / T
    knots = [(0.0, (0.5, -0.15, 0.062)), (0.25, (0.45, -0.2, 0.177)),
             (0.45, (0.3, -0.14, 0.177)), (0.8, (0.18, -0.125, 0.035)),
             (1.0, (0.27, -0.13, 0.062))]  # fmt: skip
    pos = np.tile(np.array(knots[0][1]), (m, 1))
    for (ua, a), (ub, b) in zip(knots[:-1], knots[1:], strict=True):
        s = np.clip((u - ua) / (ub - ua), 0.0, 1.0)
        pos += (s**3 * (10 - 15 * s + 6 * s * s))[:, None] * (np.array(b) - np.array(a))
    mean = np.concatenate([pos, np.tile([1.0, 0.0, 0.0, 0.0], (m, 1)), np.zeros((m, 1))], 1)
    cov = np.zeros((m, 8, 8))
    cov[:, :3, :3] = 0.005**2 * np.eye(3)
    cov[:, 3:7, 3:7] = 1e-4 * np.eye(4)
    cov[:, 7, 7] = 1e-6
    data = np.concatenate([t[:, None], mean], axis=1)
    return LearnedModel(
        t=t, mean=mean, cov=cov, gmm_weights=np.ones(1), gmm_means=data.mean(axis=0)[None],
        gmm_covs=np.cov(data.T)[None] + 1e-9 * np.eye(9)[None], meta={"source": "test"},
    )  # fmt: skip


def test_the_move_outward_of_the_band_keeps_the_margin_from_the_box_it_passed() -> None:
    """The move outward came after the bend over the box and took the descent onto it.

    Moved 70 mm outward, the path came down 1.6 mm from the box (the margin is 20 mm,
    only warned); the move is now bent round the box again, and both hold.
    """
    model = _carry_past_the_place()
    box = Box((0.385, -0.15, 0.07), (0.14, 0.2, 0.14))
    cfg = PlanConfig(
        task="motion", start=tuple(model.mean[0, :3]), goal=tuple(model.mean[-1, :3]),
        start_quat=(1.0, 0.0, 0.0, 0.0), goal_quat=(1.0, 0.0, 0.0, 0.0),
        start_velocity="zero", top_down_reach=True, z_floor=0.062, obstacles=(box,),
    )  # fmt: skip
    assert np.hypot(model.mean[:, 0], model.mean[:, 1]).min() < 0.23  # inside the band
    # without the box: moved outward of the band, down across where the box stands
    free = plan_motion(model, dataclasses.replace(cfg, obstacles=()), quiet_limits=True)
    assert np.hypot(free.position[:, 0], free.position[:, 1]).min() > 0.28
    assert distance(box, free.position).min() < cfg.margin
    plan = plan_motion(model, cfg, quiet_limits=True)
    assert distance(box, plan.position).min() >= cfg.margin - 1e-6
    assert plan.obstacle_passes[0].min_clearance >= cfg.margin - 1e-6
    x = plan.position
    inner = top_down_radius(x[:, 2])[0] + RADIUS_MARGIN
    assert np.all(np.hypot(x[:, 0], x[:, 1]) >= inner - 1e-6)  # still outside the band
    np.testing.assert_allclose(x[[0, -1]], np.array([cfg.start, cfg.goal]), atol=2e-3)


def test_a_move_outward_that_cannot_keep_the_margin_is_refused_naming_the_obstacle() -> None:
    tb = np.linspace(0.0, 1.0, 1001)
    path = _path(tb)
    moved, _ = push_outside_radius(tb, path)
    k = int(np.argmax(np.linalg.norm(moved[0] - path[0], axis=1)))
    box = Box(tuple(moved[0][k]), (0.02, 0.02, 0.02))  # where the move takes it
    calls = []

    def bend(p: tuple[np.ndarray, np.ndarray, np.ndarray]) -> tuple[tuple, None]:
        calls.append(p)
        return path, None  # each bend takes it back inside the band: moved onto the box

    with pytest.raises(InvalidInput, match=r"^moved \d+ mm outward .* obstacle 0 \(box:") as e:
        reach_clear(tb, path, bend, (box,), 0.02)
    assert "\n" not in str(e.value) and len(calls) > 1  # bent again before refusing
    # with nothing near, one bend and the move
    calls.clear()
    same, _, pushed = reach_clear(tb, path, bend, (), 0.02)
    assert len(calls) == 1
    np.testing.assert_array_equal(same[0], moved[0])
    assert pushed > 0.0
