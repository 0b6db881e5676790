"""Save/load time of the file contracts on the synthetic data set."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from dexlfd.datasets import pick_place_demonstrations
from dexlfd.io import load_demonstration, save_demonstration


def main() -> None:
    demos = pick_place_demonstrations(6, np.random.default_rng(0))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "d.npz"
        save_t, load_t = [], []
        for _ in range(20):
            t0 = time.perf_counter()
            save_demonstration(path, demos[0])
            t1 = time.perf_counter()
            load_demonstration(path)
            save_t.append(t1 - t0)
            load_t.append(time.perf_counter() - t1)
    save_ms, load_ms = np.median(save_t) * 1e3, np.median(load_t) * 1e3
    print(f"demonstration save {save_ms:.2f} ms, load {load_ms:.2f} ms")


if __name__ == "__main__":
    main()
