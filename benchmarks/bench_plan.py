"""DMP fit + rollout and full planning times (median of repeats, after warm-up).

Targets: fit + 1000-step rollout of an 8-channel DMP with 50 basis
functions <= 1 ms (movement_primitives: ~40 ms, measured here); planning with obstacles
<= 5 ms (the shaped coupling's linear programme now costs ~0.1-0.5 s per obstacle).

``--figures MODEL.npz`` prints instead the variance-avoidance figures (thesis Figs. 5.5-5.7) on
a learned model (e.g. the demo's ``model.npz``): displacement over the 0.4 m and 0.5
m cups with and without the variance term, clearance against the margin, the gain,
and the thesis Figs. 5.6-5.7 pair (the demo's box over the carry and at the lift-off).
"""

from __future__ import annotations

import sys
import timeit

import numpy as np

from dexlfd.datasets import PickPlaceConfig, pick_place_reference
from dexlfd.io import LearnedModel
from dexlfd.plan import Box, DmpConfig, PlanConfig, Sphere, fit_dmp, plan_from_model, rollout_dmp

T = 8.0


def _model(m: int = 400) -> LearnedModel:
    t = np.linspace(0.0, T, m)
    pos, quat, grip = pick_place_reference(t / T, PickPlaceConfig())
    mean = np.concatenate([pos, quat, grip[:, None]], axis=1)
    sigma = 0.005 + 0.025 * np.exp(-0.5 * ((t / T - 0.55) / 0.12) ** 2)
    cov = np.zeros((m, 8, 8))
    cov[:, 0, 0] = cov[:, 1, 1] = cov[:, 2, 2] = sigma**2
    cov[:, 3:, 3:] = 1e-4 * np.eye(5)
    return LearnedModel(
        t=t,
        mean=mean,
        cov=cov,
        gmm_weights=np.ones(1),
        gmm_means=np.zeros((1, 9)),
        gmm_covs=np.eye(9)[None],
    )


def _stats(fn, number: int, repeat: int = 7) -> tuple[float, float]:
    fn()  # warm-up (numba cache load, lru caches)
    runs = np.array(timeit.repeat(fn, number=number, repeat=repeat)) / number * 1e3
    return float(np.median(runs)), float(runs.std())


def main() -> None:
    t = np.linspace(0.0, T, 1000)
    pos, quat, grip = pick_place_reference(t / T, PickPlaceConfig())
    x8 = np.concatenate([pos, quat, grip[:, None]], axis=1)
    cfg = DmpConfig(n_basis=50)

    med, sd = _stats(lambda: fit_dmp(t, x8, cfg), 50)
    print(f"fit 8 channels x 1000 samples, 50 basis:        {med:.3f} ± {sd:.3f} ms")
    dmp = fit_dmp(t, x8, cfg)
    med, sd = _stats(lambda: rollout_dmp(dmp, n_steps=1000), 50)
    print(
        f"rollout 1000 steps, 8 channels:                  {med:.3f} ± {sd:.3f} ms "
        f"({med * 1e3 / 1000:.2f} µs/step)"
    )
    med, sd = _stats(lambda: rollout_dmp(fit_dmp(t, x8, cfg), n_steps=1000), 50)
    print(f"fit + rollout (target <= 1 ms):                  {med:.3f} ± {sd:.3f} ms")

    model = _model()
    obstacles = (Box((0.45, 0.0, 0.2), (0.1, 0.1, 0.4)), Sphere((0.45, -0.12, 0.3), 0.05))
    for rate, label in ((125.0, "1001 samples"), (1000.0, "8001 samples (1 kHz)")):
        base = PlanConfig(rate_hz=rate)
        with_obs = PlanConfig(rate_hz=rate, obstacles=obstacles)
        med0, sd0 = _stats(lambda c=base: plan_from_model(model, c), 10)
        med1, sd1 = _stats(lambda c=with_obs: plan_from_model(model, c), 10)
        print(
            f"plan_from_model, {label}: no obstacle {med0:.2f} ± {sd0:.2f} ms, "
            f"2 obstacles {med1:.2f} ± {sd1:.2f} ms"
        )


def figures(path: str) -> None:
    """The variance-avoidance figures on a learned model file."""
    from dexlfd.io import load_model

    model = load_model(path)
    for h in (0.4, 0.5):
        cup = Box((0.45, 0.0, h / 2), (0.08, 0.08, h))
        for variance in (True, False):
            cfg = PlanConfig(obstacles=(cup,), margin=0.08, variance_aware=variance)
            p = plan_from_model(model, cfg)
            ob = p.obstacle_passes[0].to_json()
            print(
                f"cup {h:.1f} m, variance {'on ' if variance else 'off'}: needed lift "
                f"{ob['required_lift']:.3f} m, displacement {ob['displacement']:.3f} m, "
                f"min clearance {ob['min_clearance']:.3f} m (margin 0.080), peak z "
                f"{p.position[:, 2].max():.3f} m, gain {ob['gain']:.3f} "
                f"(thesis k2*nu {ob['thesis_weight']:.2f}, nu {ob['variance_level']:.2f})"
            )
    from dexlfd.apps.demo_plan import variance_pair as _variance_pair

    for variance in (True, False):
        plans, labels = _variance_pair(model, variance_aware=variance)
        for p, label in zip(plans, labels, strict=True):
            ob = p.obstacle_passes[0].to_json()
            print(
                f"pair, {label}, variance {'on ' if variance else 'off'}: needed lift "
                f"{ob['required_lift']:.4f} m, displacement {ob['displacement']:.4f} m "
                f"({1e3 * (ob['displacement'] - ob['required_lift']):.1f} mm beyond), min "
                f"clearance {ob['min_clearance']:.4f} m (margin 0.020), nu "
                f"{ob.get('variance_level', 0.0):.2f}, gain {ob['gain']:.3f}"
            )


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--figures":
        figures(sys.argv[2])
    else:
        main()
