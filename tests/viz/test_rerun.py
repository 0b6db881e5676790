"""The .rrd file, read back with rerun's own reader (``rerun.chunk.RrdReader``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

rr = pytest.importorskip("rerun", reason="rerun-sdk not installed (requirements.lock)")

from dexlfd.capture import Frame, FrameKeypoints  # noqa: E402
from dexlfd.capture.tracking import HAND_CONNECTIONS  # noqa: E402
from dexlfd.datasets import (  # noqa: E402
    PickPlaceConfig,
    demonstration_with_hand,
    pick_place_demonstrations,
    pick_place_reference,
)
from dexlfd.errors import InvalidFile, InvalidInput  # noqa: E402
from dexlfd.io import LearnedModel, Rollout  # noqa: E402
from dexlfd.plan import Box, PlanConfig, plan_from_model  # noqa: E402
from dexlfd.rotations import matrix_from_quat  # noqa: E402
from dexlfd.viz.rerun_log import RerunLog, open_rerun  # noqa: E402

SIGMA = (0.01, 0.02, 0.005)  # [m] positional std of the test model along x, y, z


def _model() -> LearnedModel:
    m = 300
    t = np.linspace(0.0, 6.0, m)
    pos, quat, grip = pick_place_reference(t / t[-1], PickPlaceConfig())
    mean = np.concatenate([pos, quat, grip[:, None]], axis=1)
    cov = np.zeros((m, 8, 8))
    cov[:, :3, :3] = np.diag(np.square(SIGMA))
    cov[:, :3, :3] += np.sin(t)[:, None, None] * 4e-5 * (np.ones((3, 3)) - np.eye(3))  # tilt
    cov[:, 3:7, 3:7] = 1e-4 * np.eye(4)
    cov[:, 7, 7] = 1e-6
    data = np.concatenate([t[:, None], mean], axis=1)
    return LearnedModel(
        t=t, mean=mean, cov=cov, gmm_weights=np.ones(1), gmm_means=data.mean(0, keepdims=True),
        gmm_covs=np.cov(data.T)[None] + 1e-9 * np.eye(9)[None],
    )  # fmt: skip


def _frames() -> list[tuple[Frame, FrameKeypoints | None]]:
    out = []
    yy, xx = np.mgrid[0:48, 0:64]
    for i in range(5):
        rgb = np.stack([xx * 3 + 10 * i, yy * 5, np.full_like(xx, 90)], -1).astype(np.uint8)
        uv = np.stack([np.linspace(5, 60, 21) + i, np.linspace(5, 40, 21)], axis=1)
        kp = FrameKeypoints(
            t=i / 30, keypoints=np.zeros((21, 3)), valid=True, uv_px=uv, score=0.9,
            handedness="right", n_hands=1, depth_filled=0,
        )  # fmt: skip
        out.append((Frame(index=i, t=i / 30, rgb=rgb), None if i == 2 else kp))
    return out


@pytest.fixture(scope="module")
def logged(tmp_path_factory):
    rng = np.random.default_rng(7)
    demo = demonstration_with_hand(pick_place_demonstrations(1, rng)[0], rng)
    model = _model()
    cup = Box((0.45, 0.0, 0.1), (0.08, 0.08, 0.2))
    plan = plan_from_model(model, PlanConfig(obstacles=(cup,), margin=0.05))
    n = 400
    ro = Rollout(
        t=10.0 + 1e-3 * np.arange(n), q=np.tile(0.1 * np.arange(7.0), (n, 1)),
        dq=np.zeros((n, 7)), tau=np.zeros((n, 7)), ee_position=plan.position[:n] + 1e-3,
        ee_quaternion=plan.quaternion[:n], ref_position=plan.position[:n],
        ref_quaternion=plan.quaternion[:n], gripper=plan.gripper[:n],
    )  # fmt: skip
    path = tmp_path_factory.mktemp("rrd") / "run.rrd"
    frames = _frames()
    with RerunLog(path) as log:
        for frame, kp in frames:
            log.capture_frame(frame, kp)
        log.demonstration(demo)
        log.plan(plan, model)
        log.rollout(ro)
    rec = _load_recording(str(path))
    return {"path": path, "demo": demo, "model": model, "plan": plan, "rollout": ro,
            "frames": frames, "cup": cup, "rec": rec}  # fmt: skip


class _Recording:
    """An .rrd read with rerun's chunk reader: its schema and each entity's rows."""

    def __init__(self, path: str) -> None:
        from rerun.chunk import RrdReader

        store = RrdReader(path).store()
        self._schema = store.schema()
        self.chunks = list(store.stream().collect().stream())

    def schema(self):
        return self._schema


def _load_recording(path: str) -> _Recording:
    return _Recording(path)


def _read(rec: _Recording, entity: str):
    """The entity's rows on the "time" timeline, sorted, with its static values on every
    row (one row if it has only static data); columns named ``ENTITY:Archetype:field``."""
    import pyarrow as pa

    temporal, static = [], {}
    for chunk in rec.chunks:
        if chunk.entity_path != entity:
            continue
        table = pa.Table.from_batches([chunk.to_record_batch()])
        table = table.drop_columns([n for n in table.column_names if n.startswith("rerun.")])
        if chunk.is_static:
            static.update({n: table.column(n)[0].as_py() for n in table.column_names})
        else:
            temporal.append(table)
    if temporal:
        table = pa.concat_tables(temporal, promote_options="default")
        table = table.sort_by("time")
    else:
        table = pa.table({"time": pa.array([0], pa.duration("ns"))})
    for name, value in static.items():
        table = table.append_column(name, pa.array([value] * table.num_rows))
    return table.rename_columns([n if n == "time" else f"{entity}:{n}" for n in table.column_names])


def _seconds(table) -> np.ndarray:
    return table.column("time").to_numpy().astype("timedelta64[ns]").astype(np.int64) / 1e9


def _rows(table, column: str) -> list[np.ndarray]:
    return [np.asarray(v, dtype=np.float64) for v in table.column(column).to_pylist()]


def test_entities_and_one_timeline(logged) -> None:
    schema = logged["rec"].schema()
    assert [c.name for c in schema.index_columns()] == ["time"]
    entities = {c.entity_path for c in schema.component_columns()}
    for e in (
        "/camera/image", "/camera/image/hand", "/camera/image/hand/skeleton",
        "/world/demo/hand", "/world/demo/hand/skeleton", "/world/demo/ee", "/plots/gripper/demo",
        "/plots/grasp/demo", "/world/plan/path", "/world/plan/target", "/world/model/mean",
        "/world/model/tube", "/world/obstacles", "/world/robot/tcp_path", "/world/robot/tcp",
        "/world/robot/reference", "/plots/gripper/robot", "/plots/joints/robot",
    ):  # fmt: skip
        assert e in entities, e


def test_demonstration_values_round_trip(logged) -> None:
    demo = logged["demo"]
    v = demo.valid
    ee = _read(logged["rec"], "/world/demo/ee")
    np.testing.assert_allclose(_seconds(ee), demo.t[v], atol=1e-9)
    np.testing.assert_allclose(np.vstack(_rows(ee, "/world/demo/ee:Transform3D:translation")),
                               demo.position[v], atol=1e-6)  # fmt: skip
    np.testing.assert_allclose(np.vstack(_rows(ee, "/world/demo/ee:Transform3D:quaternion")),
                               demo.quaternion[v], atol=1e-6)  # fmt: skip
    grip = _read(logged["rec"], "/plots/gripper/demo")
    np.testing.assert_allclose(np.concatenate(_rows(grip, "/plots/gripper/demo:Scalars:scalars")),
                               demo.gripper[v], atol=1e-12)  # fmt: skip
    hand = _read(logged["rec"], "/world/demo/hand")
    pts = np.stack(_rows(hand, "/world/demo/hand:Points3D:positions"))
    assert pts.shape == (int(v.sum()), 21, 3)
    np.testing.assert_allclose(pts, demo.keypoints[v], atol=1e-6)
    bones = _read(logged["rec"], "/world/demo/hand/skeleton")
    first = np.asarray(bones.column("/world/demo/hand/skeleton:LineStrips3D:strips").to_pylist()[0])
    assert first.shape == (len(HAND_CONNECTIONS), 2, 3)
    kp0 = demo.keypoints[v][0]
    for (a, b), seg in zip(HAND_CONNECTIONS, first, strict=True):
        np.testing.assert_allclose(seg, kp0[[a, b]], atol=1e-6)


def test_camera_images_and_2d_landmarks(logged) -> None:
    import cv2

    img = _read(logged["rec"], "/camera/image")
    np.testing.assert_allclose(_seconds(img), [i / 30 for i in range(5)], atol=1e-9)
    blobs = img.column("/camera/image:EncodedImage:blob").to_pylist()
    for (frame, _), blob in zip(logged["frames"], blobs, strict=True):
        bgr = cv2.imdecode(np.frombuffer(bytes(blob[0]), np.uint8), cv2.IMREAD_COLOR)
        decoded = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB).astype(float)
        assert decoded.shape == frame.rgb.shape
        assert np.abs(decoded - frame.rgb).mean() < 3.0  # JPEG, quality 80
    hand = _read(logged["rec"], "/camera/image/hand")
    np.testing.assert_allclose(
        _seconds(hand), [0, 1 / 30, 3 / 30, 4 / 30], atol=1e-9
    )  # frame 2: none
    uv = np.stack(_rows(hand, "/camera/image/hand:Points2D:positions"))
    np.testing.assert_allclose(uv[2], logged["frames"][3][1].uv_px, atol=1e-4)


def test_plan_tube_is_two_sigma_of_the_model_covariance(logged) -> None:
    model, plan = logged["model"], logged["plan"]
    tube = _read(logged["rec"], "/world/model/tube")
    centers = np.asarray(tube.column("/world/model/tube:Ellipsoids3D:centers").to_pylist()[0])
    half = np.asarray(tube.column("/world/model/tube:Ellipsoids3D:half_sizes").to_pylist()[0])
    quats = np.asarray(tube.column("/world/model/tube:Ellipsoids3D:quaternions").to_pylist()[0])
    assert len(centers) >= 50
    R = matrix_from_quat(quats)
    ellipsoid = R @ (half[:, :, None] ** 2 * np.swapaxes(R, 1, 2))  # R diag(h^2) R^T
    for c, e in zip(centers, ellipsoid, strict=True):
        # a point of the model mean whose 2-sigma covariance is this ellipsoid
        at = np.flatnonzero(np.linalg.norm(model.mean[:, :3] - c, axis=1) < 1e-6)
        assert at.size and any(np.allclose(e, 4.0 * model.cov[j, :3, :3], atol=1e-9) for j in at)
    assert np.ptp(half, axis=0).max() > 0  # the tilt really varies along the mean
    target = _read(logged["rec"], "/world/plan/target")
    xyz = np.vstack(_rows(target, "/world/plan/target:Transform3D:translation"))
    np.testing.assert_allclose(xyz, plan.position, atol=1e-6)
    boxes = _read(logged["rec"], "/world/obstacles")
    cup = logged["cup"]
    np.testing.assert_allclose(boxes.column("/world/obstacles:Boxes3D:half_sizes").to_pylist()[0],
                               [np.asarray(cup.size) / 2], atol=1e-7)  # fmt: skip


def test_rollout_starts_the_timeline_at_zero(logged) -> None:
    ro = logged["rollout"]
    tcp = _read(logged["rec"], "/world/robot/tcp")
    np.testing.assert_allclose(_seconds(tcp), ro.t - ro.t[0], atol=1e-9)
    np.testing.assert_allclose(np.vstack(_rows(tcp, "/world/robot/tcp:Transform3D:translation")),
                               ro.ee_position, atol=1e-6)  # fmt: skip
    joints = _read(logged["rec"], "/plots/joints/robot")
    q = np.stack(_rows(joints, "/plots/joints/robot:Scalars:scalars"))
    np.testing.assert_allclose(q, ro.q, atol=1e-12)


def test_failed_run_leaves_no_file_and_keeps_the_old_one(tmp_path: Path) -> None:
    path = tmp_path / "keep.rrd"
    path.write_bytes(b"user's file")
    with pytest.raises(RuntimeError), RerunLog(path) as log:
        log.capture_frame(*_frames()[0])
        raise RuntimeError("boom")
    assert path.read_bytes() == b"user's file"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.rrd"]
    assert open_rerun(None) is None


def test_bad_paths_are_one_line_errors(tmp_path: Path) -> None:
    with pytest.raises(InvalidInput, match=r"expected a \.rrd"):
        RerunLog(tmp_path / "x.mp4")
    with pytest.raises(InvalidFile, match="does not exist"):
        RerunLog(tmp_path / "nope" / "x.rrd")
    assert list(tmp_path.iterdir()) == []


def test_record_cli_logs_frames_and_the_demonstration(hand_video: Path, tmp_path: Path) -> None:
    from dexlfd.cli import main
    from dexlfd.io import load_demonstration

    demo_path, rrd = tmp_path / "demo.npz", tmp_path / "rec.rrd"
    argv = ["record", str(hand_video), "-o", str(demo_path), "--max-frames", "12",
            "--resize-width-px", "320", "--rerun", str(rrd)]  # fmt: skip
    assert main(argv) == 0
    demo = load_demonstration(demo_path)
    rec = _load_recording(str(rrd))
    img = _read(rec, "/camera/image")
    np.testing.assert_allclose(_seconds(img), demo.t, atol=1e-9)
    hand = _read(rec, "/camera/image/hand")
    uv = np.stack(_rows(hand, "/camera/image/hand:Points2D:positions"))
    np.testing.assert_allclose(uv, demo.extras["uv_px"][demo.extras["detected"]], atol=1e-3)
    ee = _read(rec, "/world/demo/ee")
    np.testing.assert_allclose(np.vstack(_rows(ee, "/world/demo/ee:Transform3D:translation")),
                               demo.position[demo.valid], atol=1e-6)  # fmt: skip


def test_simulate_cli_logs_plan_obstacle_and_tcp_path(tmp_path: Path, capsys) -> None:
    from dexlfd.cli import main
    from dexlfd.io import load_rollout, save_plan

    cup = Box((0.45, 0.0, 0.1), (0.08, 0.08, 0.2))
    plan = plan_from_model(_model(), PlanConfig(obstacles=(cup,), margin=0.05))
    plan_path = save_plan(tmp_path / "plan.npz", plan)
    bad = [
        "simulate",
        str(plan_path),
        "-o",
        str(tmp_path / "r.npz"),
        "--rerun",
        str(tmp_path / "r.txt"),
    ]
    assert main(bad) == 1
    assert "--rerun" in capsys.readouterr().err and not (tmp_path / "r.npz").exists()
    rrd = tmp_path / "sim.rrd"
    assert (
        main(["simulate", str(plan_path), "-o", str(tmp_path / "r.npz"), "--rerun", str(rrd)]) == 0
    )
    ro = load_rollout(tmp_path / "r.npz")
    rec = _load_recording(str(rrd))
    tcp = _read(rec, "/world/robot/tcp")
    assert tcp.num_rows == ro.n_samples
    path = _read(rec, "/world/robot/tcp_path")
    strip = np.asarray(path.column("/world/robot/tcp_path:LineStrips3D:strips").to_pylist()[0][0])
    np.testing.assert_allclose(strip, ro.ee_position, atol=1e-6)
    entities = {c.entity_path for c in rec.schema().component_columns()}
    assert {"/world/plan/path", "/world/obstacles", "/plots/joints/robot"} <= entities


def test_demo_rerun_gathers_every_stage(logged, tmp_path: Path) -> None:
    """write_demo_rerun on a demo folder laid out like run_demo's (small stand-ins)."""
    import dataclasses

    from dexlfd.apps.demo import DemoConfig, write_demo_rerun
    from dexlfd.apps.record import RecordConfig, record_demonstration
    from dexlfd.data import hand_video
    from dexlfd.io import save_demonstration, save_model, save_plan, save_rollout

    cfg = dataclasses.replace(DemoConfig(), n_demos=2, real_video_width_px=320)
    assert cfg.real_video == hand_video()  # the packaged sample
    for sub in ("demos", "capture", "plans", "control"):
        (tmp_path / sub).mkdir()
    for i in range(2):
        save_demonstration(tmp_path / "demos" / f"demo_{i:02d}.npz", logged["demo"])
    real = record_demonstration(
        str(cfg.real_video), RecordConfig(max_frames=8, resize_width=cfg.real_video_width_px)
    ).demo
    save_demonstration(tmp_path / "capture" / "real_hand.npz", real)
    save_model(tmp_path / "model.npz", logged["model"])
    save_plan(tmp_path / "plans" / "task.npz", logged["plan"])
    save_rollout(tmp_path / "control" / "ntsm-pd_1.2kg.npz", logged["rollout"])
    rec = _load_recording(str(write_demo_rerun(cfg, tmp_path, tmp_path / "d.rrd")))
    entities = {c.entity_path for c in rec.schema().component_columns()}
    for e in ("/world/demo_00/ee", "/world/demo_01/hand", "/world/real_hand/ee",
              "/camera/image/hand", "/world/model/tube", "/world/obstacles",
              "/world/robot/tcp_path"):  # fmt: skip
        assert e in entities, e
    img = _read(rec, "/camera/image")
    np.testing.assert_allclose(_seconds(img), real.t, atol=1e-9)  # one image per tracked frame
    uv = np.stack(_rows(_read(rec, "/camera/image/hand"), "/camera/image/hand:Points2D:positions"))
    np.testing.assert_allclose(uv, real.extras["uv_px"][real.extras["detected"]], atol=1e-3)


def test_errors_name_the_recording_not_a_flag(tmp_path: Path) -> None:
    for bad in (tmp_path / "x.mp4", tmp_path / "nope" / "x.rrd"):
        with pytest.raises((InvalidInput, InvalidFile)) as info:
            RerunLog(bad)
        assert str(info.value).startswith(f"rerun recording {bad}: ")
        assert "--" not in str(info.value)


def test_rollout_draws_the_arm_from_its_urdf(logged) -> None:
    """The URDF's links as meshes, and each joint's transform from rerun's URDF support.

    rerun computes the joint transforms itself (``UrdfJoint.compute_transform_columns``);
    they must equal the bag export's own URDF kinematics at the rollout's joints.
    """
    from scipy.spatial.transform import Rotation

    from dexlfd.io._urdf_tf import joint_transforms, panda_joints

    ro = logged["rollout"]
    entities = {c.entity_path for c in logged["rec"].chunks}
    for link in [f"panda_link{i}" for i in range(8)] + ["panda_hand", "panda_leftfinger"]:
        assert any(f"/visual_geometries/{link}/" in e for e in entities), link
    joints = {j.name: j for j in panda_joints()}
    for name, values in (("panda_joint4", ro.q[:, 3]), ("panda_finger_joint1", ro.gripper / 2)):
        table = _read(logged["rec"], f"/robot/joints/{name}")
        assert table.num_rows == ro.n_samples
        np.testing.assert_allclose(_seconds(table), ro.t - ro.t[0], atol=1e-9)
        col = f"/robot/joints/{name}:Transform3D:"
        parent = {v[0] for v in table.column(col + "parent_frame").to_pylist()}
        assert parent == {f"robot/{joints[name].parent}"}
        p, q = joint_transforms(joints[name], values)
        got_q = np.array([v[0] for v in table.column(col + "quaternion").to_pylist()])
        got_p = np.array([v[0] for v in table.column(col + "translation").to_pylist()])
        np.testing.assert_allclose(got_p, p, atol=1e-6)  # float32
        angle = (Rotation.from_quat(got_q).inv() * Rotation.from_quat(q)).magnitude()
        assert angle.max() < 1e-5
