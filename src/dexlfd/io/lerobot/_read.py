"""Read a LeRobotDataset v3.0 of demonstrations back as :class:`Demonstration` records."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidFile, InvalidInput
from dexlfd.io._gate import json_text, numeric_list_column, parquet_rows, table_column
from dexlfd.io.demonstration import N_LANDMARKS, Demonstration
from dexlfd.io.lerobot._schema import CODEBASE_VERSION, POSE_NAMES, pyarrow_modules
from dexlfd.rotations import quat_normalize

__all__ = ["LeRobotEpisodes", "import_lerobot", "is_lerobot_dataset"]


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


def _read_info(root: Path) -> tuple[int, list[str]]:
    """The dataset's fps and ``observation.state`` names, checked."""
    info_path = root / "meta" / "info.json"
    if not info_path.is_file():
        raise InvalidFile(f"{root}: not a LeRobot dataset (no meta/info.json)")
    try:
        text = info_path.read_bytes()
    except OSError as exc:
        raise InvalidFile(f"{info_path}: unreadable LeRobot info ({exc})") from exc
    info = json_text(text, f"{info_path}: LeRobot info")
    try:
        version, fps, features = info["codebase_version"], int(info["fps"]), info["features"]
    except (ValueError, KeyError, TypeError, OverflowError) as exc:
        raise InvalidFile(f"{info_path}: unreadable LeRobot info ({exc!r})") from exc
    if version != CODEBASE_VERSION:
        raise InvalidFile(
            f"{info_path}: codebase_version {version!r}; this reads {CODEBASE_VERSION}"
        )
    if not 0 < fps <= 10_000:
        raise InvalidFile(f"{info_path}: fps {fps} is not a frame rate (expected 1..10000)")
    state = features.get("observation.state", {}) if isinstance(features, dict) else None
    if not isinstance(state, dict) or not isinstance(state.get("names") or [], list):
        raise InvalidFile(
            f"{info_path}: 'features' must map 'observation.state' to an object with a "
            f"'names' list, got {type(features).__name__}"
        )
    names = [str(n) for n in state.get("names") or []]
    if names[: len(POSE_NAMES)] != POSE_NAMES:
        raise InvalidFile(
            f"{info_path}: observation.state names must start with {POSE_NAMES} "
            f"(end-effector pose + gripper), got {names[:8]}"
        )
    return fps, names


def _read_tables(pq: Any, folder: Path, what: str, bytes_per_row: int = 1024) -> Any:
    """The ``what`` parquet files of ``folder`` as one table, their size checked first."""
    import pyarrow as pa

    files = sorted(folder.glob("chunk-*/file-*.parquet"))
    if not files:
        raise InvalidFile(f"{folder}: no {what} parquet files (chunk-XXX/file-XXX.parquet)")
    parquet_rows(pq, files, f"{folder} ({what})", bytes_per_row)  # before any table is read
    try:
        return pa.concat_tables([_read_parquet(pq, f) for f in files])
    except (OSError, pa.ArrowException) as exc:
        raise InvalidFile(f"{folder}: unreadable {what} parquet: {exc}") from exc


def _read_parquet(pq: Any, path: Path) -> Any:
    """``path``'s table, read through a Python file: pyarrow's own paths must be UTF-8."""
    with open(path, "rb") as fh:
        return pq.read_table(fh)


_MAX_VALUE = 1e6  # metres, quaternion components, gripper openings: far below this


def _matrix(table: Any, key: str, width: int, where: Path) -> FloatArray:
    if key not in table.column_names:
        raise InvalidFile(f"{where}: no column {key!r} in the data parquet")
    numeric_list_column(table, key, where)
    col = table.column(key).combine_chunks()
    try:
        values = np.asarray(col.flatten() if hasattr(col, "flatten") else col, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidFile(
            f"{where}: column {key!r} holds {table.schema.field(key).type}, expected "
            f"{width} numbers per frame"
        ) from exc
    with np.errstate(invalid="ignore"):
        huge = np.flatnonzero(np.abs(values) > _MAX_VALUE)  # inf too; NaN is a hidden frame's
    if huge.size:
        i = int(huge[0])
        raise InvalidFile(
            f"{where}: column {key!r} holds {values[i]:g} at frame {i // max(width, 1)}: "
            f"beyond any pose, gripper or keypoint value (|x| <= {_MAX_VALUE:g})"
        )
    if values.size != table.num_rows * width:
        raise InvalidFile(f"{where}: column {key!r} must hold {width} values per frame")
    return values.reshape(table.num_rows, width)


def _frames(data: Any, names: list[str], where: Path) -> dict[str, np.ndarray]:
    """The data table's columns dexlfd reads; optional ones filled with their defaults."""

    def flag(key: str, default: np.ndarray) -> np.ndarray:
        if key not in data.column_names:
            return default
        return np.asarray(data.column(key).to_pylist(), dtype=bool)

    state = _matrix(data, "observation.state", len(names), where)
    g = state[:, 7]
    kp_key = "observation.hand_keypoints"
    return {
        "episode_index": table_column(data, "episode_index", where, np.int64),
        "frame_index": table_column(data, "frame_index", where, np.int64),
        "timestamp": table_column(data, "timestamp", where, np.float64),
        "state": state,
        "keypoints": (
            _matrix(data, kp_key, 3 * N_LANDMARKS, where)
            if kp_key in data.column_names
            else np.full((data.num_rows, 3 * N_LANDMARKS), np.nan)
        ),
        "visible": flag("observation.hand_visible", np.ones(data.num_rows, dtype=bool)),
        "grasp": flag("observation.grasp", g < 0.5 * (np.nanmin(g) + np.nanmax(g))),
    }


def _demonstration(
    frames: dict[str, np.ndarray], row: dict[str, Any], root: Path, fps: int
) -> Demonstration:
    """The episode of ``row`` (an episodes-table row) as a demonstration."""
    e = int(row["episode_index"])
    sel = np.flatnonzero(frames["episode_index"] == e)
    sel = sel[np.argsort(frames["frame_index"][sel])]
    if sel.size == 0:
        raise InvalidFile(f"{root}: episode {e} has no frames in data/")
    v = frames["visible"][sel]
    pose = frames["state"][sel, :8].copy()
    pose[:, 3:7] = quat_normalize(pose[:, 3:7])  # float32 storage: renormalise
    pose[~v] = np.nan
    meta = json_text(row.get("dexlfd/meta") or "{}", f"{root}: episode {e}: dexlfd/meta")
    meta.setdefault("source", "lerobot")
    meta["lerobot"] = {"dataset": str(root), "episode_index": e, "fps": fps}
    facts, meta = Demonstration._read_facts({}, meta, 1, f"{root}: episode {e}: dexlfd/meta")
    try:
        return Demonstration(
            t=float(row.get("dexlfd/t0") or 0.0) + frames["timestamp"][sel],
            keypoints=frames["keypoints"][sel].reshape(-1, N_LANDMARKS, 3),
            valid=v,
            position=pose[:, :3],
            quaternion=pose[:, 3:7],
            gripper=pose[:, 7],
            grasp=frames["grasp"][sel],
            meta=meta,
            **facts,
        )
    except InvalidInput as exc:
        raise InvalidFile(f"{root}: episode {e}: {exc}") from exc


def import_lerobot(path: str | os.PathLike[str]) -> LeRobotEpisodes:
    """Read a LeRobotDataset v3.0 of demonstrations (as :func:`export_lerobot` writes them).

    Each episode becomes a :class:`Demonstration`: ``t = dexlfd/t0 + timestamp``
    (``t0`` = 0 for datasets from elsewhere), pose and gripper from
    ``observation.state`` (names ``x, y, z, qx, qy, qz, qw, gripper``), NaN where
    ``observation.hand_visible`` is false. Keypoints, visibility and grasp are
    optional (NaN keypoints; all visible; grasp where the gripper is below half
    its range).
    """
    _pa, pq = pyarrow_modules()
    root = Path(path)
    fps, names = _read_info(root)
    eps = _read_tables(pq, root / "meta" / "episodes", "episodes")
    kinds = (
        set(eps.column("dexlfd/kind").to_pylist()) if "dexlfd/kind" in eps.column_names else set()
    )
    if kinds - {"demonstration"}:
        raise InvalidFile(f"{root}: holds {sorted(kinds)} episodes; only demonstrations import")
    if "episode_index" not in eps.column_names:
        raise InvalidFile(f"{root / 'meta' / 'episodes'}: no column 'episode_index'")
    table_column(eps, "episode_index", root / "meta" / "episodes", np.int64)  # its type
    # what one frame costs once read: the state, the keypoints and the index columns
    per_row = 8 * (len(names) + 3 * N_LANDMARKS + 3) + 2
    frames = _frames(_read_tables(pq, root / "data", "data", per_row), names, root / "data")
    records: list[Demonstration] = []
    sources: list[str] = []
    tasks: list[str] = []
    for row in sorted(eps.to_pylist(), key=lambda r: int(r["episode_index"])):
        records.append(_demonstration(frames, row, root, fps))
        e = int(row["episode_index"])
        sources.append(str(row.get("dexlfd/source") or f"{root}#episode{e}"))
        tasks.extend(t for t in row.get("tasks") or [] if t not in tasks)
    return LeRobotEpisodes(records, fps, tasks, sources)
