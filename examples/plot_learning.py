"""Learn a pick-and-place motion with its uncertainty from six synthetic demonstrations."""

# %%
import argparse
import tempfile
from pathlib import Path

import numpy as np

from dexlfd.datasets import pick_place_demonstrations
from dexlfd.learn import LearnConfig, learn_from_demonstrations
from dexlfd.viz.learning import plot_gmr

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument(
    "--out", type=Path, help="folder for the figures (default: a new temporary folder)"
)
out = parser.parse_args().out or Path(tempfile.mkdtemp(prefix="dexlfd-example-"))
out.mkdir(parents=True, exist_ok=True)

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
fig = plot_gmr(traj, out / "gmr.png")
print(f"wrote {fig} ({fig.stat().st_size // 1024} kB)")
