"""Time and peak memory of ``dexlfd export`` of one long demonstration: LeRobot vs CSV.

Usage: ``python benchmarks/bench_lerobot_long.py [SAMPLES ...]`` (default 300000). Each
size is a 1 kHz demonstration (the hand unseen in 5 % of its samples), exported by a
fresh ``dexlfd export`` process; its wall time and peak RSS (``ru_maxrss`` of the child)
are printed, and the peak RSS of loading the file alone, for comparison.

Measured on the shared 2-core machine (``/usr/bin/time``, the same files; other helpers'
jobs made the load 6 or 13-16, which slows every figure):

=====================  ====================  ====================  ========================
input                  before                after                 notes
=====================  ====================  ====================  ========================
300,000 samples        15.1 s, 884 MB (l 6)  6.2 s, 469 MB (l 6)   CSV export of the same
(137 MB .npz)          36.0 s, 883 MB (l 13) 10.8 s, 458 MB (l 13) file: 19.8 s, 431 MB
                                                                   (l 13), 6.8 s (l 6)
3,600,000 samples      > 24 min at 3.5 GB,   59 s (l 6), 303 s     peak RSS 4.50 GB, of
(1.6 GB .npz)          or MemoryError at     (l 13)                which loading the file
                       7.4 GB                                      alone takes 4.40 GB;
                                                                   1.14 GB of parquet
=====================  ====================  ====================  ========================

"Before" at 300k is the previous code on the same file; at 3.6M its figures are those of
the report that found it (still "preparing frames" after 24 min at 3.5 GB, or
``MemoryError`` at 7.4 GB): its column grouping (``np.unique(..., axis=1)`` over a
structured dtype of one field per sample) grew faster than the record, and every frame
and its statistics were held at once. Now frames are made and written a block at a
time and the statistics read from a spill file one dimension at a time.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from dexlfd.io import Demonstration, save_demonstration

REPO = Path(__file__).resolve().parents[1]


def _demo(n: int) -> Demonstration:
    rng = np.random.default_rng(0)
    t = np.arange(n) / 1000.0
    pos = np.column_stack([0.4 + 0.1 * np.sin(t), 0.1 * np.cos(t), 0.2 + 0.05 * np.sin(0.3 * t)])
    valid = rng.random(n) >= 0.05
    kp = pos[:, None, :] + 0.01 * np.arange(21)[None, :, None]
    kp[~valid] = np.nan
    pos[~valid] = np.nan
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    quat[~valid] = np.nan
    grip = np.where(valid, 0.06, np.nan)
    return Demonstration(t=t, keypoints=kp, valid=valid, position=pos, quaternion=quat,
                         gripper=grip, grasp=np.zeros(n, bool))  # fmt: skip


def _child(code: str) -> tuple[float, float]:
    """Wall time [s] and peak RSS [MB] of one Python child running ``code``."""
    start = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-c", code], cwd=REPO)
    _, status, usage = os.wait4(proc.pid, 0)  # this child's own peak, not the largest so far
    wall = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode:
        raise SystemExit(f"failed ({proc.returncode}): {code}")
    return wall, usage.ru_maxrss / 1024


def main() -> None:
    sizes = [int(a) for a in sys.argv[1:]] or [300_000]
    for n in sizes:
        with tempfile.TemporaryDirectory() as tmp:
            src = save_demonstration(Path(tmp) / "long.npz", _demo(n))
            load = f"from dexlfd.io import load_demonstration; load_demonstration({str(src)!r})"
            wall, rss = _child(load)
            print(f"{n:,} samples ({src.stat().st_size / 1e6:.0f} MB): load {wall:.1f} s, "
                  f"peak RSS {rss:.0f} MB")  # fmt: skip
            for fmt, out in (("lerobot", Path(tmp) / "ds"), ("csv", Path(tmp) / "x.csv")):
                cmd = f"from dexlfd.cli import main; main(['export', {str(src)!r}, '--format', "
                cmd += f"{fmt!r}, '-o', {str(out)!r}, '-q'])"
                wall, rss = _child(cmd)
                print(f"  export --format {fmt}: {wall:.1f} s, peak RSS {rss:.0f} MB")


if __name__ == "__main__":
    main()
