"""Learning on real handwriting: the LASA data set (30 shapes x 7 demonstrations, 2-D).

For every shape, learn with the thesis's K=6 and with K=15, and report the
GMR mean's normalised DTW distance (mean matched distance [mm]) to each of the
7 demonstrations, next to the median distance between the demonstrations
themselves (how much humans vary), plus the worst excursion of the mean outside
the aligned demonstrations' envelope.
"""

from __future__ import annotations

import logging
import time

import numpy as np

from dexlfd.datasets.lasa import lasa_shape_names, load_lasa_shape
from dexlfd.learn import LearnConfig, dtw, learn_trajectories

MM = 1e3


def main() -> None:
    logging.disable(logging.WARNING)
    names = lasa_shape_names()
    print(f"LASA: {len(names)} shapes x 7 demos, every 4th sample (250 per demo)")
    print(
        f"{'shape':18s} {'demo-demo':>9s} | {'K=6: mean->demos [mm]':>36s} {'out':>5s} |"
        f" {'K=15: mean->demos [mm]':>36s} {'out':>5s} | {'s':>4s}"
    )
    totals = {6: [], 15: []}
    for name in names:
        shape = load_lasa_shape(name, stride=4)
        pos = shape.positions
        between = [dtw(pos[a], pos[b]).normalized_cost for a in range(7) for b in range(a + 1, 7)]
        row = f"{name:18s} {np.median(between) * MM:9.2f} |"
        t0 = time.perf_counter()
        for K in (6, 15):
            traj = learn_trajectories(
                shape.times, pos, LearnConfig(n_components=K), np.random.default_rng(0)
            )
            d = np.array([dtw(traj.mean, p).normalized_cost for p in pos]) * MM
            A = traj.alignment.aligned
            out = np.maximum(A.min(0) - traj.mean, 0) + np.maximum(traj.mean - A.max(0), 0)
            extent = np.ptp(np.concatenate(pos), axis=0).max()
            totals[K].append(d.mean())
            row += " " + " ".join(f"{v:4.1f}" for v in d) + f" {out.max() / extent:5.1%} |"
        row += f" {time.perf_counter() - t0:4.2f}"
        print(row)
    for K, v in totals.items():
        print(
            f"K={K}: mean DTW distance of the GMR mean to the demos, over shapes: "
            f"{np.mean(v):.2f} mm (median {np.median(v):.2f}, max {np.max(v):.2f})"
        )
    print("'out': worst distance of the mean outside the aligned demos' envelope / shape extent")


if __name__ == "__main__":
    main()
