"""Synthetic pick-and-place demonstrations.

Generates six seeded demonstrations (different durations, time warps, noise)
and plots their paths and channels.
"""

# %%
import argparse
import tempfile
from pathlib import Path

import numpy as np

from dexlfd.datasets import pick_place_demonstrations
from dexlfd.viz.demonstrations import plot_demonstrations

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument(
    "--out", type=Path, help="folder for the figures (default: a new temporary folder)"
)
out = parser.parse_args().out or Path(tempfile.mkdtemp(prefix="dexlfd-example-"))
out.mkdir(parents=True, exist_ok=True)

demos = pick_place_demonstrations(6, np.random.default_rng(0))
print("samples per demo:", [d.n_samples for d in demos])

# %%
print("figure:", plot_demonstrations(demos, out / "demos.png"))
