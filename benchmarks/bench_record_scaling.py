"""Does re-processing a landmark recording scale linearly in its frames?

A real landmark recording (MediaPipe output of a pick-and-place video) is tiled to N frames
at its own frame rate and ``dexlfd record`` re-processes it, once per N, in a fresh
interpreter; the CPU time of each run is printed (user + system of the child: wall time
on a shared machine says little). Linear scaling means the ratio of consecutive rows is
the ratio of their frame counts.

Usage::

    PYTHONPATH=src python benchmarks/bench_record_scaling.py LANDMARKS.npz [N ...]

Measured on the 2-core machine (breakfast.npz of the real recordings, 219 frames, tiled;
another helper's sweep running beside it): 1,500 frames 6.6 s user, 3,000 frames 13.2 s
user; under cProfile 3,000 -> 6,000 frames took 201 -> 338 s of profiled time (1.7x) with
every per-frame step called exactly twice as often (``fit_hand_pose`` 5,867 -> 11,727
calls, ``recording_pose._rts`` 28 calls at 0.17 -> 0.30 s each): no step grows faster
than the frame count. Again after the landmark-recording and writer checks (2026-12-02,
a load far above the 2 cores): 1,500 frames 5.5 s, 6,000 frames 18.0 s of CPU (3.7 and
3.0 ms a frame): linear; the 21 s -> 62 s of 3,000 -> 6,000 frames reported were wall
times under load.
"""

from __future__ import annotations

import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np


def tiled(src: Path, n: int, dest: Path) -> Path:
    """``src``'s per-frame arrays repeated to ``n`` frames, timestamps at its median step."""
    with np.load(src, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    t = arrays["t_s"]
    reps = -(-n // len(t))
    out = {
        k: np.concatenate([a] * reps)[:n] if a.ndim and a.shape[0] == len(t) else a
        for k, a in arrays.items()
    }
    out["t_s"] = np.arange(n) * float(np.median(np.diff(t)))
    np.savez(dest, **out)
    return dest


def cpu_seconds(argv: list[str]) -> float:
    """User + system CPU seconds of one ``dexlfd`` run in a fresh interpreter."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([sys.executable, "-m", "dexlfd", *argv, "-q"], check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main(argv: list[str]) -> int:
    src = Path(argv[0])
    sizes = [int(a) for a in argv[1:]] or [1500, 3000, 6000]
    with tempfile.TemporaryDirectory() as tmp:
        rows = []
        for n in sizes:
            lm = tiled(src, n, Path(tmp) / f"lm{n}.npz")
            rows.append((n, cpu_seconds(["record", str(lm), "-o", str(Path(tmp) / f"d{n}.npz")])))
    print(f"{'frames':>8} {'cpu s':>8} {'s/frame':>9}")
    for n, s in rows:
        print(f"{n:>8} {s:>8.1f} {1e3 * s / n:>8.2f}m")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
