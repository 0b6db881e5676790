from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dexlfd.datasets import pick_place_demonstrations
from dexlfd.errors import InvalidFile
from dexlfd.io import Plan, Rollout
from dexlfd.io.csv import export_csv
from dexlfd.io.rosbag import export_plan_rosbag, export_rollout_rosbag, read_rosbag


def _plan(rng: np.random.Generator, n: int = 50) -> Plan:
    t = np.linspace(0.0, 2.0, n)
    pos = rng.normal(size=(n, 3))
    return Plan(
        t=t,
        position=pos,
        velocity=np.gradient(pos, t, axis=0),
        acceleration=rng.normal(size=(n, 3)),
        quaternion=Rotation.random(n, random_state=3).as_quat(),
        angular_velocity=rng.normal(size=(n, 3)),
        gripper=rng.uniform(0, 0.08, n),
    )


def _rollout(rng: np.random.Generator, n: int = 30) -> Rollout:
    q4 = Rotation.random(n, random_state=4).as_quat()
    return Rollout(
        t=np.arange(n) * 1e-3 + 0.9995,
        q=rng.normal(size=(n, 7)),
        dq=rng.normal(size=(n, 7)),
        tau=rng.normal(size=(n, 7)),
        ee_position=rng.normal(size=(n, 3)),
        ee_quaternion=q4,
        ref_position=rng.normal(size=(n, 3)),
        ref_quaternion=q4,
        gripper=np.zeros(n),
    )


def test_plan_bag_round_trip(tmp_path: Path, rng: np.random.Generator) -> None:
    plan = _plan(rng)
    bag = export_plan_rosbag(plan, tmp_path / "plan_bag", stamp_origin_ns=10**18)
    msgs = read_rosbag(bag)
    poses = msgs["/dexlfd/plan/pose"]
    assert len(poses) == plan.n_samples
    pos = np.array([[m.pose.position.x, m.pose.position.y, m.pose.position.z] for _, m in poses])
    np.testing.assert_array_equal(pos, plan.position)
    stamps = np.array([ns for ns, _ in poses])
    np.testing.assert_allclose((stamps - 10**18) * 1e-9, plan.t, atol=1e-9)
    assert poses[0][1].header.frame_id == "panda_link0"
    grip = msgs["/dexlfd/plan/gripper"]  # the finger joints, each half the opening
    assert list(grip[0][1].name) == ["panda_finger_joint1", "panda_finger_joint2"]
    np.testing.assert_array_equal(
        [2 * m.position for _, m in grip], np.c_[plan.gripper, plan.gripper]
    )
    target = [m.transforms[0] for _, m in msgs["/tf"]]
    assert {(t.header.frame_id, t.child_frame_id) for t in target} == {
        ("panda_link0", "dexlfd_plan_target")
    }
    np.testing.assert_array_equal([t.transform.translation.z for t in target], plan.position[:, 2])


def test_rollout_bag_round_trip(tmp_path: Path, rng: np.random.Generator) -> None:
    ro = _rollout(rng)
    msgs = read_rosbag(export_rollout_rosbag(ro, tmp_path / "ro", stamp_origin_ns=0))
    js = msgs["/joint_states"]
    np.testing.assert_array_equal(np.array([m.position[:7] for _, m in js]), ro.q)
    np.testing.assert_array_equal(np.array([m.effort[:7] for _, m in js]), ro.tau)
    fingers = ["panda_finger_joint1", "panda_finger_joint2"]
    assert list(js[0][1].name) == [f"panda_joint{i}" for i in range(1, 8)] + fingers
    np.testing.assert_array_equal(
        [2 * m.position[7:] for _, m in js], np.c_[ro.gripper, ro.gripper]
    )
    ((_, traj),) = msgs["/dexlfd/joint_trajectory"]
    assert len(traj.points) == ro.n_samples
    tfs = np.array([p.time_from_start.sec + p.time_from_start.nanosec * 1e-9 for p in traj.points])
    np.testing.assert_allclose(tfs, ro.t - ro.t[0], atol=1e-9)


def test_existing_bag_is_not_clobbered(tmp_path: Path, rng: np.random.Generator) -> None:
    (tmp_path / "bag").mkdir()
    with pytest.raises(InvalidFile, match="already exists"):
        export_plan_rosbag(_plan(rng), tmp_path / "bag")
    with pytest.raises(InvalidFile, match="not a readable ROS 2 bag"):
        read_rosbag(tmp_path / "bag")
    assert [p.name for p in tmp_path.iterdir()] == ["bag"]


def test_csv_columns_and_values(tmp_path: Path, rng: np.random.Generator) -> None:
    plan = _plan(rng, 7)
    path = export_csv(plan, tmp_path / "plan.csv")
    header = path.read_text().splitlines()[0].split(",")
    assert header[:4] == ["t [s]", "position_x [m]", "position_y [m]", "position_z [m]"]
    assert "quaternion_w" in header
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, 0], plan.t, rtol=1e-8)  # %.9g text
    np.testing.assert_allclose(table[:, 1:4], plan.position, rtol=1e-8)
    ro = _rollout(rng, 5)
    header = export_csv(ro, tmp_path / "ro.csv").read_text().splitlines()[0].split(",")
    assert "q_panda_joint7 [rad]" in header and "tau_panda_joint1 [N m]" in header


def test_csv_leaves_out_an_array_without_any_value_and_says_so(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A synthetic demonstration has no keypoints: no column of only ``nan`` is written."""
    demo = pick_place_demonstrations(1, np.random.default_rng(3))[0]
    assert np.isnan(demo.keypoints).all()
    with caplog.at_level("INFO", logger="dexlfd.io.csv"):
        path = export_csv(demo, tmp_path / "demo.csv")
    header = path.read_text().splitlines()[0].split(",")
    assert not any(h.startswith("keypoints") for h in header)
    assert "position_x [m]" in header and "gripper [m]" in header
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    assert table.shape == (demo.n_samples, len(header))
    assert not np.isnan(table).all(axis=0).any()
    assert "no value in any row: keypoints" in caplog.text


def test_csv_export_at_a_given_rate_writes_the_recorded_samples_nearest_each_step(
    tmp_path: Path, rng: np.random.Generator, capsys
) -> None:
    from dexlfd.cli import main
    from dexlfd.io import save_plan

    plan = _plan(rng, 201)  # 100 Hz over 2 s
    src = save_plan(tmp_path / "plan.npz", plan)
    out = tmp_path / "d.csv"
    assert main(["export", str(src), "-o", str(out), "--fps", "10", "-q"]) == 0
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, 0], np.arange(21) / 10, atol=1e-9)  # 0, 0.1 .. 2 s
    np.testing.assert_allclose(table[:, 1:4], plan.position[::10], rtol=1e-8)  # recorded ones
    # the log counts the rows written, not the record's samples
    capsys.readouterr()
    assert main(["export", str(src), "-o", str(tmp_path / "d2.csv"), "--fps", "10"]) == 0
    assert "(csv, 21 rows at 10 Hz from 201 samples)" in capsys.readouterr().err
    # above the record's own rate: refused in one line, nothing written
    assert main(["export", str(src), "-o", str(tmp_path / "e.csv"), "--fps", "500"]) == 1
    errors = [ln for ln in capsys.readouterr().err.splitlines() if "error" in ln]
    assert len(errors) == 1 and "--fps 500 Hz is above the record's own rate (100 Hz)" in errors[0]
    assert not (tmp_path / "e.csv").exists()


def _cli_error(argv: list[str], capsys) -> str:
    """Run ``dexlfd`` expecting a one-line error (exit 1); that line."""
    from dexlfd.cli import main

    assert main([*argv, "-q"]) == 1
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.startswith("dexlfd export: error: ")]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@pytest.mark.parametrize("fmt", ["csv", "mcap", "lerobot"])
def test_a_one_sample_file_is_refused(
    tmp_path: Path, rng: np.random.Generator, capsys, fmt: str
) -> None:
    from dataclasses import fields, replace

    from dexlfd.io import save_rollout

    ro = _rollout(rng)
    one = replace(ro, **{f.name: getattr(ro, f.name)[:1] for f in fields(ro) if f.name in
                         ro.SPECS and getattr(ro, f.name) is not None})  # fmt: skip
    src = save_rollout(tmp_path / "one.npz", one)
    out = tmp_path / ("o.csv" if fmt == "csv" else "o")
    line = _cli_error(["export", str(src), "--format", fmt, "-o", str(out)], capsys)
    assert "one.npz" in line and "at least 2 samples" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["one.npz"]


@pytest.mark.parametrize("name", ["out.txt", "out.mcap", "out.db3", "out.npz"])
def test_a_bag_folder_named_like_a_file_is_refused(
    tmp_path: Path, rng: np.random.Generator, capsys, name: str
) -> None:
    from dexlfd.io import save_rollout

    src = save_rollout(tmp_path / "r.npz", _rollout(rng))
    line = _cli_error(["export", str(src), "-o", str(tmp_path / name)], capsys)
    assert f"-o/--output {tmp_path / name}: expected a folder name" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.npz"]
    # the one file output, CSV, must be named .csv
    csv_as_txt = ["export", str(src), "--format", "csv", "-o", str(tmp_path / "o.txt")]
    assert _cli_error(csv_as_txt, capsys).endswith(
        "must end in .csv (CSV text is written), got '.txt'"
    )


def test_a_plain_or_dated_bag_folder_name_is_written(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    from dexlfd.cli import main
    from dexlfd.io import save_rollout

    src = save_rollout(tmp_path / "r.npz", _rollout(rng))
    for name in ("bag", "bag_2024.05", "franka.pick", "ds.v2"):
        assert main(["export", str(src), "-o", str(tmp_path / name), "-q"]) == 0
        assert (tmp_path / name / "metadata.yaml").is_file()


def test_lerobot_export_of_demonstrations_and_rollouts_names_both(
    tmp_path: Path, rng: np.random.Generator, demos, capsys
) -> None:
    """The help offers demonstrations or rollouts, one kind per dataset; a mix is refused
    naming a file of each kind, and nothing is written."""
    from dexlfd._commands import export
    from dexlfd.io import save_demonstration, save_rollout

    d = save_demonstration(tmp_path / "d.npz", demos[0])
    r = save_rollout(tmp_path / "r.npz", _rollout(rng))
    line = _cli_error(["export", str(d), str(r), "--format", "lerobot", "-o", str(tmp_path / "ds")],
                      capsys)  # fmt: skip
    assert "d.npz is a demonstration" in line and "r.npz a rollout" in line
    assert not (tmp_path / "ds").exists()
    import argparse

    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers()
    text = " ".join(export.add_parser(sub, "export").format_help().split())
    assert "demonstrations or rollouts" in text and "not both" in text
    assert "demonstrations and rollouts" not in text
