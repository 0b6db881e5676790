"""Write demonstrations or rollouts as a LeRobotDataset v3.0 folder (the export)."""

from __future__ import annotations

import json
import logging
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd.errors import InvalidFile, InvalidInput
from dexlfd.io._atomic import atomic_folder
from dexlfd.io.demonstration import Demonstration
from dexlfd.io.lerobot._card import dataset_card
from dexlfd.io.lerobot._frames import Episode, episode_of, median_fps
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

__all__ = ["ROLLOUT_FPS", "default_task", "export_lerobot"]

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


def _frame_columns(
    episodes: Sequence[Episode], features: dict[str, Any], rate: int, task_index: list[int]
) -> dict[str, np.ndarray]:
    """Every feature over every frame of every episode, as stored (float32 features)."""
    lengths = [e.n_frames for e in episodes]
    cat = {
        k: np.concatenate([e.columns[k] for e in episodes], axis=0)
        for k in features
        if k not in DEFAULT_FEATURES
    }
    for k in cat:  # statistics of what is stored: float32
        if features[k]["dtype"] == "float32":
            cat[k] = cat[k].astype(np.float32)
    frame_index = np.concatenate([np.arange(n) for n in lengths])
    total = frame_index.shape[0]
    cat["timestamp"] = (frame_index / rate).astype(np.float32)
    cat["frame_index"] = frame_index
    cat["episode_index"] = np.repeat(np.arange(len(episodes)), lengths)
    cat["index"] = np.arange(total)
    cat["task_index"] = np.repeat(np.asarray(task_index, dtype=np.int64), lengths)
    return cat


def _episode_columns(
    episodes: Sequence[Episode],
    cat: dict[str, np.ndarray],
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
    for k in cat:
        per_ep = [feature_stats(cat[k][a:b]) for a, b in zip(starts[:-1], starts[1:], strict=True)]
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

    Returns
    -------
    Path
        The dataset folder.
    """
    pa, pq = pyarrow_modules()
    is_demo = _check_records(records)
    if fps is not None:
        rate = round(float(fps))
    else:
        rate = median_fps(records) if is_demo else ROLLOUT_FPS
    if rate < 1:
        raise InvalidInput(f"fps must round to an integer >= 1 Hz, got {fps}", param="fps")
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

    episodes = [episode_of(r, rate) for r in records]
    features = {**(DEMO_FEATURES if is_demo else ROLLOUT_FEATURES), **DEFAULT_FEATURES}
    cat = _frame_columns(episodes, features, rate, [tasks.index(t) for t in ep_tasks])
    data = pa.table({k: arrow_column(pa, features[k], cat[k]) for k in features})
    ep_cols = _episode_columns(episodes, {k: cat[k] for k in features}, ep_tasks, names, is_demo)
    info = _info(features, len(episodes), data.num_rows, rate, robot_type, len(tasks))
    stats = {k: feature_stats(cat[k]) for k in features}

    with_video = _with_video(episodes, is_demo)
    with atomic_folder(out) as tmp:
        for rel in ("meta/episodes/chunk-000", "data/chunk-000"):
            (tmp / rel).mkdir(parents=True)
        if with_video:
            stats[VIDEO_KEY] = _add_video(tmp, episodes, rate, info, ep_cols, video_size, callback)
        (tmp / "meta/info.json").write_text(json.dumps(info, indent=4) + "\n")
        (tmp / "meta/stats.json").write_text(json.dumps(stats, indent=4) + "\n")
        _write_parquet(pq, tasks_table(pa, tasks), tmp / "meta/tasks.parquet")
        ep_file = tmp / EPISODES_PATH.format(chunk_index=0, file_index=0)
        _write_parquet(pq, pa.table(ep_cols), ep_file)
        _write_parquet(pq, data, tmp / DATA_PATH.format(chunk_index=0, file_index=0))
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
