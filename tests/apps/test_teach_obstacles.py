"""``dexlfd teach --obstacle``: what is in the way is planned round and checked in simulation."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest

from dexlfd.cli import main
from dexlfd.geometry import Box

from ._teach_sources import write_camera_demos

# between the default pick (0.5, -0.15) and the demonstrated place (~0.51, 0.35), 0.3 m tall
BETWEEN = "box:0.5,0.1,0.15,0.08,0.08,0.3"


@pytest.mark.integration
def test_teach_carries_the_object_over_an_obstacle_and_replans_without_it(tmp_path) -> None:
    """The hand, the held object and the arm keep clear of the box along the plan and in
    the simulation; the object is still placed. Taught again without the box, only the
    robot's stages run again (the recordings, frame and model are reused)."""
    from dexlfd.io import load_plan

    sources = write_camera_demos(tmp_path / "takes", n=4, seed=0)
    out = tmp_path / "out"
    assert main(["teach", *map(str, sources), "-o", str(out), "-q", "--obstacle", BETWEEN]) == 0
    record = json.loads((out / "teach.json").read_text())
    assert record["placement"]["ok"], record["placement"]
    (given,) = record["obstacles"]
    box = Box(tuple(given["center"]), tuple(given["size"]))
    plan_clear, simulated = record["clearance_m"]["plan"], record["clearance_m"]["simulated"]
    assert plan_clear["hand_and_object"] >= 0.02 - 1e-3  # the default margin
    assert plan_clear["arm_links"] > 0.0
    assert simulated["min_m"] > 0.0  # no link, hand or finger touched it
    # the held TCP over the box's footprint is above its top (the object hangs below)
    plan = load_plan(out / "plan.npz")
    assert plan.obstacles == (box,)
    half = np.asarray(box.size) / 2
    over = np.all(np.abs(plan.position[:, :2] - np.asarray(box.center)[:2]) <= half[:2], axis=1)
    assert over.any()
    assert plan.position[over, 2].min() > box.center[2] + half[2]
    assert "1 obstacle(s)" in (out / "report.html").read_text()

    before = json.loads((out / "manifest.json").read_text())
    assert main(["teach", *map(str, sources), "-o", str(out), "-q"]) == 0
    after = json.loads((out / "manifest.json").read_text())
    for stage in ("record", "frame", "learn"):
        assert after[stage]["key"] == before[stage]["key"]
    assert after["plan"]["key"] != before["plan"]["key"]
    assert load_plan(out / "plan.npz").obstacles == ()
    assert json.loads((out / "teach.json").read_text())["clearance_m"]["plan"] is None


def _refusal(sources: list, out, capsys, obstacle: str) -> str:  # noqa: ANN001
    """The one error line of a teach run refused for ``obstacle``; no plan written."""
    code = main(["teach", *map(str, sources), "-o", str(out), "-q", "--obstacle", obstacle])
    err = [line for line in capsys.readouterr().err.splitlines() if "error:" in line]
    assert code == 1 and len(err) == 1
    assert not (out / "plan.npz").exists()
    return err[0]


def test_teach_refuses_a_default_pick_inside_an_obstacle_in_one_line(tmp_path, capsys) -> None:
    sources = write_camera_demos(tmp_path / "takes", n=2, seed=1)
    err = _refusal(sources, tmp_path / "out", capsys, "box:0.5,-0.15,0.05,0.1,0.1,0.1")
    # the user gave no --pick: the message says it is the default, and how to move it
    assert "the default pick (set it with --pick)" in err and "inside obstacle 0" in err
    # a --pick the user gave is named by its flag, not called the default
    given = ["--pick", "0.45,0.1,0.05", "--obstacle", "box:0.45,0.1,0.05,0.1,0.1,0.1"]
    code = main(["teach", *map(str, sources), "-o", str(tmp_path / "given"), "-q", *given])
    err_lines = [ln for ln in capsys.readouterr().err.splitlines() if "error:" in ln]
    assert code == 1 and len(err_lines) == 1
    assert "error: --pick [0.45, 0.1, 0.05] m is inside obstacle 0" in err_lines[0]
    assert "default" not in err_lines[0]
    # an obstacle the hand would meet at the default pick (its TCP outside it): the
    # planner's refusal too calls the pick the default one
    err = _refusal(sources, tmp_path / "out", capsys, "box:0.5,-0.04,0.1,0.1,0.1,0.2")
    assert "the default pick (set it with --pick)" in err and "overlap" in err


def test_the_simulated_arms_clearance_is_measured_on_its_own_geometry() -> None:
    """A box round the hand's position at the ready pose overlaps it; one far off does not."""
    from dexlfd.apps.teach_robot import obstacle_clearance
    from dexlfd.panda import Q_READY
    from dexlfd.panda_kinematics import DhPanda

    t = np.arange(0.0, 0.1, 0.001)
    rollout = SimpleNamespace(t=t, q=np.tile(Q_READY, (t.size, 1)))
    tcp, _ = DhPanda().tcp_pose(np.asarray(Q_READY))
    assert obstacle_clearance(rollout, ()) is None  # type: ignore[arg-type]
    touching = obstacle_clearance(rollout, (Box(tuple(tcp + [0, 0, 0.1]), (0.1, 0.1, 0.1)),))
    far = obstacle_clearance(rollout, (Box((0.6, 0.6, 0.05), (0.1, 0.1, 0.1)),))
    assert touching is not None and touching["min_m"] < 0.0
    assert far is not None and far["min_m"] > 0.3
    # a rollout stopped at its first tick has one sample
    one = SimpleNamespace(t=t[:1], q=rollout.q[:1])
    first = obstacle_clearance(one, (Box((0.6, 0.6, 0.05), (0.1, 0.1, 0.1)),))  # type: ignore[arg-type]
    assert first is not None and first["t_s"] == 0.0
