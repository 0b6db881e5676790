"""Write demonstrations or rollouts as a LeRobotDataset v3.0 folder (the export)."""

from __future__ import annotations

import json
import logging
import os
import shutil
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd.errors import InvalidFile, InvalidInput
from dexlfd.io._atomic import atomic_folder
from dexlfd.io.demonstration import Demonstration
from dexlfd.io.lerobot._card import dataset_card
from dexlfd.io.lerobot._frames import Episode, episode_of, grid_length, median_fps
from dexlfd.io.lerobot._schema import (
    CODEBASE_VERSION,
    DATA_PATH,
    DEFAULT_FEATURES,
    DEMO_FEATURES,
    EPISODES_PATH,
    ROLLOUT_FEATURES,
    VIDEO_KEY,
    VIDEO_PATH,
    arrow_column,
    feature_stats,
    image_stats,
    pyarrow_modules,
    tasks_table,
)
from dexlfd.io.lerobot._video import source_video, video_feature, write_episode_video
from dexlfd.io.rollout import Rollout

__all__ = [
    "MAX_FRAMES",
    "check_frames",
    "ROLLOUT_FPS",
    "default_task",
    "export_lerobot",
    "frame_count",
    "frame_rate",
]

# a rollout is simulated at 1 kHz; a dataset of it defaults to a camera's rate
ROLLOUT_FPS = 30
PICK_AND_PLACE = "pick and place"
NOT_A_TASK = "hand motion that is not a pick and place (its recording is NOT USABLE)"


def default_task(record: Demonstration | Rollout) -> str:
    """The task text of ``record``: what its recording's quality verdict says it shows.

    A demonstration whose quality report (its ``quality``) calls it NOT usable
    is not a pick and place: :data:`NOT_A_TASK`; any other record (a usable or a
    synthetic demonstration, a rollout of a learned task) is :data:`PICK_AND_PLACE`.
    """
    quality = record.quality if isinstance(record, Demonstration) else None
    if quality is not None and not quality.usable:
        return NOT_A_TASK
    return PICK_AND_PLACE


logger = logging.getLogger("dexlfd.io.lerobot")


def _check_records(records: Sequence[Demonstration | Rollout]) -> bool:
    """True for demonstrations, False for rollouts; an error for none or a mix."""
    if not records:
        raise InvalidInput("export_lerobot: no demonstrations or rollouts given")
    kinds = {type(r) for r in records}
    if len(kinds) != 1 or not kinds <= {Demonstration, Rollout}:
        raise InvalidInput(
            "a LeRobot dataset holds demonstrations or rollouts, not both "
            f"(their observation.state differs); got {sorted(k.__name__ for k in kinds)}"
        )
    return kinds == {Demonstration}


def _check_target(out: Path) -> None:
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise InvalidFile(f"{out}: already exists and is not an empty folder (remove it first)")
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise InvalidFile(f"cannot write {out}: folder {parent} does not exist")


CHUNK_FRAMES = 20_000  # frames made and written at once: memory stays bounded on long records
MAX_FRAMES = 20_000_000  # frames of one dataset (~6.4 GB of parquet for demonstrations)


def frame_count(records: Sequence[Demonstration | Rollout], rate: int) -> int:
    """Frames of a dataset of ``records`` at ``rate`` [Hz] (what :func:`export_lerobot` writes)."""
    return sum(grid_length(r.t, rate) for r in records)


def frame_rate(records: Sequence[Demonstration | Rollout], fps: float | None) -> int:
    """The dataset's frame rate [Hz]: ``fps`` rounded, or the records' own (``export_lerobot``)."""
    if fps is not None:
        rate = round(float(fps))
    else:
        rate = median_fps(records) if _check_records(records) else ROLLOUT_FPS
    if rate < 1:
        raise InvalidInput(f"fps must round to an integer >= 1 Hz, got {fps}", param="fps")
    return rate


def check_frames(records: Sequence[Demonstration | Rollout], rate: int, names: list[str]) -> int:
    """The dataset's frame count; :class:`InvalidInput` beyond :data:`MAX_FRAMES`."""
    counts = [grid_length(r.t, rate) for r in records]
    total = sum(counts)
    if total > MAX_FRAMES:
        longest = int(np.argmax(counts))
        name = f" ({names[longest] or 'record ' + str(longest)}: {counts[longest]:,})"
        raise InvalidInput(
            f"fps {rate} Hz makes {total:,} frames of {len(records)} record(s){name}; a "
            f"dataset holds at most {MAX_FRAMES:,}: a lower fps or fewer records",
            param="fps",
        )
    return total


def _stored(features: dict[str, Any], cols: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The columns as stored (float32 features as float32), each (frames, width)."""
    out = {}
    for k, v in cols.items():
        a = np.asarray(v, dtype=np.float32) if features[k]["dtype"] == "float32" else v
        out[k] = a.reshape(a.shape[0], -1)
    return out


_SPILL_DTYPE = {"int64": np.float64, "float32": np.float32, "bool": np.float32}  # exact


class _Spill:
    """Every stored value of every feature, one file per feature in ``folder`` (dims x frames).

    The statistics (quantiles among them) need every frame at once; held in files, not in
    memory (nor mapped into it), they are read one dimension's span at a time.
    """

    BUDGET = 4_000_000  # values read at once for the statistics

    def __init__(self, folder: Path, features: dict[str, Any], total: int) -> None:
        folder.mkdir()
        self.total = total
        self.done: dict[tuple[str, int, int], dict[str, list[Any]]] = {}
        self.files = {
            k: (folder / f"{i}.bin", np.dtype(_SPILL_DTYPE[spec["dtype"]]), int(spec["shape"][0]))
            for i, (k, spec) in enumerate(features.items())
        }  # fmt: skip
        for path, dtype, dims in self.files.values():
            with open(path, "wb") as fh:
                fh.truncate(dims * total * dtype.itemsize)

    def put(self, start: int, cols: dict[str, np.ndarray]) -> None:
        """Store the block of frames beginning at frame ``start``."""
        for k, v in cols.items():
            path, dtype, dims = self.files[k]
            with open(path, "r+b") as fh:
                for d in range(dims):
                    fh.seek((d * self.total + start) * dtype.itemsize)
                    fh.write(np.ascontiguousarray(v[:, d], dtype=dtype).tobytes())

    def stats(self, key: str, a: int, b: int) -> dict[str, list[Any]]:
        """:func:`feature_stats` of ``key`` over frames ``a .. b - 1``, by blocks of dimensions."""
        if (key, a, b) in self.done:  # the one episode of a dataset: its statistics
            return self.done[key, a, b]
        path, dtype, dims = self.files[key]
        step = max(1, self.BUDGET // max(1, b - a))
        parts = []
        for d0 in range(0, dims, step):
            block = [
                np.fromfile(path, dtype, count=b - a, offset=(d * self.total + a) * dtype.itemsize)
                for d in range(d0, min(d0 + step, dims))
            ]
            parts.append(feature_stats(np.stack(block, axis=1)))
        out = {s: [v for p in parts for v in p[s]] for s in parts[0]}
        out["count"] = [b - a]
        self.done[key, a, b] = out
        return out


def _write_frames(
    pa: Any,
    pq: Any,
    path: Path,
    episodes: Sequence[Episode],
    features: dict[str, Any],
    rate: int,
    task_index: list[int],
    spill: _Spill,
    on_frames: Callable[[int], None] | None,
) -> None:
    """Every frame of every episode into the parquet file ``path``, a block at a time."""
    schema = None
    index = 0
    with open(path, "wb") as fh:
        writer = None
        try:
            for e, (ep, task) in enumerate(zip(episodes, task_index, strict=True)):
                for lo in range(0, ep.n_frames, CHUNK_FRAMES):
                    hi = min(lo + CHUNK_FRAMES, ep.n_frames)
                    cols = ep.frames(lo, hi)
                    frame_index = np.arange(lo, hi)
                    cols["timestamp"] = (frame_index / rate).astype(np.float32)
                    cols["frame_index"] = frame_index
                    cols["episode_index"] = np.full(hi - lo, e)
                    cols["index"] = np.arange(index, index + hi - lo)
                    cols["task_index"] = np.full(hi - lo, task)
                    stored = _stored(features, cols)
                    spill.put(index, stored)
                    table = pa.table(
                        {k: arrow_column(pa, features[k], stored[k]) for k in features}
                    )
                    if writer is None:
                        schema = table.schema
                        writer = pq.ParquetWriter(fh, schema)
                    writer.write_table(table)
                    index += hi - lo
                    if on_frames is not None:
                        on_frames(hi - lo)
        finally:
            if writer is not None:
                writer.close()


def _episode_columns(
    episodes: Sequence[Episode],
    spill: _Spill,
    tasks: list[str],
    names: list[str],
    is_demo: bool,
) -> dict[str, list[Any]]:
    """One row per episode: its frames' range, per-episode statistics, dexlfd's own fields."""
    n = len(episodes)
    starts = np.concatenate([[0], np.cumsum([e.n_frames for e in episodes])]).astype(np.int64)
    cols: dict[str, list[Any]] = {
        "episode_index": list(range(n)),
        "tasks": [[task] for task in tasks],
        "length": [e.n_frames for e in episodes],
        "data/chunk_index": [0] * n,
        "data/file_index": [0] * n,
        "dataset_from_index": starts[:-1].tolist(),
        "dataset_to_index": starts[1:].tolist(),
        "meta/episodes/chunk_index": [0] * n,
        "meta/episodes/file_index": [0] * n,
    }
    for k in spill.files:
        per_ep = [
            spill.stats(k, int(a), int(b)) for a, b in zip(starts[:-1], starts[1:], strict=True)
        ]
        for stat in per_ep[0]:
            cols[f"stats/{k}/{stat}"] = [s[stat] for s in per_ep]
    cols["dexlfd/kind"] = ["demonstration" if is_demo else "rollout"] * n
    cols["dexlfd/t0"] = [e.t0 for e in episodes]
    cols["dexlfd/source"] = names
    cols["dexlfd/meta"] = [json.dumps(e.meta, sort_keys=True, default=str) for e in episodes]
    return cols


def _info(
    features: dict[str, Any],
    n_episodes: int,
    n_frames: int,
    rate: int,
    robot_type: str,
    n_tasks: int = 1,
) -> dict[str, Any]:
    """``meta/info.json`` without video."""
    return {
        "codebase_version": CODEBASE_VERSION,
        "robot_type": robot_type,
        "total_episodes": n_episodes,
        "total_frames": n_frames,
        "total_tasks": n_tasks,
        "chunks_size": 1000,
        "data_files_size_in_mb": 100,
        "video_files_size_in_mb": 200,
        "fps": rate,
        "splits": {"train": f"0:{n_episodes}"},
        "data_path": DATA_PATH,
        "video_path": None,
        "features": features,
    }


def _with_video(episodes: Sequence[Episode], is_demo: bool) -> bool:
    """Whether every episode's source video exists (then the dataset gets a video)."""
    found = [source_video(e.meta) is not None for e in episodes] if is_demo else [False]
    if not all(found) and any(found):
        logger.warning("not every demonstration has its source video: no videos written")
    return all(found)


def _add_video(
    folder: Path,
    episodes: Sequence[Episode],
    rate: int,
    info: dict[str, Any],
    ep_cols: dict[str, list[Any]],
    video_size: tuple[int, int] | None = None,
    callback: Callable[[int, float], None] | None = None,
) -> dict[str, list[Any]]:
    """Write the episodes' video into ``folder``; add it to ``info`` and the episode columns.

    Returns the camera's statistics over every frame (LeRobot's training reads them).
    """
    mp4 = folder / VIDEO_PATH.format(video_key=VIDEO_KEY, chunk_index=0, file_index=0)
    mp4.parent.mkdir(parents=True)
    spans, histograms = write_episode_video(episodes, rate, mp4, video_size, callback)
    info["features"][VIDEO_KEY] = video_feature(mp4, rate)
    info["video_path"] = VIDEO_PATH
    ep_cols[f"videos/{VIDEO_KEY}/chunk_index"] = [0] * len(episodes)
    ep_cols[f"videos/{VIDEO_KEY}/file_index"] = [0] * len(episodes)
    ep_cols[f"videos/{VIDEO_KEY}/from_timestamp"] = [a for a, _ in spans]
    ep_cols[f"videos/{VIDEO_KEY}/to_timestamp"] = [b for _, b in spans]
    per_ep = [image_stats(h, e.n_frames) for h, e in zip(histograms, episodes, strict=True)]
    for stat in per_ep[0]:
        ep_cols[f"stats/{VIDEO_KEY}/{stat}"] = [s[stat] for s in per_ep]
    return image_stats(np.sum(histograms, axis=0), sum(e.n_frames for e in episodes))


def export_lerobot(
    records: Sequence[Demonstration | Rollout],
    path: str | os.PathLike[str],
    *,
    fps: float | None = None,
    task: str | None = None,
    names: Sequence[str] | None = None,
    robot_type: str = "franka_panda",
    video_size: tuple[int, int] | None = None,
    callback: Callable[[int, float], None] | None = None,
    on_frames: Callable[[int], None] | None = None,
) -> Path:
    """Write demonstrations or rollouts as a LeRobotDataset v3.0 folder (:mod:`dexlfd.io.lerobot`).

    Parameters
    ----------
    records : sequence of Demonstration or sequence of Rollout
        One episode each, in this order; all of one kind.
    path : path
        Dataset folder to create; it must not exist, or be empty.
    fps : float or None
        Frame rate [Hz], rounded to an integer (LeRobot stores an int); default: the
        recordings' own rate (the rounded median of ``records``), for rollouts (simulated
        at 1 kHz) :data:`ROLLOUT_FPS`.
    task : str or None
        Natural-language task of every episode; default: each record's own
        (:func:`default_task`: never "pick and place" for a recording its quality
        report calls NOT USABLE).
    names : sequence of str or None
        Source name of each record (e.g. its file), stored as ``dexlfd/source``.
    robot_type : str
        ``info.json``'s ``robot_type``.
    video_size : (width, height) or None
        The camera video's frame size [px] (default: the source video's).
    callback : callable or None
        ``callback(i, seconds)`` after each camera frame written (``seconds``: its time
        in the dataset's video), for a progress bar; not called without a video.
    on_frames : callable or None
        ``on_frames(n)`` after each block of ``n`` frames written to the table (of the
        :func:`frame_count` in all), for a progress bar.

    Raises
    ------
    InvalidInput
        Beyond :data:`MAX_FRAMES` frames (``param="fps"``), before anything is written.

    Returns
    -------
    Path
        The dataset folder.
    """
    pa, pq = pyarrow_modules()
    is_demo = _check_records(records)
    rate = frame_rate(records, fps)
    if task is not None and not task.strip():
        raise InvalidInput("task must be a non-empty description", param="task")
    if video_size is not None and not all(16 <= v <= 8192 for v in video_size):
        raise InvalidInput(
            f"video size must be 16..8192 px each, got {video_size}", param="video_size"
        )
    ep_tasks = [task if task is not None else default_task(r) for r in records]
    tasks = list(dict.fromkeys(ep_tasks))  # unique, in order of first use
    names = [_text(n) for n in names] if names is not None else [""] * len(records)
    out = Path(path)
    _check_target(out)

    total = check_frames(records, rate, names)

    episodes = [episode_of(r, rate) for r in records]
    features = {**(DEMO_FEATURES if is_demo else ROLLOUT_FEATURES), **DEFAULT_FEATURES}
    info = _info(features, len(episodes), total, rate, robot_type, len(tasks))
    with_video = _with_video(episodes, is_demo)
    with atomic_folder(out) as tmp:
        for rel in ("meta/episodes/chunk-000", "data/chunk-000"):
            (tmp / rel).mkdir(parents=True)
        spill = _Spill(tmp / ".frames", features, total)
        task_index = [tasks.index(t) for t in ep_tasks]
        data = tmp / DATA_PATH.format(chunk_index=0, file_index=0)
        _write_frames(pa, pq, data, episodes, features, rate, task_index, spill, on_frames)
        ep_cols = _episode_columns(episodes, spill, ep_tasks, names, is_demo)
        stats = {k: spill.stats(k, 0, total) for k in features}
        del spill
        shutil.rmtree(tmp / ".frames")
        if with_video:
            stats[VIDEO_KEY] = _add_video(tmp, episodes, rate, info, ep_cols, video_size, callback)
        (tmp / "meta/info.json").write_text(json.dumps(info, indent=4) + "\n")
        (tmp / "meta/stats.json").write_text(json.dumps(stats, indent=4) + "\n")
        _write_parquet(pq, tasks_table(pa, tasks), tmp / "meta/tasks.parquet")
        ep_file = tmp / EPISODES_PATH.format(chunk_index=0, file_index=0)
        _write_parquet(pq, pa.table(ep_cols), ep_file)
        card = dataset_card(info, records, ep_tasks, names, is_demo)
        (tmp / "README.md").write_text(card)
    return out


def _write_parquet(pq: Any, table: Any, path: Path) -> None:
    """``table`` to ``path`` through a Python file: pyarrow's own paths must be UTF-8."""
    with open(path, "wb") as fh:
        pq.write_table(table, fh)


def _text(name: object) -> str:
    r"""``name`` as UTF-8 text: a file name's undecodable bytes become ``\xNN`` escapes."""
    return os.fsencode(str(name)).decode("utf-8", "backslashreplace")
