"""The placement check: carried, where, how upright, how gently; every failing check named."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from dexlfd.control.grasp import placement_report
from dexlfd.control.rollout_report import object_report
from dexlfd.io.plan_facts import GraspSchedule
from dexlfd.io.rollout_facts import ObjectReport, Placement, TaskPoses
from dexlfd.rotations import quat_from_matrix

PICK = np.array([0.45, -0.25, 0.12])
PLACE = np.array([0.45, 0.25, 0.12])
DT = 1e-3


def _rollout(final_offset=(0.0, 0.0, 0.0), tilt_deg: float = 0.0, drop_m: float = 0.0):
    """An object carried from PICK to PLACE (+ offset), lowered at 0.05 m/s (or let go
    ``drop_m`` above the surface), ending tilted by ``tilt_deg`` about x."""
    end = PLACE + np.asarray(final_offset)
    t_carry, t_lower, t_rest = 2.0, 1.0, 1.0
    n1, n2, n3 = int(t_carry / DT), int(t_lower / DT), int(t_rest / DT)
    u = np.linspace(0.0, 1.0, n1)[:, None]
    carry = PICK + [0, 0, 0.05] + u * (end - PICK)
    high = end + [0.0, 0.0, 0.05]
    s = np.linspace(0.0, 1.0, n2)[:, None]
    lower = high + s * ([0.0, 0.0, -0.05 + drop_m])
    held_end = lower[-1]
    if drop_m > 0:  # free fall from held_end down to the surface
        tf = np.sqrt(2 * drop_m / 9.81)
        tt = np.arange(0.0, tf, DT)
        fall = held_end - np.outer(0.5 * 9.81 * tt**2, [0, 0, 1])
        rest = np.vstack([fall, np.tile(end, (n3, 1))])
    else:
        rest = np.tile(end, (n3, 1))
    p = np.vstack([carry, lower, rest])
    t = np.arange(p.shape[0]) * DT
    attached = np.zeros(p.shape[0], bool)
    attached[: n1 + n2] = True
    c, sn = np.cos(np.radians(tilt_deg)), np.sin(np.radians(tilt_deg))
    R_end = np.array([[1, 0, 0], [0, c, -sn], [0, sn, c]])
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (p.shape[0], 1))
    quat[n1 + n2 :] = quat_from_matrix(R_end)
    obj = object_report(t, p, quat, attached)
    schedule = GraspSchedule(
        intervals_s=((0.0, float(t[n1 + n2])),), grasp_position=tuple(PICK.tolist()),
        release_t=float(t[n1 + n2]), release_position=tuple(held_end.tolist()),
    )  # fmt: skip
    pose = (*PLACE.tolist(), 0.0, 0.0, 0.0, 1.0)
    return SimpleNamespace(
        task=TaskPoses(pick_pose=pose, place_pose=pose),
        object_report=ObjectReport.from_json(obj, "object"),
        grasp_schedule=schedule, grasp_events=(), extras={"attached": attached},
    )  # fmt: skip


def test_a_gentle_upright_placement_is_ok() -> None:
    rep = placement_report(_rollout())
    assert isinstance(rep, Placement)
    assert rep.ok and rep.carried and rep.failure is None
    assert rep.error_m == pytest.approx(0.0, abs=1e-9)
    assert rep.tilt_deg == pytest.approx(0.0, abs=1e-6)
    assert rep.set_down_speed_mps is not None
    assert rep.set_down_speed_mps == pytest.approx(0.05, rel=0.1)  # lowered at 0.05 m/s
    d = rep.to_dict()  # the older keys stay readable
    assert d["success"] is True and d["place_error_m"] == rep.error_m
    assert rep["success"] is True and rep.get("set_down_speed") == rep.set_down_speed_mps


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"tilt_deg": 21.0}, ["tilted 21.0 deg"]),
        ({"final_offset": (0.0, 0.03, 0.0)}, ["30.0 mm from the place"]),
        ({"drop_m": 0.05}, ["set down at"]),
        ({"tilt_deg": 41.0, "final_offset": (0.04, 0.0, 0.0)}, ["40.0 mm", "tilted 41.0"]),
    ],
)
def test_each_failing_check_is_named(kwargs, words) -> None:
    rep = placement_report(_rollout(**kwargs))
    assert not rep.ok and rep.failure is not None
    for w in words:
        assert w in rep.failure
    if "drop_m" in kwargs:  # let go 5 cm up: it meets the surface near sqrt(2 g h)
        assert rep.set_down_speed_mps == pytest.approx(np.sqrt(2 * 9.81 * 0.05), rel=0.15)
