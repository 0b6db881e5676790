"""Tracking a lift with an object the controller does not know.

The thesis's NTSM-PD and our NTSM-PD with a momentum disturbance observer carry
a 1.2 kg box (grasped by the fingers) along a 3 s lift on the simulated Panda
with friction, a 10 % model error, noise and a torque delay.
"""

# %%
import argparse
import tempfile
from pathlib import Path

import numpy as np

from dexlfd.control import LoopConfig, make_controller, track
from dexlfd.plan.moves import lift_plan
from dexlfd.robot import PlantConfig, perturbed_model
from dexlfd.viz.control import plot_rollout

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument(
    "--out", type=Path, help="folder for the figures (default: a new temporary folder)"
)
out = parser.parse_args().out or Path(tempfile.mkdtemp(prefix="dexlfd-example-"))
out.mkdir(parents=True, exist_ok=True)

plan = lift_plan(3.0, z_high=0.4)
model = perturbed_model(0.1, np.random.default_rng(1))  # what the controllers believe
for name in ("ntsm-pd", "ntsm-pd-dob"):
    rollout = track(plan, make_controller(name), model, PlantConfig(payload_kg=1.2), LoopConfig(),
                    rng=np.random.default_rng(0))  # fmt: skip
    ez = rollout.ee_position[:, 2] - rollout.ref_position[:, 2]
    print(f"{name:12s} z error RMS {1e3 * np.sqrt(np.mean(ez**2)):.2f} mm")
    # %%
    print("figure:", plot_rollout(rollout, out / f"{name}.png"))
