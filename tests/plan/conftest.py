"""Learned models built without the learn stage (which lives in another branch)."""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable

import numpy as np
import pytest

from dexlfd.datasets import PickPlaceConfig, pick_place_demonstrations, pick_place_reference
from dexlfd.io import LearnedModel, Plan
from dexlfd.panda import CARTESIAN_LIMITS
from dexlfd.rotations import quat_sign_continuous


def _gmm_placeholder(t: np.ndarray, mean: np.ndarray) -> dict[str, np.ndarray]:
    # planning never reads the GMM; a one-component placeholder keeps the contract
    data = np.concatenate([t[:, None], mean], axis=1)
    return {
        "gmm_weights": np.ones(1),
        "gmm_means": data.mean(axis=0, keepdims=True),
        "gmm_covs": np.cov(data.T)[None] + 1e-9 * np.eye(9)[None],
    }


def reference_model(
    duration: float = 8.0,
    m: int = 400,
    sigma_low: float = 0.005,
    sigma_high: float = 0.03,
    high_at: float = 0.55,
    high_width: float = 0.12,
) -> LearnedModel:
    """Noise-free pick-and-place mean; positional std sigma(t) peaks at phase ``high_at``."""
    t = np.linspace(0.0, duration, m)
    u = t / duration
    pos, quat, grip = pick_place_reference(u, PickPlaceConfig())
    mean = np.concatenate([pos, quat, grip[:, None]], axis=1)
    sigma = sigma_low + (sigma_high - sigma_low) * np.exp(-0.5 * ((u - high_at) / high_width) ** 2)
    cov = np.zeros((m, 8, 8))
    cov[:, 0, 0] = cov[:, 1, 1] = cov[:, 2, 2] = sigma**2
    cov[:, 3:7, 3:7] = 1e-4 * np.eye(4)
    cov[:, 7, 7] = 1e-6
    return LearnedModel(
        t=t, mean=mean, cov=cov, **_gmm_placeholder(t, mean), meta={"source": "test reference"}
    )


def stacked_demo_model(n_demos: int = 6, m: int = 300, seed: int = 3) -> LearnedModel:
    """Pointwise mean and covariance of demos resampled to a common phase."""
    demos = pick_place_demonstrations(n_demos, np.random.default_rng(seed))
    u = np.linspace(0.0, 1.0, m)
    stack = []
    for d in demos:
        ud = (d.t - d.t[0]) / (d.t[-1] - d.t[0])
        pose = d.pose.copy()
        pose[:, 3:7] = quat_sign_continuous(pose[:, 3:7])
        if pose[0, 6] < 0:
            pose[:, 3:7] *= -1
        stack.append(np.stack([np.interp(u, ud, pose[:, j]) for j in range(8)], axis=1))
    arr = np.stack(stack)  # (n_demos, m, 8)
    mean = arr.mean(axis=0)
    mean[:, 3:7] /= np.linalg.norm(mean[:, 3:7], axis=1, keepdims=True)
    dev = arr - mean[None]
    cov = np.einsum("kmi,kmj->mij", dev, dev) / (n_demos - 1) + 1e-8 * np.eye(8)
    duration = float(np.mean([d.t[-1] for d in demos]))
    t = u * duration
    return LearnedModel(
        t=t,
        mean=mean,
        cov=cov,
        **_gmm_placeholder(t, mean),
        meta={"source": "stacked synthetic demos"},
    )


@pytest.fixture(autouse=True)
def _dexlfd_logging_propagates():
    """``dexlfd.cli.main`` detaches the package logger from the root (for its own
    stderr handler); restore it so ``caplog`` sees warnings in every test."""
    logger = logging.getLogger("dexlfd")
    saved = (logger.handlers[:], logger.propagate, logger.level)
    logger.handlers[:] = []
    logger.propagate = True
    logger.setLevel(logging.NOTSET)
    yield
    logger.handlers[:], logger.propagate, _ = saved
    logger.setLevel(saved[2])


@pytest.fixture(scope="session")
def ref_model() -> LearnedModel:
    return reference_model()


@pytest.fixture(scope="session")
def demo_model() -> LearnedModel:
    return stacked_demo_model()


def _min_jerk(u: np.ndarray) -> np.ndarray:
    u = np.clip(u, 0.0, 1.0)
    return u**3 * (10 - 15 * u + 6 * u * u)


def flat_carry_model(duration: float = 8.0, m: int = 400) -> LearnedModel:
    """Rise to z = 0.35 m, carry flat along y, descend. Demonstrations disagree
    (sigma 3 cm) over the first half of the carry, agree (5 mm) elsewhere: the
    set-up of thesis Figs. 5.6-5.7 with a symmetric path."""
    t = np.linspace(0.0, duration, m)
    u = t / duration
    y = -0.3 + 0.6 * _min_jerk(u)
    z = 0.15 + 0.2 * _min_jerk(u / 0.25) - 0.2 * _min_jerk((u - 0.75) / 0.25)
    pos = np.stack([np.full(m, 0.45), y, z], axis=1)
    mean = np.concatenate([pos, np.tile([1.0, 0.0, 0.0, 0.0], (m, 1)), np.full((m, 1), 0.04)], 1)
    sigma = 0.005 + 0.025 * _min_jerk((u - 0.15) / 0.1) * (1 - _min_jerk((u - 0.45) / 0.1))
    cov = np.zeros((m, 8, 8))
    cov[:, 0, 0] = cov[:, 1, 1] = cov[:, 2, 2] = sigma**2
    cov[:, 3:7, 3:7] = 1e-4 * np.eye(4)
    cov[:, 7, 7] = 1e-6
    return LearnedModel(
        t=t, mean=mean, cov=cov, **_gmm_placeholder(t, mean), meta={"source": "test flat carry"}
    )


@pytest.fixture(scope="session")
def flat_model() -> LearnedModel:
    return flat_carry_model()


@pytest.fixture(scope="session")
def learned_demo_model() -> LearnedModel:
    """The demo's own learned model: its demonstrations and learn settings (seed 0)."""
    from dexlfd.apps.demo import DemoConfig
    from dexlfd.datasets import demonstration_with_hand
    from dexlfd.learn import learn_from_demonstrations

    cfg = DemoConfig(real_video=None)
    rng = np.random.default_rng([cfg.seed, 0])
    demos = [demonstration_with_hand(d, rng) for d in pick_place_demonstrations(cfg.n_demos, rng)]
    learned = learn_from_demonstrations(demos, cfg.learn, np.random.default_rng([cfg.seed, 1]))
    return learned.model


@pytest.fixture(scope="session")
def event_model() -> LearnedModel:
    """Learned from six synthetic pick-and-places with grasp events (seed 0, 8 components)."""
    from dexlfd.learn import LearnConfig, learn_from_demonstrations

    demos = pick_place_demonstrations(6, np.random.default_rng(0))
    return learn_from_demonstrations(
        demos, LearnConfig(n_components=8), np.random.default_rng(0)
    ).model


PICK, PLACE = (0.5, -0.15, 0.03), (0.45, 0.15, 0.03)  # [m] both on the table


def planned_with_carry(model: LearnedModel, dz: Callable[[np.ndarray], np.ndarray]) -> Plan:
    """``model`` (a pick-and-place) with ``dz(u)`` [m] added to the carry's height, planned.

    ``u`` is the carry's phase (0 at the grasp, 1 at the release); planned between
    :data:`PICK` and :data:`PLACE`. Checked: never below them, at them, and smooth
    (within the Panda's Cartesian acceleration limit, the velocity the position's
    derivative).
    """
    from dexlfd.plan import PlanConfig, plan_from_model

    assert model.event_t is not None
    t_g, t_r = model.event_t
    mean = model.mean.copy()
    mean[:, 2] += dz(np.clip((model.t - t_g) / (t_r - t_g), 0, 1))
    changed = dataclasses.replace(model, mean=mean)
    plan = plan_from_model(changed, PlanConfig(pick=PICK, place=PLACE, rate_hz=500.0))
    # no part takes the TCP (and the held object's bottom) below the pick and place
    assert plan.position[:, 2].min() >= min(PICK[2], PLACE[2]) - 1e-9
    held = np.flatnonzero(plan.grasp)
    np.testing.assert_allclose(plan.position[held[0]], PICK, atol=0.005)
    np.testing.assert_allclose(plan.position[held[-1]], PLACE, atol=0.005)
    assert (
        np.linalg.norm(plan.acceleration, axis=1).max()
        <= CARTESIAN_LIMITS["translational_acceleration"][0]
    )
    v_fd = np.gradient(plan.position[:, 2], plan.t)
    assert np.abs(v_fd - plan.velocity[:, 2]).max() < 0.01
    return plan
