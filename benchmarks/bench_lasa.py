"""Learning on real handwriting: the LASA data set (30 shapes x 7 demonstrations, 2-D).

Per shape, the GMR mean's distance from the 7 demonstrations (DTW cost per
sample, mean over the demonstrations [mm]) for

* ``default``: what ``dexlfd learn`` does: the demonstrations as pose series
  (x, y, z = 0, a constant quaternion, a constant gripper), the mean filter
  (window 10) where it lowers Stein's risk estimate (column ``w``: the window
  applied; 1 = none), DTW with per-group scales, K chosen by held-out
  demonstration error (:mod:`dexlfd.learn.model_selection`), GMR;
* ``plain``: DTW to the medoid, EM GMM with K = 6, GMR, no filter, on the 2-D
  positions only;
* ``sklearn``: as ``plain`` with scikit-learn's ``GaussianMixture`` (k-means
  initialisation) instead of our EM, as an outside reference;

and the ratio default / plain (<= 1: the default is no farther from the
demonstrations). All runs have the same sample count (every 4th sample: 251
per demonstration). Deterministic (rng seed 0).
"""

from __future__ import annotations

import logging
import time

import numpy as np

from dexlfd.datasets.lasa import lasa_shape_names, load_lasa_shape
from dexlfd.learn import LearnConfig, dtw, learn_poses, learn_trajectories
from dexlfd.learn.gmm import Gmm
from dexlfd.learn.gmr import gmr

MM = 1e3
STRIDE = 4


def as_poses(positions: tuple[np.ndarray, ...]) -> list[np.ndarray]:
    """2-D pen positions as pose series: x, y, z = 0, quaternion (0, 0, 0, 1), gripper 0.04 m."""
    out = []
    for p in positions:
        pose = np.zeros((p.shape[0], 8))
        pose[:, :2] = p
        pose[:, 6] = 1.0
        pose[:, 7] = 0.04
        out.append(pose)
    return out


def distance_per_sample(mean: np.ndarray, demos: tuple[np.ndarray, ...]) -> float:
    """Mean over the demonstrations of the DTW cost per demonstration sample [m]."""
    return float(np.mean([dtw(mean, p).cost / p.shape[0] for p in demos]))


def default_learn(shape) -> tuple[np.ndarray, int, int]:  # type: ignore[no-untyped-def]
    """GMR mean (x, y) of the default pose pipeline, the K and the filter window it chose."""
    res = learn_poses(shape.times, as_poses(shape.positions), LearnConfig(),
                      np.random.default_rng(0))  # fmt: skip
    traj = res.trajectory
    return traj.mean[:, :2], traj.gmm_result.gmm.n_components, int(traj.window or 1)


def plain_chain(shape) -> tuple[np.ndarray, object]:  # type: ignore[no-untyped-def]
    """GMR mean of DTW (medoid) + EM GMM K = 6 + GMR, unfiltered, and the trajectory."""
    cfg = LearnConfig(n_components=6, window=1)
    traj = learn_trajectories(shape.times, shape.positions, cfg, np.random.default_rng(0))
    return traj.mean, traj


def sklearn_chain(traj) -> np.ndarray:  # type: ignore[no-untyped-def]
    """As the plain chain, with scikit-learn's GaussianMixture (K = 6) on the same alignment."""
    from sklearn.mixture import GaussianMixture

    A = traj.alignment.aligned
    t = traj.t_reference
    X = np.concatenate([np.broadcast_to(t[None, :, None], (A.shape[0], t.size, 1)), A], 2)
    g = GaussianMixture(6, covariance_type="full", random_state=0).fit(X.reshape(-1, 3))
    return gmr(Gmm(g.weights_, g.means_, g.covariances_), t).mean


def main() -> None:
    logging.disable(logging.WARNING)
    names = lasa_shape_names()
    print(f"LASA: {len(names)} shapes x 7 demos, every {STRIDE}th sample")
    print("DTW cost per sample from the GMR mean to the demonstrations, mean over 7 demos [mm]")
    print(f"{'shape':18s} {'K':>3s} {'w':>3s} {'default':>8s} {'plain':>8s} {'ratio':>6s} "
          f"{'sklearn':>8s} {'s':>5s}")  # fmt: skip
    ratios: list[float] = []
    diffs: list[float] = []
    for name in names:
        shape = load_lasa_shape(name, stride=STRIDE)
        t0 = time.perf_counter()
        mean_d, k, w = default_learn(shape)
        dt = time.perf_counter() - t0
        mean_p, traj_p = plain_chain(shape)
        d = distance_per_sample(mean_d, shape.positions)
        p = distance_per_sample(mean_p, shape.positions)
        s = distance_per_sample(sklearn_chain(traj_p), shape.positions)
        ratios.append(d / p)
        diffs.append(d - p)
        print(f"{name:18s} {k:3d} {w:3d} {MM * d:8.3f} {MM * p:8.3f} {d / p:6.3f} {MM * s:8.3f} "
              f"{dt:5.1f}", flush=True)  # fmt: skip
    r = np.array(ratios)
    print(
        f"default / plain over {r.size} shapes: max {r.max():.3f}, median {np.median(r):.3f}, "
        f"min {r.min():.3f}; shapes with ratio > 1: {int((r > 1).sum())}; "
        f"largest difference {MM * max(diffs):+.4f} mm"
    )
    print("'s': wall time of the default learn [s] (K selection included)")


if __name__ == "__main__":
    main()
