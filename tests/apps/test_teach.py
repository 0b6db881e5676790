"""``dexlfd teach``: demonstrations filmed by a known camera -> the simulated Panda placing it.

The sources are synthetic pick-and-places moved into the frame of a camera at a known
pose (``_teach_sources``): the task frame found from them is checked against the true
camera, the robot's pick and place against the demonstrated displacement, and the
placement against the simulator's own check.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from dexlfd.cli import main

from ._teach_sources import camera_to_base, write_camera_demos


@pytest.fixture(scope="module")
def taught(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, int, list[Path]]:
    """One teach run on four synthetic takes of one camera (shared by the checks)."""
    root = tmp_path_factory.mktemp("teach")
    sources = write_camera_demos(root / "takes", n=4, seed=0)
    out = root / "out"
    code = main(["teach", *map(str, sources), "-o", str(out), "-q"])
    return out, code, sources


@pytest.mark.integration
def test_teach_places_the_object_and_writes_every_file(taught) -> None:
    out, code, _ = taught
    record = json.loads((out / "teach.json").read_text())
    assert code == 0, record["placement"]
    for key in ("sources", "demonstrations", "task_frame", "pick", "place", "placement",
                "lift_m"):  # fmt: skip
        assert key in record
    v = record["placement"]
    assert v["ok"] and v["carried"] and v["error_m"] <= 0.02 and v["tilt_deg"] <= 10.0
    assert v["set_down_speed_mps"] < 0.1
    for name in ("model.npz", "plan.npz", "rollout.npz", "robot.mp4", "report.html",
                 "task_frame.json", "figures/plan.png", "figures/model.png",
                 "figures/demos_task.png", "figures/rollout.png"):  # fmt: skip
        assert (out / name).is_file(), name
    assert len(record["demonstrations"]) == 4
    html = (out / "report.html").read_text()
    assert "the object was placed" in html and "<video" in html
    assert "figure missing" not in html
    for caption in ("the demonstrations in the task frame", "the model: GMR mean",
                    "the plan with the object and its supports", 'alt="tracking"'):  # fmt: skip
        assert caption in html, caption


@pytest.mark.integration
def test_teach_robot_video_replays_the_whole_rollout_at_its_size_and_rate(taught) -> None:
    import cv2

    from dexlfd.apps.teach import TeachConfig
    from dexlfd.io import load_rollout

    out, _, _ = taught
    cfg = TeachConfig(sources=())
    rollout = load_rollout(out / "rollout.npz")
    cap = cv2.VideoCapture(str(out / "robot.mp4"))
    try:
        n, w, h = (int(cap.get(p)) for p in (cv2.CAP_PROP_FRAME_COUNT, cv2.CAP_PROP_FRAME_WIDTH,
                                             cv2.CAP_PROP_FRAME_HEIGHT))  # fmt: skip
        fps = cap.get(cv2.CAP_PROP_FPS)
    finally:
        cap.release()
    assert (w, h) == cfg.video_size_px
    assert fps == pytest.approx(cfg.video_fps)
    # a frame every 1/fps s from the rollout's first sample to its last
    assert n == int(np.floor((rollout.t[-1] - rollout.t[0]) * cfg.video_fps)) + 1


@pytest.mark.integration
def test_teach_finds_the_cameras_up_and_keeps_the_demonstrated_displacement(taught) -> None:
    out, _, _ = taught
    record = json.loads((out / "teach.json").read_text())
    frame = record["task_frame"]
    assert frame["method"] == "demonstrations"
    true_up = camera_to_base()[:3, :3].T @ [0.0, 0.0, 1.0]  # base z seen from the camera
    for cam in frame["cameras"]:  # each take alone: one lift and one set-down
        err = np.degrees(np.arccos(np.clip(np.dot(cam["up_camera"], true_up), -1, 1)))
        assert err < 5.0
    # the synthetic task moves the object 0.5 m along base +y; the camera looks along
    # base +x, so the task frame's axes are the base's: the default place is the default
    # pick moved by that displacement
    pick, place = (np.array(record[k]["position_m"]) for k in ("pick", "place"))
    np.testing.assert_allclose(pick[:2], [0.5, -0.15])
    np.testing.assert_allclose(place - pick, [0.0, 0.5, 0.0], atol=0.03)
    lift = record["lift_m"]
    assert lift["demonstrated"] == pytest.approx(0.30, abs=0.04)  # the synthetic lift
    assert lift["plan"] > 0.5 * lift["demonstrated"]


@pytest.mark.integration
def test_teach_resumes_and_refuses_files_it_did_not_write(taught, tmp_path, capsys) -> None:
    out, _, sources = taught
    assert main(["teach", *map(str, sources), "-o", str(out), "-q"]) == 0  # all reused
    manifest = json.loads((out / "manifest.json").read_text())
    stages = (
        "record",
        "frame",
        "learn",
        "figures",
        "plan",
        "plan_figure",
        "simulate",
        "tracking_figure",
        "video",
    )
    assert set(stages) <= set(manifest)
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "model.npz").write_bytes(b"a user's file")
    assert main(["teach", str(sources[0]), "-o", str(mine)]) == 1
    err = capsys.readouterr().err
    assert "model.npz" in err and "not written by dexlfd teach" in err
    assert (mine / "model.npz").read_bytes() == b"a user's file"


@pytest.mark.integration
def test_teach_resumed_redraws_the_missing_figures_alone(taught) -> None:
    from PIL import Image

    out, _, sources = taught
    kept = {n: (out / n).stat().st_mtime_ns for n in ("model.npz", "plan.npz", "rollout.npz")}
    for name in ("model.png", "plan.png", "rollout.png"):  # one of each figure stage's
        (out / "figures" / name).unlink()
    assert main(["teach", *map(str, sources), "-o", str(out), "-q"]) == 0
    for name in ("demos_task.png", "model.png", "plan.png", "rollout.png"):
        with Image.open(out / "figures" / name) as im:
            im.verify()  # a whole PNG
    # the learned model, the plan and the rollout were reused, not made again
    assert {n: (out / n).stat().st_mtime_ns for n in kept} == kept
    assert "figure missing" not in (out / "report.html").read_text()


def test_teach_refuses_a_pick_out_of_reach_in_one_line(tmp_path, capsys) -> None:
    sources = write_camera_demos(tmp_path / "takes", n=2, seed=1)
    code = main(["teach", *map(str, sources), "-o", str(tmp_path / "out"),
                 "--pick", "1.2,0,0.03", "-q"])  # fmt: skip
    err = [line for line in capsys.readouterr().err.splitlines() if "error:" in line]
    assert code == 1
    assert len(err) == 1 and "--pick" in err[0] and "reach of 0.855 m" in err[0]
    assert not (tmp_path / "out" / "plan.npz").exists()


def test_teach_refuses_a_source_without_a_pick_and_place(tmp_path, capsys) -> None:
    from dataclasses import replace

    from dexlfd.io import load_demonstration, save_demonstration

    sources = write_camera_demos(tmp_path / "takes", n=2, seed=2)
    held = load_demonstration(sources[1])
    # the hand closes and never opens again: a grasp, no release
    k = int(np.argmax(held.grasp))
    grasp = held.grasp.copy()
    grasp[k:] = True
    still = tmp_path / "takes" / "no_release.npz"
    save_demonstration(still, replace(held, grasp=grasp, meta={**held.meta, "source": "b"}))
    code = main(["teach", str(sources[0]), str(still), "-o", str(tmp_path / "out"), "-q"])
    err = [line for line in capsys.readouterr().err.splitlines() if "error:" in line]
    assert code == 1 and len(err) == 1
    assert "no_release.npz: no pick-and-place" in err[0] and "frames" in err[0]
    assert not (tmp_path / "out" / "plan.npz").exists()


def test_calibrated_and_uncalibrated_takes_end_in_one_base_frame(tmp_path) -> None:
    """A calibrated take and an uncalibrated camera's: each through its own frame, never mixed."""
    from dataclasses import replace

    from dexlfd.apps.teach import TeachConfig, _stage_frame, _stage_record
    from dexlfd.apps.teach_frame import demonstrated_events
    from dexlfd.datasets import demonstration_with_hand, pick_place_demonstrations
    from dexlfd.io import load_demonstration, save_demonstration

    cam = write_camera_demos(tmp_path / "cam", n=2, seed=3)
    rng = np.random.default_rng(4)
    calibrated = []
    for i, demo in enumerate(pick_place_demonstrations(2, rng)):
        demo = demonstration_with_hand(demo, rng)
        meta = {**demo.meta, "source": "calibrated-camera"}
        demo = replace(demo, meta=meta, frame="panda_base")
        calibrated.append(save_demonstration(tmp_path / f"base_{i}.npz", demo))
    cfg = TeachConfig(sources=tuple(str(p) for p in (*cam, *calibrated)))
    out = tmp_path / "out"
    out.mkdir()
    _, record = _stage_record(cfg, out)
    _, frame = _stage_frame(cfg, out, {"summary": record})
    assert sorted(f["method"] for f in frame["frames"]) == ["demonstrations", "extrinsics"]
    pick = np.array(frame["placement"]["pick"])
    np.testing.assert_allclose(pick[:2], [0.5, -0.15])  # not every take is calibrated
    for rel in frame["demonstrations"]:
        demo = load_demonstration(out / rel)
        assert demo.frame == "panda_base"
        k_grasp, _ = demonstrated_events(demo, rel)
        # each camera's mean pick lands on the robot's pick: a take is off by its own
        # scatter around that mean (the synthetic via points vary by 2 cm)
        assert np.linalg.norm(demo.position[k_grasp] - pick) < 0.06


def test_default_place_is_the_demonstrated_displacement_never_under_the_table(caplog) -> None:
    from dexlfd.apps.teach_frame import placement_targets
    from dexlfd.datasets import pick_place_demonstrations
    from dexlfd.datasets.synthetic import PickPlaceConfig

    # set down 5 cm lower than picked, 0.5 m to the left (the frame is the task frame here)
    task = PickPlaceConfig(pick=(0.0, 0.0, 0.0), place=(0.0, 0.5, -0.05))
    demos = pick_place_demonstrations(3, np.random.default_rng(5), task)
    names = [f"d{i}" for i in range(3)]
    size = (0.04, 0.04, 0.04)
    with caplog.at_level("INFO", logger="dexlfd.apps.teach_frame"):
        on_table = placement_targets(demos, names, pick=None, place=None, object_size=size)
    assert caplog.text.count("set down on the table") == 1  # said once, not per pick tried
    assert on_table.pick == pytest.approx((0.5, -0.15, 0.02))  # half the object over the table
    assert on_table.place[:2] == pytest.approx((0.5, 0.35), abs=0.03)
    assert on_table.place[2] == pytest.approx(0.02)  # not under the table
    assert on_table.defaults == ("pick", "place")
    high = placement_targets(demos, names, pick=(0.5, -0.15, 0.2), place=None, object_size=size)
    assert high.place[2] == pytest.approx(0.15, abs=0.01)  # the demonstrated drop of 5 cm
    assert high.pick_yaw is None and high.demonstrated_lift_m > 0.2


@pytest.mark.integration
def test_the_simulated_object_is_the_planned_one_set_upright_on_a_raised_place(
    taught, tmp_path
) -> None:
    """A 3.6 cm object set down on a support 4.2 cm high stands on it, its centre at half height.

    The plan holds the object at its middle: simulated as the plant's default 6 cm box it
    hung 1.2 cm lower than planned, met the support while the hand still pushed down,
    and tipped over (90 deg).
    """
    _, _, sources = taught
    out = tmp_path / "raised"
    code = main(["teach", *map(str, sources), "-o", str(out), "-q", "--object-size", "0.036",
                 "--place", "0.5,0.2,0.06"])  # fmt: skip
    record = json.loads((out / "teach.json").read_text())
    assert code == 0, record["placement"]
    assert record["placement"]["tilt_deg"] <= 10.0
    final = json.loads((out / "manifest.json").read_text())["simulate"]["summary"]
    support_top = 0.06 - 0.018
    assert final["object_final_m"][2] == pytest.approx(support_top + 0.018, abs=0.003)
