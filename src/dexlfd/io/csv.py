"""CSV export of any dexlfd record (demonstration, model mean, plan, rollout).

One row per sample, one column per scalar channel, a header naming each column
with its unit, e.g. ``t [s]``, ``position_x [m]``, ``q_panda_joint4 [rad]`` (the Panda's
joints named as in the ROS 2 bags and LeRobot datasets: ``panda_joint1..7``). Arrays with
more than two axes (keypoints, covariances) are flattened; ``valid`` false rows
keep their NaN (written as ``nan``). An array without a value in any row (the
keypoints of a synthetic demonstration, which has none) is left out, and the log says so.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd.io._record import Record

__all__ = ["export_csv", "rows_at_rate"]

logger = logging.getLogger(__name__)

_AXES = {3: "xyz", 4: "xyzw"}
_JOINT_ARRAYS = {"q", "dq", "tau"}
JOINT_NAMES = tuple(f"panda_joint{i}" for i in range(1, 8))  # franka_ros, as everywhere


def _columns(name: str, arr: np.ndarray, unit: str) -> tuple[list[str], np.ndarray]:
    flat = arr.reshape(arr.shape[0], -1).astype(np.float64)
    suffix = f" [{unit}]" if unit and "," not in unit else ""
    if flat.shape[1] == 1 and arr.ndim == 1:
        return [f"{name}{suffix}"], flat
    if arr.ndim == 2 and name in _JOINT_ARRAYS and arr.shape[1] == len(JOINT_NAMES):
        return [f"{name}_{j}{suffix}" for j in JOINT_NAMES], flat
    if arr.ndim == 2 and arr.shape[1] in _AXES and name not in _JOINT_ARRAYS:
        return [f"{name}_{a}{suffix}" for a in _AXES[arr.shape[1]]], flat
    return [f"{name}_{i}{suffix}" for i in range(flat.shape[1])], flat


CHUNK_ROWS = 20_000  # rows formatted at once: memory stays bounded on long records


def rows_at_rate(t: np.ndarray, fps: float) -> np.ndarray:
    """Indices of the samples of ``t`` [s] nearest ``t[0] + k / fps`` [Hz], each once.

    Raises InvalidInput when ``fps`` is above the record's own rate (the median of its
    steps): the rows are recorded samples, never interpolated, so none would be repeated.
    """
    from dexlfd.errors import InvalidInput

    rate = 1.0 / float(np.median(np.diff(t)))
    if fps > rate * (1.0 + 1e-6):
        raise InvalidInput(
            f"--fps {fps:g} Hz is above the record's own rate ({rate:.4g} Hz): a CSV holds "
            "recorded samples, one row per 1/fps s; give at most that rate"
        )
    grid = t[0] + np.arange(int(np.floor((t[-1] - t[0]) * fps + 1e-9)) + 1) / fps
    k = np.clip(np.searchsorted(t, grid), 1, t.shape[0] - 1)
    k = np.where(grid - t[k - 1] <= t[k] - grid, k - 1, k)
    return np.unique(k)


def export_csv(record: Record, path: str | os.PathLike[str], fps: float | None = None) -> Path:
    """Write the per-sample arrays of ``record`` (those with ``t``'s length) as CSV.

    ``fps`` [Hz]: one row per ``1 / fps`` s, the recorded sample nearest each time
    (:func:`rows_at_rate`; default every sample). Written in chunks of
    :data:`CHUNK_ROWS` rows: a long record (millions of samples) needs little more
    memory than the record itself.
    """
    from dexlfd.io._atomic import atomic_write

    n = record.n_samples
    rows = None if fps is None or n < 2 else rows_at_rate(np.asarray(record.t), fps)
    headers: list[str] = []
    arrays: list[tuple[str, np.ndarray, str]] = []
    empty: list[str] = []
    for name, spec in record.SPECS.items():
        arr = getattr(record, name)
        if (
            arr is None
            or arr.ndim == 0
            or arr.shape[0] != n
            or spec.shape[0] != record.SPECS["t"].shape[0]
        ):
            continue
        if n and name != "t" and bool(np.isnan(arr[0]).all() and np.isnan(arr).all()):
            empty.append(name)
            continue
        arrays.append((name, np.asarray(arr) if rows is None else np.asarray(arr)[rows], spec.unit))
        headers += _columns(name, np.asarray(arr[:1]), spec.unit)[0]

    if empty:
        logger.info("left out of the CSV, no value in any row: %s", ", ".join(empty))
    row = ",".join(["%.9g"] * len(headers)) + "\n"  # as np.savetxt formats a row

    def write(fh: Any) -> None:
        fh.write((",".join(headers) + "\n").encode())
        for lo in range(0, n if rows is None else rows.shape[0], CHUNK_ROWS):
            table = np.hstack([_columns(nm, a[lo : lo + CHUNK_ROWS], u)[1] for nm, a, u in arrays])
            fh.write("".join([row % tuple(r) for r in table.tolist()]).encode())

    path = Path(path)
    atomic_write(path, write)
    return path
