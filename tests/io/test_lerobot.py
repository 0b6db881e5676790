"""LeRobotDataset v3.0 export/import; checked with the ``lerobot`` package itself when present."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from dexlfd.cli import main
from dexlfd.errors import InvalidFile, InvalidInput
from dexlfd.io import Demonstration, Rollout, load_demonstration, load_model
from dexlfd.io.demonstration_facts import Quality
from dexlfd.io.lerobot import export_lerobot, import_lerobot, uniform_grid

pq = pytest.importorskip("pyarrow.parquet", reason="pyarrow not installed")

REPO = Path(__file__).resolve().parents[2]
F32 = float(np.finfo(np.float32).eps)


def _mat(table, key: str, width: int) -> np.ndarray:
    return np.asarray(table.column(key).combine_chunks().flatten()).reshape(-1, width)


def _lerobot_python(*, decoding_video: bool = False) -> Path:
    """The LeRobot environment ``make lerobot-env`` built for this machine's Python."""
    from dexlfd.io._lerobot_env import choose_lerobot, default_lerobot_root, lerobot_python

    choice = choose_lerobot()
    python = lerobot_python(default_lerobot_root(), choice.recipe)
    if not (python.parent.parent / ".installed").is_file():
        pytest.skip(
            f"no LeRobot environment at {python.parent.parent} ({choice.recipe.size}, created "
            "by `make lerobot-env`); the check with lerobot's own loader is skipped"
        )
    if decoding_video and not choice.recipe.decodes_video:
        pytest.skip(
            f"lerobot {choice.recipe.version} ({choice.reason}) cannot decode video here; "
            "the exported video is checked with OpenCV"
        )
    return python


def _assert_demo_close(got: Demonstration, want: Demonstration) -> None:
    np.testing.assert_allclose(got.t, want.t, rtol=0, atol=4 * F32 * max(1.0, want.t[-1]))
    np.testing.assert_array_equal(got.valid, want.valid)
    np.testing.assert_array_equal(got.grasp, want.grasp)
    v = want.valid
    np.testing.assert_allclose(got.position[v], want.position[v], rtol=F32, atol=1e-7)
    np.testing.assert_allclose(got.quaternion[v], want.quaternion[v], rtol=0, atol=4 * F32)
    np.testing.assert_allclose(got.gripper[v], want.gripper[v], rtol=F32, atol=1e-8)
    np.testing.assert_allclose(got.keypoints, want.keypoints, rtol=F32, atol=1e-7)  # NaN kept
    assert np.isnan(got.position[~v]).all()


def test_layout_and_round_trip(tmp_path: Path, demos: list[Demonstration]) -> None:
    out = export_lerobot(demos, tmp_path / "ds", task="pick the box and place it")
    info = json.loads((out / "meta/info.json").read_text())
    assert info["codebase_version"] == "v3.0" and info["fps"] == 30
    assert info["total_episodes"] == 6
    assert info["total_frames"] == sum(d.n_samples for d in demos)
    assert info["features"]["observation.state"]["names"][-1] == "gripper"
    for rel in (
        "meta/stats.json",
        "meta/tasks.parquet",
        "meta/episodes/chunk-000/file-000.parquet",
    ):
        assert (out / rel).is_file()
    data = pq.read_table(out / "data/chunk-000/file-000.parquet")
    ts = np.asarray(data.column("timestamp"))
    assert ts.dtype == np.float32
    eps = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    for e, (row, demo) in enumerate(zip(eps, demos, strict=True)):
        a, b = row["dataset_from_index"], row["dataset_to_index"]
        assert b - a == demo.n_samples == row["length"]
        assert (np.asarray(data.column("episode_index"))[a:b] == e).all()
        np.testing.assert_allclose(ts[a:b], np.arange(b - a) / 30.0, atol=1e-6)  # lerobot: 1e-4
        state = _mat(data, "observation.state", 8)[a:b]
        np.testing.assert_array_equal(state[:, :3], demo.position.astype(np.float32))
        assert row["tasks"] == ["pick the box and place it"]
    stats = json.loads((out / "meta/stats.json").read_text())
    st = _mat(data, "observation.state", 8)
    np.testing.assert_allclose(
        stats["observation.state"]["mean"], st.astype(np.float64).mean(axis=0), rtol=1e-12
    )
    assert stats["observation.state"]["count"] == [len(st)]
    back = import_lerobot(out)
    assert back.fps == 30 and back.tasks == ["pick the box and place it"]
    for got, want in zip(back.records, demos, strict=True):
        _assert_demo_close(got, want)
        assert got.meta["generator"] == want.meta["generator"]


def test_unseen_frames_are_filled_flagged_and_restored(tmp_path: Path, demos) -> None:
    d = demos[0]
    valid = d.valid.copy()
    valid[40:55] = False
    nan = np.where(valid[:, None], 1.0, np.nan)
    demo = Demonstration(
        t=d.t + 2.5,
        keypoints=d.keypoints * nan[:, :, None],
        valid=valid,
        position=d.position * nan,
        quaternion=d.quaternion * nan,
        gripper=d.gripper * nan[:, 0],
        grasp=d.grasp,
    )
    out = export_lerobot([demo], tmp_path / "ds")
    data = pq.read_table(out / "data/chunk-000/file-000.parquet")
    state = _mat(data, "observation.state", 8)
    assert np.isfinite(state).all()  # no NaN reaches a training loop
    assert np.asarray(data.column("observation.hand_visible")).tolist() == valid.tolist()
    # filled by linear interpolation between the nearest seen frames
    i = 47
    w = (demo.t[i] - demo.t[39]) / (demo.t[55] - demo.t[39])
    np.testing.assert_allclose(
        state[i, :3], (1 - w) * d.position[39] + w * d.position[55], atol=1e-6
    )
    (got,) = import_lerobot(out).records
    _assert_demo_close(got, demo)  # t0 = 2.5 s restored, NaN where unseen


def test_irregular_times_are_resampled_to_the_grid(tmp_path: Path, rng) -> None:
    t = np.sort(rng.uniform(0.0, 2.0, 90))
    t[0], t[-1] = 0.0, 2.0
    rot = Rotation.from_rotvec(np.outer(t, [0.0, 0.0, 0.8]))  # constant rate about z
    n = t.size
    demo = Demonstration(
        t=t,
        keypoints=np.zeros((n, 21, 3)) + t[:, None, None],
        valid=np.ones(n, dtype=bool),
        position=np.outer(t, [0.1, -0.2, 0.05]) + [0.4, 0.0, 0.3],
        quaternion=rot.as_quat(),
        gripper=0.08 - 0.01 * t,
        grasp=t > 1.0,
    )
    grid, same = uniform_grid(t, 25)
    assert not same and grid.size == 51
    (got,) = import_lerobot(export_lerobot([demo], tmp_path / "ds", fps=25)).records
    np.testing.assert_allclose(got.t, grid, atol=1e-6)
    # linear motions are reproduced exactly by linear interpolation (closed form)
    np.testing.assert_allclose(
        got.position, np.outer(grid, [0.1, -0.2, 0.05]) + [0.4, 0, 0.3], atol=1e-6
    )
    np.testing.assert_allclose(got.gripper, 0.08 - 0.01 * grid, atol=1e-7)
    want_q = Slerp(t, rot)(grid).as_quat()  # scipy's slerp as the oracle
    np.testing.assert_allclose(got.quaternion, want_q, atol=1e-6)
    np.testing.assert_array_equal(
        got.grasp[np.abs(grid - 1.0) > 0.05], grid[np.abs(grid - 1.0) > 0.05] > 1.0
    )


def _rollout(rng, n: int = 40) -> Rollout:
    q4 = Rotation.random(n, random_state=8).as_quat()
    return Rollout(
        t=np.arange(n) / 100.0,
        q=rng.normal(size=(n, 7)),
        dq=rng.normal(size=(n, 7)),
        tau=rng.normal(size=(n, 7)),
        ee_position=rng.normal(size=(n, 3)),
        ee_quaternion=q4,
        ref_position=rng.normal(size=(n, 3)),
        ref_quaternion=q4,
        gripper=np.full(n, 0.03),
    )


def test_rollouts_state_has_joints(tmp_path: Path, rng) -> None:
    ro = _rollout(rng)
    out = export_lerobot([ro, _rollout(rng, 25)], tmp_path / "ro", fps=100)
    info = json.loads((out / "meta/info.json").read_text())
    assert info["fps"] == 100
    assert info["features"]["observation.state"]["shape"] == [15]
    data = pq.read_table(out / "data/chunk-000/file-000.parquet")
    state = _mat(data, "observation.state", 15)[:40]
    np.testing.assert_array_equal(state[:, 8:], ro.q.astype(np.float32))
    np.testing.assert_array_equal(state[:, 3:7], ro.ee_quaternion.astype(np.float32))
    action = _mat(data, "action", 8)[:40]
    np.testing.assert_array_equal(action[:, :3], ro.ref_position.astype(np.float32))
    effort = _mat(data, "observation.effort", 7)[:40]
    np.testing.assert_array_equal(effort, ro.tau.astype(np.float32))
    with pytest.raises(InvalidFile, match="only demonstrations import"):
        import_lerobot(out)


def test_a_rollouts_typed_facts_go_with_its_episode(tmp_path: Path, rng) -> None:
    """As a demonstration's do: in the episode's ``dexlfd/meta``, read back the same."""
    import dataclasses

    from dexlfd.io.plan_facts import GraspSchedule
    from dexlfd.io.rollout_facts import GraspEvent, ObjectReport, Placement, TaskPoses

    pose = (0.5, 0.0, 0.2, 0.0, 0.0, 0.0, 1.0)
    facts = {
        "stopped": "joint 4 velocity limit at t = 0.3 s", "controller": "ntsm_dob",
        "rate_hz": 100.0, "payload_kg": 1.2,
        "grasp_schedule": GraspSchedule(source="plan", grasp_t=0.1, release_t=0.3,
                                        intervals_s=((0.1, 0.3),)),
        "grasp_events": (GraspEvent("dropped", 0.25, 0.04),),
        "object_report": ObjectReport((0.5, 0.1, 0.05), (0.0, 0.0, 0.0, 1.0), 2.5),
        "task": TaskPoses(pose, pose),
        "placement": Placement(False, True, 0.03, 0.02, 2.5, 0.05, "2.0 cm from the place"),
    }  # fmt: skip
    ro = dataclasses.replace(_rollout(rng), meta={"controller": {"kp": 1.0}}, **facts)
    out = export_lerobot([ro], tmp_path / "ro", fps=100)
    episodes = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet")
    meta = json.loads(episodes.column("dexlfd/meta")[0].as_py())
    back, rest = Rollout._read_facts({}, meta, 2, "episode 0")
    assert back == facts
    assert rest["controller"] == {"kp": 1.0, "name": "ntsm_dob"}  # the gains stay


@pytest.mark.slow
def test_lerobot_itself_loads_rollouts(tmp_path: Path, rng) -> None:
    from dexlfd.io._lerobot_env import load_with_lerobot

    python = _lerobot_python()
    rollouts = [_rollout(rng), _rollout(rng, 25)]
    got = load_with_lerobot(
        python, export_lerobot(rollouts, tmp_path / "ro", fps=100), tmp_path / "hf"
    )
    assert got["fps"] == 100 and got["episode_ranges"] == [[0, 40], [40, 65]]
    frames = {k: np.asarray(v) for k, v in got["frames"].items()}
    for ro, s in zip(rollouts, (slice(0, 40), slice(40, 65)), strict=True):
        pose = np.concatenate([ro.ee_position, ro.ee_quaternion, ro.gripper[:, None]], axis=1)
        np.testing.assert_array_equal(
            frames["observation.state"][s], np.concatenate([pose, ro.q], axis=1).astype(np.float32)
        )
        np.testing.assert_array_equal(frames["observation.velocity"][s], ro.dq.astype(np.float32))
        np.testing.assert_array_equal(frames["observation.effort"][s], ro.tau.astype(np.float32))
        ref = np.concatenate([ro.ref_position, ro.ref_quaternion, ro.gripper[:, None]], axis=1)
        np.testing.assert_array_equal(frames["action"][s], ref.astype(np.float32))


def test_bad_inputs(tmp_path: Path, demos, rng) -> None:
    with pytest.raises(InvalidInput, match="not both"):
        export_lerobot([demos[0], _rollout(rng)], tmp_path / "mixed")
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "keep.txt").write_text("mine")
    with pytest.raises(InvalidFile, match="not an empty folder"):
        export_lerobot(demos[:1], tmp_path / "full")
    assert (tmp_path / "full" / "keep.txt").read_text() == "mine"
    with pytest.raises(InvalidInput, match="fps"):
        export_lerobot(demos[:1], tmp_path / "x", fps=0.2)
    with pytest.raises(InvalidFile, match="not a LeRobot dataset"):
        import_lerobot(tmp_path / "full")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["full"]  # nothing half-written


def test_cli_export_then_learn_from_the_folder(tmp_path: Path, capsys) -> None:
    assert main(["synth", "-n", "3", "-o", str(tmp_path / "d")]) == 0
    files = sorted(str(p) for p in (tmp_path / "d").glob("demo_*.npz"))
    assert main(["export", *files, "-o", str(tmp_path / "ds")]) == 0  # several -> lerobot
    assert (tmp_path / "ds" / "meta" / "info.json").is_file()
    args = ["--k", "3", "--seed", "1"]
    assert main(["learn", str(tmp_path / "ds"), "-o", str(tmp_path / "a.npz"), *args]) == 0
    assert main(["learn", *files, "-o", str(tmp_path / "b.npz"), *args]) == 0
    a, b = load_model(tmp_path / "a.npz"), load_model(tmp_path / "b.npz")
    np.testing.assert_allclose(a.mean, b.mean, atol=1e-4)  # float32 storage only
    for f in files:
        load_demonstration(f)  # inputs untouched and still valid
    # the folder synth wrote is read as its demonstration files: the same model
    assert main(["learn", str(tmp_path / "d"), "-o", str(tmp_path / "c.npz"), *args]) == 0
    np.testing.assert_allclose(load_model(tmp_path / "c.npz").mean, b.mean, atol=1e-12)


@pytest.mark.slow
def test_lerobot_itself_loads_the_same_numbers(tmp_path: Path, demos) -> None:
    from dexlfd.io._lerobot_env import load_with_lerobot

    python = _lerobot_python()
    out = export_lerobot(demos, tmp_path / "ds", task="pick and place")
    got = load_with_lerobot(python, out, tmp_path / "hf-cache")
    assert got["fps"] == 30 and got["num_episodes"] == 6
    assert got["num_frames"] == sum(d.n_samples for d in demos)
    assert set(got["tasks"]) == {"pick and place"}
    starts = np.cumsum([0] + [d.n_samples for d in demos])
    assert got["episode_ranges"] == [
        [int(a), int(b)] for a, b in zip(starts[:-1], starts[1:], strict=True)
    ]
    state = np.asarray(got["frames"]["observation.state"])
    action = np.asarray(got["frames"]["action"])
    kp = np.asarray(got["frames"]["observation.hand_keypoints"])
    ts = np.asarray(got["frames"]["timestamp"])
    for e, d in enumerate(demos):
        s = slice(starts[e], starts[e + 1])
        pose = np.concatenate([d.position, d.quaternion, d.gripper[:, None]], axis=1)
        np.testing.assert_array_equal(state[s], pose.astype(np.float32))
        np.testing.assert_array_equal(action[s][:-1], pose[1:].astype(np.float32))
        np.testing.assert_array_equal(
            kp[s], d.keypoints.reshape(d.n_samples, -1).astype(np.float32)
        )
        np.testing.assert_allclose(ts[s], d.t, atol=1e-6)
        assert np.asarray(got["frames"]["episode_index"])[s].tolist() == [e] * d.n_samples


def _gray_video(path: Path, n: int, fps: float = 30.0) -> Path:
    from dexlfd.io.video import VideoWriter

    with VideoWriter(path, fps=fps, crf=0) as writer:
        for i in range(n):
            writer.write(np.full((48, 64, 3), 4 * i, dtype=np.uint8))  # frame i has gray 4 i
    return path


def _sliced(d: Demonstration, a: int, b: int, meta: dict) -> Demonstration:
    meta = dict(meta)
    quality = meta.pop("quality", None)
    return Demonstration(
        t=d.t[a:b],
        keypoints=d.keypoints[a:b],
        valid=d.valid[a:b],
        position=d.position[a:b],
        quaternion=d.quaternion[a:b],
        gripper=d.gripper[a:b],
        grasp=d.grasp[a:b],
        meta=meta,
        quality=None if quality is None else Quality.from_json(quality, "quality"),
    )


def test_source_video_frames_go_into_the_episode_video(tmp_path: Path, demos) -> None:
    import cv2

    video = _gray_video(tmp_path / "hand.mp4", 60)
    meta = {"source": f"video file {video}", "source_kind": "video", "fps": 30.0}
    recorded = {"capture": meta}  # where dexlfd record keeps them
    eps = [_sliced(demos[0], 0, 20, recorded), _sliced(demos[1], 30, 55, meta)]  # t = k / 30 s
    ticks: list[tuple[int, float]] = []
    out = export_lerobot(eps, tmp_path / "ds", callback=lambda i, t: ticks.append((i, t)))
    # progress: one call per frame written, with its time in the dataset's video
    assert ticks == [(i, i / 30) for i in range(45)]
    info = json.loads((out / "meta/info.json").read_text())
    feat = info["features"]["observation.images.camera"]
    assert feat["dtype"] == "video" and feat["shape"] == [48, 64, 3]
    assert (
        info["video_path"] == "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
    )
    rows = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    key = "videos/observation.images.camera"
    assert [(r[f"{key}/from_timestamp"], r[f"{key}/to_timestamp"]) for r in rows] == [
        (0.0, 20 / 30),
        (20 / 30, 45 / 30),
    ]
    cap = cv2.VideoCapture(str(out / "videos/observation.images.camera/chunk-000/file-000.mp4"))
    gray = []
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        gray.append(float(frame.mean()))
    cap.release()
    want = [4.0 * i for i in range(20)] + [4.0 * i for i in range(30, 55)]  # source frame = t * 30
    np.testing.assert_allclose(gray, want, atol=2.0)
    (tmp_path / "gone.mp4").write_bytes(b"")
    eps2 = [_sliced(demos[0], 0, 20, meta), _sliced(demos[0], 0, 20, {})]
    out2 = export_lerobot(eps2, tmp_path / "ds2")  # not every demo has a video: none written
    assert not (out2 / "videos").exists()
    assert (
        "observation.images.camera"
        not in json.loads((out2 / "meta/info.json").read_text())["features"]
    )


def test_image_statistics_from_histograms_match_numpy(rng) -> None:
    from dexlfd.io.lerobot._schema import QUANTILES, image_stats

    pixels = rng.integers(0, 256, size=(7, 5, 9, 3)).astype(np.uint8)  # frames, h, w, rgb
    pixels[..., 2] = np.clip(pixels[..., 2], 40, 90)  # one channel uses few values
    hist = np.stack([np.bincount(pixels[..., c].ravel(), minlength=256) for c in range(3)])
    got = image_stats(hist, 7)
    x = pixels.reshape(-1, 3) / 255.0  # numpy on every value: the oracle
    want = {"min": x.min(0), "max": x.max(0), "mean": x.mean(0), "std": x.std(0)}
    want |= {f"q{round(q * 100):02d}": np.quantile(x, q, axis=0) for q in QUANTILES}
    assert set(got) == {*want, "count"} and got["count"] == [7]
    for key, value in want.items():
        assert np.asarray(got[key]).shape == (3, 1, 1)  # as LeRobot stores a camera's
        np.testing.assert_allclose(np.asarray(got[key]).ravel(), value, rtol=1e-12, atol=1e-15)


def test_the_camera_has_statistics_of_the_frames_written(tmp_path: Path, demos) -> None:
    import cv2

    from dexlfd.io.video import VideoWriter

    video = tmp_path / "hand.mp4"
    with VideoWriter(video, fps=30.0, crf=0) as writer:
        for i in range(40):
            writer.write(
                np.dstack([np.full((32, 48), v, np.uint8) for v in (4 * i, 2 * i, 200 - i)])
            )
    meta = {"source": f"video file {video}", "source_kind": "video", "fps": 30.0}
    eps = [_sliced(demos[0], 0, 10, meta), _sliced(demos[1], 20, 35, meta)]
    out = export_lerobot(eps, tmp_path / "ds")
    cap, source = cv2.VideoCapture(str(video)), []
    while (frame := cap.read())[0]:
        source.append(cv2.cvtColor(frame[1], cv2.COLOR_BGR2RGB))
    cap.release()
    key = "observation.images.camera"
    stats = json.loads((out / "meta/stats.json").read_text())[key]
    frames = [source[:10], source[20:35]]  # what the episodes took from the source
    pixels = np.concatenate([np.asarray(f) for f in frames]).reshape(-1, 3) / 255.0
    assert stats["count"] == [25]
    for name, want in (("mean", pixels.mean(0)), ("q50", np.quantile(pixels, 0.5, axis=0))):
        np.testing.assert_allclose(np.asarray(stats[name]).ravel(), want, rtol=1e-12)
    rows = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    for row, f in zip(rows, frames, strict=True):
        mine = np.asarray(f).reshape(-1, 3) / 255.0
        assert row[f"stats/{key}/count"] == [len(f)]
        np.testing.assert_allclose(np.asarray(row[f"stats/{key}/max"]).ravel(), mine.max(0))


def test_resampling_skips_each_columns_unseen_samples(rng) -> None:
    from dexlfd.io.lerobot._frames import _Linear

    t = np.sort(rng.uniform(0.0, 3.0, 40))
    x = rng.normal(size=(40, 5, 3))
    x[3:9, 1] = np.nan  # one landmark unseen for a while
    x[20:, 2, 0] = np.nan  # one coordinate unseen to the end
    x[:, 4] = np.nan  # one landmark never seen
    grid = np.linspace(0.0, 3.0, 31)
    lin = _Linear(t, x)
    got = lin.at(grid)
    by_block = np.concatenate([lin.at(grid[a : a + 7]) for a in range(0, grid.size, 7)])
    np.testing.assert_array_equal(by_block, got)  # a block's frames: those of the whole grid
    for j in range(5):
        for a in range(3):
            ok = np.isfinite(x[:, j, a])
            want = np.interp(grid, t[ok], x[ok, j, a]) if ok.any() else np.zeros(grid.size)
            np.testing.assert_array_equal(got[:, j, a], want)  # np.interp per column: the oracle


@pytest.mark.slow
def test_lerobot_itself_decodes_the_episode_video(tmp_path: Path, demos) -> None:
    from dexlfd.io._lerobot_env import load_with_lerobot

    python = _lerobot_python(decoding_video=True)
    video = _gray_video(tmp_path / "hand.mp4", 60)
    meta = {"source": f"video file {video}", "source_kind": "video", "fps": 30.0}
    eps = [_sliced(demos[0], 0, 20, meta), _sliced(demos[1], 30, 55, meta)]  # t = k / 30 s
    out = export_lerobot(eps, tmp_path / "ds")
    got = load_with_lerobot(python, out, tmp_path / "hf-cache")
    assert got["num_frames"] == 45 and got["episode_ranges"] == [[0, 20], [20, 45]]
    assert got["video_backend"] in {"pyav", "torchcodec"}  # decoded by lerobot itself
    assert "observation.images.camera" in got["stats_keys"]  # its training normalizes with them
    camera = got["images"]["observation.images.camera"]
    assert camera["shape"] == [[3, 48, 64]] * 45  # channels first, as lerobot returns them
    gray = 255.0 * np.asarray(camera["mean"])  # lerobot scales to [0, 1]
    want = [4.0 * i for i in range(20)] + [4.0 * i for i in range(30, 55)]  # source frame = t * 30
    np.testing.assert_allclose(gray, np.repeat(np.asarray(want)[:, None], 3, axis=1), atol=2.0)
    state = np.asarray(got["frames"]["observation.state"])
    np.testing.assert_array_equal(state[:20, :3], demos[0].position[:20].astype(np.float32))


@pytest.mark.slow
def test_a_recorded_video_keeps_its_camera_video_in_the_export(tmp_path: Path) -> None:
    """record -> export --format lerobot: the real recording's frames reach the dataset."""
    from dexlfd.data import hand_video

    demo = tmp_path / "rec.npz"
    argv = ["record", str(hand_video()), "--max-frames", "40", "--no-trim", "-o", str(demo)]
    assert main(argv) == 0
    out = tmp_path / "ds"
    assert main(["export", str(demo), "--format", "lerobot", "-o", str(out)]) == 0
    info = json.loads((out / "meta/info.json").read_text())
    assert info["features"]["observation.images.camera"]["dtype"] == "video"
    assert list((out / "videos/observation.images.camera").rglob("*.mp4"))


@pytest.mark.parametrize("stage", ["parquet", "parser"])
def test_ctrl_c_during_a_lerobot_export_is_one_line_and_leaves_nothing(
    tmp_path: Path, capsys, monkeypatch, stage: str
) -> None:
    """Ctrl-C while the dataset is written (or while the command starts): exit 130, one
    line, no traceback, no dataset folder and no temporary folder beside it."""
    import dexlfd.cli

    assert main(["synth", "-n", "2", "-o", str(tmp_path / "d"), "-q"]) == 0
    files = sorted(str(p) for p in (tmp_path / "d").glob("demo_*.npz"))
    capsys.readouterr()

    def ctrl_c(*args: object, **kwargs: object) -> None:
        raise KeyboardInterrupt  # what SIGINT raises in the main thread

    if stage == "parquet":
        written = []

        def write_table(table: object, where: object) -> None:
            written.append(where)
            if len(written) == 2:  # some of the dataset's files are already on disk
                ctrl_c()
            real_write_table(table, where)

        real_write_table = pq.write_table
        monkeypatch.setattr(pq, "write_table", write_table)
    else:
        monkeypatch.setattr(dexlfd.cli, "_build_parser", ctrl_c)
    out = tmp_path / "ds"
    assert main(["export", *files, "--format", "lerobot", "-o", str(out)]) == 130
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1].startswith("dexlfd export: interrupted")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d"]  # nothing beside the inputs


def test_defaults_rate_task_card_and_video_size(tmp_path: Path, demos, rng) -> None:
    """A rollout is not 1000 fps by default; a NOT USABLE recording is not "pick and place"."""
    from dexlfd.io.lerobot._write import NOT_A_TASK, PICK_AND_PLACE, ROLLOUT_FPS

    fast = _rollout(rng, 1001)
    fast = Rollout(**{**{k: getattr(fast, k) for k in fast.SPECS if getattr(fast, k) is not None},
                      "t": np.arange(1001) / 1000.0})  # fmt: skip
    out = export_lerobot([fast], tmp_path / "ro")
    info = json.loads((out / "meta/info.json").read_text())
    assert info["fps"] == ROLLOUT_FPS == 30 and info["total_frames"] == 31
    video = _gray_video(tmp_path / "hand.mp4", 60)
    meta = {"source": f"video file {video}", "source_kind": "video", "fps": 30.0}
    bad = {"capture": meta, "quality": {"usable": False, "warnings": ["no pick-and-place"]}}
    good = {"capture": meta, "quality": {"usable": True, "warnings": []}}
    eps = [_sliced(demos[0], 0, 20, bad), _sliced(demos[1], 0, 20, good)]
    out = export_lerobot(eps, tmp_path / "ds", names=["a.npz", "b.npz"], video_size=(32, 24))
    info = json.loads((out / "meta/info.json").read_text())
    assert info["fps"] == 30 and info["total_tasks"] == 2  # the recordings' own rate
    assert info["features"]["observation.images.camera"]["shape"] == [24, 32, 3]
    rows = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    assert [r["tasks"] for r in rows] == [[NOT_A_TASK], [PICK_AND_PLACE]]
    data = pq.read_table(out / "data/chunk-000/file-000.parquet")
    np.testing.assert_array_equal(np.asarray(data.column("task_index")), [0] * 20 + [1] * 20)
    tasks = pq.read_table(out / "meta/tasks.parquet").to_pylist()  # pandas' index column
    assert [(r["__index_level_0__"], r["task_index"]) for r in tasks] == [
        (NOT_A_TASK, 0), (PICK_AND_PLACE, 1)
    ]  # fmt: skip
    card = (out / "README.md").read_text()
    assert card.startswith("---\nlicense: mit\n") and "- LeRobot" in card
    assert "| 0 | a.npz | recorded demonstration, NOT USABLE |" in card
    assert '"total_frames": 40' in card
    assert import_lerobot(out).tasks == [NOT_A_TASK, PICK_AND_PLACE]
    given = export_lerobot(eps, tmp_path / "given", task="wave")
    assert pq.read_table(given / "meta/tasks.parquet").num_rows == 1


def test_cli_export_video_size_and_fps_flags(tmp_path: Path, capsys) -> None:
    assert main(["synth", "-n", "1", "-o", str(tmp_path)]) == 0
    src = str(tmp_path / "demo_00.npz")
    assert main(["export", src, "-o", str(tmp_path / "bag"), "--fps", "10"]) == 1
    assert "--fps applies to --format lerobot and csv only" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:  # a usage error: one line, exit 2
        main(["export", src, "-o", str(tmp_path / "ds"), "--format", "lerobot",
              "--video-size", "32x"])  # fmt: skip
    assert exc.value.code == 2 and "--video-size" in capsys.readouterr().err
    assert not (tmp_path / "d.csv").exists() and not (tmp_path / "ds").exists()
