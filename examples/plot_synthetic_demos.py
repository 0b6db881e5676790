"""Synthetic pick-and-place demonstrations.

Generates six seeded demonstrations (different durations, time warps, noise)
and plots their paths and channels.
"""

# %%
import tempfile
from pathlib import Path

import numpy as np

from dexlfd.datasets import pick_place_demonstrations
from dexlfd.viz.demonstrations import plot_demonstrations

demos = pick_place_demonstrations(6, np.random.default_rng(0))
print("samples per demo:", [d.n_samples for d in demos])

# %%
out = Path(tempfile.mkdtemp()) / "demos.png"
plot_demonstrations(demos, out)
print("figure:", out)
