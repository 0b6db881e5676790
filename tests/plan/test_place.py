"""Place, don't drop: the plan lowers the object onto the surface before opening."""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.control.rollout_report import object_report
from dexlfd.errors import InvalidInput
from dexlfd.plan import PlanConfig, place_correction, plan_from_model, release_index

from .conftest import reference_model

G = 9.81


def test_release_index_finds_the_opening_after_the_grasp() -> None:
    g = np.r_[np.full(10, 0.08), np.full(20, 0.04), np.full(10, 0.08)]
    t = 0.01 * np.arange(40)
    assert release_index(t, g) == 30
    assert release_index(t[:10], np.full(10, 0.08)) == -1  # no grasp
    g2 = np.r_[np.full(10, 0.08), np.full(25, 0.0)]
    assert release_index(t[:35], g2) == -1  # never opens
    # a moment closed at the start (0.1 s < min_duration_s) is no grasp; the main
    # (longest) closed run is the one released, not the first
    g3 = np.r_[np.full(10, 0.0), np.full(20, 0.08), np.full(20, 0.0), np.full(10, 0.08)]
    assert release_index(0.01 * np.arange(60), g3) == 50
    g4 = np.r_[np.full(18, 0.0), np.full(20, 0.08), np.full(30, 0.0), np.full(10, 0.08)]
    assert release_index(0.01 * np.arange(78), g4) == 68


def test_correction_rests_at_the_surface_then_returns() -> None:
    t = np.linspace(0.0, 6.0, 601)
    x = np.stack([np.full_like(t, 0.45), 0.05 * t, 0.2 + 0.01 * np.sin(t)], axis=1)
    xd = np.gradient(x, t, axis=0)
    xdd = np.gradient(xd, t, axis=0)
    grip = np.where((t > 1.0) & (t < 4.0), 0.04, 0.08)
    pc = place_correction(t, x, xd, xdd, grip, surface_z=0.05, object_bottom=0.03, press=0.0)
    z = x[:, 2] + pc.dz[:, 2]
    k = int(np.searchsorted(t, pc.release_t))
    assert pc.release_t == pytest.approx(4.0, abs=0.011)
    # standing still at the resting height from settle before to hold after release
    still = (t > pc.release_t - 0.29) & (t < pc.release_t + 0.2)
    np.testing.assert_allclose(z[still], 0.08, atol=1e-12)
    xy = (x[:, :2] + pc.dz[:, :2])[still]
    np.testing.assert_allclose(xy, np.tile(x[k, :2], (still.sum(), 1)), atol=1e-12)
    # untouched before the floor switches on (0.3 s before the lowering) and at the end;
    # derivatives consistent
    assert np.all(pc.dz[t < pc.release_t - 1.6] == 0) and np.all(pc.dz[-1] == 0)
    np.testing.assert_allclose(np.gradient(pc.dz, t, axis=0)[2:-2], pc.dzd[2:-2], atol=2e-3)


def test_no_room_for_the_ramps_is_refused() -> None:
    t = np.linspace(0.0, 2.0, 201)
    x = np.zeros((201, 3)) + [0.45, 0.0, 0.2]
    grip = np.where(t < 0.5, 0.04, 0.08)  # released at 0.5 s: no time to lower
    with pytest.raises(InvalidInput, match="no room"):
        place_correction(t, x, 0 * x, 0 * x, grip, surface_z=0.0, object_bottom=0.03)


def test_object_report_closed_forms() -> None:
    dt = 1e-3
    # carried at 0.20 m, released at t = 1 s, falls 0.1 m onto a surface at 0.10 m
    t = np.arange(0.0, 2.0, dt)
    h = 0.1
    z = np.where(t < 1.0, 0.2, np.maximum(0.2 - 0.5 * G * (t - 1.0) ** 2, 0.1))
    p = np.stack([np.full_like(t, 0.4), np.zeros_like(t), z], axis=1)
    q = np.tile([0.0, 0.0, 0.0, 1.0], (t.size, 1))
    rep = object_report(t, p, q, t < 1.0)
    assert rep["released_t"] == pytest.approx(1.0, abs=dt)
    assert rep["impact_speed"] == pytest.approx(np.sqrt(2 * G * h), rel=0.03)
    assert rep["tilt_deg"] == pytest.approx(0.0, abs=1e-9)
    # lowered at 2 cm/s while held, then released at rest: the impact is the lowering
    z2 = np.where(t < 0.5, 0.15, np.maximum(0.15 - 0.02 * (t - 0.5), 0.1))
    p2 = p.copy()
    p2[:, 2] = z2
    rep2 = object_report(t, p2, q, t < 3.2)  # held beyond the touchdown at 3.0 s
    assert rep2["released_t"] is None  # never let go within the record
    rep2 = object_report(t, p2, q, t < 1.8)
    assert rep2["impact_speed"] == pytest.approx(0.02, rel=0.05)
    # a box tipped over by 90 degrees about x
    s = np.sqrt(0.5)
    q3 = q.copy()
    q3[-1] = [s, 0.0, 0.0, s]
    assert object_report(t, p, q3, t < 1.0)["tilt_deg"] == pytest.approx(90.0)


def test_plan_places_on_the_surface_and_records_it() -> None:
    model = reference_model()
    plan = plan_from_model(model, PlanConfig(rate_hz=200, place_surface_z=0.05))
    place = plan.place_correction
    k = int(np.searchsorted(plan.t, place.release_t))
    assert plan.position[k, 2] == pytest.approx(0.05 + 0.03, abs=1e-9)  # resting, not pressed
    assert np.linalg.norm(plan.velocity[k]) < 1e-6  # standing still when it lets go
    assert place.support.size[2] == pytest.approx(0.05)
    np.testing.assert_allclose(plan.position[-1], model.mean[-1, :3], atol=1e-9)
    with pytest.raises(InvalidInput, match="place_surface_z"):
        PlanConfig(place_surface_z=-0.1)
