"""Learn a pick-and-place motion with its uncertainty from six synthetic demonstrations."""

# %%
import tempfile
from pathlib import Path

import numpy as np

from dexlfd.datasets import pick_place_demonstrations
from dexlfd.learn import LearnConfig, learn_from_demonstrations
from dexlfd.viz.learning import plot_gmr

demos = pick_place_demonstrations(6, np.random.default_rng(0))
result = learn_from_demonstrations(demos, LearnConfig(), np.random.default_rng(0))

# %%
traj = result.trajectory
gmm = traj.gmm_result
sd = np.sqrt(np.diagonal(result.model.cov, axis1=1, axis2=2))
print(f"reference: demo {traj.alignment.reference_index} (the medoid)")
print(f"DTW distances to it: {traj.quality.distances.round(3)}")
print(f"GMM: {gmm.n_iter} EM iterations, log-likelihood {gmm.log_likelihood:.1f}")
print(f"largest position std along the motion: {sd[:, :3].max() * 1000:.1f} mm")
with tempfile.TemporaryDirectory() as folder:
    out = plot_gmr(traj, Path(folder) / "gmr.png")
    print(f"wrote {out.name} ({out.stat().st_size // 1024} kB)")
