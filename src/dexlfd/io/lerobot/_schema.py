"""The LeRobotDataset v3.0 schema dexlfd writes: paths, features, columns, statistics.

Everything here describes the stored dataset (what a frame and an episode row hold
and how they are typed in parquet), not how records are turned into frames.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from dexlfd.io.demonstration import N_LANDMARKS
from dexlfd.panda import N_JOINTS

__all__ = [
    "CODEBASE_VERSION",
    "DATA_PATH",
    "DEFAULT_FEATURES",
    "DEMO_FEATURES",
    "EPISODES_PATH",
    "POSE_NAMES",
    "ROLLOUT_FEATURES",
    "VIDEO_KEY",
    "VIDEO_PATH",
    "arrow_column",
    "feature_stats",
    "image_stats",
    "pyarrow_modules",
    "tasks_table",
]

CODEBASE_VERSION = "v3.0"
CHUNK_FILE = "chunk-{chunk_index:03d}/file-{file_index:03d}"
DATA_PATH = "data/" + CHUNK_FILE + ".parquet"
VIDEO_PATH = "videos/{video_key}/" + CHUNK_FILE + ".mp4"
EPISODES_PATH = "meta/episodes/" + CHUNK_FILE + ".parquet"
VIDEO_KEY = "observation.images.camera"
QUANTILES = (0.01, 0.10, 0.50, 0.90, 0.99)

POSE_NAMES = ["x", "y", "z", "qx", "qy", "qz", "qw", "gripper"]
JOINT_NAMES = [f"panda_joint{i}" for i in range(1, N_JOINTS + 1)]
KEYPOINT_NAMES = [f"kp{i:02d}_{a}" for i in range(N_LANDMARKS) for a in "xyz"]


def pyarrow_modules() -> Any:
    """``(pyarrow, pyarrow.parquet)``; a clear error when pyarrow is missing."""
    from dexlfd._extras import import_extra

    what = "LeRobot dataset export/import"
    return import_extra("pyarrow", what), import_extra("pyarrow.parquet", what)


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


def feature_stats(x: np.ndarray) -> dict[str, list[Any]]:
    """LeRobot per-feature statistics over frames (axis 0); NaN ignored.

    ``min, max, mean, std, count`` and the quantiles ``q01 .. q99``; a value never
    seen (all NaN) counts as zeros.
    """
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
    for q, values in zip(QUANTILES, np.nanquantile(a, QUANTILES, axis=0), strict=True):
        out[f"q{round(q * 100):02d}"] = values.tolist()
    return out


def image_stats(histogram: np.ndarray, n_frames: int) -> dict[str, list[Any]]:
    """LeRobot statistics of 8-bit frames from their value histogram, as ``[0, 1]`` intensities.

    Parameters
    ----------
    histogram : ndarray, shape (channels, 256)
        How many pixels of each channel have each value 0..255, over all frames.
    n_frames : int
        Number of frames counted (LeRobot's ``count``).

    Returns
    -------
    dict
        ``min, max, mean, std`` and the quantiles ``q01 .. q99`` per channel, each
        shaped ``(channels, 1, 1)`` as LeRobot stores a camera's statistics, and
        ``count``. The same numbers as :func:`feature_stats` of every pixel value / 255
        (quantiles interpolated linearly between sorted values, as ``np.quantile``).
    """
    h = np.asarray(histogram, dtype=np.int64)
    values = np.arange(h.shape[1]) / 255.0
    total = h.sum(axis=1)
    if (total == 0).any():
        raise ValueError("image_stats: a channel has no pixel counted")
    mean = (h * values).sum(axis=1) / total
    var = (h * (values[None, :] - mean[:, None]) ** 2).sum(axis=1) / total
    seen = h > 0
    lo = np.array([values[np.flatnonzero(row)[0]] for row in seen])
    hi = np.array([values[np.flatnonzero(row)[-1]] for row in seen])

    ends = np.cumsum(h, axis=1)  # per channel: sorted values [end[v-1], end[v]) hold v

    def quantile(q: float) -> np.ndarray:
        out = np.empty(h.shape[0])
        for c, end in enumerate(ends):
            pos = q * (total[c] - 1)  # np.quantile's "linear" position among sorted values
            k = int(np.floor(pos))
            at = values[np.searchsorted(end, [k, min(k + 1, total[c] - 1)], side="right")]
            out[c] = at[0] + (pos - k) * (at[1] - at[0])
        return out

    def cell(x: np.ndarray) -> list[Any]:
        return np.asarray(x, dtype=np.float64).reshape(-1, 1, 1).tolist()

    out: dict[str, list[Any]] = {
        "min": cell(lo),
        "max": cell(hi),
        "mean": cell(mean),
        "std": cell(np.sqrt(var)),
        "count": [int(n_frames)],
    }
    for q in QUANTILES:
        out[f"q{round(q * 100):02d}"] = cell(quantile(q))
    return out


def arrow_column(pa: Any, spec: dict[str, Any], values: np.ndarray) -> Any:
    """The pyarrow array of one feature (``spec`` from the features dict) over all frames."""
    if spec["dtype"] == "bool":
        return pa.array(np.asarray(values, dtype=bool).reshape(-1), type=pa.bool_())
    if spec["dtype"] == "int64":
        return pa.array(np.asarray(values, dtype=np.int64).reshape(-1), type=pa.int64())
    if spec["shape"] == [1] and spec["names"] is None:
        return pa.array(np.asarray(values, dtype=np.float32).reshape(-1), type=pa.float32())
    flat = np.ascontiguousarray(values, dtype=np.float32).reshape(-1)
    return pa.FixedSizeListArray.from_arrays(pa.array(flat, type=pa.float32()), spec["shape"][0])


def tasks_table(pa: Any, tasks: list[str]) -> Any:
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
