"""LeRobotDataset v3.0 export and import of demonstrations and rollouts (pyarrow only).

Layout written (LeRobot's ``codebase_version`` ``"v3.0"``)::

    DIR/meta/info.json                           fps, features, totals, path templates
    DIR/meta/stats.json                          min/max/mean/std/count (+ quantiles) per feature
    DIR/meta/tasks.parquet                       task string (pandas index) -> task_index
    DIR/meta/episodes/chunk-000/file-000.parquet one row per episode
    DIR/data/chunk-000/file-000.parquet          one row per frame, every episode
    DIR/videos/observation.images.camera/chunk-000/file-000.mp4   (see below)

One episode per demonstration or rollout; a dataset holds one kind (their
``observation.state`` differ). Every episode is put on the uniform time grid
``timestamp = frame_index / fps`` that LeRobot requires (its loader checks it to
1e-4 s): an input already on that grid is copied, any other one is resampled
(linear interpolation; spherical for quaternions; nearest sample for flags).

Demonstration features (float32 unless said): ``observation.state`` (8,)
= end-effector ``x, y, z`` [m], ``qx, qy, qz, qw`` (scalar-last), ``gripper`` [m];
``action`` (8,) = the next frame's state (the target the hand moved to; the last
frame repeats itself); ``observation.hand_keypoints`` (63,) = 21 MediaPipe
landmarks × ``x, y, z`` [m], base frame, NaN where unseen (as in the
demonstration); ``observation.hand_visible`` and ``observation.grasp`` (bool).
Where the hand was not seen, state and action are interpolated from the nearest
seen frames (no NaN in them) and ``observation.hand_visible`` is false;
:func:`import_lerobot` restores NaN there. Statistics ignore NaN.

Rollout features: ``observation.state`` (15,) = measured pose + gripper + joint
positions ``panda_joint1..7`` [rad]; ``observation.velocity`` and
``observation.effort`` (7,) [rad/s], [N·m]; ``action`` (8,) = the reference pose
+ gripper the controller tracked.

When every demonstration was recorded from a video file that still exists
(``meta["source"] == "video file PATH"``, ``meta["fps"]``, as ``dexlfd record``
writes them), the frames at the episode's frame times (nearest source frame) are
re-encoded (H.264) into one MP4, feature ``observation.images.camera``, with
LeRobot's ``videos/<key>/from_timestamp`` / ``to_timestamp`` per episode.

Each episode row also carries ``dexlfd/t0`` (the input's first time [s]) and
``dexlfd/meta`` (its ``meta`` as JSON), so an import gives back the original
records. The dataset is written into a temporary sibling folder and renamed: an
interrupted export leaves nothing under the final name.
"""

from __future__ import annotations

import json
import logging
import os
import shutil
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import DependencyNotInstalled, InvalidFile, InvalidInput
from dexlfd.io.demonstration import N_LANDMARKS, Demonstration
from dexlfd.io.rollout import N_JOINTS, Rollout
from dexlfd.rotations import (
    quat_conjugate,
    quat_exp,
    quat_log,
    quat_multiply,
    quat_normalize,
    quat_sign_continuous,
)

__all__ = [
    "CODEBASE_VERSION",
    "LeRobotEpisodes",
    "export_lerobot",
    "import_lerobot",
    "is_lerobot_dataset",
    "uniform_grid",
]

logger = logging.getLogger(__name__)

CODEBASE_VERSION = "v3.0"
CHUNK_FILE = "chunk-{chunk_index:03d}/file-{file_index:03d}"
DATA_PATH = "data/" + CHUNK_FILE + ".parquet"
VIDEO_PATH = "videos/{video_key}/" + CHUNK_FILE + ".mp4"
EPISODES_PATH = "meta/episodes/" + CHUNK_FILE + ".parquet"
GRID_TOL_S = 1e-6  # an input whose times are within this of k/fps is copied, not resampled
QUANTILES = (0.01, 0.10, 0.50, 0.90, 0.99)

POSE_NAMES = ["x", "y", "z", "qx", "qy", "qz", "qw", "gripper"]
JOINT_NAMES = [f"panda_joint{i}" for i in range(1, N_JOINTS + 1)]
KEYPOINT_NAMES = [f"kp{i:02d}_{a}" for i in range(N_LANDMARKS) for a in "xyz"]


def _pa() -> Any:
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError as exc:  # pragma: no cover - pyarrow is a dependency
        raise DependencyNotInstalled("pyarrow", "LeRobot dataset export/import") from exc
    return pa, pq


def _feature(dtype: str, names: list[str] | None) -> dict[str, Any]:
    return {"dtype": dtype, "shape": [len(names) if names else 1], "names": names}


DEFAULT_FEATURES = {
    "timestamp": _feature("float32", None),
    "frame_index": _feature("int64", None),
    "episode_index": _feature("int64", None),
    "index": _feature("int64", None),
    "task_index": _feature("int64", None),
}
DEMO_FEATURES = {
    "observation.state": _feature("float32", POSE_NAMES),
    "action": _feature("float32", POSE_NAMES),
    "observation.hand_keypoints": _feature("float32", KEYPOINT_NAMES),
    "observation.hand_visible": _feature("bool", None),
    "observation.grasp": _feature("bool", None),
}
ROLLOUT_FEATURES = {
    "observation.state": _feature("float32", POSE_NAMES + JOINT_NAMES),
    "observation.velocity": _feature("float32", JOINT_NAMES),
    "observation.effort": _feature("float32", JOINT_NAMES),
    "action": _feature("float32", POSE_NAMES),
}


# ----------------------------------------------------------------------------- resampling


def uniform_grid(t: FloatArray, fps: int) -> tuple[FloatArray, bool]:
    """Uniform times ``t[0] + k / fps`` covering ``t``; and whether ``t`` already is that grid.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Strictly increasing sample times [s].
    fps : int
        Frame rate of the grid [Hz].

    Returns
    -------
    grid : ndarray, shape (m,)
        ``t[0] + k / fps`` for ``k = 0 .. floor((t[-1] - t[0]) fps + 1e-9)``.
    same : bool
        True if ``t`` equals ``grid`` to :data:`GRID_TOL_S` (then nothing is resampled).
    """
    n = int(np.floor((t[-1] - t[0]) * fps + 1e-9)) + 1
    grid = t[0] + np.arange(n) / fps
    same = n == t.shape[0] and bool(np.all(np.abs(grid - t) <= GRID_TOL_S))
    return grid, same


def _interp(t: FloatArray, x: np.ndarray, grid: FloatArray) -> FloatArray:
    """Linear interpolation of each column of ``x`` (n, ...) at ``grid``; NaN rows skipped."""
    flat = np.asarray(x, dtype=np.float64).reshape(x.shape[0], -1)
    out = np.empty((grid.shape[0], flat.shape[1]))
    for j in range(flat.shape[1]):
        ok = np.isfinite(flat[:, j])
        out[:, j] = np.interp(grid, t[ok], flat[ok, j]) if ok.any() else 0.0
    return out.reshape((grid.shape[0], *x.shape[1:]))


def _slerp(t: FloatArray, q: FloatArray, grid: FloatArray) -> FloatArray:
    """Spherical interpolation of unit quaternions ``q`` (n, 4) at ``grid`` (NaN rows skipped)."""
    ok = np.isfinite(q).all(axis=1)
    if not ok.any():
        return np.tile([0.0, 0.0, 0.0, 1.0], (grid.shape[0], 1))
    tv, qv = t[ok], quat_sign_continuous(q[ok])
    k = np.clip(np.searchsorted(tv, grid, side="right") - 1, 0, max(tv.shape[0] - 2, 0))
    if tv.shape[0] == 1:
        return np.tile(qv[0], (grid.shape[0], 1))
    s = np.clip((grid - tv[k]) / (tv[k + 1] - tv[k]), 0.0, 1.0)
    rel = quat_log(quat_multiply(quat_conjugate(qv[k]), qv[k + 1]))  # half rotation vector
    out: FloatArray = quat_normalize(quat_multiply(qv[k], quat_exp(s[:, None] * rel)))
    return out


def _nearest(t: FloatArray, x: np.ndarray, grid: FloatArray) -> np.ndarray:
    """Value of ``x`` (n, ...) at the sample nearest to each time of ``grid``."""
    x = np.asarray(x)
    if t.shape[0] == 1:
        return x[np.zeros(grid.shape[0], dtype=np.intp)]
    k = np.clip(np.searchsorted(t, grid), 1, t.shape[0] - 1)
    left = (grid - t[k - 1]) <= (t[k] - grid)
    return x[np.where(left, k - 1, k)]


# ----------------------------------------------------------------------------- episodes


@dataclass(frozen=True)
class _Episode:
    columns: dict[str, np.ndarray]  # feature key -> (m, d) or (m,)
    t0: float
    meta: dict[str, Any]
    times: FloatArray  # the episode's frame times [s], on the input's clock


VIDEO_KEY = "observation.images.camera"


def _source_video(meta: dict[str, Any]) -> tuple[Path, float] | None:
    """The source video file and its frame rate recorded by ``dexlfd record``, if it exists."""
    source = str(meta.get("source", ""))
    if meta.get("source_kind") != "video" or not source.startswith("video file "):
        return None
    path = Path(source[len("video file ") :])
    fps = float(meta.get("fps") or 0.0)
    return (path, fps) if path.is_file() and fps > 0 else None


def _write_videos(episodes: list[_Episode], rate: int, path: Path) -> list[tuple[float, float]]:
    """Frames of each episode's source video at its frame times -> one MP4; episode spans [s].

    Source frame ``i`` is at ``i / fps`` (as ``dexlfd record`` timed it); each
    frame time takes the nearest source frame (the last one past the end).
    """
    import cv2

    from dexlfd.viz.video import VideoWriter

    spans: list[tuple[float, float]] = []
    start = 0
    with VideoWriter(path, fps=rate) as writer:
        for ep in episodes:
            src = _source_video(ep.meta)
            assert src is not None
            video, fps = src
            wanted = np.rint(ep.times * fps).astype(np.int64)
            cap = cv2.VideoCapture(str(video))
            try:
                i, frame, ok = -1, None, True
                for k in wanted:
                    while i < k and ok:
                        ok, bgr = cap.read()
                        if ok:
                            i, frame = i + 1, bgr
                    if frame is None:
                        raise InvalidFile(f"{video}: no frame could be decoded")
                    writer.write(cv2.cvtColor(frame, cv2.COLOR_BGR2RGB))
            finally:
                cap.release()
            spans.append((start / rate, (start + wanted.size) / rate))
            start += wanted.size
    return spans


def _video_feature(path: Path, rate: int) -> dict[str, Any]:
    import cv2

    cap = cv2.VideoCapture(str(path))
    w, h = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
    cap.release()
    return {
        "dtype": "video",
        "shape": [h, w, 3],
        "names": ["height", "width", "channels"],
        "info": {
            "video.height": h,
            "video.width": w,
            "video.codec": "h264",
            "video.pix_fmt": "yuv420p",
            "video.is_depth_map": False,
            "video.fps": rate,
            "video.channels": 3,
            "has_audio": False,
        },
    }


def _demo_episode(demo: Demonstration, fps: int) -> _Episode:
    t = demo.t
    grid, same = uniform_grid(t, fps)
    if not demo.valid.any():
        raise InvalidInput("a demonstration with no valid sample (hand never seen) has no motion")
    if same:
        pos, quat, grip = (
            _interp(t, demo.position, t),
            _slerp(t, demo.quaternion, t),
            _interp(t, demo.gripper, t),
        )
        valid, grasp, kp = demo.valid, demo.grasp, np.array(demo.keypoints)
        # copied samples stay bit-identical where they were valid
        pos[demo.valid], quat[demo.valid] = demo.position[demo.valid], demo.quaternion[demo.valid]
        grip[demo.valid] = demo.gripper[demo.valid]
    else:
        pos, quat = _interp(t, demo.position, grid), _slerp(t, demo.quaternion, grid)
        grip, kp = _interp(t, demo.gripper, grid), _interp(t, demo.keypoints, grid)
        kp[np.isnan(_nearest(t, demo.keypoints, grid))] = np.nan  # unseen stays unseen
        valid, grasp = _nearest(t, demo.valid, grid), _nearest(t, demo.grasp, grid)
    state = np.concatenate([pos, quat, grip[:, None]], axis=1)
    action = np.concatenate([state[1:], state[-1:]], axis=0)
    return _Episode(
        {
            "observation.state": state,
            "action": action,
            "observation.hand_keypoints": kp.reshape(kp.shape[0], -1),
            "observation.hand_visible": np.asarray(valid, dtype=bool),
            "observation.grasp": np.asarray(grasp, dtype=bool),
        },
        float(t[0]),
        dict(demo.meta),
        np.asarray(t if same else grid, dtype=np.float64),
    )


def _rollout_episode(ro: Rollout, fps: int) -> _Episode:
    t = ro.t
    grid, same = uniform_grid(t, fps)
    g = t if same else grid

    def lin(x: np.ndarray) -> np.ndarray:
        return np.asarray(x, dtype=np.float64) if same else _interp(t, x, grid)

    def rot(q: np.ndarray) -> np.ndarray:
        return np.asarray(q, dtype=np.float64) if same else _slerp(t, q, grid)

    grip = lin(ro.gripper)[:, None]
    state = np.concatenate([lin(ro.ee_position), rot(ro.ee_quaternion), grip, lin(ro.q)], axis=1)
    action = np.concatenate([lin(ro.ref_position), rot(ro.ref_quaternion), grip], axis=1)
    cols = {
        "observation.state": state,
        "observation.velocity": lin(ro.dq),
        "observation.effort": lin(ro.tau),
        "action": action,
    }
    assert all(c.shape[0] == g.shape[0] for c in cols.values())
    return _Episode(cols, float(t[0]), dict(ro.meta), np.asarray(g, dtype=np.float64))


# ----------------------------------------------------------------------------- writing


def _stats(x: np.ndarray) -> dict[str, list[Any]]:
    """LeRobot per-feature statistics over frames (axis 0)."""
    a = np.asarray(x, dtype=np.float64).reshape(x.shape[0], -1)
    if np.isnan(a).all(axis=0).any():  # a keypoint never seen: statistics of zeros
        a = np.where(np.isnan(a).all(axis=0), 0.0, a)
    out: dict[str, list[Any]] = {
        "min": np.nanmin(a, axis=0).tolist(),
        "max": np.nanmax(a, axis=0).tolist(),
        "mean": np.nanmean(a, axis=0).tolist(),
        "std": np.nanstd(a, axis=0).tolist(),
        "count": [int(a.shape[0])],
    }
    for q in QUANTILES:
        out[f"q{round(q * 100):02d}"] = np.nanquantile(a, q, axis=0).tolist()
    return out


def _column(pa: Any, key: str, spec: dict[str, Any], values: np.ndarray) -> Any:
    if spec["dtype"] == "bool":
        return pa.array(np.asarray(values, dtype=bool).reshape(-1), type=pa.bool_())
    if spec["dtype"] == "int64":
        return pa.array(np.asarray(values, dtype=np.int64).reshape(-1), type=pa.int64())
    if spec["shape"] == [1] and spec["names"] is None:
        return pa.array(np.asarray(values, dtype=np.float32).reshape(-1), type=pa.float32())
    flat = np.ascontiguousarray(values, dtype=np.float32).reshape(-1)
    return pa.FixedSizeListArray.from_arrays(pa.array(flat, type=pa.float32()), spec["shape"][0])


def _tasks_table(pa: Any, tasks: list[str]) -> Any:
    """``meta/tasks.parquet``: what pandas writes for ``DataFrame({"task_index"}, index=tasks)``."""
    pandas_meta = {
        "index_columns": ["__index_level_0__"],
        "column_indexes": [
            {
                "name": None,
                "field_name": None,
                "pandas_type": "unicode",
                "numpy_type": "object",
                "metadata": {"encoding": "UTF-8"},
            }
        ],
        "columns": [
            {
                "name": "task_index",
                "field_name": "task_index",
                "pandas_type": "int64",
                "numpy_type": "int64",
                "metadata": None,
            },
            {
                "name": None,
                "field_name": "__index_level_0__",
                "pandas_type": "unicode",
                "numpy_type": "object",
                "metadata": None,
            },
        ],
        "creator": {"library": "pyarrow", "version": pa.__version__},
        "pandas_version": "2.2.3",
    }
    table = pa.table(
        {
            "task_index": pa.array(range(len(tasks)), type=pa.int64()),
            "__index_level_0__": pa.array(tasks, type=pa.string()),
        }
    )
    return table.replace_schema_metadata({b"pandas": json.dumps(pandas_meta).encode()})


def _median_fps(records: Sequence[Demonstration | Rollout]) -> int:
    rates = [1.0 / float(np.median(np.diff(r.t))) for r in records if r.n_samples > 1]
    return max(1, round(float(np.median(rates)))) if rates else 30


def export_lerobot(
    records: Sequence[Demonstration | Rollout],
    path: str | os.PathLike[str],
    *,
    fps: float | None = None,
    task: str = "pick and place",
    names: Sequence[str] | None = None,
    robot_type: str = "franka_panda",
) -> Path:
    """Write demonstrations or rollouts as a LeRobotDataset v3.0 folder (module docstring).

    Parameters
    ----------
    records : sequence of Demonstration or sequence of Rollout
        One episode each, in this order; all of one kind.
    path : path
        Dataset folder to create; it must not exist, or be empty.
    fps : float or None
        Frame rate [Hz], rounded to an integer (LeRobot stores an int); default:
        the rounded median sample rate of ``records``.
    task : str
        Natural-language task of every episode.
    names : sequence of str or None
        Source name of each record (e.g. its file), stored as ``dexlfd/source``.
    robot_type : str
        ``info.json``'s ``robot_type``.

    Returns
    -------
    Path
        The dataset folder.
    """
    pa, pq = _pa()
    if not records:
        raise InvalidInput("export_lerobot: no demonstrations or rollouts given")
    kinds = {type(r) for r in records}
    if len(kinds) != 1 or not kinds <= {Demonstration, Rollout}:
        raise InvalidInput(
            "a LeRobot dataset holds demonstrations or rollouts, not both "
            f"(their observation.state differs); got {sorted(k.__name__ for k in kinds)}"
        )
    is_demo = kinds == {Demonstration}
    rate = _median_fps(records) if fps is None else round(float(fps))
    if rate < 1:
        raise InvalidInput(f"fps must round to an integer >= 1 Hz, got {fps}")
    if not task.strip():
        raise InvalidInput("task must be a non-empty description")
    names = [str(n) for n in names] if names is not None else [""] * len(records)
    out = Path(path)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise InvalidFile(f"{out}: already exists and is not an empty folder (remove it first)")
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise InvalidFile(f"cannot write {out}: folder {parent} does not exist")

    episodes = [
        _demo_episode(r, rate) if is_demo else _rollout_episode(r, rate)  # type: ignore[arg-type]
        for r in records
    ]
    features = {**(DEMO_FEATURES if is_demo else ROLLOUT_FEATURES), **DEFAULT_FEATURES}
    keys = [k for k in features if k not in DEFAULT_FEATURES]

    # frame table
    lengths = [e.columns["observation.state"].shape[0] for e in episodes]
    starts = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    total = int(starts[-1])
    cat = {k: np.concatenate([e.columns[k] for e in episodes], axis=0) for k in keys}
    for k in keys:  # statistics of what is stored: float32
        if features[k]["dtype"] == "float32":
            cat[k] = cat[k].astype(np.float32)
    frame_index = np.concatenate([np.arange(n) for n in lengths])
    cat["timestamp"] = (frame_index / rate).astype(np.float32)
    cat["frame_index"] = frame_index
    cat["episode_index"] = np.repeat(np.arange(len(episodes)), lengths)
    cat["index"] = np.arange(total)
    cat["task_index"] = np.zeros(total, dtype=np.int64)
    data = pa.table({k: _column(pa, k, features[k], cat[k]) for k in features})

    # episode table with per-episode statistics
    ep_cols: dict[str, list[Any]] = {
        "episode_index": list(range(len(episodes))),
        "tasks": [[task] for _ in episodes],
        "length": lengths,
        "data/chunk_index": [0] * len(episodes),
        "data/file_index": [0] * len(episodes),
        "dataset_from_index": starts[:-1].tolist(),
        "dataset_to_index": starts[1:].tolist(),
        "meta/episodes/chunk_index": [0] * len(episodes),
        "meta/episodes/file_index": [0] * len(episodes),
    }
    for k in features:
        per_ep = [_stats(cat[k][a:b]) for a, b in zip(starts[:-1], starts[1:], strict=True)]
        for stat in per_ep[0]:
            ep_cols[f"stats/{k}/{stat}"] = [s[stat] for s in per_ep]
    ep_cols["dexlfd/kind"] = ["demonstration" if is_demo else "rollout"] * len(episodes)
    ep_cols["dexlfd/t0"] = [e.t0 for e in episodes]
    ep_cols["dexlfd/source"] = names
    ep_cols["dexlfd/meta"] = [json.dumps(e.meta, sort_keys=True, default=str) for e in episodes]
    ep_table = pa.table(ep_cols)

    info: dict[str, Any] = {
        "codebase_version": CODEBASE_VERSION,
        "robot_type": robot_type,
        "total_episodes": len(episodes),
        "total_frames": total,
        "total_tasks": 1,
        "chunks_size": 1000,
        "data_files_size_in_mb": 100,
        "video_files_size_in_mb": 200,
        "fps": rate,
        "splits": {"train": f"0:{len(episodes)}"},
        "data_path": DATA_PATH,
        "video_path": None,
        "features": features,
    }
    stats = {k: _stats(cat[k]) for k in features}

    with_video = is_demo and all(_source_video(e.meta) is not None for e in episodes)
    if is_demo and not with_video and any(_source_video(e.meta) for e in episodes):
        logger.warning("not every demonstration has its source video: no videos written")
    tmp_root = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=parent))
    tmp = tmp_root / out.name
    try:
        for rel in ("meta/episodes/chunk-000", "data/chunk-000"):
            (tmp / rel).mkdir(parents=True)
        if with_video:
            mp4 = tmp / VIDEO_PATH.format(video_key=VIDEO_KEY, chunk_index=0, file_index=0)
            mp4.parent.mkdir(parents=True)
            spans = _write_videos(episodes, rate, mp4)
            info["features"][VIDEO_KEY] = _video_feature(mp4, rate)
            info["video_path"] = VIDEO_PATH
            video_cols = {
                f"videos/{VIDEO_KEY}/chunk_index": [0] * len(episodes),
                f"videos/{VIDEO_KEY}/file_index": [0] * len(episodes),
                f"videos/{VIDEO_KEY}/from_timestamp": [a for a, _ in spans],
                f"videos/{VIDEO_KEY}/to_timestamp": [b for _, b in spans],
            }
            for name, values in video_cols.items():
                ep_table = ep_table.append_column(name, pa.array(values))
        (tmp / "meta/info.json").write_text(json.dumps(info, indent=4) + "\n")
        (tmp / "meta/stats.json").write_text(json.dumps(stats, indent=4) + "\n")
        pq.write_table(_tasks_table(pa, [task]), tmp / "meta/tasks.parquet")
        pq.write_table(ep_table, tmp / EPISODES_PATH.format(chunk_index=0, file_index=0))
        pq.write_table(data, tmp / DATA_PATH.format(chunk_index=0, file_index=0))
        if out.is_dir():
            out.rmdir()  # empty (checked above)
        os.replace(tmp, out)
    except OSError as exc:
        raise InvalidFile(f"cannot write {out}: {exc.strerror or exc}") from exc
    finally:
        shutil.rmtree(tmp_root, ignore_errors=True)
    return out


# ----------------------------------------------------------------------------- reading


@dataclass(frozen=True)
class LeRobotEpisodes:
    """What :func:`import_lerobot` read: the records and the dataset's settings."""

    records: list[Demonstration]
    fps: int
    tasks: list[str]
    sources: list[str]


def is_lerobot_dataset(path: str | os.PathLike[str]) -> bool:
    """True if ``path`` is a folder with ``meta/info.json`` (a LeRobot dataset)."""
    return (Path(path) / "meta" / "info.json").is_file()


def _read_tables(pq: Any, folder: Path, what: str) -> Any:
    import pyarrow as pa

    files = sorted(folder.glob("chunk-*/file-*.parquet"))
    if not files:
        raise InvalidFile(f"{folder}: no {what} parquet files (chunk-XXX/file-XXX.parquet)")
    try:
        return pa.concat_tables([pq.read_table(f) for f in files])
    except (OSError, pa.ArrowInvalid) as exc:
        raise InvalidFile(f"{folder}: unreadable {what} parquet: {exc}") from exc


def _matrix(table: Any, key: str, width: int, where: Path) -> FloatArray:
    if key not in table.column_names:
        raise InvalidFile(f"{where}: no column {key!r} in the data parquet")
    col = table.column(key).combine_chunks()
    values = np.asarray(col.flatten() if hasattr(col, "flatten") else col, dtype=np.float64)
    if values.size != table.num_rows * width:
        raise InvalidFile(f"{where}: column {key!r} must hold {width} values per frame")
    return values.reshape(table.num_rows, width)


def import_lerobot(path: str | os.PathLike[str]) -> LeRobotEpisodes:
    """Read a LeRobotDataset v3.0 of demonstrations (as :func:`export_lerobot` writes them).

    Each episode becomes a :class:`Demonstration`: ``t = dexlfd/t0 + timestamp``
    (``t0`` = 0 for datasets from elsewhere), pose and gripper from
    ``observation.state`` (names ``x, y, z, qx, qy, qz, qw, gripper``), NaN where
    ``observation.hand_visible`` is false. Keypoints, visibility and grasp are
    optional (NaN keypoints; all visible; grasp where the gripper is below half
    its range).
    """
    pa, pq = _pa()
    root = Path(path)
    info_path = root / "meta" / "info.json"
    if not info_path.is_file():
        raise InvalidFile(f"{root}: not a LeRobot dataset (no meta/info.json)")
    try:
        info = json.loads(info_path.read_text())
        version, fps, features = info["codebase_version"], int(info["fps"]), info["features"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise InvalidFile(f"{info_path}: unreadable LeRobot info ({exc})") from exc
    if version != CODEBASE_VERSION:
        raise InvalidFile(
            f"{info_path}: codebase_version {version!r}; this reads {CODEBASE_VERSION}"
        )
    state = features.get("observation.state", {})
    names = list(state.get("names") or [])
    if names[: len(POSE_NAMES)] != POSE_NAMES:
        raise InvalidFile(
            f"{info_path}: observation.state names must start with {POSE_NAMES} "
            f"(end-effector pose + gripper), got {names[:8]}"
        )
    eps = _read_tables(pq, root / "meta" / "episodes", "episodes")
    kinds = (
        set(eps.column("dexlfd/kind").to_pylist()) if "dexlfd/kind" in eps.column_names else set()
    )
    if kinds - {"demonstration"}:
        raise InvalidFile(f"{root}: holds {sorted(kinds)} episodes; only demonstrations import")
    data = _read_tables(pq, root / "data", "data")
    ep_index = np.asarray(data.column("episode_index"), dtype=np.int64)
    frame_index = np.asarray(data.column("frame_index"), dtype=np.int64)
    stamp = np.asarray(data.column("timestamp"), dtype=np.float64)
    st = _matrix(data, "observation.state", len(names), data_path := root / "data")
    kp = (
        _matrix(data, "observation.hand_keypoints", 3 * N_LANDMARKS, data_path)
        if "observation.hand_keypoints" in data.column_names
        else np.full((data.num_rows, 3 * N_LANDMARKS), np.nan)
    )

    def flag(key: str, default: np.ndarray) -> np.ndarray:
        if key not in data.column_names:
            return default
        return np.asarray(data.column(key).to_pylist(), dtype=bool)

    visible = flag("observation.hand_visible", np.ones(data.num_rows, dtype=bool))
    g = st[:, 7]
    grasp = flag("observation.grasp", g < 0.5 * (np.nanmin(g) + np.nanmax(g)))
    rows = eps.to_pylist()
    records: list[Demonstration] = []
    sources: list[str] = []
    tasks: list[str] = []
    for row in sorted(rows, key=lambda r: int(r["episode_index"])):
        e = int(row["episode_index"])
        sel = np.flatnonzero(ep_index == e)
        sel = sel[np.argsort(frame_index[sel])]
        if sel.size == 0:
            raise InvalidFile(f"{root}: episode {e} has no frames in data/")
        v = visible[sel]
        pose = st[sel, :8].copy()
        pose[:, 3:7] = quat_normalize(pose[:, 3:7])  # float32 storage: renormalise
        pose[~v] = np.nan
        keypoints = kp[sel].reshape(-1, N_LANDMARKS, 3)
        meta = json.loads(row.get("dexlfd/meta") or "{}")
        meta.setdefault("source", "lerobot")
        meta["lerobot"] = {"dataset": str(root), "episode_index": e, "fps": fps}
        try:
            records.append(
                Demonstration(
                    t=float(row.get("dexlfd/t0") or 0.0) + stamp[sel],
                    keypoints=keypoints,
                    valid=v,
                    position=pose[:, :3],
                    quaternion=pose[:, 3:7],
                    gripper=pose[:, 7],
                    grasp=grasp[sel],
                    meta=meta,
                )
            )
        except InvalidInput as exc:
            raise InvalidFile(f"{root}: episode {e}: {exc}") from exc
        sources.append(str(row.get("dexlfd/source") or f"{root}#episode{e}"))
        tasks.extend(t for t in row.get("tasks") or [] if t not in tasks)
    return LeRobotEpisodes(records, fps, tasks, sources)
