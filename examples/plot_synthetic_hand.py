"""Synthetic hand keypoints for a pick-and-place demonstration, and its motion figures.

A pose-level synthetic demonstration is turned into 21 MediaPipe-like hand
landmarks (the inverse of the motion definition, thesis Section 4.2), the motion
is recomputed from the landmarks, and the capture figures are written.
"""

# %%
import argparse
import tempfile
from pathlib import Path

import numpy as np

from dexlfd.datasets import demonstration_with_hand, pick_place_demonstrations
from dexlfd.viz.capture import save_capture_figures

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument(
    "--out", type=Path, help="folder for the figures (default: a new temporary folder)"
)
out = parser.parse_args().out or Path(tempfile.mkdtemp(prefix="dexlfd-example-"))
out.mkdir(parents=True, exist_ok=True)

rng = np.random.default_rng(0)
demo = pick_place_demonstrations(1, rng)[0]
hand = demonstration_with_hand(demo, rng)

# %% the motion recomputed from the keypoints equals the original pose
print("max position error [m]:", np.abs(hand.position - demo.position).max())
print("max gripper error [m]:", np.abs(hand.gripper - demo.gripper).max())

# %% figures
for path in save_capture_figures(hand, out):
    print("wrote", path)
