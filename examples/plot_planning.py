"""Planning with DMPs: new starts and goals, obstacles, variance (thesis Figs. 5.4-5.8).

Builds a learned model from the noise-free synthetic pick-and-place task with a
covariance that is large where the (synthetic) demonstrations would disagree -- a
stand-in for the learn stage's GMR output -- and plans with it. The last cell learns
a model from six synthetic demonstrations (as ``dexlfd demo`` does) and shows the
Figs. 5.6-5.7 pair on it.
"""

# %%
import argparse
import tempfile
from pathlib import Path

import numpy as np

from dexlfd.datasets import PickPlaceConfig, pick_place_demonstrations, pick_place_reference
from dexlfd.io import LearnedModel
from dexlfd.learn import LearnConfig, learn_from_demonstrations
from dexlfd.plan import Box, PlanConfig, Sphere, plan_from_model
from dexlfd.viz.planning import plot_obstacle_comparison, plot_paths

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument(
    "--out", type=Path, help="folder for the figures (default: a new temporary folder)"
)
out = parser.parse_args().out or Path(tempfile.mkdtemp(prefix="dexlfd-example-"))
out.mkdir(parents=True, exist_ok=True)


def synthetic_model(sigma: np.ndarray, t: np.ndarray, pos: np.ndarray, quat, grip):
    m = len(t)
    mean = np.concatenate([pos, quat, grip[:, None]], axis=1)
    cov = np.zeros((m, 8, 8))
    cov[:, 0, 0] = cov[:, 1, 1] = cov[:, 2, 2] = sigma**2
    cov[:, 3:7, 3:7] = 1e-4 * np.eye(4)
    cov[:, 7, 7] = 1e-6
    return LearnedModel(
        t=t,
        mean=mean,
        cov=cov,
        gmm_weights=np.ones(1),
        gmm_means=np.zeros((1, 9)),
        gmm_covs=np.eye(9)[None],
        meta={"source": "SYNTHETIC stand-in for a GMR output"},
    )


T = 8.0
t = np.linspace(0.0, T, 400)
u = t / T
pos, quat, grip = pick_place_reference(u, PickPlaceConfig())
model = synthetic_model(0.005 + 0.025 * np.exp(-0.5 * ((u - 0.55) / 0.12) ** 2), t, pos, quat, grip)

# %% Fig. 5.4: three new starts and goals of Section 5.3.1
starts = [(0.37, -0.34, 0.22), (0.50, -0.25, 0.21), (0.55, -0.34, 0.28)]
goals = [(0.51, 0.11, 0.31), (0.50, 0.19, 0.30), (0.50, 0.28, 0.32)]
plans = [
    plan_from_model(model, PlanConfig(start=s, goal=g, rate_hz=200))
    for s, g in zip(starts, goals, strict=True)
]
for p, g in zip(plans, goals, strict=True):
    print(f"goal {g}: reached within {1e3 * np.linalg.norm(p.position[-1] - g):.2f} mm")
print(
    "figure:",
    plot_paths(
        model,
        plans,
        out / "fig5_4_new_goals.png",
        labels=[f"start {s} -> goal {g}" for s, g in zip(starts, goals, strict=True)],
        title="Modified DMP: new starts and goals (cf. thesis Fig. 5.4)",
    ),
)

# %% Fig. 5.5: obstacles 0.4 m and 0.5 m high under the carry
boxes = [Box((0.45, 0.0, h / 2), (0.1, 0.1, h)) for h in (0.4, 0.5)]
plans = [plan_from_model(model, PlanConfig(obstacles=(b,), rate_hz=200)) for b in boxes]
print(
    "figure:",
    plot_obstacle_comparison(
        model,
        plans,
        ["obstacle 0.4 m", "obstacle 0.5 m"],
        out / "fig5_5_heights.png",
        title="Variance-avoidance DMP: higher obstacle, larger bend (cf. thesis Fig. 5.5)",
    ),
)


# %% Figs. 5.6-5.7: the same obstacle where the demonstrations disagreed or agreed
def mj(x):
    x = np.clip(x, 0, 1)
    return x**3 * (10 - 15 * x + 6 * x * x)


flat = np.stack(
    [
        np.full_like(u, 0.45),
        -0.3 + 0.6 * mj(u),
        0.15 + 0.2 * mj(u / 0.25) - 0.2 * mj((u - 0.75) / 0.25),
    ],
    axis=1,
)
sigma = 0.005 + 0.025 * mj((u - 0.15) / 0.1) * (1 - mj((u - 0.45) / 0.1))
flat_model = synthetic_model(
    sigma, t, flat, np.tile([1.0, 0, 0, 0], (len(t), 1)), np.full(len(t), 0.04)
)
plans = [
    plan_from_model(
        flat_model, PlanConfig(obstacles=(Box((0.45, y, 0.18), (0.1, 0.06, 0.36)),), rate_hz=200)
    )
    for y in (-0.15, 0.15)
]
print(
    "figure:",
    plot_obstacle_comparison(
        flat_model,
        plans,
        ["high-variance part", "low-variance part"],
        out / "fig5_6_7_variance.png",
        title="Same obstacle, different variance (cf. thesis Figs. 5.6-5.7)",
    ),
)

# %% Fig. 5.8: obstacles in 3-D, passed over and beside
obstacles = (Box((0.45, -0.12, 0.15), (0.12, 0.06, 0.3)), Sphere((0.45, 0.1, 0.33), 0.05, "auto"))
plan = plan_from_model(model, PlanConfig(obstacles=obstacles, rate_hz=200))
for ob in plan.obstacle_passes:
    print(f"{ob.type}: passed along {ob.direction_used}, clearance {ob.min_clearance:.3f} m")
print(
    "figure:",
    plot_paths(
        model,
        [plan],
        out / "fig5_8_3d.png",
        labels=["variance-avoidance DMP"],
        title="Obstacles in 3-D (cf. thesis Fig. 5.8)",
    ),
)

# %% Figs. 5.5-5.7 on a model learned from demonstrations (the demo's set-up)
rng = np.random.default_rng(0)
demos = pick_place_demonstrations(6, rng)
learned = learn_from_demonstrations(demos, LearnConfig(n_components=12), rng).model
cups = [Box((0.45, 0.0, h / 2), (0.08, 0.08, h)) for h in (0.4, 0.5)]
for variance in (True, False):
    for cup in cups:
        p = plan_from_model(
            learned,
            PlanConfig(
                obstacles=(cup,), margin=0.08, variance_aware=variance, rate_hz=200, task="motion"
            ),
        )
        ob = p.obstacle_passes[0]
        print(
            f"cup {cup.size[2]:.1f} m, variance term {'on ' if variance else 'off'}: "
            f"displacement {ob.displacement:.3f} m, clearance {ob.min_clearance:.3f} m "
            f"(margin 0.08 m), gain {ob.gain:.2f}, peak z {p.position[:, 2].max():.3f} m"
        )
nominal = plan_from_model(learned, PlanConfig(rate_hz=100, task="motion"))
tb = nominal.t / nominal.t[-1]
pair = []
for phase in (0.55, 0.41):  # the carry (demonstrations disagree), the lift-off (agree)
    c = nominal.position[int(np.searchsorted(tb, phase))]
    top = c[2] + 0.03  # the same obstacle relative to the path: 3 cm above it
    box = Box((c[0], c[1], top / 2), (0.06, 0.03, top))
    pair.append(plan_from_model(learned, PlanConfig(obstacles=(box,), rate_hz=100, task="motion")))
for p, name in zip(pair, ("high", "low"), strict=True):
    ob = p.obstacle_passes[0]
    print(
        f"{name}-variance part: nu {ob.variance_level:.2f}, displacement "
        f"{ob.displacement:.3f} m, clearance {ob.min_clearance:.3f} m"
    )
print(
    "figure:",
    plot_obstacle_comparison(
        learned,
        pair,
        ["high-variance part (carry)", "low-variance part (lift-off)"],
        out / "fig5_6_7_learned.png",
        title="Same obstacle relative to the path, learned model (cf. Figs. 5.6-5.7)",
    ),
)
